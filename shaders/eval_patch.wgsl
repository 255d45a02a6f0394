//! eval_patch.wgsl: squared closest-point offsets of the target points, summed per individual.
//!
//! Mirrored by src/eval/cpu/eval_patch.rs (same bindings, same f32 arithmetic in the same order).
//!
//! Mixed precision. Each individual arrives as its difference from a reference design (the
//! `net` binding is the expanded difference, written by expand.wgsl), and each target carries
//! the reference's offset at the target's start parameters, computed on the host in f64:
//! r0 = S_ref(u0, v0) - q. An offset is then r0 plus the difference net's point, a sum of
//! small terms, so its f32 error is relative to the offset and the difference, not to where
//! the data sit. Newton steps move the parameters by Δ (in the start patch's local units);
//! the reference then enters through its second-order Taylor polynomial about the start
//! parameters, whose partials (`jets`) are also computed in f64.
//!
//! One invocation owns PER individuals (a workgroup, 64); the invocations of a workgroup walk
//! the same group of target points in the same order, so every per-point load (target, jets,
//! breaks) has the same address in every lane. Targets are sorted by patch: the control
//! points of a patch are loaded into registers once per run of points on it and reused for
//! all of them. A curve is the one-dimensional case: DV = 0, one patch along v, DIM = 2.
//!
//! Written for a SIMD-on-CPU driver (Mesa lavapipe) as much as for GPUs: the body of an `if`
//! runs, masked, even when no lane takes it, so no expensive work sits under a per-point
//! condition; loops marked `// @unroll` have constant trip counts and are unrolled before
//! compilation (src/eval/gpu/unroll.rs), which turns every array index into a constant and
//! every array into registers.
//!
//! Per-point loads are lavapipe's other cost: inside a loop it loads from a storage buffer
//! lane by lane, a scalar loop with a branch per lane for every load instruction, even where
//! every lane reads the same address (as here). So a point's data are six `vec4`s in one
//! buffer (its Target, then its RefJet), read by `fetch_target` and `fetch_point` of the
//! include points.wgsl: on devices with subgroup operations the host splices in
//! points_subgroup.wgsl instead, where lane l loads vec4 l alone and the others are
//! broadcast from it (one load instruction a point instead of one a scalar). And on a CPU
//! adapter the host specialises PER > 1, so that each load and each point's loop overhead
//! serve PER individuals. Neither changes an individual's arithmetic: results are the same
//! for every PER and either include.

// Specialised at pipeline creation (src/eval/gpu/mod.rs rewrites these lines with the
// layout's values); the values written here keep the file valid on its own for naga.
const DU: u32 = 3u;
const DV: u32 = 3u;
const DIM: u32 = 3u;
// 1: Newton steps may cross patch borders (reloading control points as they go); 0: they are
// clamped to the patch the point starts on.
const CROSS: u32 = 0u;
// 1: the foot-point search also descends from candidate starts (`seed`, config.seeds a patch
// side); 0: from the start parameters only. A constant, so that a kernel without them carries
// none of their code (lavapipe runs the body of an `if` masked even when no lane takes it).
const SEEDED: u32 = 0u;
// Individuals per invocation, a divisor of 64 (specialised by the host: 1 on GPUs, more on
// CPU adapters, where they share the per-point loads and loop overhead).
const PER: u32 = 1u;
// Invocations per workgroup: a workgroup covers 64 individuals whatever PER is, the individual
// of slot k of invocation `lane` of workgroup w being w * 64 + k * WG + lane.
const WG: u32 = 64u / PER;

const NU: u32 = DU + 1u;
const NV: u32 = DV + 1u;
const NMAX: u32 = max(NU, NV);
// Control points of a patch.
const NCP: u32 = NU * NV;
// A 2x2 Newton system whose determinant is below this fraction of its diagonal product is
// treated as singular.
const SINGULAR: f32 = 1e-6;
// A candidate start's descent replaces the start's only where it ends further than this from
// it (|ΔΔu| + |ΔΔv|, start-patch units) and lower: where both reach the same foot point, the
// start's value stands, so that rounding noise (offsets below the f32 resolution of the data's
// extent) is not minimised over several draws, differently on every backend.
const SAME_FOOT: f32 = 1e-3;

