//! The CPU path: rayon over blocks of `LANES` individuals, each block a blocked
//! structure-of-arrays (`value[lane]`) so the kernels vectorise over individuals.
//!
//! Every file here mirrors the shader of the same name in `shaders/`, operation for operation.
//! The shaders' `fma(a, b, c)` is [`fma`] here: a multiply, then an add. That is what Mesa
//! lavapipe computes for it (measured: the GPU and the CPU results are bit-identical over
//! whole populations), so the two paths agree exactly there; a GPU that fuses the operation
//! rounds once less and differs in the last bits. The kernels are compiled twice: with AVX2
//! (picked at run time when the CPU has it) and for the build target (SSE2 on x86_64); both
//! compute the same values.

// The mirrors index as their shaders do (`for k in 0..j { out[k] … }`), line for line.
#![allow(clippy::needless_range_loop)]

pub(crate) mod aero;
pub(crate) mod dense_grid;
pub(crate) mod eval_patch;
pub(crate) mod expand;
pub(crate) mod reduce;

use super::kernel::{point_groups, Config, Partial, Problem};
use super::{Backend, BackendInfo, EvalLayout, Fitness, PopulationEvaluator, Targets};
use crate::error::Result;
use rayon::prelude::*;

/// Individuals per block: one lane each.
pub(crate) const LANES: usize = 32;
/// One value per lane of a block.
pub(crate) type Lanes = [f32; LANES];
/// The coordinates of one point for every lane (the third unused for curves).
pub(crate) type Point = [Lanes; 3];

/// The shaders' `fma(a, b, c)` as lavapipe computes it: `a * b + c`, rounded twice.
#[inline(always)]
pub(crate) fn fma(a: f32, b: f32, c: f32) -> f32 {
    a * b + c
}

/// Which compiled kernels run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Simd {
    /// AVX2 (x86_64, detected at run time).
    Avx2,
    /// Whatever the build target has.
    Portable,
}

impl Simd {
    /// The best kernels this CPU runs.
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                return Simd::Avx2;
            }
        }
        Simd::Portable
    }

    pub(crate) fn describe(self) -> &'static str {
        match self {
            Simd::Avx2 => "AVX2",
            Simd::Portable => "portable",
        }
    }
}

/// Per-task scratch: a block's transposed design rows, its control nets and the held patch.
pub(crate) struct Scratch {
    pub(crate) design: Vec<Lanes>,
    pub(crate) net: Vec<Lanes>,
    pub(crate) cp: Vec<Point>,
    pub(crate) newton: Box<eval_patch::NewtonWork>,
}

impl Scratch {
    pub(crate) fn new(problem: &Problem) -> Self {
        let patch = (problem.du + 1) * (problem.dv + 1);
        Scratch {
            design: vec![[0.0; LANES]; problem.n_vars],
            net: vec![[0.0; LANES]; problem.n_ctrl * problem.dim],
            cp: vec![[[0.0; LANES]; 3]; patch],
            newton: Box::default(),
        }
    }
}

/// The `expand` mirror for block `block` into the scratch net.
#[inline(always)]
fn expand_block(config: &Config, problem: &Problem, population: &[f32], block: usize, scratch: &mut Scratch) {
    expand::expand(
        config,
        &problem.map_start,
        &problem.map_entries,
        population,
        block,
        &mut scratch.design,
        &mut scratch.net,
    );
}

/// The `eval_patch` mirror for point group `group` on the scratch net.
#[inline(always)]
fn eval_block<const DIM: usize>(
    config: &Config,
    problem: &Problem,
    group: usize,
    scratch: &mut Scratch,
    partial: &mut [Partial; LANES],
) {
    let Scratch { net, cp, newton, .. } = scratch;
    eval_patch::eval_patch::<DIM>(
        config,
        &problem.targets,
        &problem.breaks,
        net,
        group,
        cp,
        newton,
        partial,
    );
}

