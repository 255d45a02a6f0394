//! Population evaluation: the `PopulationEvaluator` trait with a rayon CPU path and a wgpu
//! GPU path that give the same answers.
//!
//! An evaluator is built once from a layout (curve chain or patch grid), the target points
//! with per-point start parameters, a Newton step count and a backend; it then evaluates
//! population after population (P individuals × design variables, f32 or f64, one row each)
//! into one [`Fitness`] per individual: the sum of squared closest-point offsets and the
//! largest offset.
//!
//! The kernels compute in f32 against a reference design evaluated in f64 (see [`kernel`] for
//! the scheme and its accuracy): population methods re-anchor it at their best design with
//! [`PopulationEvaluator::set_reference`]; without one it is the centre of the targets, so
//! results never depend on where the data sit.
//!
//! The work is four kernels, each a WGSL shader in `shaders/` with a CPU mirror of the same
//! name in [`cpu`]: `expand` (design differences to control nets through the sparse
//! extraction map), `eval_patch` (offsets at each point's parameters, optionally refined by
//! clamped Newton steps), `reduce` (per-individual sum and maximum) and `dense_grid` (a patch
//! grid sampled on a tensor grid of parameters, for meshes, renders and `bezchain sample`).
//! `shaders/config.wgsl` and `shaders/basis.wgsl` are written once and spliced into the
//! shaders that use them. The GPU is one context per process ([`GpuContext::shared`]).
//!
//! Environment: `BEZCHAIN_NO_GPU=1` makes every GPU request behave as if no adapter existed
//! (so `Backend::Auto` takes the CPU and says why); `RAYON_NUM_THREADS` sets the CPU threads.

mod basis;
pub mod cpu;
pub mod dense;
pub mod gpu;
pub mod kernel;

pub use cpu::{CpuEvaluator, Simd};
pub use gpu::{GpuContext, GpuEvaluator, GpuOptions};
pub use kernel::{Config, Gene, MapEntry, Partial, RefJet, Sample, Target, Vertex, MAX_DEGREE};

use crate::chain::{ChainLayout, GridLayout};
use crate::error::{Error, Result};
use crate::keyword::keywords;
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use kernel::Problem;
use serde::Serialize;
use std::fmt;

/// Where populations are evaluated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// The GPU when wgpu's Vulkan backend finds a hardware adapter, else the CPU. A software
    /// adapter (Mesa lavapipe) runs only when asked for by [`Backend::Gpu`]: it is slower than
    /// the CPU kernels. The panel method's population kernel always takes the CPU here
    /// ([`crate::aero::batch::build_aero_evaluator`]).
    #[default]
    Auto,
    /// The GPU; an error when no adapter exists.
    Gpu,
    /// The CPU (rayon, SIMD over individuals).
    Cpu,
}

keywords!(Backend, "backend", { Auto => "auto", Gpu => "gpu", Cpu => "cpu" });

/// Which backend ran, on which adapter, and why Auto chose it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct BackendInfo {
    /// [`Backend::Cpu`] or [`Backend::Gpu`] (never Auto).
    pub backend: Backend,
    /// The adapter: the GPU's name and driver, or a description of the CPU path.
    pub adapter: String,
    /// Set when Auto took the CPU: why (what the GPU request answered, or why the kernel
    /// runs on the CPU).
    pub fallback: Option<String>,
}

impl fmt::Display for BackendInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.backend, self.adapter)?;
        if let Some(why) = &self.fallback {
            write!(f, " (auto took the CPU: {why})")?;
        }
        Ok(())
    }
}

/// The fitness of one individual. Must be kept in sync with `struct Fitness` in
/// `shaders/reduce.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable, Serialize)]
pub struct Fitness {
    /// Sum over the target points of the squared offsets, in model units squared.
    pub sum_sq: f32,
    /// The largest offset, in model units.
    pub max: f32,
}

/// The shape being evaluated: a curve chain (2D, design rows `x0,y0,x1,y1,…`) or a patch grid
/// (3D, design rows `x,y,z` per design point of the row-major design net).
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)] // one per evaluator, never in bulk
pub enum EvalLayout {
    /// A chain of Bezier curves in the plane.
    Curve(ChainLayout),
    /// A grid of tensor-product Bezier patches in space.
    Grid(GridLayout),
}

impl EvalLayout {
    /// Design variables per individual: design points times coordinates.
    #[must_use]
    pub fn design_variables(&self) -> usize {
        match self {
            EvalLayout::Curve(c) => c.design_count() * 2,
            EvalLayout::Grid(g) => {
                let (nu, nv) = g.design_shape();
                nu * nv * 3
            }
        }
    }
}

/// Target points with their start parameters (global, in `[0, 1]`).
#[derive(Clone, Debug, PartialEq)]
pub struct Targets {
    points: Vec<DVec3>,
    params: Vec<DVec2>,
}