// @include config.wgsl
// @include basis.wgsl
// @include points.wgsl

// Must be kept in sync with `Target` in src/eval/kernel.rs.
struct Target {
    // The reference's offset S_ref(u0, v0) - q at the start parameters (z = 0 for a curve).
    rx: f32,
    ry: f32,
    rz: f32,
    // Patch index i * patches_v + j.
    patch_id: u32,
    // Start parameters, local to that patch, in [0, 1].
    u: f32,
    v: f32,
    // How far Newton steps may move from them (local units) for the reference's Taylor
    // polynomial to stay within its tolerance.
    reach_u: f32,
    reach_v: f32,
}

// Must be kept in sync with `RefJet` in src/eval/kernel.rs: the reference's partials at a
// target's start parameters, in the start patch's local units.
struct RefJet {
    su: array<f32, 3>,
    sv: array<f32, 3>,
    suu: array<f32, 3>,
    suv: array<f32, 3>,
    svv: array<f32, 3>,
    _pad: f32,
}

// Must be kept in sync with `Partial` in src/eval/kernel.rs and reduce.wgsl.
struct Partial {
    sum_sq: f32,
    max_sq: f32,
}

@group(0) @binding(0) var<uniform> config: Config;
// Six vec4s a target point p: its Target (points[6p], points[6p + 1], see `target_of`) and
// its RefJet (points[6p + 2] to points[6p + 5], see `jet_of`); read through points.wgsl.
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
// breaks_u (patches_u + 1 values) followed by breaks_v (patches_v + 1 values).
@group(0) @binding(2) var<storage, read> breaks: array<f32>;
// Difference nets as structure of arrays: coordinate c of control point r of individual i is
// net[(r * DIM + c) * net_stride + i], with r = row * net_cols + column.
@group(0) @binding(3) var<storage, read> net: array<f32>;
// partials[group * population + individual].
@group(0) @binding(4) var<storage, read_write> partials: array<Partial>;

// The control points of the patch slot k holds, (k * NCP + a * NV + b) * DIM + c, and its
// index.
var<private> cp: array<f32, PER * NCP * DIM>;
var<private> held: array<u32, PER>;

// A Target from its two vec4s (the patch index is stored as the bits of a float).
fn target_of(a: vec4<f32>, b: vec4<f32>) -> Target {
    return Target(a.x, a.y, a.z, bitcast<u32>(a.w), b.x, b.y, b.z, b.w);
}

// A RefJet from its four vec4s.
fn jet_of(a: vec4<f32>, b: vec4<f32>, c: vec4<f32>, d: vec4<f32>) -> RefJet {
    return RefJet(
        array<f32, 3>(a.x, a.y, a.z),
        array<f32, 3>(a.w, b.x, b.y),
        array<f32, 3>(b.z, b.w, c.x),
        array<f32, 3>(c.y, c.z, c.w),
        array<f32, 3>(d.x, d.y, d.z),
        d.w,
    );
}

// A target point with the reference's partials there.
struct PointData {
    t: Target,
    rj: RefJet,
}

// Load the control points of patch `patch_id` of individual `ind` into slot k of `cp`.
fn load_patch(k: u32, ind: u32, patch_id: u32) {
    held[k] = patch_id;
    let i = patch_id / config.patches_v;
    let j = patch_id - i * config.patches_v;
    for (var a = 0u; a < NU; a++) { // @unroll
        for (var b = 0u; b < NV; b++) { // @unroll
            let r = (i * DU + a) * config.net_cols + j * DV + b;
            for (var c = 0u; c < DIM; c++) { // @unroll
                cp[(k * NCP + a * NV + b) * DIM + c] = net[(r * DIM + c) * config.net_stride + ind];
            }
        }
    }
}

