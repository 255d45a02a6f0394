//! config.wgsl: the uniform block of every population shader, written once and spliced into
//! each shader at its line `// @include config.wgsl` (src/eval/gpu/mod.rs, `source::expand`).
//!
//! Must be kept in sync with `Config` in src/eval/kernel.rs.

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
    seeds: u32,
    seed_ring: u32,
    _pad2: u32,
}
