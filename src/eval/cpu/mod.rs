//! The CPU path: rayon over blocks of `LANES` individuals, each block a blocked
//! structure-of-arrays (`value[lane]`) so the kernels vectorise over individuals.
//!
//! Every file here mirrors the shader of the same name in `shaders/`, operation for operation
//! (`../basis.rs` mirrors `basis.wgsl`, spliced into the shaders). The shaders' `fma(a, b, c)` is
//! `Arith::fma` here, in two forms:
//!
//! - `Unfused`: a multiply, then an add. That is what Mesa lavapipe computes for it
//!   (measured: the GPU and the CPU results are bit-identical over whole populations), so the
//!   portable kernels agree with lavapipe exactly.
//! - `Fused`: one rounding (`f32::mul_add`, a hardware FMA), on the SIMD kernels, as a GPU
//!   that fuses computes it; results differ from lavapipe's in the last bits.
//!
//! Three kernel sets ([`Simd`]), picked at run time: AVX-512 (the fixed-parameter loop in
//! explicit 16-lane intrinsics, the rest auto-vectorised with AVX-512 and FMA), AVX2 + FMA (8
//! lanes) and portable (whatever the build target has, SSE2 on x86_64). All three compute the
//! same sums in the same order; the tests run each.

// The mirrors index as their shaders do (`for k in 0..j { out[k] … }`), line for line.
#![allow(clippy::needless_range_loop)]

pub(crate) mod dense_grid;
pub(crate) mod eval_patch;
pub(crate) mod expand;
pub(crate) mod fixed;
pub(crate) mod reduce;

use self::eval_patch::{Bindings, NewtonWork};
use super::kernel::{point_groups, Config, Gene, Partial, Problem};
use super::{Backend, BackendInfo, EvalLayout, Fitness, HoldsProblem, Targets};
use crate::error::{Error, Result};
use rayon::prelude::*;
use serde::Serialize;
use std::fmt;

/// The coordinates of one point for every lane (the third unused for curves).
pub(crate) type Point = [Lanes; 3];

pub(crate) use super::basis::{Arith, Fused, Lanes, Unfused, LANES};

/// A set of CPU kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Simd {
    /// AVX-512F with FMA (x86_64, detected at run time): 16 lanes a register, fused.
    Avx512,
    /// AVX2 with FMA (x86_64, detected at run time): 8 lanes a register, fused.
    Avx2,
    /// Whatever the build target has; unfused, bit-identical to lavapipe.
    Portable,
}

impl Simd {
    /// The best kernels this CPU runs.
    #[must_use]
    pub fn detect() -> Self {
        [Simd::Avx512, Simd::Avx2]
            .into_iter()
            .find(|s| s.supported())
            .unwrap_or(Simd::Portable)
    }

    /// Whether this CPU runs these kernels.
    #[must_use]
    pub fn supported(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
            }
            Simd::Portable => true,
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }

    /// Every kernel set this CPU runs, best first.
    #[must_use]
    pub fn available() -> Vec<Simd> {
        [Simd::Avx512, Simd::Avx2, Simd::Portable]
            .into_iter()
            .filter(|s| s.supported())
            .collect()
    }
}

impl fmt::Display for Simd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Simd::Avx512 => "AVX-512",
            Simd::Avx2 => "AVX2",
            Simd::Portable => "portable",
        })
    }
}

/// Per-task scratch: a block's transposed design differences, its difference nets, the held
/// patch and the Newton path's arrays.
pub(crate) struct Scratch {
    pub(crate) design: Vec<Lanes>,
    pub(crate) net: Vec<Lanes>,
    pub(crate) cp: Vec<Point>,
    pub(crate) newton: Box<NewtonWork>,
}

impl Scratch {
    pub(crate) fn new(problem: &Problem) -> Self {
        Scratch {
            design: vec![[0.0; LANES]; problem.n_vars],
            net: vec![[0.0; LANES]; problem.n_ctrl * problem.dim],
            cp: vec![[[0.0; LANES]; 3]; problem.ncp()],
            newton: Box::default(),
        }
    }
}

/// A kernel set: its `fma` and its fixed-parameter loop.
trait Kernels {
    type A: Arith;
    /// The fixed-parameter partials of group `group`.
    ///
    /// # Safety
    ///
    /// The CPU must have the set's features.
    unsafe fn fixed<const DIM: usize>(
        b: &Bindings<'_>,
        group: usize,
        s: &mut Scratch,
        out: &mut [Partial; LANES],
    );
}

struct PortableKernels;

impl Kernels for PortableKernels {
    type A = Unfused;
    #[inline(always)]
    unsafe fn fixed<const DIM: usize>(
        b: &Bindings<'_>,
        group: usize,
        s: &mut Scratch,
        out: &mut [Partial; LANES],
    ) {
        eval_patch::fixed::<Unfused, DIM>(b, group, &mut s.cp, out);
    }
}

/// The vector kernel sets: `V` lanes, `G2` / `G3` points at a time in two / three dimensions.
/// AVX2 holds G × DIM accumulators, G broadcast weights and a control point in its 16 ymm
/// registers; AVX-512 the same in its 32 zmm registers.
#[cfg(target_arch = "x86_64")]
struct Wide<V, const G2: usize, const G3: usize>(std::marker::PhantomData<V>);

#[cfg(target_arch = "x86_64")]
type Avx2Kernels = Wide<std::arch::x86_64::__m256, 4, 3>;

#[cfg(target_arch = "x86_64")]
type Avx512Kernels = Wide<std::arch::x86_64::__m512, 10, 7>;