// Squared offset of target t at its start parameters: |r0 + Σ B_a(u) B_b(v) cp_ab|², the GA
// fitness kernel proper. (The CPU kernels read the same weights, computed once per point by
// this recurrence on the host, from the `weights` binding.)
fn offset_sq_fixed(k: u32, t: Target) -> f32 {
    let r0 = array<f32, 3>(t.rx, t.ry, t.rz);
    var s: array<f32, DIM>;
    for (var c = 0u; c < DIM; c++) { // @unroll
        s[c] = r0[c];
    }
    let bu = bernstein(DU, t.u);
    let bv = bernstein(DV, t.v);
    for (var a = 0u; a < NU; a++) { // @unroll
        for (var b = 0u; b < NV; b++) { // @unroll
            let w = bu[a] * bv[b];
            for (var c = 0u; c < DIM; c++) { // @unroll
                s[c] = fma(w, cp[(k * NCP + a * NV + b) * DIM + c], s[c]);
            }
        }
    }
    var e2 = 0.0;
    for (var c = 0u; c < DIM; c++) { // @unroll
        e2 = fma(s[c], s[c], e2);
    }
    return e2;
}

// Squared length of `base` plus slot k's patch at local (u, v).
fn offset_sq(k: u32, u: f32, v: f32, base: array<f32, DIM>) -> f32 {
    let bu = bernstein(DU, u);
    let bv = bernstein(DV, v);
    var s = base;
    for (var a = 0u; a < NU; a++) { // @unroll
        for (var b = 0u; b < NV; b++) { // @unroll
            let w = bu[a] * bv[b];
            for (var c = 0u; c < DIM; c++) { // @unroll
                s[c] = fma(w, cp[(k * NCP + a * NV + b) * DIM + c], s[c]);
            }
        }
    }
    var e2 = 0.0;
    for (var c = 0u; c < DIM; c++) { // @unroll
        e2 = fma(s[c], s[c], e2);
    }
    return e2;
}

// A point of the held patch with its first and second partial derivatives.
struct Jet {
    s: array<f32, DIM>,
    su: array<f32, DIM>,
    sv: array<f32, DIM>,
    suu: array<f32, DIM>,
    suv: array<f32, DIM>,
    svv: array<f32, DIM>,
}

// Slot k's patch and its partials at local (u, v): rows contracted along v first, then along u.
fn jet(k: u32, u: f32, v: f32) -> Jet {
    let bu = basis(DU, u);
    let bv = basis(DV, v);
    var out: Jet;
    for (var a = 0u; a < NU; a++) { // @unroll
        var r0: array<f32, DIM>;
        var r1: array<f32, DIM>;
        var r2: array<f32, DIM>;
        for (var b = 0u; b < NV; b++) { // @unroll
            for (var c = 0u; c < DIM; c++) { // @unroll
                let p = cp[(k * NCP + a * NV + b) * DIM + c];
                r0[c] = fma(bv.b[b], p, r0[c]);
                r1[c] = fma(bv.d1[b], p, r1[c]);
                r2[c] = fma(bv.d2[b], p, r2[c]);
            }
        }
        for (var c = 0u; c < DIM; c++) { // @unroll
            out.s[c] = fma(bu.b[a], r0[c], out.s[c]);
            out.su[c] = fma(bu.d1[a], r0[c], out.su[c]);
            out.suu[c] = fma(bu.d2[a], r0[c], out.suu[c]);
            out.sv[c] = fma(bu.b[a], r1[c], out.sv[c]);
            out.suv[c] = fma(bu.d1[a], r1[c], out.suv[c]);
            out.svv[c] = fma(bu.b[a], r2[c], out.svv[c]);
        }
    }
    return out;
}

// The reference's second-order Taylor polynomial about target t's start parameters at
// displacement (du, dv): the reference offset there and its first partials.
struct Taylor {
    val: array<f32, DIM>,
    du: array<f32, DIM>,
    dv: array<f32, DIM>,
}

