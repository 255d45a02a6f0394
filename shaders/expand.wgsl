//! expand.wgsl: design variables to control nets through the sparse extraction map.
//!
//! Mirrored by src/eval/cpu/expand.rs. The map (`net = E_u · D · E_vᵀ` for grids, `E · D`
//! for curves) is uploaded once in compressed-row form; each invocation expands one
//! individual, applying the same row to every coordinate. The map is linear, so it serves the
//! differences from the reference design that the host uploads (`x - x_ref`, taken in f64 and
//! then rounded to f32) as well as designs.

// Specialised at pipeline creation, and `// @unroll` loops unrolled, as in eval_patch.wgsl.
const DIM: u32 = 3u;

// @include config.wgsl

// Must be kept in sync with `MapEntry` in src/eval/kernel.rs.
struct MapEntry {
    // Design point index.
    index: u32,
    weight: f32,
}

@group(0) @binding(0) var<uniform> config: Config;
// Row r of the map holds entries map_start[r] .. map_start[r + 1].
@group(0) @binding(1) var<storage, read> map_start: array<u32>;
@group(0) @binding(2) var<storage, read> map_entries: array<MapEntry>;
// One individual per row of n_vars values (its difference from the reference design): design
// point k, coordinate c at k * DIM + c.
@group(0) @binding(3) var<storage, read> population: array<f32>;
// Output, structure of arrays as read by eval_patch.wgsl: net[(r * DIM + c) * net_stride + i].
@group(0) @binding(4) var<storage, read_write> net: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let ind = gid.x;
    if (ind >= config.population) {
        return;
    }
    let base = ind * config.n_vars;
    for (var r = 0u; r < config.n_ctrl; r++) {
        let e0 = map_start[r];
        let e1 = map_start[r + 1u];
        for (var c = 0u; c < DIM; c++) { // @unroll
            var acc = 0.0;
            for (var e = e0; e < e1; e++) {
                let m = map_entries[e];
                acc = fma(m.weight, population[base + m.index * DIM + c], acc);
            }
            net[(r * DIM + c) * config.net_stride + ind] = acc;
        }
    }
}