// The AVX2 builds: one function per kernel, so that each is optimised on its own.

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn expand_avx2(config: &Config, problem: &Problem, population: &[f32], block: usize, scratch: &mut Scratch) {
    expand_block(config, problem, population, block, scratch);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn eval_avx2<const DIM: usize>(
    config: &Config,
    problem: &Problem,
    group: usize,
    scratch: &mut Scratch,
    partial: &mut [Partial; LANES],
) {
    eval_block::<DIM>(config, problem, group, scratch, partial);
}

/// Run one (block, group) task, expanding the block and evaluating the group, on the kernels
/// `simd` names.
#[allow(clippy::too_many_arguments)]
fn run_block(
    simd: Simd,
    config: &Config,
    problem: &Problem,
    population: &[f32],
    block: usize,
    group: usize,
    scratch: &mut Scratch,
    partial: &mut [Partial; LANES],
) {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Simd::Avx2` is only produced by `Simd::detect` after it has seen AVX2 on
        // this CPU, which is all these functions require.
        Simd::Avx2 => unsafe {
            expand_avx2(config, problem, population, block, scratch);
            if problem.dim == 2 {
                eval_avx2::<2>(config, problem, group, scratch, partial);
            } else {
                eval_avx2::<3>(config, problem, group, scratch, partial);
            }
        },
        _ => {
            expand_block(config, problem, population, block, scratch);
            if problem.dim == 2 {
                eval_block::<2>(config, problem, group, scratch, partial);
            } else {
                eval_block::<3>(config, problem, group, scratch, partial);
            }
        }
    }
}

/// Population evaluation on the CPU: rayon over (block of `LANES` individuals, point group)
/// tasks, each expanding its block and running the `eval_patch` mirror, then `reduce`.
#[derive(Clone, Debug)]
pub struct CpuEvaluator {
    problem: Problem,
    simd: Simd,
    info: BackendInfo,
}

impl CpuEvaluator {
    /// An evaluator for `layout` against `targets` with `newton` foot-point steps, on the best
    /// kernels this CPU runs.
    pub fn new(layout: &EvalLayout, targets: &Targets, newton: u32) -> Result<Self> {
        Self::with_simd(layout, targets, newton, Simd::detect())
    }

    /// The same, forced onto the portable kernels (for tests and comparisons).
    pub fn new_portable(layout: &EvalLayout, targets: &Targets, newton: u32) -> Result<Self> {
        Self::with_simd(layout, targets, newton, Simd::Portable)
    }

    fn with_simd(layout: &EvalLayout, targets: &Targets, newton: u32, simd: Simd) -> Result<Self> {
        let problem = Problem::new(layout, targets, newton)?;
        let info = BackendInfo {
            backend: Backend::Cpu,
            adapter: format!(
                "CPU: {} rayon threads, {} kernels, {LANES} individuals per block",
                rayon::current_num_threads(),
                simd.describe()
            ),
            fallback: None,
        };
        Ok(CpuEvaluator { problem, simd, info })
    }

    /// Let Newton steps cross patch borders (see [`EvalOptions::cross_patches`]).
    ///
    /// [`EvalOptions::cross_patches`]: super::EvalOptions::cross_patches
    #[must_use]
    pub fn crossing(mut self, cross: bool) -> Self {
        self.problem.cross = cross;
        self
    }

    /// Record why Auto took the CPU.
    pub(crate) fn with_fallback(mut self, why: String) -> Self {
        self.info.fallback = Some(why);
        self
    }
}

impl PopulationEvaluator for CpuEvaluator {
    fn evaluate(&mut self, population: &[f32], out: &mut [Fitness]) -> Result<()> {
        let problem = &self.problem;
        let rows = problem.rows(population, out.len())?;
        if rows == 0 {
            return Ok(());
        }
        let groups = point_groups(rows, problem.n_points());
        let config = problem.config(rows, LANES, groups);
        let blocks = rows.div_ceil(LANES);
        let simd = self.simd;
        let mut partials = vec![[Partial::default(); LANES]; groups.1 * blocks];
        partials.par_iter_mut().enumerate().for_each_init(
            || Scratch::new(problem),
            |scratch, (k, partial)| {
                let (group, block) = (k / blocks, k % blocks);
                run_block(simd, &config, problem, population, block, group, scratch, partial);
            },
        );
        out.par_chunks_mut(LANES)
            .enumerate()
            .for_each(|(block, fitness)| reduce::reduce(&config, &partials, blocks, block, fitness));
        Ok(())
    }

    fn set_params(&mut self, params: &[[f64; 2]]) -> Result<()> {
        self.problem.set_params(params)
    }

    fn set_newton(&mut self, newton: u32) {
        self.problem.newton = newton;
    }

    fn info(&self) -> &BackendInfo {
        &self.info
    }

    fn design_variables(&self) -> usize {
        self.problem.n_vars
    }

    fn points(&self) -> usize {
        self.problem.n_points()
    }
}
