//! CPU mirror of `shaders/reduce.wgsl`: per individual, the sum and maximum of its partials.

use super::LANES;
use crate::eval::kernel::{Config, Partial};
use crate::eval::Fitness;

/// `reduce.wgsl` for block `block`: `partials[g * blocks + block][lane]` is the shader's
/// `partials[g * population + individual]` with individuals counted in blocks; `fitness` is
/// the block's slice of the output (its length is the number of live lanes).
#[inline]
pub(crate) fn reduce(
    config: &Config,
    partials: &[[Partial; LANES]],
    blocks: usize,
    block: usize,
    fitness: &mut [Fitness],
) {
    for (lane, out) in fitness.iter_mut().enumerate() {
        let mut sum = 0.0f32;
        let mut worst = 0.0f32;
        for g in 0..config.n_groups as usize {
            let p = partials[g * blocks + block][lane];
            sum += p.sum_sq;
            worst = worst.max(p.max_sq);
        }
        *out = Fitness {
            sum_sq: sum,
            max: worst.sqrt(),
        };
    }
}