impl Targets {
    /// Points of a curve with their chain parameters `t`.
    pub fn curve(points: &[DVec2], t: &[f64]) -> Result<Self> {
        let params: Vec<DVec2> = t.iter().map(|&t| DVec2::new(t, 0.0)).collect();
        Self::checked(points.iter().map(|p| p.extend(0.0)).collect(), params)
    }

    /// Points of a patch grid with their parameters `(u, v)`.
    pub fn grid(points: &[DVec3], uv: &[DVec2]) -> Result<Self> {
        Self::checked(points.to_vec(), uv.to_vec())
    }

    fn checked(points: Vec<DVec3>, params: Vec<DVec2>) -> Result<Self> {
        if points.len() != params.len() {
            return Err(Error::invalid(format!(
                "{} target points but {} parameters",
                points.len(),
                params.len()
            )));
        }
        if points.iter().any(|p| !p.is_finite()) {
            return Err(Error::invalid("target points must be finite"));
        }
        Ok(Targets { points, params })
    }

    /// Number of points.
    #[must_use]
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The points (z = 0 for a curve).
    #[must_use]
    pub fn points(&self) -> &[DVec3] {
        &self.points
    }

    /// The start parameters (v = 0 for a curve).
    #[must_use]
    pub fn params(&self) -> &[DVec2] {
        &self.params
    }
}

/// How to build an evaluator.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalOptions {
    /// Where to run. Default: [`Backend::Auto`].
    pub backend: Backend,
    /// Foot-point Newton steps per point and individual; 0 holds each point's parameters fixed
    /// (the offset is then to the point at those parameters). Default: 0.
    pub newton: u32,
    /// Whether Newton steps may cross patch (segment) borders, following the foot point
    /// over the whole domain; otherwise they are clamped to the patch each point starts on,
    /// which is cheaper on the GPU. Default: false.
    pub cross_patches: bool,
    /// Candidate starts of the foot-point search (see [`PopulationEvaluator::set_seeds`]).
    /// Default: 0.
    pub seeds: u32,
    /// GPU settings. Default: [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            backend: Backend::Auto,
            newton: 0,
            cross_patches: false,
            seeds: 0,
            gpu: GpuOptions::default(),
        }
    }
}

impl EvalOptions {
    /// The options of the fitting objectives: `newton` foot-point steps that follow the foot
    /// point across patch (segment) borders, on `backend` with the GPU settings `gpu`.
    #[must_use]
    pub fn crossing(backend: Backend, newton: u32, gpu: &GpuOptions) -> Self {
        EvalOptions {
            backend,
            newton,
            cross_patches: true,
            seeds: 0,
            gpu: gpu.clone(),
        }
    }
}

/// The kernel problem behind an evaluator, which the provided methods of
/// [`PopulationEvaluator`] read and change. Crate-private, so that trait is sealed: the CPU
/// and GPU evaluators are its only implementations.
pub(crate) trait HoldsProblem {
    /// The kernel problem: layout, targets, reference and parameters.
    fn problem(&self) -> &Problem;

    /// The same, to change; [`HoldsProblem::problem_changed`] follows a change of its
    /// per-target data.
    fn problem_mut(&mut self) -> &mut Problem;

    /// The problem's per-target data changed (parameters or reference): a backend that keeps
    /// a copy of them (the GPU's buffers) refreshes it.
    fn problem_changed(&mut self) {}

    /// [`PopulationEvaluator::set_seeds`] changed the candidate starts: a backend whose
    /// kernel depends on them rebuilds it.
    fn seeds_changed(&mut self) -> Result<()> {
        Ok(())
    }

    /// The backend and adapter that run the evaluations.
    fn backend_info(&self) -> &BackendInfo;

    /// Evaluate `population`, rows of f32 or f64 design variables, into `out` (the
    /// [`PopulationEvaluator`] methods of both precisions).
    fn run<T: Gene>(&mut self, population: &[T], out: &mut [Fitness]) -> Result<()>
    where
        Self: Sized;
}

/// Every backend evaluates both precisions through its one generic `HoldsProblem::run`.
impl<E: HoldsProblem + Send> PopulationEvaluator for E {
    fn evaluate(&mut self, population: &[f32], out: &mut [Fitness]) -> Result<()> {
        self.run(population, out)
    }

    fn evaluate_f64(&mut self, population: &[f64], out: &mut [Fitness]) -> Result<()> {
        self.run(population, out)
    }

    fn info(&self) -> &BackendInfo {
        self.backend_info()
    }
}

/// Evaluates whole populations of one layout against fixed targets, generation after
/// generation.
#[allow(private_bounds)]
pub trait PopulationEvaluator: Send + HoldsProblem {
    /// Evaluate `population` (rows of [`design_variables`](Self::design_variables) values)
    /// into `out`, one [`Fitness`] per row, in row order.
    fn evaluate(&mut self, population: &[f32], out: &mut [Fitness]) -> Result<()>;

    /// The same for rows in f64 (designs whose coordinates f32 cannot hold finely enough, such
    /// as data far from the origin): each row's difference from the reference is taken in f64.
    fn evaluate_f64(&mut self, population: &[f64], out: &mut [Fitness]) -> Result<()>;

