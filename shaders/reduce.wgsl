//! reduce.wgsl: per individual, the sum and the maximum of the group partials of eval_patch.
//!
//! Mirrored by src/eval/cpu/reduce.rs. The groups are added in order, so the sum is the same
//! on both paths.

// @include config.wgsl

// Must be kept in sync with `Partial` in src/eval/kernel.rs and eval_patch.wgsl.
struct Partial {
    sum_sq: f32,
    max_sq: f32,
}

// Must be kept in sync with `Fitness` in src/eval/kernel.rs.
struct Fitness {
    sum_sq: f32,
    max: f32,
}

@group(0) @binding(0) var<uniform> config: Config;
// partials[group * population + individual], written by eval_patch.wgsl.
@group(0) @binding(1) var<storage, read> partials: array<Partial>;
@group(0) @binding(2) var<storage, read_write> fitness: array<Fitness>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let ind = gid.x;
    if (ind >= config.population) {
        return;
    }
    var sum = 0.0;
    var worst = 0.0;
    for (var g = 0u; g < config.n_groups; g++) {
        let p = partials[g * config.population + ind];
        sum += p.sum_sq;
        worst = max(worst, p.max_sq);
    }
    fitness[ind] = Fitness(sum, sqrt(worst));
}
