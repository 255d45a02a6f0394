//! eval_patch.wgsl: squared closest-point offsets of the target points, summed per individual.
//!
//! Mirrored by src/eval/cpu/eval_patch.rs (same bindings, same f32 arithmetic in the same order).
//!
//! One invocation owns one individual; the invocations of a workgroup walk the same group of
//! target points in the same order, so every per-point load (target, breaks) has the same
//! address in every lane. Targets are sorted by patch: the control points of a patch are
//! loaded into registers once per run of points on it and reused for all of them.
//! A curve is the one-dimensional case: DV = 0, one patch along v, DIM = 2.
//!
//! Written for a SIMD-on-CPU driver (Mesa lavapipe) as much as for GPUs: the body of an `if`
//! runs, masked, even when no lane takes it, so no expensive work sits under a per-point
//! condition; loops marked `// @unroll` have constant trip counts and are unrolled before
//! compilation (src/eval/gpu/unroll.rs), which turns every array index into a constant and
//! every array into registers.

// Specialised at pipeline creation (src/eval/gpu/mod.rs rewrites these lines with the
// layout's values); the values written here keep the file valid on its own for naga.
const DU: u32 = 3u;
const DV: u32 = 3u;
const DIM: u32 = 3u;
// 1: Newton steps may cross patch borders (reloading control points as they go); 0: they are
// clamped to the patch the point starts on.
const CROSS: u32 = 0u;

const NU: u32 = DU + 1u;
const NV: u32 = DV + 1u;
const NMAX: u32 = max(NU, NV);
// A 2x2 Newton system whose determinant is below this fraction of its diagonal product is
// treated as singular.
const SINGULAR: f32 = 1e-6;

