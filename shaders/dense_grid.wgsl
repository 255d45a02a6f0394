//! dense_grid.wgsl: points, normals and tangent sizes of patch grids on a tensor grid of
//! parameters, for meshes, renders and `bezchain sample`.
//!
//! Mirrored by src/eval/cpu/dense_grid.rs. Reads the control nets written by expand.wgsl (the
//! designs less a reference point, so positions come out relative to it and the host adds it
//! back in f64); sample (iu, iv) of individual i is at u-sample iu and v-sample iv, each a
//! patch index and a local parameter located on the host in f64.

// Specialised at pipeline creation, and `// @unroll` loops unrolled, as in eval_patch.wgsl
// (DIM is always 3 here).
const DU: u32 = 3u;
const DV: u32 = 3u;
const DIM: u32 = 3u;

const NU: u32 = DU + 1u;
const NV: u32 = DV + 1u;
const NMAX: u32 = max(NU, NV);

// @include config.wgsl
// @include basis.wgsl

// Must be kept in sync with `Sample` in src/eval/kernel.rs.
struct Sample {
    // Patch index along this direction.
    index: u32,
    // Local parameter in that patch, in [0, 1].
    t: f32,
}

// Must be kept in sync with `Vertex` in src/eval/kernel.rs.
struct Vertex {
    px: f32,
    py: f32,
    pz: f32,
    // ∂S/∂u × ∂S/∂v in the patch's local parameters (not normalised: the host decides where
    // it is too small to give a direction).
    nx: f32,
    ny: f32,
    nz: f32,
    // max(|∂S/∂u|², |∂S/∂v|²), the scale of that product.
    tangent_sq: f32,
    _pad: f32,
}

@group(0) @binding(0) var<uniform> config: Config;
// The grid_u samples along u, then the grid_v samples along v.
@group(0) @binding(1) var<storage, read> samples: array<Sample>;
// Control nets, structure of arrays, as written by expand.wgsl.
@group(0) @binding(2) var<storage, read> net: array<f32>;
// vertices[(individual * grid_u + iu) * grid_v + iv].
@group(0) @binding(3) var<storage, read_write> vertices: array<Vertex>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let iu = gid.x;
    let iv = gid.y;
    let ind = gid.z;
    if (iu >= config.grid_u || iv >= config.grid_v || ind >= config.population) {
        return;
    }
    let lu = samples[iu];
    let lv = samples[config.grid_u + iv];
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
    let nx = su[1] * sv[2] - su[2] * sv[1];
    let ny = su[2] * sv[0] - su[0] * sv[2];
    let nz = su[0] * sv[1] - su[1] * sv[0];
    let tu = su[0] * su[0] + su[1] * su[1] + su[2] * su[2];
    let tv = sv[0] * sv[0] + sv[1] * sv[1] + sv[2] * sv[2];
    vertices[(ind * config.grid_u + iu) * config.grid_v + iv] =
        Vertex(s[0], s[1], s[2], nx, ny, nz, max(tu, tv), 0.0);
}
