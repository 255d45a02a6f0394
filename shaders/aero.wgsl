// The inviscid linear-vorticity panel method (XFOIL's formulation) for a whole population:
// one invocation per individual. Its design vector goes through the node map to the panel
// nodes; the (N+1)² stream-function system is assembled and solved for the two unit free
// streams (α = 0°, 90°); CL, CM, the thickness, the objective and the score come out.
//
// CPU mirror: src/aero/batch/cpu.rs (same name, same bindings, the same f32 arithmetic line for
// line). The f64 reference is src/aero/panel.rs with src/aero/batch/mod.rs.
//
// Each individual's working set lives in `work`, interleaved: element `e` of individual `i` at
// `e * config.stride + i`, so neighbouring invocations touch neighbouring words. Elements:
// nodes (2N), the matrix ((N+1)², row-major), two right-hand sides (2(N+1)), which hold the two
// unit solutions after the solve, and 16 scalars (status, chord and trailing edge).
//
// The work runs in phases, one dispatch each, all in one submission (`step` says which phase
// and which rows or steps): nodes; assembly rows; elimination steps; back-substitution rows;
// the coefficients and the score. Mesa's llvmpipe (lavapipe) ends every loop of an invocation
// once all its loops together have run 65535 iterations, so the host cuts the assembly, the
// elimination and the back substitution into dispatches of at most 60000 iterations each.
//
// Unknowns: γ at the N nodes, then Ψ₀. Rows: Ψ(node i) = Ψ₀ (the last one replaced by the
// bisector condition at a sharp trailing edge), then the Kutta condition. The first N − 1
// columns are eliminated without pivoting (the stream-function block is a discretised
// logarithmic single layer, near symmetric definite on unit-chord shapes); the last 2 × 2 block
// is solved directly.

// Must be kept in sync with `AeroConfig` in src/aero/batch/kernel.rs.
struct AeroConfig {
    population: u32,
    stride: u32,
    n_vars: u32,
    n_nodes: u32,
    objective: u32,
    target_samples: u32,
    constraints: u32,
    _pad0: u32,
    cos_alpha: f32,
    sin_alpha: f32,
    min_thickness: f32,
    cm_min: f32,
}

// One dispatch of the plan. Must be kept in sync with `AeroStep` in src/aero/batch/kernel.rs.
struct AeroStep {
    phase: u32,
    first: u32,
    last: u32,
    _pad0: u32,
}