fn taylor(rj: RefJet, t: Target, du: f32, dv: f32) -> Taylor {
    let r0 = array<f32, 3>(t.rx, t.ry, t.rz);
    var out: Taylor;
    for (var c = 0u; c < DIM; c++) { // @unroll
        let tu = fma(rj.suu[c], du, fma(rj.suv[c], dv, rj.su[c]));
        let tv = fma(rj.suv[c], du, fma(rj.svv[c], dv, rj.sv[c]));
        // r0 + su du + sv dv + suu du²/2 + suv du dv + svv dv²/2.
        out.val[c] = fma(0.5 * du, tu + rj.su[c], fma(0.5 * dv, tv + rj.sv[c], r0[c]));
        out.du[c] = tu;
        out.dv[c] = tv;
    }
    return out;
}

// A segment of a chain and the local parameter in it.
struct Located {
    index: u32,
    t: f32,
}

// The segment of a chain (breaks from breaks[first], `count` segments) holding global g in
// [0, 1], and the local parameter in it (as ChainLayout::locate).
fn locate(first: u32, count: u32, g: f32) -> Located {
    var m = 0u;
    for (var i = 1u; i < count; i++) {
        if (g >= breaks[first + i]) {
            m = i;
        }
    }
    let b0 = breaks[first + m];
    return Located(m, clamp((g - b0) / (breaks[first + m + 1u] - b0), 0.0, 1.0));
}

// dot(x, y) over DIM coordinates.
fn dot_n(x: array<f32, DIM>, y: array<f32, DIM>) -> f32 {
    var acc = 0.0;
    for (var c = 0u; c < DIM; c++) { // @unroll
        acc = fma(x[c], y[c], acc);
    }
    return acc;
}

// The frame of target t's foot-point search: the start patch (i0, j0), the first v break,
// the start patch's lengths (1 without CROSS) and the domain of Δ: the start patch (or with
// CROSS the whole domain), within the target's reach.
struct Frame {
    i0: u32,
    j0: u32,
    fv: u32,
    h0u: f32,
    h0v: f32,
    lo_u: f32,
    hi_u: f32,
    lo_v: f32,
    hi_v: f32,
}

fn frame_of(t: Target) -> Frame {
    let i0 = t.patch_id / config.patches_v;
    let j0 = t.patch_id - i0 * config.patches_v;
    let fv = config.patches_u + 1u;
    var h0u = 1.0;
    var h0v = 1.0;
    var lo_u = -t.u;
    var hi_u = 1.0 - t.u;
    var lo_v = -t.v;
    var hi_v = 1.0 - t.v;
    if (CROSS != 0u) {
        h0u = breaks[i0 + 1u] - breaks[i0];
        h0v = breaks[fv + j0 + 1u] - breaks[fv + j0];
        lo_u = -(t.u + breaks[i0] / h0u);
        hi_u = (1.0 - breaks[i0]) / h0u - t.u;
        lo_v = -(t.v + breaks[fv + j0] / h0v);
        hi_v = (1.0 - breaks[fv + j0]) / h0v - t.v;
    }
    lo_u = max(lo_u, -t.reach_u);
    hi_u = min(hi_u, t.reach_u);
    lo_v = max(lo_v, -t.reach_v);
    hi_v = min(hi_v, t.reach_v);
    return Frame(i0, j0, fv, h0u, h0v, lo_u, hi_u, lo_v, hi_v);
}

// Where a descent starts: Δ, the local parameters there and d(local) / dΔ, its patch held in
// slot k.
struct Seed {
    du: f32,
    dv: f32,
    u: f32,
    v: f32,
    ku: f32,
    kv: f32,
}

// A candidate start: its squared offset, where it lies, and its patch.
struct Cand {
    e2: f32,
    s: Seed,
    at: u32,
}

// Two best local minima of the candidates so far, and the last candidate (`down`: it lies
// below the one before it, or starts a run).
struct Pick {
    first: Cand,
    second: Cand,
    last: Cand,
    down: bool,
}

