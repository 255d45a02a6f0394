//! The batched panel kernel's data, shared by the shader `shaders/aero.wgsl`, its CPU mirror
//! ([`super::cpu`]) and the GPU driver ([`super::gpu`]): the `#[repr(C)]` structs both read, the
//! per-individual results and flags, the dispatch plan and the evaluator trait.

use crate::error::{Error, Result};
use crate::eval::BackendInfo;
use bytemuck::{Pod, Zeroable};
use serde::Serialize;

/// The kernel's settings. Must be kept in sync with `struct AeroConfig` in `shaders/aero.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AeroConfig {
    /// Individuals in this dispatch.
    pub population: u32,
    /// Interleaving stride of the work buffer (individuals it holds).
    pub stride: u32,
    /// Design variables per individual.
    pub n_vars: u32,
    /// Panel nodes.
    pub n_nodes: u32,
    /// 0: coefficients only, 1: max CL, 2: inverse (target Cp).
    pub objective: u32,
    /// Samples per surface of the target Cp table.
    pub target_samples: u32,
    /// Bit 0: minimum thickness; bit 1: minimum CM.
    pub constraints: u32,
    /// Padding.
    pub _pad0: u32,
    /// cos α.
    pub cos_alpha: f32,
    /// sin α.
    pub sin_alpha: f32,
    /// Smallest thickness/chord allowed.
    pub min_thickness: f32,
    /// Smallest CM allowed.
    pub cm_min: f32,
}

/// One dispatch of the kernel's plan: a phase and its range of rows or steps. Must be kept in
/// sync with `struct AeroStep` in `shaders/aero.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct AeroStep {
    /// 0 nodes, 1 assembly, 2 elimination, 3 back substitution, 4 coefficients and score.
    pub phase: u32,
    /// First row or step.
    pub first: u32,
    /// One past the last row or step.
    pub last: u32,
    /// Padding.
    pub _pad0: u32,
}

/// Loop iterations one dispatch may run per invocation. Mesa's llvmpipe (lavapipe) ends every
/// loop of an invocation after 65535 iterations of all its loops together
/// (`LP_MAX_TGSI_LOOP_ITERATIONS`), silently; the plan keeps each dispatch below this.
pub const LOOP_BUDGET: usize = 60_000;
/// The most nodes the GPU kernel takes: one elimination step of `N (N + 1)` iterations must fit
/// [`LOOP_BUDGET`].
pub const MAX_GPU_NODES: usize = 240;

/// One individual's result. Must be kept in sync with `struct AeroResult` in
/// `shaders/aero.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable, Serialize)]
pub struct AeroResult {
    /// Lift coefficient.
    pub cl: f32,
    /// Moment coefficient about the quarter chord.
    pub cm: f32,
    /// Largest thickness over chord.
    pub thickness: f32,
    /// The objective (0 without one).
    pub objective: f32,
    /// What the optimisers minimise (see the module documentation).
    pub score: f32,
    /// [`flags`] bits.
    pub flags: u32,
    /// How far outside the constraints (or the valid geometry) the shape is.
    pub violation: f32,
    /// Padding.
    pub _pad0: u32,
}

/// The bits of [`AeroResult::flags`]: what is wrong with a shape.
pub mod flags {
    /// A node or coefficient is not finite.
    pub const NON_FINITE: u32 = 1;
    /// A surface runs back in x by more than 10⁻³ chord.
    pub const FOLD: u32 = 2;
    /// The upper surface lies below the lower one somewhere (negative thickness).
    pub const CROSSING: u32 = 4;
    /// Two nodes coincide, the chord vanishes or the system is singular.
    pub const SINGULAR: u32 = 8;
    /// Thinner than the minimum thickness.
    pub const THIN: u32 = 16;
    /// CM below its minimum.
    pub const CM: u32 = 32;
    /// The viscous analysis did not converge (set on the CPU, never by the kernel).
    pub const UNCONVERGED: u32 = 64;
    /// Thinner than a minimum at a given station (set on the CPU after the kernel).
    pub const THIN_AT: u32 = 128;
    /// A trailing-edge wedge angle below its minimum (set on the CPU after the kernel).
    pub const TE_ANGLE: u32 = 256;
    /// An area below its minimum (set on the CPU after the kernel).
    pub const AREA: u32 = 512;
    /// CL below its minimum (set on the CPU after the kernel).
    pub const CL: u32 = 1024;
    /// The flags that make the geometry unusable.
    pub const GEOMETRY: u32 = NON_FINITE | FOLD | CROSSING | SINGULAR;

