//! CPU mirror of `shaders/expand.wgsl`: design variables to control nets, one block of
//! `LANES` individuals at a time.

use super::{fma, Lanes, LANES};
use crate::eval::kernel::{Config, MapEntry};

/// `expand.wgsl` for the individuals `block * LANES ..` of `population` (bindings 0-3 as in
/// the shader; binding 4 is the block's net, `net[r * DIM + c][lane]`, stride `LANES`).
///
/// The block's design rows are first transposed into `design` (`design[k * DIM + c][lane]`),
/// the same per-lane gather the shader does with its loads, so that applying the map runs
/// over all lanes at once. Lanes past the population hold zeros.
#[inline(always)]
pub(crate) fn expand(
    config: &Config,
    map_start: &[u32],
    map_entries: &[MapEntry],
    population: &[f32],
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
        for (d, &x) in design.iter_mut().zip(row) {
            d[lane] = x;
        }
    }
    for (r, out) in net.chunks_exact_mut(dim).enumerate().take(config.n_ctrl as usize) {
        let entries = &map_entries[map_start[r] as usize..map_start[r + 1] as usize];
        for (c, acc) in out.iter_mut().enumerate() {
            *acc = [0.0; LANES];
            for m in entries {
                let x = &design[m.index as usize * dim + c];
                for l in 0..LANES {
                    acc[l] = fma(m.weight, x[l], acc[l]);
                }
            }
        }
    }
}