// Offer candidate c as a local minimum.
fn offer(p: Pick, c: Cand) -> Pick {
    var out = p;
    if (c.e2 < p.first.e2) {
        out.second = p.first;
        out.first = c;
    } else if (c.e2 < p.second.e2) {
        out.second = c;
    }
    return out;
}

// Add candidate c to the run of candidates (a new run when `fresh`): the last one becomes a
// local minimum when it lies below its predecessor and not above c.
fn step_pick(p: Pick, c: Cand, fresh: bool) -> Pick {
    var out = p;
    if (p.down && (fresh || p.last.e2 <= c.e2)) {
        out = offer(p, p.last);
    }
    out.down = fresh || c.e2 < p.last.e2;
    out.last = c;
    return out;
}

// The two candidate starts of target t's foot-point search: the two deepest local minima of
// the squared offset over config.seeds + 1 samples per patch side (0, 1 / seeds, ..., 1; one
// along v for a curve) on every patch within config.seed_ring patches of the start patch
// (with CROSS; else the start patch). The samples run patch by patch, u then v; local minima
// are taken along that run (for a curve, along the whole chain; for a grid, along each line
// of constant u), ties to the earlier. Samples whose Δ lies outside the frame's domain are
// skipped; where fewer than two minima exist, the start parameters stand in. Every
// individual sees the same candidates in the same order, so every backend starts from the
// same ones.
fn seed(k: u32, ind: u32, t: Target, rj: RefJet, f: Frame) -> Pick {
    let none = Cand(3.0e38, Seed(0.0, 0.0, t.u, t.v, 1.0, 1.0), t.patch_id);
    var pick = Pick(none, none, none, false);
    let ring = select(0u, config.seed_ring, CROSS != 0u);
    let i_lo = f.i0 - min(f.i0, ring);
    let i_hi = min(f.i0 + ring, config.patches_u - 1u);
    let j_lo = f.j0 - min(f.j0, ring);
    let j_hi = min(f.j0 + ring, config.patches_v - 1u);
    let n = f32(config.seeds);
    let nv = select(config.seeds + 1u, 1u, DV == 0u);
    var first = true;
    for (var i = i_lo; i <= i_hi; i++) {
        let hu = breaks[i + 1u] - breaks[i];
        for (var j = j_lo; j <= j_hi; j++) {
            let hv = breaks[f.fv + j + 1u] - breaks[f.fv + j];
            let here = i * config.patches_v + j;
            load_patch(k, ind, here);
            for (var a = 0u; a <= config.seeds; a++) {
                let uc = f32(a) / n;
                var du = uc - t.u;
                var ku = 1.0;
                if (i != f.i0) {
                    du = (fma(uc, hu, breaks[i]) - breaks[f.i0]) / f.h0u - t.u;
                    ku = f.h0u / hu;
                }
                for (var b = 0u; b < nv; b++) {
                    var vc = t.v;
                    var dv = 0.0;
                    var kv = 1.0;
                    if (DV != 0u) {
                        vc = f32(b) / n;
                        dv = vc - t.v;
                        if (j != f.j0) {
                            dv = (fma(vc, hv, breaks[f.fv + j]) - breaks[f.fv + f.j0]) / f.h0v - t.v;
                            kv = f.h0v / hv;
                        }
                    }
                    let inside = du >= f.lo_u && du <= f.hi_u && dv >= f.lo_v && dv <= f.hi_v;
                    let e2 = offset_sq(k, uc, vc, taylor(rj, t, du, dv).val);
                    let c = Cand(e2, Seed(du, dv, uc, vc, ku, kv), here);
                    if (inside) {
                        pick = step_pick(pick, c, first || (DV != 0u && b == 0u));
                        first = false;
                    }
                }
            }
        }
    }
    if (pick.down) {
        pick = offer(pick, pick.last);
    }
    return pick;
}

// Descend from candidate c: hold its patch first.
fn descend_from(k: u32, ind: u32, t: Target, rj: RefJet, f: Frame, c: Cand) -> vec3<f32> {
    if (held[k] != c.at) {
        load_patch(k, ind, c.at);
    }
    return descend(k, ind, t, rj, f, c.s);
}