// Must be kept in sync with `Config` in src/eval/kernel.rs and the other shaders.
struct Config {
    population: u32,
    net_stride: u32,
    n_vars: u32,
    n_ctrl: u32,
    n_points: u32,
    group_points: u32,
    n_groups: u32,
    newton: u32,
    patches_u: u32,
    patches_v: u32,
    net_cols: u32,
    grid_u: u32,
    grid_v: u32,
    degree_u: u32,
    degree_v: u32,
    dim: u32,
    cross: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Must be kept in sync with `Target` in src/eval/kernel.rs.
struct Target {
    x: f32,
    y: f32,
    z: f32,
    // Patch index i * patches_v + j.
    patch_id: u32,
    // Local parameters in that patch, in [0, 1].
    u: f32,
    v: f32,
    _pad0: u32,
    _pad1: u32,
}

// Must be kept in sync with `Partial` in src/eval/kernel.rs and reduce.wgsl.
struct Partial {
    sum_sq: f32,
    max_sq: f32,
}

@group(0) @binding(0) var<uniform> config: Config;
@group(0) @binding(1) var<storage, read> targets: array<Target>;
// breaks_u (patches_u + 1 values) followed by breaks_v (patches_v + 1 values).
@group(0) @binding(2) var<storage, read> breaks: array<f32>;
// Control nets as structure of arrays: coordinate c of control point r of individual i is
// net[(r * DIM + c) * net_stride + i], with r = row * net_cols + column.
@group(0) @binding(3) var<storage, read> net: array<f32>;
// partials[group * population + individual].
@group(0) @binding(4) var<storage, read_write> partials: array<Partial>;

// The control points of the patch this invocation holds, (a * NV + b) * DIM + c, and its index.
var<private> cp: array<f32, NU * NV * DIM>;
var<private> held: u32;

// Load the control points of patch `patch_id` of individual `ind` into `cp`.
fn load_patch(ind: u32, patch_id: u32) {
    held = patch_id;
    let i = patch_id / config.patches_v;
    let j = patch_id - i * config.patches_v;
    for (var a = 0u; a < NU; a++) { // @unroll
        for (var b = 0u; b < NV; b++) { // @unroll
            let r = (i * DU + a) * config.net_cols + j * DV + b;
            for (var c = 0u; c < DIM; c++) { // @unroll
                cp[(a * NV + b) * DIM + c] = net[(r * DIM + c) * config.net_stride + ind];
            }
        }
    }
}

// The degree-n Bernstein polynomials at t, n <= NMAX - 1 (the triangular recurrence of
// bezier::bernstein).
fn bernstein(n: u32, t: f32) -> array<f32, NMAX> {
    var out: array<f32, NMAX>;
    out[0] = 1.0;
    let s = 1.0 - t;
    for (var j = 1u; j < NMAX; j++) { // @unroll
        if (j <= n) {
            var saved = 0.0;
            for (var k = 0u; k < j; k++) { // @unroll
                let tmp = out[k];
                out[k] = fma(s, tmp, saved);
                saved = t * tmp;
            }
            out[j] = saved;
        }
    }
    return out;
}

// Squared distance from q to the held patch at local (u, v): the GA fitness kernel proper.
fn offset_sq(u: f32, v: f32, q: array<f32, 3>) -> f32 {
    let bu = bernstein(DU, u);
    let bv = bernstein(DV, v);
    var s: array<f32, DIM>;
    for (var a = 0u; a < NU; a++) { // @unroll
        for (var b = 0u; b < NV; b++) { // @unroll
            let w = bu[a] * bv[b];
            for (var c = 0u; c < DIM; c++) { // @unroll
                s[c] = fma(w, cp[(a * NV + b) * DIM + c], s[c]);
            }
        }
    }
    var e2 = 0.0;
    for (var c = 0u; c < DIM; c++) { // @unroll
        let d = s[c] - q[c];
        e2 = fma(d, d, e2);
    }
    return e2;
}

// Bernstein values with first and second derivatives.
struct Basis {
    b: array<f32, NMAX>,
    d1: array<f32, NMAX>,
    d2: array<f32, NMAX>,
}

// The degree-n basis at t with its derivatives (paper eq. 2 applied once and twice), taken
// from levels n - 1 and n - 2 of the same recurrence.
fn basis(n: u32, t: f32) -> Basis {
    var lvl: array<f32, NMAX>;
    var low1: array<f32, NMAX>;
    var low2: array<f32, NMAX>;
    lvl[0] = 1.0;
    let s = 1.0 - t;
    for (var j = 1u; j < NMAX; j++) { // @unroll
        if (j <= n) {
            if (j + 1u == n) {
                low2 = lvl;
            }
            if (j == n) {
                low1 = lvl;
            }
            var saved = 0.0;
            for (var k = 0u; k < j; k++) { // @unroll
                let tmp = lvl[k];
                lvl[k] = fma(s, tmp, saved);
                saved = t * tmp;
            }
            lvl[j] = saved;
        }
    }
    var out: Basis;
    out.b = lvl;
    let nf = f32(n);
    let nn = nf * (nf - 1.0);
    // low1[i - 1], low2[i - 2] and low2[i - 1], zero before the start.
    var l1 = 0.0;
    var l2a = 0.0;
    var l2b = 0.0;
    for (var i = 0u; i < NMAX; i++) { // @unroll
        if (i <= n) {
            out.d1[i] = nf * (l1 - low1[i]);
            out.d2[i] = nn * ((l2a - 2.0 * l2b) + low2[i]);
            l1 = low1[i];
            l2a = l2b;
            l2b = low2[i];
        }
    }
    return out;
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

// The held patch and its partials at local (u, v): rows contracted along v first, then along u.
fn jet(u: f32, v: f32) -> Jet {
    let bu = basis(DU, u);
    let bv = basis(DV, v);
    var out: Jet;
    for (var a = 0u; a < NU; a++) { // @unroll
        var r0: array<f32, DIM>;
        var r1: array<f32, DIM>;
        var r2: array<f32, DIM>;
        for (var b = 0u; b < NV; b++) { // @unroll
            for (var c = 0u; c < DIM; c++) { // @unroll
                let p = cp[(a * NV + b) * DIM + c];
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

// A segment of a chain and the local parameter in it.
struct Located {
    index: u32,
    t: f32,
}

// Move local parameter t of segment k (of a chain whose breaks start at breaks[first], with
// `count` segments) to the segment holding it, clamped to the chain's domain [0, 1].
fn relocate(first: u32, count: u32, k: u32, t: f32) -> Located {
    let t0 = breaks[first + k];
    let g = clamp(fma(t, breaks[first + k + 1u] - t0, t0), 0.0, 1.0);
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

// Squared closest-point offset of q, from config.newton (>= 1) Newton steps on
// |S(u, v) - q|^2 started at the target's local (u, v) on the held patch. Steps are clamped
// to that patch, or with CROSS move across borders (clamped to the domain); the result is the
// least squared distance met on the way, so it never exceeds the start's.
fn foot_point_sq(ind: u32, t: Target, q: array<f32, 3>) -> f32 {
    var i = t.patch_id / config.patches_v;
    var j = t.patch_id - i * config.patches_v;
    var u = t.u;
    var v = t.v;
    var best = 3.0e38;
    var it = 0u;
    loop {
        let e = jet(u, v);
        var r: array<f32, DIM>;
        for (var c = 0u; c < DIM; c++) { // @unroll
            r[c] = e.s[c] - q[c];
        }
        best = min(best, dot_n(r, r));
        let gu = dot_n(r, e.su);
        let gv = dot_n(r, e.sv);
        // Gauss-Newton part (semi-definite) and the full Hessian.
        let guu = dot_n(e.su, e.su);
        let guv = dot_n(e.su, e.sv);
        let gvv = dot_n(e.sv, e.sv);
        let huu = guu + dot_n(r, e.suu);
        let huv = guv + dot_n(r, e.suv);
        let hvv = gvv + dot_n(r, e.svv);
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
        u = u + step_u;
        v = v + step_v;
        if (CROSS == 0u) {
            u = clamp(u, 0.0, 1.0);
            v = clamp(v, 0.0, 1.0);
        } else {
            if (u < 0.0 || u > 1.0) {
                let l = relocate(0u, config.patches_u, i, u);
                i = l.index;
                u = l.t;
            }
            if (v < 0.0 || v > 1.0) {
                let l = relocate(config.patches_u + 1u, config.patches_v, j, v);
                j = l.index;
                v = l.t;
            }
            let moved = i * config.patches_v + j;
            if (moved != held) {
                load_patch(ind, moved);
            }
        }
        continuing {
            it++;
            break if it >= config.newton;
        }
    }
    let e2 = min(best, offset_sq(u, v, q));
    if (CROSS != 0u && held != t.patch_id) {
        load_patch(ind, t.patch_id);
    }
    return e2;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    // Lanes past the population compute on padding (the net is allocated for whole
    // workgroups) and only their store is skipped: no early return, so the point loops stay
    // free of divergent control flow.
    let ind = gid.x;
    let group = gid.y;
    let first = group * config.group_points;
    let last = min(first + config.group_points, config.n_points);
    var sum = 0.0;
    var worst = 0.0;
    // One outer iteration per run of points on one patch, whose control points are loaded
    // once; the two variants are separate loops so that neither runs inside the other's `if`.
    var p = first;
    if (config.newton == 0u) {
        while (p < last) {
            let run = targets[p].patch_id;
            load_patch(ind, run);
            while (p < last) {
                let t = targets[p];
                if (t.patch_id != run) {
                    break;
                }
                let e2 = offset_sq(t.u, t.v, array<f32, 3>(t.x, t.y, t.z));
                sum += e2;
                worst = max(worst, e2);
                p++;
            }
        }
    } else {
        while (p < last) {
            let run = targets[p].patch_id;
            load_patch(ind, run);
            while (p < last) {
                let t = targets[p];
                if (t.patch_id != run) {
                    break;
                }
                let e2 = foot_point_sq(ind, t, array<f32, 3>(t.x, t.y, t.z));
                sum += e2;
                worst = max(worst, e2);
                p++;
            }
        }
    }
    if (ind < config.population) {
        partials[group * config.population + ind] = Partial(sum, worst);
    }
}
