//! dense_grid.wgsl: points and unit normals of patch grids on a regular grid_u x grid_v grid
//! of global parameters, for meshes and renders.
//!
//! Mirrored by src/eval/cpu/dense_grid.rs. Reads the control nets written by expand.wgsl;
//! sample (iu, iv) of individual i sits at global (iu / (grid_u - 1), iv / (grid_v - 1)).

// Specialised at pipeline creation, and `// @unroll` loops unrolled, as in eval_patch.wgsl
// (DIM is always 3 here).
const DU: u32 = 3u;
const DV: u32 = 3u;
const DIM: u32 = 3u;

const NU: u32 = DU + 1u;
const NV: u32 = DV + 1u;
const NMAX: u32 = max(NU, NV);

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

// Must be kept in sync with `Vertex` in src/eval/kernel.rs.
struct Vertex {
    px: f32,
    py: f32,
    pz: f32,
    nx: f32,
    ny: f32,
    nz: f32,
}

@group(0) @binding(0) var<uniform> config: Config;
// breaks_u (patches_u + 1 values) followed by breaks_v (patches_v + 1 values).
@group(0) @binding(1) var<storage, read> breaks: array<f32>;
// Control nets, structure of arrays, as written by expand.wgsl.
@group(0) @binding(2) var<storage, read> net: array<f32>;
// vertices[(individual * grid_u + iu) * grid_v + iv].
@group(0) @binding(3) var<storage, read_write> vertices: array<Vertex>;

// The degree-n Bernstein polynomials at t and their derivatives (as in eval_patch.wgsl).
struct Basis {
    b: array<f32, NMAX>,
    d1: array<f32, NMAX>,
}

fn basis(n: u32, t: f32) -> Basis {
    var lvl: array<f32, NMAX>;
    var low1: array<f32, NMAX>;
    lvl[0] = 1.0;
    let s = 1.0 - t;
    for (var j = 1u; j < NMAX; j++) { // @unroll
        if (j <= n) {
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
    // low1[i - 1], zero before the start.
    var l1 = 0.0;
    for (var i = 0u; i < NMAX; i++) { // @unroll
        if (i <= n) {
            out.d1[i] = nf * (l1 - low1[i]);
            l1 = low1[i];
        }
    }
    return out;
}

// The segment of a chain (breaks from breaks[first], `count` segments) holding global t in
// [0, 1], and the local parameter in it (as ChainLayout::locate).
struct Located {
    index: u32,
    t: f32,
}

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

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let iu = gid.x;
    let iv = gid.y;
    let ind = gid.z;
    if (iu >= config.grid_u || iv >= config.grid_v || ind >= config.population) {
        return;
    }
    let lu = locate(0u, config.patches_u, f32(iu) / f32(config.grid_u - 1u));
    let lv = locate(config.patches_u + 1u, config.patches_v, f32(iv) / f32(config.grid_v - 1u));
    let bu = basis(DU, lu.t);
    let bv = basis(DV, lv.t);
    var s: array<f32, DIM>;
    var su: array<f32, DIM>;
    var sv: array<f32, DIM>;
    for (var a = 0u; a < NU; a++) { // @unroll
        var r0: array<f32, DIM>;
        var r1: array<f32, DIM>;
        for (var b = 0u; b < NV; b++) { // @unroll
            let r = (lu.index * DU + a) * config.net_cols + lv.index * DV + b;
            for (var c = 0u; c < DIM; c++) { // @unroll
                let p = net[(r * DIM + c) * config.net_stride + ind];
                r0[c] = fma(bv.b[b], p, r0[c]);
                r1[c] = fma(bv.d1[b], p, r1[c]);
            }
        }
        for (var c = 0u; c < DIM; c++) { // @unroll
            s[c] = fma(bu.b[a], r0[c], s[c]);
            su[c] = fma(bu.d1[a], r0[c], su[c]);
            sv[c] = fma(bu.b[a], r1[c], sv[c]);
        }
    }
    // Normal: su x sv, normalised; zero where the surface is degenerate (a closed tip).
    var n = array<f32, 3>(su[1] * sv[2] - su[2] * sv[1], su[2] * sv[0] - su[0] * sv[2], su[0] * sv[1] - su[1] * sv[0]);
    let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    var inv = 0.0;
    if (len2 > 0.0) {
        inv = 1.0 / sqrt(len2);
    }
    vertices[(ind * config.grid_u + iu) * config.grid_v + iv] =
        Vertex(s[0], s[1], s[2], n[0] * inv, n[1] * inv, n[2] * inv);
}