// Must be kept in sync with `AeroResult` in src/aero/batch/kernel.rs.
struct AeroResult {
    cl: f32,
    cm: f32,
    thickness: f32,
    objective: f32,
    score: f32,
    flags: u32,
    violation: f32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> config: AeroConfig;
@group(0) @binding(1) var<storage, read> node_map: array<f32>;
@group(0) @binding(2) var<storage, read> node_base: array<f32>;
@group(0) @binding(3) var<storage, read> target_cp: array<f32>;
@group(0) @binding(4) var<storage, read> population: array<f32>;
@group(0) @binding(5) var<storage, read_write> work: array<f32>;
@group(0) @binding(6) var<storage, read_write> results: array<AeroResult>;
@group(0) @binding(7) var<uniform> step: AeroStep;

const QOPI: f32 = 0.07957747;
const HOPI: f32 = 0.15915494;
const PI: f32 = 3.14159265;
const SHARP_GAP: f32 = 1e-4;
const BISECTOR_OFFSET: f32 = 0.1;
const FOLD_TOLERANCE: f32 = 1e-3;
// Surfaces that swap by less than this (per chord) do not cross: f32 cannot tell a closed
// trailing edge, whose upper and lower nodes meet, from one crossed by rounding (an H200
// put a closed NACA 4415 edge 1e-11 on the wrong side where lavapipe put it on neither).
const CROSS_TOLERANCE: f32 = 1e-6;
const TINY: f32 = 1e-20;

const OBJECTIVE_NONE: u32 = 0u;
const OBJECTIVE_MAX_CL: u32 = 1u;
const OBJECTIVE_INVERSE: u32 = 2u;
const CONSTRAIN_THICKNESS: u32 = 1u;
const CONSTRAIN_CM: u32 = 2u;

const FLAG_NON_FINITE: u32 = 1u;
const FLAG_FOLD: u32 = 2u;
const FLAG_CROSSING: u32 = 4u;
const FLAG_SINGULAR: u32 = 8u;
const FLAG_THIN: u32 = 16u;
const FLAG_CM: u32 = 32u;
const FLAGS_GEOMETRY: u32 = 15u;

const PHASE_NODES: u32 = 0u;
const PHASE_ASSEMBLE: u32 = 1u;
const PHASE_ELIMINATE: u32 = 2u;
const PHASE_BACK: u32 = 3u;
const PHASE_FINISH: u32 = 4u;

// The scalars after the right-hand sides.
const S_STATUS: u32 = 0u;
const S_KLE: u32 = 1u;
const S_LE: u32 = 2u;
const S_TE: u32 = 4u;
const S_CHORD: u32 = 6u;
const S_SHARP: u32 = 7u;
const S_CLOSED: u32 = 8u;
const S_SCS: u32 = 9u;
const S_SDS: u32 = 10u;
const S_FB: u32 = 11u;
const S_NB: u32 = 13u;
const S_LE_AFTER: u32 = 15u;

const PENALTY_GEOMETRY: f32 = 1e6;
const PENALTY_CONSTRAINT: f32 = 1e3;
const MAX_VIOLATION: f32 = 1e5;

var<private> ind: u32;

fn at(e: u32) -> u32 {
    return e * config.stride + ind;
}

fn node(k: u32) -> vec2<f32> {
    return vec2<f32>(work[at(2u * k)], work[at(2u * k + 1u)]);
}

fn mat(i: u32, j: u32) -> u32 {
    let n1 = config.n_nodes + 1u;
    return at(2u * config.n_nodes + i * n1 + j);
}

fn rhs(r: u32, i: u32) -> u32 {
    let n1 = config.n_nodes + 1u;
    return at(2u * config.n_nodes + n1 * n1 + r * n1 + i);
}

fn scalar(k: u32) -> u32 {
    let n1 = config.n_nodes + 1u;
    return at(2u * config.n_nodes + n1 * n1 + 2u * n1 + k);
}

fn scalar2(k: u32) -> vec2<f32> {
    return vec2<f32>(work[scalar(k)], work[scalar(k + 1u)]);
}

fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// ln(x) for x > 0 (x = m 2^e, m in [√½, √2), ln m = 2 atanh s): ~1 ulp; 0 for x <= 0.
fn ln(x: f32) -> f32 {
    let bits = bitcast<u32>(x);
    var e = i32((bits >> 23u) & 0xffu) - 127;
    var m = bitcast<f32>((bits & 0x007fffffu) | 0x3f800000u);
    let big = m > 1.41421356;
    m = select(m, 0.5 * m, big);
    e = select(e, e + 1, big);
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    let p = s * (2.0 + z * (0.6666667 + z * (0.4 + z * (0.2857143 + z * 0.2222222))));
    let r = p + f32(e) * 0.6931472;
    return select(0.0, r, x > 0.0);
}

// atan2(y, x) in (−π, π], 0 at (0, 0) (Cephes' atanf reduction and polynomial).
fn atan2r(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let swap = ay > ax;
    let num = select(ay, ax, swap);
    let den = select(ax, ay, swap);
    let t = select(num / den, 0.0, den == 0.0);
    // atan t on [0, 1]: reduce by π/4 above tan(π/8).
    let high = t > 0.41421356;
    let u = select(t, (t - 1.0) / (t + 1.0), high);
    let z = u * u;
    let poly = (((0.0805374449538 * z - 0.138776856032) * z + 0.199777106478) * z - 0.333329491539) * z * u + u;
    var a = select(poly, poly + 0.78539816, high);
    a = select(a, 1.57079633 - a, swap);
    a = select(a, PI - a, x < 0.0);
    return select(a, -a, y < 0.0);
}

// Panels seen from farther than 5 panel lengths (from their midpoint) take the integrals'
// Taylor series about the midpoint: the closed forms lose |r|/L of f32's digits there (their
// terms are of size |r|² ln|r| where the result is of size L |r|), the series none; its first
// neglected term is below 1e-7 of the result at that distance.
const FAR2: f32 = 25.0;

// A panel a → b seen from f: its length, unit direction, and f's coordinates along (c) and
// across (y) it from its midpoint, with rho = c² + y² (what the far-field series take).
struct Far {
    s: vec2<f32>,
    len: f32,
    len2: f32,
    c: f32,
    y: f32,
    c2: f32,
    y2: f32,
    rho: f32,
}

fn unit_along(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let d = b - a;
    return d / sqrt(d.x * d.x + d.y * d.y);
}

fn far_frame(f: vec2<f32>, a: vec2<f32>, b: vec2<f32>) -> Far {
    let d = b - a;
    let len2 = d.x * d.x + d.y * d.y;
    let len = sqrt(len2);
    let s = d / len;
    let rm = f - 0.5 * (a + b);
    let c = s.x * rm.x + s.y * rm.y;
    let y = s.x * rm.y - s.y * rm.x;
    let c2 = c * c;
    let y2 = y * y;
    return Far(s, len, len2, c, y, c2, y2, c2 + y2);
}

// The source stream function's far-field series.
fn far_psis(p: Far) -> f32 {
    let g = ln(p.rho);
    let g2 = 2.0 * (p.y2 - p.c2) / (p.rho * p.rho);
    let g4 = -12.0 * (p.c2 * p.c2 - 6.0 * p.c2 * p.y2 + p.y2 * p.y2) / (p.rho * p.rho * p.rho * p.rho);
    return 0.5 * p.len * g + p.len * p.len2 / 48.0 * g2 + p.len * p.len2 * p.len2 / 3840.0 * g4;
}

// The closed forms' shared terms for f and panel a → b with unit direction s: f's coordinates
// along (x1, x2 from each end) and across (yy) the panel, the squared distances and their logs,
// the angle the panel subtends (sub) and the source stream function psis.
struct Near {
    x1: f32,
    x2: f32,
    yy: f32,
    rs1: f32,
    rs2: f32,
    g1: f32,
    g2: f32,
    sub: f32,
    psis: f32,
}

fn near_frame(f: vec2<f32>, a: vec2<f32>, b: vec2<f32>, s: vec2<f32>) -> Near {
    let r1 = f - a;
    let r2 = f - b;
    let x1 = s.x * r1.x + s.y * r1.y;
    let x2 = s.x * r2.x + s.y * r2.y;
    let yy = s.x * r1.y - s.y * r1.x;
    let rs1 = r1.x * r1.x + r1.y * r1.y;
    let rs2 = r2.x * r2.x + r2.y * r2.y;
    let g1 = ln(rs1);
    let g2 = ln(rs2);
    let sub = atan2r(r1.x * r2.y - r1.y * r2.x, r1.x * r2.x + r1.y * r2.y);
    let psis = 0.5 * x1 * g1 - 0.5 * x2 * g2 + x2 - x1 + yy * sub;
    return Near(x1, x2, yy, rs1, rs2, g1, g2, sub, psis);
}

// The linear-vortex stream function.
fn near_psid(n: Near) -> f32 {
    return ((n.x1 + n.x2) * n.psis + 0.5 * (n.rs2 * n.g2 - n.rs1 * n.g1 + n.x1 * n.x1 - n.x2 * n.x2)) / (n.x1 - n.x2);
}

// The angles from each end, 0 at the end itself.
fn near_thetas(n: Near) -> vec2<f32> {
    return vec2<f32>(select(0.0, atan2r(n.x1, n.yy), n.rs1 > 0.0), select(0.0, atan2r(n.x2, n.yy), n.rs2 > 0.0));
}

// The vortex integrals of panel a → b at f (src/aero/panel.rs `panel_terms`) from the Taylor
// series about the midpoint: (psis, psid, 1 if the panel is far, else 0).
fn vortex_far(f: vec2<f32>, a: vec2<f32>, b: vec2<f32>) -> vec3<f32> {
    let p = far_frame(f, a, b);
    let g1 = 2.0 * p.c / p.rho;
    let g3 = 4.0 * p.c * (p.c2 - 3.0 * p.y2) / (p.rho * p.rho * p.rho);
    let psid = -p.len2 / 12.0 * g1 - p.len2 * p.len2 / 480.0 * g3;
    return vec3<f32>(far_psis(p), psid, select(0.0, 1.0, p.rho > FAR2 * p.len2));
}

// The same from the closed forms (near panels): (psis, psid).
fn vortex_near(f: vec2<f32>, a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let n = near_frame(f, a, b, unit_along(a, b));
    return vec2<f32>(n.psis, near_psid(n));
}

// The vortex integrals: the series when the panel is far, else the closed forms.
fn vortex_terms(f: vec2<f32>, a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let t = vortex_far(f, a, b);
    if t.z != 0.0 {
        return t.xy;
    }
    return vortex_near(f, a, b);
}

// The uniform vortex and source integrals of the trailing-edge panel a → b at f: (psis, psig).
fn source_terms(f: vec2<f32>, a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let p = far_frame(f, a, b);
    if p.rho > FAR2 * p.len2 {
        let t = atan2r(p.c, p.y);
        let t2 = -2.0 * p.c * p.y / (p.rho * p.rho);
        return vec2<f32>(far_psis(p), -(p.len * t + p.len * p.len2 / 24.0 * t2));
    }
    let n = near_frame(f, a, b, p.s);
    let t = near_thetas(n);
    return vec2<f32>(n.psis, 0.5 * n.yy * (n.g1 - n.g2) + n.x2 * t.y - n.x1 * t.x);
}

// The derivatives of the same along nv: (d psis, d psid, d psig).
fn panel_derivs(f: vec2<f32>, a: vec2<f32>, b: vec2<f32>, nv: vec2<f32>) -> vec3<f32> {
    let s = unit_along(a, b);
    let n = near_frame(f, a, b, s);
    let psid = near_psid(n);
    let t = near_thetas(n);
    let x1 = n.x1;
    let x2 = n.x2;
    let dx = x1 - x2;
    let xn = s.x * nv.x + s.y * nv.y;
    let yn = s.x * nv.y - s.y * nv.x;
    let psx1 = 0.5 * n.g1;
    let psx2 = -0.5 * n.g2;
    let pdx1 = ((x1 + x2) * psx1 + n.psis - x1 * n.g1 - psid) / dx;
    let pdx2 = ((x1 + x2) * psx2 + n.psis + x2 * n.g2 + psid) / dx;
    let pdyy = ((x1 + x2) * n.sub - n.yy * (n.g1 - n.g2)) / dx;
    return vec3<f32>((psx1 + psx2) * xn + n.sub * yn, (pdx1 + pdx2) * xn + pdyy * yn, (t.y - t.x) * xn + 0.5 * (n.g1 - n.g2) * yn);
}

// The unit tangent at p0 of the parabola through p0, p1, p2 (chord-length spacing), pointing
// away from p1.
fn end_tangent(p0: vec2<f32>, p1: vec2<f32>, p2: vec2<f32>) -> vec2<f32> {
    let h1 = length(p1 - p0);
    let h2 = length(p2 - p1);
    let d = (p1 - p0) * ((h1 + h2) / (h1 * h2)) - (p2 - p0) * (h1 / (h2 * (h1 + h2)));
    let l = length(d);
    return select(vec2<f32>(0.0, 0.0), -d / l, l > 0.0);
}

fn finish(out: AeroResult) {
    results[ind] = out;
}

// Score of an individual whose geometry or solve failed.
fn failed(flags: u32, violation: f32) -> AeroResult {
    var out: AeroResult;
    out.cl = 0.0;
    out.cm = 0.0;
    out.thickness = 0.0;
    out.objective = 0.0;
    out.flags = flags;
    out.violation = min(violation, MAX_VIOLATION);
    out.score = PENALTY_GEOMETRY + out.violation;
    out._pad0 = 0u;
    return out;
}

// Phase 0: the nodes (base + map · design), their checks, the chord and the trailing edge.
fn phase_nodes() {
    let n = config.n_nodes;
    let nv = config.n_vars;
    var bad = false;
    for (var e = 0u; e < 2u * n; e++) {
        var v = node_base[e];
        for (var i = 0u; i < nv; i++) {
            v = v + node_map[e * nv + i] * population[ind * nv + i];
        }
        bad = bad || !finite(v);
        work[at(e)] = v;
    }
    // Status: 0 alive, 1 failed (its result already written).
    work[scalar(S_STATUS)] = 1.0;
    if bad {
        finish(failed(FLAG_NON_FINITE, MAX_VIOLATION));
        return;
    }
    for (var k = 0u; k + 1u < n; k++) {
        let d = node(k + 1u) - node(k);
        if d.x == 0.0 && d.y == 0.0 {
            finish(failed(FLAG_SINGULAR, MAX_VIOLATION));
            return;
        }
    }
    // The chord: leading edge farthest from the trailing-edge midpoint, refined by a parabola.
    let te = 0.5 * (node(0u) + node(n - 1u));
    var kle = 1u;
    var far = -1.0;
    for (var k = 1u; k + 1u < n; k++) {
        let r = node(k) - te;
        let d2 = r.x * r.x + r.y * r.y;
        if d2 > far {
            far = d2;
            kle = k;
        }
    }
    let pa = node(kle - 1u);
    let pb = node(kle);
    let pc = node(kle + 1u);
    let h0 = length(pb - pa);
    let h1 = length(pc - pb);
    let d0 = length(pa - te);
    let d1 = length(pb - te);
    let d2 = length(pc - te);
    let denom = h0 * h1 * (h0 + h1);
    let curv = 2.0 * (h0 * (d2 - d1) - h1 * (d1 - d0)) / denom;
    let slope = (h0 * h0 * (d2 - d1) + h1 * h1 * (d1 - d0)) / denom;
    let sv = select(0.0, clamp(-slope / curv, -h0, h1), curv < 0.0);
    let la = sv * (sv - h1) / (h0 * (h0 + h1));
    let lb = (sv + h0) * (h1 - sv) / (h0 * h1);
    let lc = sv * (sv + h0) / (h1 * (h0 + h1));
    let le = la * pa + lb * pb + lc * pc;
    let chord = length(te - le);
    if !(chord > TINY) || !finite(chord) {
        finish(failed(FLAG_SINGULAR, MAX_VIOLATION));
        return;
    }
    // The trailing edge: gap, source and vortex weights, the bisector control point.
    let gap = node(0u) - node(n - 1u);
    let aft_first = end_tangent(node(0u), node(1u), node(2u));
    let aft_last = end_tangent(node(n - 1u), node(n - 2u), node(n - 3u));
    let mean = 0.5 * (aft_first + aft_last);
    let dste = length(gap);
    let sharp = dste < SHARP_GAP * chord;
    let closed = dste == 0.0;
    let ml = length(mean);
    let bis = select(vec2<f32>(1.0, 0.0), mean / ml, ml > 0.0);
    let ds = min(length(node(0u) - node(1u)), length(node(n - 1u) - node(n - 2u)));
    let fb = 0.5 * (node(0u) + node(n - 1u)) - BISECTOR_OFFSET * ds * bis;
    work[scalar(S_STATUS)] = 0.0;
    work[scalar(S_KLE)] = f32(kle);
    work[scalar(S_LE)] = le.x;
    work[scalar(S_LE + 1u)] = le.y;
    work[scalar(S_TE)] = te.x;
    work[scalar(S_TE + 1u)] = te.y;
    work[scalar(S_CHORD)] = chord;
    work[scalar(S_SHARP)] = select(0.0, 1.0, sharp);
    work[scalar(S_CLOSED)] = select(0.0, 1.0, closed);
    work[scalar(S_SCS)] = select((mean.x * gap.y - mean.y * gap.x) / dste, 1.0, sharp);
    work[scalar(S_SDS)] = select((mean.x * gap.x + mean.y * gap.y) / dste, 0.0, sharp);
    work[scalar(S_FB)] = fb.x;
    work[scalar(S_FB + 1u)] = fb.y;
    work[scalar(S_NB)] = -bis.y;
    work[scalar(S_NB + 1u)] = bis.x;
    // The leading edge lies after node kle: kle is on the upper surface.
    work[scalar(S_LE_AFTER)] = select(0.0, 1.0, sv > 0.0);
}

// Phase 1: Ψ at nodes first..last (rows); with the last row, the sharp edge's bisector row
// and the Kutta row.
fn phase_assemble(first: u32, last: u32) {
    let n = config.n_nodes;
    let closed = work[scalar(S_CLOSED)] != 0.0;
    let scs = work[scalar(S_SCS)];
    let sds = work[scalar(S_SDS)];
    for (var i = first; i < last; i++) {
        let f = node(i);
        var a = node(0u);
        var carry = 0.0;
        for (var j = 0u; j + 1u < n; j++) {
            let b = node(j + 1u);
            let t = vortex_terms(f, a, b);
            work[mat(i, j)] = carry + QOPI * (t.x - t.y);
            carry = QOPI * (t.x + t.y);
            a = b;
        }
        work[mat(i, n - 1u)] = carry;
        if !closed {
            let t = source_terms(f, node(n - 1u), node(0u));
            let w = HOPI * (0.5 * scs * t.y - 0.5 * sds * t.x);
            work[mat(i, 0u)] = work[mat(i, 0u)] + w;
            work[mat(i, n - 1u)] = work[mat(i, n - 1u)] - w;
        }
        work[mat(i, n)] = -1.0;
        work[rhs(0u, i)] = -f.y;
        work[rhs(1u, i)] = f.x;
    }
    if last < n {
        return;
    }
    if work[scalar(S_SHARP)] != 0.0 {
        // Zero velocity along the bisector just inside the trailing edge replaces the last row.
        let f = scalar2(S_FB);
        let nb = scalar2(S_NB);
        var carry = 0.0;
        for (var j = 0u; j + 1u < n; j++) {
            let t = panel_derivs(f, node(j), node(j + 1u), nb);
            work[mat(n - 1u, j)] = carry + QOPI * (t.x - t.y);
            carry = QOPI * (t.x + t.y);
        }
        work[mat(n - 1u, n - 1u)] = carry;
        if !closed {
            let t = panel_derivs(f, node(n - 1u), node(0u), nb);
            let w = HOPI * (0.5 * scs * t.z - 0.5 * sds * t.x);
            work[mat(n - 1u, 0u)] = work[mat(n - 1u, 0u)] + w;
            work[mat(n - 1u, n - 1u)] = work[mat(n - 1u, n - 1u)] - w;
        }
        work[mat(n - 1u, n)] = 0.0;
        // The bisector is (nb.y, −nb.x).
        work[rhs(0u, n - 1u)] = -nb.y;
        work[rhs(1u, n - 1u)] = nb.x;
    }
    // Kutta: γ_first + γ_last = 0.
    for (var j = 0u; j <= n; j++) {
        work[mat(n, j)] = 0.0;
    }
    work[mat(n, 0u)] = 1.0;
    work[mat(n, n - 1u)] = 1.0;
    work[rhs(0u, n)] = 0.0;
    work[rhs(1u, n)] = 0.0;
}

// Phase 2: elimination steps first..last of the first N − 1 columns, without pivoting.
fn phase_eliminate(first: u32, last: u32) {
    let n = config.n_nodes;
    for (var k = first; k < last; k++) {
        let inv = 1.0 / work[mat(k, k)];
        let b0 = work[rhs(0u, k)];
        let b1 = work[rhs(1u, k)];
        for (var i = k + 1u; i <= n; i++) {
            let l = work[mat(i, k)] * inv;
            for (var j = k + 1u; j <= n; j++) {
                work[mat(i, j)] = work[mat(i, j)] - l * work[mat(k, j)];
            }
            work[rhs(0u, i)] = work[rhs(0u, i)] - l * b0;
            work[rhs(1u, i)] = work[rhs(1u, i)] - l * b1;
        }
    }
}

// Phase 3: back substitution of rows last−1 down to first (the first dispatch, last = N − 1,
// solves the final 2 × 2 block of γ_last and Ψ₀ first).
fn phase_back(first: u32, last: u32) {
    let n = config.n_nodes;
    if last == n - 1u {
        let p = work[mat(n - 1u, n - 1u)];
        let q = work[mat(n - 1u, n)];
        let r = work[mat(n, n - 1u)];
        let s = work[mat(n, n)];
        let det = p * s - q * r;
        for (var c = 0u; c < 2u; c++) {
            let u = work[rhs(c, n - 1u)];
            let v = work[rhs(c, n)];
            work[rhs(c, n - 1u)] = (u * s - q * v) / det;
            work[rhs(c, n)] = (p * v - r * u) / det;
        }
    }
    for (var c = 0u; c < 2u; c++) {
        for (var kk = first; kk < last; kk++) {
            let k = last - 1u - (kk - first);
            var acc = work[rhs(c, k)];
            for (var j = k + 1u; j <= n; j++) {
                acc = acc - work[mat(k, j)] * work[rhs(c, j)];
            }
            work[rhs(c, k)] = acc / work[mat(k, k)];
        }
    }
}

// Phase 4: the pivots' check, CL and CM, the geometry checks, the objective and the score.
fn phase_finish() {
    let n = config.n_nodes;
    // The pivots of the elimination sit on the diagonal; the 2 × 2 block's determinant is
    // recomputed from its (unchanged) entries.
    var singular = false;
    for (var k = 0u; k + 1u < n; k++) {
        singular = singular || !(abs(work[mat(k, k)]) > TINY);
    }
    let det = work[mat(n - 1u, n - 1u)] * work[mat(n, n)] - work[mat(n - 1u, n)] * work[mat(n, n - 1u)];
    singular = singular || !(abs(det) > TINY);
    if singular {
        finish(failed(FLAG_SINGULAR, MAX_VIOLATION));
        return;
    }
    let kle = u32(work[scalar(S_KLE)]);
    let le_after = work[scalar(S_LE_AFTER)] != 0.0;
    let le = scalar2(S_LE);
    let te = scalar2(S_TE);
    let chord = work[scalar(S_CHORD)];

    // CL and CM: trapezoidal Cp per panel, trailing-edge panel included, wind axes, per chord.
    let ca = config.cos_alpha;
    let sa = config.sin_alpha;
    let quarter = le + 0.25 * (te - le);
    var cl = 0.0;
    var cm = 0.0;
    var gi = ca * work[rhs(0u, 0u)] + sa * work[rhs(1u, 0u)];
    var cpi = 1.0 - gi * gi;
    for (var i = 0u; i < n; i++) {
        let j = select(i + 1u, 0u, i + 1u == n);
        let gj = ca * work[rhs(0u, j)] + sa * work[rhs(1u, j)];
        let cpj = 1.0 - gj * gj;
        let d = node(j) - node(i);
        let mid = 0.5 * (node(j) + node(i)) - quarter;
        let dx = d.x * ca + d.y * sa;
        let dy = d.y * ca - d.x * sa;
        let ax = mid.x * ca + mid.y * sa;
        let ay = mid.y * ca - mid.x * sa;
        let ag = 0.5 * (cpi + cpj);
        let dg = cpj - cpi;
        cl = cl + dx * ag;
        cm = cm - (dx * (ag * ax + dg * dx / 12.0) + dy * (ag * ay + dg * dy / 12.0));
        cpi = cpj;
    }
    cl = cl / chord;
    cm = cm / (chord * chord);

    // Geometry in chord axes: X from the leading edge along the chord, Y across, per chord.
    let cdir = (te - le) / chord;
    var flags = 0u;
    var violation = 0.0;
    // Each surface must run monotonically in X: upper from the trailing edge to the leading
    // edge, lower back.
    for (var k = 0u; k < kle; k++) {
        let x0 = dot(node(k) - le, cdir) / chord;
        let x1 = dot(node(k + 1u) - le, cdir) / chord;
        let back = x1 - x0;
        if back > FOLD_TOLERANCE {
            flags = flags | FLAG_FOLD;
            violation = max(violation, back);
        }
    }
    for (var k = kle; k + 1u < n; k++) {
        let x0 = dot(node(k) - le, cdir) / chord;
        let x1 = dot(node(k + 1u) - le, cdir) / chord;
        let back = x0 - x1;
        if back > FOLD_TOLERANCE {
            flags = flags | FLAG_FOLD;
            violation = max(violation, back);
        }
    }
    // Thickness: each upper node against the lower surface at its X.
    var thick = 0.0;
    var m = kle;
    for (var kk = 0u; kk < kle; kk++) {
        let k = kle - 1u - kk;
        let pu = node(k) - le;
        let xu = dot(pu, cdir) / chord;
        let yu = (cdir.x * pu.y - cdir.y * pu.x) / chord;
        while m + 2u < n && dot(node(m + 1u) - le, cdir) / chord < xu {
            m = m + 1u;
        }
        let pl0 = node(m) - le;
        let pl1 = node(m + 1u) - le;
        let xl0 = dot(pl0, cdir) / chord;
        let xl1 = dot(pl1, cdir) / chord;
        let yl0 = (cdir.x * pl0.y - cdir.y * pl0.x) / chord;
        let yl1 = (cdir.x * pl1.y - cdir.y * pl1.x) / chord;
        if xu >= xl0 && xu <= xl1 && xl1 > xl0 {
            let yl = yl0 + (xu - xl0) / (xl1 - xl0) * (yl1 - yl0);
            let t = yu - yl;
            thick = max(thick, t);
            if t < -CROSS_TOLERANCE {
                flags = flags | FLAG_CROSSING;
                violation = max(violation, -t);
            }
        }
    }
    // The trailing-edge ends must not swap.
    let pu = node(0u) - le;
    let pl = node(n - 1u) - le;
    let te_cross = ((cdir.x * pl.y - cdir.y * pl.x) - (cdir.x * pu.y - cdir.y * pu.x)) / chord;
    if te_cross > CROSS_TOLERANCE {
        flags = flags | FLAG_CROSSING;
        violation = max(violation, te_cross);
    }
    if !finite(cl) || !finite(cm) {
        flags = flags | FLAG_NON_FINITE;
        violation = MAX_VIOLATION;
    }
    if (flags & FLAGS_GEOMETRY) != 0u {
        finish(failed(flags, violation));
        return;
    }

    // The objective.
    var objective = 0.0;
    if config.objective == OBJECTIVE_MAX_CL {
        objective = -cl;
    } else if config.objective == OBJECTIVE_INVERSE {
        // Mean square of Cp − Cp_target over the surface (arclength weights), the target
        // tabulated per surface against ξ = √X at target_samples even steps.
        let ns = config.target_samples;
        var sum = 0.0;
        var wsum = 0.0;
        for (var k = 0u; k < n; k++) {
            let prev = select(k - 1u, 0u, k == 0u);
            let next = select(k + 1u, n - 1u, k + 1u == n);
            let w = 0.5 * (length(node(k) - node(prev)) + length(node(next) - node(k)));
            let xk = max(dot(node(k) - le, cdir) / chord, 0.0);
            let xi = min(sqrt(xk), 1.0) * f32(ns - 1u);
            let lo = min(u32(xi), ns - 2u);
            let fr = xi - f32(lo);
            let upper = k < kle || (k == kle && le_after);
            let side = select(ns, 0u, upper);
            let ct = target_cp[side + lo] + fr * (target_cp[side + lo + 1u] - target_cp[side + lo]);
            let g = ca * work[rhs(0u, k)] + sa * work[rhs(1u, k)];
            let dc = (1.0 - g * g) - ct;
            sum = sum + w * dc * dc;
            wsum = wsum + w;
        }
        objective = sum / wsum;
    }
    var score = objective;
    var cviol = 0.0;
    if (config.constraints & CONSTRAIN_THICKNESS) != 0u && thick < config.min_thickness {
        flags = flags | FLAG_THIN;
        cviol = cviol + (config.min_thickness - thick);
    }
    if (config.constraints & CONSTRAIN_CM) != 0u && cm < config.cm_min {
        flags = flags | FLAG_CM;
        cviol = cviol + (config.cm_min - cm);
    }
    if cviol > 0.0 {
        score = PENALTY_CONSTRAINT + cviol;
    }
    var out: AeroResult;
    out.cl = cl;
    out.cm = cm;
    out.thickness = thick;
    out.objective = objective;
    out.score = score;
    out.flags = flags;
    out.violation = cviol;
    out._pad0 = 0u;
    finish(out);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    ind = gid.x;
    if ind >= config.population {
        return;
    }
    if step.phase == PHASE_NODES {
        phase_nodes();
        return;
    }
    // An individual that failed in phase 0 has its result already.
    if work[scalar(S_STATUS)] != 0.0 {
        return;
    }
    if step.phase == PHASE_ASSEMBLE {
        phase_assemble(step.first, step.last);
    } else if step.phase == PHASE_ELIMINATE {
        phase_eliminate(step.first, step.last);
    } else if step.phase == PHASE_BACK {
        phase_back(step.first, step.last);
    } else {
        phase_finish();
    }
}