    /// The reasons, one word each, with their bits.
    pub const NAMES: [(u32, &str); 11] = [
        (NON_FINITE, "non-finite"),
        (FOLD, "fold"),
        (CROSSING, "crossing"),
        (SINGULAR, "singular"),
        (THIN, "thin"),
        (CM, "cm"),
        (UNCONVERGED, "unconverged"),
        (THIN_AT, "thin-at"),
        (TE_ANGLE, "te-angle"),
        (AREA, "area"),
        (CL, "cl"),
    ];
}

/// Added to the score of a shape that breaks a constraint.
pub const PENALTY_CONSTRAINT: f64 = 1e3;
/// Added to the score of a valid shape whose viscous analysis does not converge (it ranks
/// after every converged shape, before every unusable one).
pub const PENALTY_UNCONVERGED: f64 = 1e4;
/// Added to the score of an unusable shape.
pub const PENALTY_GEOMETRY: f64 = 1e6;
/// The largest violation counted in a score.
pub const MAX_VIOLATION: f64 = 1e5;
/// A surface may run back in x by this much (chord fraction) before it counts as folded.
pub const FOLD_TOLERANCE: f64 = 1e-3;
/// The upper and lower surfaces may swap by this much (chord fraction) before they count as
/// crossed: the kernels' f32 cannot tell a closed trailing edge from one crossed by rounding.
pub const CROSS_TOLERANCE: f64 = 1e-6;
/// Samples per surface of the target Cp table.
pub const TARGET_SAMPLES: usize = 1001;

/// What the kernels read, in f32 (see `shaders/aero.wgsl`).
#[derive(Clone, Debug, PartialEq)]
pub struct AeroKernel {
    /// Settings (`population` and `stride` are set per dispatch).
    pub config: AeroConfig,
    /// `2N × n_vars`, row `2k + c` the effect of every variable on coordinate `c` of node `k`.
    pub node_map: Vec<f32>,
    /// `2N`: the nodes at zero offsets.
    pub node_base: Vec<f32>,
    /// `2 × TARGET_SAMPLES`: the target Cp table (zeros without an inverse objective).
    pub target: Vec<f32>,
}

impl AeroKernel {
    /// f32 words of one individual's working set: nodes, matrix, two right-hand sides, 16
    /// scalars.
    #[must_use]
    pub fn work_words(&self) -> usize {
        let n = self.config.n_nodes as usize;
        2 * n + (n + 1) * (n + 1) + 2 * (n + 1) + 16
    }

    /// The dispatches of one evaluation: nodes, assembly rows, elimination steps and
    /// back-substitution rows in groups of at most [`LOOP_BUDGET`] loop iterations per
    /// invocation, then the coefficients.
    #[must_use]
    pub fn plan(&self) -> Vec<AeroStep> {
        let n = self.config.n_nodes as usize;
        let step = |phase: u32, first: usize, last: usize| AeroStep {
            phase,
            first: first as u32,
            last: last as u32,
            _pad0: 0,
        };
        let mut plan = vec![step(0, 0, 0)];
        let rows = ((LOOP_BUDGET.saturating_sub(2 * n + 2)) / (n + 1)).max(1);
        for first in (0..n).step_by(rows) {
            plan.push(step(1, first, (first + rows).min(n)));
        }
        let (mut first, mut cost) = (0, 0);
        for k in 0..n - 1 {
            let c = (n - k) * (n - k + 1) + 1;
            if cost + c > LOOP_BUDGET && k > first {
                plan.push(step(2, first, k));
                (first, cost) = (k, 0);
            }
            cost += c;
        }
        plan.push(step(2, first, n - 1));
        let (mut last, mut cost) = (n - 1, 2);
        for k in (0..n - 1).rev() {
            let c = 2 * (n - k + 1);
            if cost + c > LOOP_BUDGET && k + 1 < last {
                plan.push(step(3, k + 1, last));
                (last, cost) = (k + 1, 2);
            }
            cost += c;
        }
        plan.push(step(3, 0, last));
        plan.push(step(4, 0, 0));
        plan
    }

    /// Rows of `population` (flat, `n_vars` per row) for `out.len()` results, checked.
    pub fn rows(&self, population: &[f32], results: usize) -> Result<usize> {
        let nv = self.config.n_vars as usize;
        if population.len() != results * nv {
            return Err(Error::invalid(format!(
                "population of {} values for {results} individuals of {nv} variables",
                population.len()
            )));
        }
        Ok(results)
    }
}

/// Evaluates populations of an [`AeroBatch`](super::AeroBatch)'s kernel on one backend.
pub trait AeroEvaluator: Send {
    /// Evaluate the rows of `population` (`n_vars` offsets each) into `out`, in order.
    fn evaluate(&mut self, population: &[f32], out: &mut [AeroResult]) -> Result<()>;

    /// The backend and adapter that run the evaluations.
    fn info(&self) -> &BackendInfo;
}