#[cfg(target_arch = "x86_64")]
impl<V: fixed::Vector, const G2: usize, const G3: usize> Kernels for Wide<V, G2, G3> {
    type A = Fused;
    #[inline(always)]
    unsafe fn fixed<const DIM: usize>(
        b: &Bindings<'_>,
        group: usize,
        _: &mut Scratch,
        out: &mut [Partial; LANES],
    ) {
        if DIM == 3 {
            fixed::fixed::<V, DIM, G3>(b.config, b.targets, b.weights, b.net, group, out);
        } else {
            fixed::fixed::<V, DIM, G2>(b.config, b.targets, b.weights, b.net, group, out);
        }
    }
}

/// One (block, group) task: which individuals, which points.
struct Task<'a, T> {
    config: &'a Config,
    problem: &'a Problem,
    population: &'a [T],
    block: usize,
    group: usize,
}

/// Run `t` on kernel set `K`: expand the block's differences, then evaluate the group.
///
/// # Safety
///
/// The CPU must have `K`'s features.
#[inline(always)]
unsafe fn task<K: Kernels, T: Gene>(t: &Task<'_, T>, scratch: &mut Scratch, out: &mut [Partial; LANES]) {
    let (config, problem) = (t.config, t.problem);
    expand::expand::<K::A, T>(
        config,
        &problem.map_start,
        &problem.map_entries,
        problem.reference(),
        t.population,
        t.block,
        &mut scratch.design,
        &mut scratch.net,
    );
    let net = std::mem::take(&mut scratch.net);
    let b = Bindings {
        config,
        targets: &problem.targets,
        breaks: &problem.breaks,
        net: &net,
        weights: &problem.weights,
        jets: &problem.jets,
    };
    let group = t.group;
    match (problem.dim, config.newton) {
        (2, 0) => K::fixed::<2>(&b, group, scratch, out),
        (_, 0) => K::fixed::<3>(&b, group, scratch, out),
        (2, _) => eval_patch::newton::<K::A, 2>(&b, group, &mut scratch.cp, &mut scratch.newton, out),
        _ => eval_patch::newton::<K::A, 3>(&b, group, &mut scratch.cp, &mut scratch.newton, out),
    }
    scratch.net = net;
}

// One compiled function per kernel set, so that each is optimised for its features.

fn task_portable<T: Gene>(t: &Task<'_, T>, scratch: &mut Scratch, out: &mut [Partial; LANES]) {
    // SAFETY: the portable set needs no feature beyond the build target's.
    unsafe { task::<PortableKernels, T>(t, scratch, out) }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn task_avx2<T: Gene>(t: &Task<'_, T>, scratch: &mut Scratch, out: &mut [Partial; LANES]) {
    task::<Avx2Kernels, T>(t, scratch, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn task_avx512<T: Gene>(t: &Task<'_, T>, scratch: &mut Scratch, out: &mut [Partial; LANES]) {
    task::<Avx512Kernels, T>(t, scratch, out);
}

/// Run one (block, group) task on the kernels `simd` names.
fn run_task<T: Gene>(simd: Simd, t: &Task<'_, T>, scratch: &mut Scratch, out: &mut [Partial; LANES]) {
    match simd {
        // SAFETY: a `CpuEvaluator` holds `Avx512` or `Avx2` only where `Simd::supported`
        // saw the features on this CPU.
        #[cfg(target_arch = "x86_64")]
        Simd::Avx512 => unsafe { task_avx512(t, scratch, out) },
        #[cfg(target_arch = "x86_64")]
        Simd::Avx2 => unsafe { task_avx2(t, scratch, out) },
        _ => task_portable(t, scratch, out),
    }
}

/// Population evaluation on the CPU: rayon over (block of `LANES` individuals, point group)
/// tasks, each expanding its block and running the `eval_patch` kernels, then `reduce`.
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

    /// The same on the kernel set `simd`; an error when this CPU lacks its features.
    pub fn with_simd(layout: &EvalLayout, targets: &Targets, newton: u32, simd: Simd) -> Result<Self> {
        if !simd.supported() {
            return Err(Error::invalid(format!(
                "this CPU does not run the {simd} kernels"
            )));
        }
        let problem = Problem::new(layout, targets, newton)?;
        let info = BackendInfo {
            backend: Backend::Cpu,
            adapter: format!(
                "CPU: {} rayon threads, {simd} kernels, {LANES} individuals per block",
                rayon::current_num_threads(),
            ),
            fallback: None,
        };
        Ok(CpuEvaluator { problem, simd, info })
    }

    /// The kernel set in use.
    #[must_use]
    pub fn simd(&self) -> Simd {
        self.simd
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

impl HoldsProblem for CpuEvaluator {
    fn problem(&self) -> &Problem {
        &self.problem
    }

    fn problem_mut(&mut self) -> &mut Problem {
        &mut self.problem
    }

    fn backend_info(&self) -> &BackendInfo {
        &self.info
    }

    fn run<T: Gene>(&mut self, population: &[T], out: &mut [Fitness]) -> Result<()> {
        let problem = &self.problem;
        let rows = problem.rows(population.len(), out.len())?;
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
                let t = Task {
                    config: &config,
                    problem,
                    population,
                    block: k % blocks,
                    group: k / blocks,
                };
                run_task(simd, &t, scratch, partial);
            },
        );
        out.par_chunks_mut(LANES)
            .enumerate()
            .for_each(|(block, fitness)| reduce::reduce(&config, &partials, blocks, block, fitness));
        Ok(())
    }
}