// The least squared offset of target t met in config.newton (>= 1) Newton steps on |r(Δ)|²
// from seed s, r(Δ) = T(Δ) + D(u, v): T the reference's Taylor polynomial, D the held
// difference patch at the local parameters Δ reaches. Δ is clamped to the frame's domain (with
// CROSS the steps cross borders, loading patches as they go); the result never exceeds the
// seed's offset.
fn descend(k: u32, ind: u32, t: Target, rj: RefJet, f: Frame, s: Seed) -> vec3<f32> {
    var du = s.du;
    var dv = s.dv;
    var u = s.u;
    var v = s.v;
    var ku = s.ku;
    var kv = s.kv;
    var best = 3.0e38;
    var it = 0u;
    loop {
        let e = jet(k, u, v);
        let tp = taylor(rj, t, du, dv);
        var r: array<f32, DIM>;
        var su: array<f32, DIM>;
        var sv: array<f32, DIM>;
        var suu: array<f32, DIM>;
        var suv: array<f32, DIM>;
        var svv: array<f32, DIM>;
        for (var c = 0u; c < DIM; c++) { // @unroll
            r[c] = tp.val[c] + e.s[c];
            su[c] = fma(ku, e.su[c], tp.du[c]);
            sv[c] = fma(kv, e.sv[c], tp.dv[c]);
            suu[c] = fma(ku * ku, e.suu[c], rj.suu[c]);
            suv[c] = fma(ku * kv, e.suv[c], rj.suv[c]);
            svv[c] = fma(kv * kv, e.svv[c], rj.svv[c]);
        }
        best = min(best, dot_n(r, r));
        let gu = dot_n(r, su);
        let gv = dot_n(r, sv);
        // Gauss-Newton part (semi-definite) and the full Hessian.
        let guu = dot_n(su, su);
        let guv = dot_n(su, sv);
        let gvv = dot_n(sv, sv);
        let huu = guu + dot_n(r, suu);
        let huv = guv + dot_n(r, suv);
        let hvv = gvv + dot_n(r, svv);
        var step_u = 0.0;
        var step_v = 0.0;
        let det = huu * hvv - huv * huv;
        let gdet = guu * gvv - guv * guv;
        if (huu > 0.0 && det > SINGULAR * huu * hvv) {
            step_u = (huv * gv - hvv * gu) / det;
            step_v = (huv * gu - huu * gv) / det;
        } else if (guu > 0.0 && gdet > SINGULAR * guu * gvv) {
            step_u = (guv * gv - gvv * gu) / gdet;
            step_v = (guv * gu - guu * gv) / gdet;
        } else {
            // Singular in one direction (a curve, or a degenerate row of the net): step along
            // each direction on its own, with the Newton or else the Gauss-Newton curvature.
            let cu = select(guu, huu, huu > 0.0);
            let cv = select(gvv, hvv, hvv > 0.0);
            if (cu > 0.0) {
                step_u = -gu / cu;
            }
            if (cv > 0.0) {
                step_v = -gv / cv;
            }
        }
        du = clamp(du + step_u, f.lo_u, f.hi_u);
        dv = clamp(dv + step_v, f.lo_v, f.hi_v);
        // The local parameters of Δ: in the start patch, or (CROSS) in the patch holding it.
        let wu = t.u + du;
        let wv = t.v + dv;
        if (CROSS == 0u) {
            u = clamp(wu, 0.0, 1.0);
            v = clamp(wv, 0.0, 1.0);
        } else {
            var i = f.i0;
            var j = f.j0;
            u = wu;
            v = wv;
            ku = 1.0;
            kv = 1.0;
            if (wu < 0.0 || wu > 1.0) {
                let l = locate(0u, config.patches_u, clamp(fma(wu, f.h0u, breaks[f.i0]), 0.0, 1.0));
                i = l.index;
                u = l.t;
                ku = f.h0u / (breaks[i + 1u] - breaks[i]);
            }
            if (wv < 0.0 || wv > 1.0) {
                let l = locate(f.fv, config.patches_v, clamp(fma(wv, f.h0v, breaks[f.fv + f.j0]), 0.0, 1.0));
                j = l.index;
                v = l.t;
                kv = f.h0v / (breaks[f.fv + j + 1u] - breaks[f.fv + j]);
            }
            let moved = i * config.patches_v + j;
            if (moved != held[k]) {
                load_patch(k, ind, moved);
            }
        }
        continuing {
            it++;
            break if it >= config.newton;
        }
    }
    return vec3<f32>(min(best, offset_sq(k, u, v, taylor(rj, t, du, dv).val)), du, dv);
}

