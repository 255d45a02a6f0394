//! CPU mirror of `shaders/expand.wgsl`: differences from the reference design to difference
//! nets, one block of `LANES` individuals at a time.

use super::{Arith, Lanes, LANES};
use crate::eval::kernel::{Config, Gene, MapEntry};

/// `expand.wgsl` for the individuals `block * LANES ..` of `population` (bindings 0-3 as in
/// the shader; binding 4 is the block's net, `net[r * DIM + c][lane]`, stride `LANES`).
///
/// The block's rows are first transposed into `design` (`design[k * DIM + c][lane]`) as
/// differences from `reference`, taken in f64 and rounded to f32: the values the GPU path
/// uploads. Applying the map then runs over all lanes at once. Lanes past the population hold
/// zeros.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the shader's bindings, the reference and the scratch
pub(crate) fn expand<A: Arith, T: Gene>(
    config: &Config,
    map_start: &[u32],
    map_entries: &[MapEntry],
    reference: &[f64],
    population: &[T],
    block: usize,
    design: &mut [Lanes],
    net: &mut [Lanes],
) {
    let n_vars = config.n_vars as usize;
    let dim = config.dim as usize;
    let first = block * LANES;
    let active = (config.population as usize).saturating_sub(first).min(LANES);
    let rows = &population[first * n_vars..(first + active) * n_vars];
    for d in design.iter_mut() {
        *d = [0.0; LANES];
    }
    for (lane, row) in rows.chunks_exact(n_vars).enumerate() {
        for ((d, &x), &r) in design.iter_mut().zip(row).zip(reference) {
            d[lane] = (x.to_f64() - r) as f32;
        }
    }
    for (r, out) in net.chunks_exact_mut(dim).enumerate().take(config.n_ctrl as usize) {
        let entries = &map_entries[map_start[r] as usize..map_start[r + 1] as usize];
        for (c, acc) in out.iter_mut().enumerate() {
            *acc = [0.0; LANES];
            for m in entries {
                let x = &design[m.index as usize * dim + c];
                for l in 0..LANES {
                    acc[l] = A::fma(m.weight, x[l], acc[l]);
                }
            }
        }
    }
}