    /// Replace the start parameters: global `(u, v)` per target point in input order (`v` is
    /// ignored for a curve), clamped to `[0, 1]`.
    fn set_params(&mut self, params: &[[f64; 2]]) -> Result<()> {
        self.problem_mut().set_params(params)?;
        self.problem_changed();
        Ok(())
    }

    /// Re-anchor the reference design (`design_variables` finite values): the kernels then
    /// compute only each individual's difference from it in f32. Results are accurate to f32
    /// relative to the offsets when the population lies near the reference (see
    /// [`kernel`]); population methods set it to their best design every
    /// generation.
    fn set_reference(&mut self, design: &[f64]) -> Result<()> {
        self.problem_mut().set_reference(design)?;
        self.problem_changed();
        Ok(())
    }

    /// Set the number of foot-point Newton steps (0: parameters held fixed). A GPU kernel
    /// keeps the individuals per invocation chosen for the steps it was built with: they
    /// change its speed, not its results.
    fn set_newton(&mut self, newton: u32) {
        self.problem_mut().newton = newton;
    }

    /// Set the candidate starts of the foot-point search: `seeds + 1` samples per patch side
    /// (one along v for a curve) over the start patch and its neighbours (the whole chain for
    /// a curve); per point and individual, Newton steps also run from the two deepest local
    /// minima among them, and a descent that ends at a foot point other than the start's and
    /// lower replaces it. 0 (the default): Newton starts at the start parameters only, which
    /// suits a population near the reference; with samples that resolve every basin, every
    /// backend finds the global closest point within reach. The GPU rebuilds its kernel when
    /// this turns the candidates on or off ([`EvalOptions::seeds`] builds it so at once).
    fn set_seeds(&mut self, seeds: u32) -> Result<()> {
        self.problem_mut().seeds = seeds;
        self.seeds_changed()
    }

    /// The rounding error a sum of squares near `sum_sq` from this evaluator may carry (model
    /// units squared, first order, for individuals near the reference): differences below it
    /// are not resolved.
    fn resolution(&self, sum_sq: f64) -> f64 {
        self.problem().resolution(sum_sq)
    }

    /// The backend and adapter that run the evaluations.
    fn info(&self) -> &BackendInfo;

    /// Design variables per individual.
    fn design_variables(&self) -> usize {
        self.problem().n_vars
    }

    /// Number of target points.
    fn points(&self) -> usize {
        self.problem().n_points()
    }
}

/// Build an evaluator on the backend `options` asks for. [`Backend::Auto`] takes a hardware
/// GPU ([`GpuContext::shared_hardware`]); without one (no adapter, a software adapter such as
/// lavapipe, `BEZCHAIN_NO_GPU=1`, a device error) it falls back to the CPU, and
/// [`BackendInfo::fallback`] says why.
pub fn build_evaluator(
    layout: &EvalLayout,
    targets: &Targets,
    options: &EvalOptions,
) -> Result<Box<dyn PopulationEvaluator>> {
    let cpu = || -> Result<CpuEvaluator> {
        let mut e = CpuEvaluator::new(layout, targets, options.newton)?.crossing(options.cross_patches);
        e.set_seeds(options.seeds)?;
        Ok(e)
    };
    let gpu = |context: Result<GpuContext>| {
        context.and_then(|ctx| {
            GpuEvaluator::with_seeds(
                &ctx,
                layout,
                targets,
                (options.newton, options.cross_patches, options.seeds),
                &options.gpu,
            )
        })
    };
    Ok(match options.backend {
        Backend::Cpu => Box::new(cpu()?),
        Backend::Gpu => Box::new(gpu(GpuContext::shared())?),
        Backend::Auto => {
            // Input errors are the caller's whichever path runs: check them before trying.
            let cpu = cpu()?;
            match gpu(GpuContext::shared_hardware()) {
                Ok(g) => Box::new(g),
                Err(e) => Box::new(cpu.with_fallback(e.to_string())),
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backends_parse_and_print() {
        for b in [Backend::Auto, Backend::Gpu, Backend::Cpu] {
            assert_eq!(b.to_string().parse::<Backend>().unwrap(), b);
        }
        assert_eq!("GPU".parse::<Backend>().unwrap(), Backend::Gpu);
        assert!("cuda".parse::<Backend>().is_err());
    }

    #[test]
    fn targets_check_their_sizes() {
        assert!(Targets::curve(&[DVec2::ZERO], &[0.1, 0.2]).is_err());
        assert!(Targets::grid(&[DVec3::new(f64::NAN, 0.0, 0.0)], &[DVec2::ZERO]).is_err());
        let t = Targets::curve(&[DVec2::new(1.0, 2.0)], &[0.3]).unwrap();
        assert_eq!(t.points()[0], DVec3::new(1.0, 2.0, 0.0));
        assert_eq!(t.params()[0], DVec2::new(0.3, 0.0));
    }
}