// Squared closest-point offset of target t (individual `ind`, patch slot k; rj the
// reference's partials at t): the least of a descent from the start parameters and, with
// config.seeds, descents from the two candidate starts of `seed`, which find the global
// closest point where the start sits in another basin (a perturbed contour's fold, or its far
// end across the trailing edge). Leaves the start patch held.
fn foot_point_sq(k: u32, ind: u32, t: Target, rj: RefJet) -> f32 {
    let f = frame_of(t);
    let start = descend(k, ind, t, rj, f, Seed(0.0, 0.0, t.u, t.v, 1.0, 1.0));
    var e2 = start.x;
    if (SEEDED != 0u) {
        let pick = seed(k, ind, t, rj, f);
        let a = descend_from(k, ind, t, rj, f, pick.first);
        let b = descend_from(k, ind, t, rj, f, pick.second);
        let other = select(a, b, b.x < a.x);
        let apart = abs(other.y - start.y) + abs(other.z - start.z) > SAME_FOOT;
        e2 = select(e2, other.x, apart && other.x < e2);
    }
    if (CROSS != 0u && held[k] != t.patch_id) {
        load_patch(k, ind, t.patch_id);
    }
    return e2;
}

@compute @workgroup_size(WG)
fn main(ids: Ids) {
    // Lanes past the population compute on padding (the net is allocated for whole
    // workgroups of 64 individuals) and only their store is skipped: no early return, so the
    // point loops stay free of divergent control flow.
    let ind = ids.wid.x * 64u + ids.lane;
    let group = ids.wid.y;
    let first = group * config.group_points;
    let last = min(first + config.group_points, config.n_points);
    var sum: array<f32, PER>;
    var worst: array<f32, PER>;
    // One outer iteration per run of points on one patch, whose control points are loaded
    // once; the two variants are separate loops so that neither runs inside the other's `if`.
    var p = first;
    if (config.newton == 0u) {
        while (p < last) {
            let run = fetch_target(ids, p).patch_id;
            for (var k = 0u; k < PER; k++) { // @unroll
                load_patch(k, ind + k * WG, run);
            }
            while (p < last) {
                let t = fetch_target(ids, p);
                if (t.patch_id != run) {
                    break;
                }
                for (var k = 0u; k < PER; k++) { // @unroll
                    let e2 = offset_sq_fixed(k, t);
                    sum[k] += e2;
                    worst[k] = max(worst[k], e2);
                }
                p++;
            }
        }
    } else {
        while (p < last) {
            let run = fetch_target(ids, p).patch_id;
            for (var k = 0u; k < PER; k++) { // @unroll
                load_patch(k, ind + k * WG, run);
            }
            while (p < last) {
                let d = fetch_point(ids, p);
                if (d.t.patch_id != run) {
                    break;
                }
                for (var k = 0u; k < PER; k++) { // @unroll
                    let e2 = foot_point_sq(k, ind + k * WG, d.t, d.rj);
                    sum[k] += e2;
                    worst[k] = max(worst[k], e2);
                }
                p++;
            }
        }
    }
    for (var k = 0u; k < PER; k++) { // @unroll
        if (ind + k * WG < config.population) {
            partials[group * config.population + ind + k * WG] = Partial(sum[k], worst[k]);
        }
    }
}
