//! The panel method for whole populations: design vectors mapped linearly to panel nodes,
//! solved on the population evaluator (`shaders/aero.wgsl`, its CPU mirror
//! `src/aero/batch/cpu.rs`), and the same in f64 for reference.
//!
//! An individual is a vector `δ` of offsets from a start design. Its panel nodes are
//! `base + M δ`: the node parameters are fixed (placed once on the start shape by
//! [`panel_params`](super::panel_params)), and every node is then a fixed linear combination
//! of the control points, themselves linear in the stored numbers of the encoding (see
//! [`NodeMap`]). The kernel takes the nodes in the start's chord frame (origin at its
//! mid-chord, unit chord), so f32 sees numbers near 1 wherever the shape sits.
//!
//! Per individual the kernel returns CL, CM about the quarter chord, the thickness/chord,
//! the objective, flags saying what is wrong with the shape, and a score the optimisers
//! minimise: the objective when the shape is valid and meets the constraints; otherwise
//! `1e3 + violation` when it breaks a constraint (the summed shortfalls of t/c and CM, so the
//! solvers are led back to the feasible side), and `1e6 + violation` when its geometry is
//! unusable (non-finite nodes, a zero-length panel, a surface that folds back in x by more
//! than 10⁻³ chord, an upper surface below the lower one, a singular system). The score is
//! never NaN.

use super::panel::{Chord, PanelSolution};
use crate::error::{Error, Result};
use crate::eval::{Backend, GpuOptions};
use glam::DVec2;
use serde::Serialize;

pub mod cpu;
pub mod gpu;
pub mod kernel;

pub use kernel::{
    flags, AeroConfig, AeroEvaluator, AeroKernel, AeroResult, AeroStep, CROSS_TOLERANCE, FOLD_TOLERANCE,
    LOOP_BUDGET, MAX_GPU_NODES, MAX_VIOLATION, PENALTY_CONSTRAINT, PENALTY_GEOMETRY, PENALTY_UNCONVERGED,
    TARGET_SAMPLES,
};

/// Panel nodes as an affine function of the design offsets: node `k` is
/// `base[k] + Σ_i columns[i][k] δ_i` (model units).
#[derive(Clone, Debug, PartialEq)]
pub struct NodeMap {
    /// The nodes at `δ = 0`, counterclockwise from the upper trailing edge.
    pub base: Vec<DVec2>,
    /// Each design variable's effect on every node.
    pub columns: Vec<Vec<DVec2>>,
}

impl NodeMap {
    /// The nodes of `delta` (f64).
    #[must_use]
    pub fn nodes(&self, delta: &[f64]) -> Vec<DVec2> {
        let mut out = self.base.clone();
        for (col, &d) in self.columns.iter().zip(delta) {
            for (o, c) in out.iter_mut().zip(col) {
                *o += *c * d;
            }
        }
        out
    }
}

/// The pressure distribution to match: Cp against `ξ = √(x/c)` on each surface (from the
/// leading edge), [`TARGET_SAMPLES`] even steps of ξ from 0 to 1, upper surface then lower.
/// A node belongs to the upper surface when it lies before the leading edge
/// ([`Chord::upper`]: the refined leading edge, so that the assignment changes only where a
/// node passes the leading edge itself, ξ = 0, and the objective stays continuous).
#[derive(Clone, Debug, PartialEq)]
pub struct TargetCp {
    /// `2 × TARGET_SAMPLES` values.
    pub table: Vec<f64>,
}

impl TargetCp {
    /// The table of a solved shape at `alpha` degrees.
    pub fn of(solution: &PanelSolution, alpha: f64) -> Result<TargetCp> {
        let nodes = solution.nodes();
        let chord = solution.chord();
        let cp = solution.cp(alpha);
        let dir = (chord.te - chord.le) / chord.length;
        let xi = |p: DVec2| ((p - chord.le).dot(dir) / chord.length).max(0.0).sqrt().min(1.0);
        // Each surface from the leading edge: (ξ, Cp), ξ increasing.
        let n = nodes.len();
        let upper: Vec<(f64, f64)> = (0..n)
            .rev()
            .filter(|&i| chord.upper(i))
            .map(|i| (xi(nodes[i]), cp[i]))
            .collect();
        let lower: Vec<(f64, f64)> = (0..n)
            .filter(|&i| !chord.upper(i))
            .map(|i| (xi(nodes[i]), cp[i]))
            .collect();
        let mut table = Vec::with_capacity(2 * TARGET_SAMPLES);
        for side in [&upper, &lower] {
            for m in 0..TARGET_SAMPLES {
                table.push(interpolate(side, m as f64 / (TARGET_SAMPLES - 1) as f64));
            }
        }
        if table.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical("the target pressures are not finite".into()));
        }
        Ok(TargetCp { table })
    }

    /// The target Cp at `xi` on the upper (`true`) or lower surface, as the kernel reads it.
    #[must_use]
    pub fn at(&self, upper: bool, xi: f64) -> f64 {
        let ns = TARGET_SAMPLES;
        let side = if upper { 0 } else { ns };
        let x = xi.clamp(0.0, 1.0) * (ns - 1) as f64;
        let lo = (x as usize).min(ns - 2);
        let fr = x - lo as f64;
        self.table[side + lo] + fr * (self.table[side + lo + 1] - self.table[side + lo])
    }
}

/// Linear interpolation in `(x, y)` pairs sorted by x (mostly: near the leading edge a node
/// may step back; the first bracketing pair is used), clamped at the ends.
fn interpolate(pairs: &[(f64, f64)], x: f64) -> f64 {
    if x <= pairs[0].0 {
        return pairs[0].1;
    }
    for w in pairs.windows(2) {
        if x >= w[0].0 && x <= w[1].0 && w[1].0 > w[0].0 {
            return w[0].1 + (x - w[0].0) / (w[1].0 - w[0].0) * (w[1].1 - w[0].1);
        }
    }
    pairs[pairs.len() - 1].1
}

/// What a population is scored on.
#[derive(Clone, Debug, PartialEq)]
pub enum Objective {
    /// Coefficients only (score 0).
    None,
    /// Maximise CL (score `−CL`).
    MaxCl,
    /// Match a pressure distribution (score: the arclength-weighted mean of `(Cp − Cp_t)²`).
    Inverse(TargetCp),
}

/// Constraints on a shape.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Constraints {
    /// Smallest thickness/chord allowed. Default none.
    pub min_thickness: Option<f64>,
    /// Smallest CM (about the quarter chord) allowed. Default none.
    pub cm_min: Option<f64>,
}

/// A population problem: the node map, the angle of attack, the objective and constraints.
#[derive(Clone, Debug, PartialEq)]
pub struct AeroBatch {
    map: NodeMap,
    alpha: f64,
    objective: Objective,
    constraints: Constraints,
    origin: DVec2,
    scale: f64,
}

/// One individual measured in f64.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct AeroEval {
    /// Lift coefficient.
    pub cl: f64,
    /// Moment coefficient about the quarter chord.
    pub cm: f64,
    /// Largest thickness over chord.
    pub thickness: f64,
    /// The objective.
    pub objective: f64,
    /// The score.
    pub score: f64,
    /// [`flags`] bits.
    pub flags: u32,
    /// The violation.
    pub violation: f64,
    /// The drag coefficient, for viscous objectives (at the first operating point).
    pub cd: Option<f64>,
    /// The angle of attack of the first operating point, degrees, for viscous objectives
    /// (solved for when the point is a CL).
    pub alpha: Option<f64>,
}

/// Thickness, folds and crossings of nodes in chord axes (see the module documentation):
/// `(thickness, flags, violation)`.
fn geometry(nodes: &[DVec2], chord: &Chord) -> (f64, u32, f64) {
    let n = nodes.len();
    let dir = (chord.te - chord.le) / chord.length;
    let x = |p: DVec2| (p - chord.le).dot(dir) / chord.length;
    let y = |p: DVec2| dir.perp_dot(p - chord.le) / chord.length;
    let k = chord.le_node;
    let (mut flags, mut violation) = (0u32, 0.0f64);
    for i in 0..k {
        let back = x(nodes[i + 1]) - x(nodes[i]);
        if back > FOLD_TOLERANCE {
            flags |= flags::FOLD;
            violation = violation.max(back);
        }
    }
    for i in k..n - 1 {
        let back = x(nodes[i]) - x(nodes[i + 1]);
        if back > FOLD_TOLERANCE {
            flags |= flags::FOLD;
            violation = violation.max(back);
        }
    }
    let mut thick = 0.0f64;
    let mut m = k;
    for i in (0..k).rev() {
        let (xu, yu) = (x(nodes[i]), y(nodes[i]));
        while m + 2 < n && x(nodes[m + 1]) < xu {
            m += 1;
        }
        let (xl0, xl1) = (x(nodes[m]), x(nodes[m + 1]));
        if xu >= xl0 && xu <= xl1 && xl1 > xl0 {
            let yl = y(nodes[m]) + (xu - xl0) / (xl1 - xl0) * (y(nodes[m + 1]) - y(nodes[m]));
            let t = yu - yl;
            thick = thick.max(t);
            if t < -CROSS_TOLERANCE {
                flags |= flags::CROSSING;
                violation = violation.max(-t);
            }
        }
    }
    let te_cross = y(nodes[n - 1]) - y(nodes[0]);
    if te_cross > CROSS_TOLERANCE {
        flags |= flags::CROSSING;
        violation = violation.max(te_cross);
    }
    (thick, flags, violation)
}

impl AeroBatch {
    /// A problem on `map` at `alpha` degrees. The kernel's frame is the base shape's chord.
    pub fn new(map: NodeMap, alpha: f64, objective: Objective, constraints: Constraints) -> Result<Self> {
        if map.base.len() < super::panel::MIN_NODES {
            return Err(Error::invalid(format!(
                "at least {} panel nodes are needed, not {}",
                super::panel::MIN_NODES,
                map.base.len()
            )));
        }
        if map.columns.iter().any(|c| c.len() != map.base.len()) {
            return Err(Error::invalid("node map: every column needs one entry per node"));
        }
        if !alpha.is_finite() {
            return Err(Error::invalid("the angle of attack must be finite"));
        }
        let chord = Chord::of(&map.base);
        if !(chord.length > 0.0) || !chord.length.is_finite() {
            return Err(Error::invalid("the start shape has no chord"));
        }
        Ok(AeroBatch {
            origin: 0.5 * (chord.le + chord.te),
            scale: 1.0 / chord.length,
            map,
            alpha,
            objective,
            constraints,
        })
    }

    /// Design variables per individual.
    #[must_use]
    pub fn n_vars(&self) -> usize {
        self.map.columns.len()
    }

    /// Panel nodes.
    #[must_use]
    pub fn n_nodes(&self) -> usize {
        self.map.base.len()
    }

    /// The node map.
    #[must_use]
    pub fn map(&self) -> &NodeMap {
        &self.map
    }

    /// The angle of attack, degrees.
    #[must_use]
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// The objective.
    #[must_use]
    pub fn objective(&self) -> &Objective {
        &self.objective
    }

    /// The constraints.
    #[must_use]
    pub fn constraints(&self) -> Constraints {
        self.constraints
    }

    /// The panel solution of one individual (f64), or why there is none.
    pub fn solve(&self, delta: &[f64]) -> Result<PanelSolution> {
        PanelSolution::solve(&self.map.nodes(delta))
    }

    /// One individual measured in f64: the reference for the kernel.
    #[must_use]
    pub fn reference(&self, delta: &[f64]) -> AeroEval {
        let fail = |flags: u32, violation: f64| AeroEval {
            flags,
            violation: violation.min(MAX_VIOLATION),
            score: PENALTY_GEOMETRY + violation.min(MAX_VIOLATION),
            ..AeroEval::default()
        };
        if delta.len() != self.n_vars() || delta.iter().any(|d| !d.is_finite()) {
            return fail(flags::NON_FINITE, MAX_VIOLATION);
        }
        let nodes = self.map.nodes(delta);
        if nodes.iter().any(|p| !p.is_finite()) {
            return fail(flags::NON_FINITE, MAX_VIOLATION);
        }
        let sol = match PanelSolution::solve(&nodes) {
            Ok(s) => s,
            Err(_) => return fail(flags::SINGULAR, MAX_VIOLATION),
        };
        let c = sol.coefficients(self.alpha);
        let (thickness, mut fl, mut violation) = geometry(&nodes, &sol.chord());
        if !c.cl.is_finite() || !c.cm.is_finite() {
            fl |= flags::NON_FINITE;
            violation = MAX_VIOLATION;
        }
        if fl & flags::GEOMETRY != 0 {
            return fail(fl, violation);
        }
        let objective = match &self.objective {
            Objective::None => 0.0,
            Objective::MaxCl => -c.cl,
            Objective::Inverse(target) => inverse_objective(&sol, self.alpha, target),
        };
        let mut cviol = 0.0;
        if let Some(t) = self.constraints.min_thickness {
            if thickness < t {
                fl |= flags::THIN;
                cviol += t - thickness;
            }
        }
        if let Some(m) = self.constraints.cm_min {
            if c.cm < m {
                fl |= flags::CM;
                cviol += m - c.cm;
            }
        }
        AeroEval {
            cl: c.cl,
            cm: c.cm,
            thickness,
            objective,
            score: if cviol > 0.0 {
                PENALTY_CONSTRAINT + cviol
            } else {
                objective
            },
            flags: fl,
            violation: cviol,
            ..AeroEval::default()
        }
    }

    /// The f32 data the kernels read: settings, node map, base nodes and target, in the start's
    /// chord frame.
    #[must_use]
    pub fn kernel(&self) -> AeroKernel {
        let n = self.n_nodes();
        let nv = self.n_vars();
        let mut node_map = vec![0.0f32; 2 * n * nv];
        let mut node_base = vec![0.0f32; 2 * n];
        for k in 0..n {
            let b = (self.map.base[k] - self.origin) * self.scale;
            node_base[2 * k] = b.x as f32;
            node_base[2 * k + 1] = b.y as f32;
            for (i, col) in self.map.columns.iter().enumerate() {
                let c = col[k] * self.scale;
                node_map[2 * k * nv + i] = c.x as f32;
                node_map[(2 * k + 1) * nv + i] = c.y as f32;
            }
        }
        let (objective, target) = match &self.objective {
            Objective::None => (0, vec![0.0; 2 * TARGET_SAMPLES]),
            Objective::MaxCl => (1, vec![0.0; 2 * TARGET_SAMPLES]),
            Objective::Inverse(t) => (2, t.table.iter().map(|&v| v as f32).collect()),
        };
        let (s, c) = self.alpha.to_radians().sin_cos();
        let mut constraints = 0;
        if self.constraints.min_thickness.is_some() {
            constraints |= 1;
        }
        if self.constraints.cm_min.is_some() {
            constraints |= 2;
        }
        AeroKernel {
            config: AeroConfig {
                population: 0,
                stride: 0,
                n_vars: nv as u32,
                n_nodes: n as u32,
                objective,
                target_samples: TARGET_SAMPLES as u32,
                constraints,
                _pad0: 0,
                cos_alpha: c as f32,
                sin_alpha: s as f32,
                min_thickness: self.constraints.min_thickness.unwrap_or(0.0) as f32,
                cm_min: self.constraints.cm_min.unwrap_or(0.0) as f32,
            },
            node_map,
            node_base,
            target,
        }
    }
}

/// The arclength-weighted mean of `(Cp − Cp_target)²` over the nodes (as the kernel has it).
fn inverse_objective(sol: &PanelSolution, alpha: f64, target: &TargetCp) -> f64 {
    let nodes = sol.nodes();
    let chord = sol.chord();
    let dir = (chord.te - chord.le) / chord.length;
    let cp = sol.cp(alpha);
    let n = nodes.len();
    let (mut sum, mut wsum) = (0.0, 0.0);
    for k in 0..n {
        let prev = k.saturating_sub(1);
        let next = (k + 1).min(n - 1);
        let w = 0.5 * ((nodes[k] - nodes[prev]).length() + (nodes[next] - nodes[k]).length());
        let x = ((nodes[k] - chord.le).dot(dir) / chord.length).max(0.0);
        let ct = target.at(chord.upper(k), x.sqrt().min(1.0));
        sum += w * (cp[k] - ct).powi(2);
        wsum += w;
    }
    sum / wsum
}

/// Build an evaluator for `kernel` on `backend`. Auto takes the CPU and says why: the kernel
/// solves one shape's dense panel system an invocation, and at a GA's populations a GPU is
/// slower than the CPU with it (on an NVIDIA H200 0.04 × the machine's 16 cores at 1,024
/// shapes and 0.5 × at 16,384; lavapipe 0.02 × on two cores); `Backend::Gpu` runs it there.
pub fn build_aero_evaluator(
    kernel: &AeroKernel,
    backend: Backend,
    gpu: &GpuOptions,
) -> Result<Box<dyn AeroEvaluator>> {
    use crate::eval::GpuContext;
    use cpu::CpuAero;
    use gpu::GpuAero;
    match backend {
        Backend::Cpu => Ok(Box::new(CpuAero::new(kernel.clone()))),
        Backend::Gpu => Ok(Box::new(GpuAero::new(
            &GpuContext::shared()?,
            kernel.clone(),
            gpu,
        )?)),
        Backend::Auto => Ok(Box::new(
            CpuAero::new(kernel.clone()).with_fallback(
                "the panel kernel runs faster on the CPU than on a GPU at a GA's populations \
             (--backend gpu runs it there)"
                    .into(),
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 build and the portable build compute the same values, and a row's result does
    /// not depend on the other rows of its batch (a generation split over MPI ranks,
    /// [`crate::team::share`], gives the same bits as one batch).
    #[test]
    fn every_build_of_the_kernels_gives_the_same_bits() {
        let pts = crate::geometry::test_contour("4412", 82);
        let a = crate::aero::Analysis::of_points(&pts, &crate::aero::Paneling::with_nodes(48)).unwrap();
        let base = a.solution.nodes().to_vec();
        let k = a.solution.chord().le_node;
        // One variable lifting the upper surface.
        let col = (0..base.len())
            .map(|i| {
                if i < k {
                    glam::DVec2::new(0.0, base[i].x * (1.0 - base[i].x))
                } else {
                    glam::DVec2::ZERO
                }
            })
            .collect();
        let map = crate::aero::NodeMap {
            base,
            columns: vec![col],
        };
        let b =
            crate::aero::AeroBatch::new(map, 3.0, crate::aero::Objective::MaxCl, Default::default()).unwrap();
        let pop: Vec<f32> = (0..20).map(|i| 0.002 * i as f32 - 0.02).collect();
        let mut fast = vec![AeroResult::default(); 20];
        let mut portable = fast.clone();
        cpu::CpuAero::new(b.kernel()).evaluate(&pop, &mut fast).unwrap();
        cpu::CpuAero::new_portable(b.kernel())
            .evaluate(&pop, &mut portable)
            .unwrap();
        assert_eq!(fast, portable);
        assert!(fast.iter().all(|r| r.flags == 0 && r.cl > 0.5));
        let bits = |r: &[AeroResult]| bytemuck::cast_slice::<AeroResult, u32>(r).to_vec();
        for ranks in [2, 3, 20] {
            let mut split = Vec::new();
            for rank in 0..ranks {
                let rows = crate::team::share(20, rank, ranks);
                let mut part = vec![AeroResult::default(); rows.len()];
                cpu::CpuAero::new(b.kernel())
                    .evaluate(&pop[rows], &mut part)
                    .unwrap();
                split.extend(part);
            }
            assert_eq!(bits(&split), bits(&fast), "{ranks} shares");
        }
    }

    use crate::aero::{Analysis, Paneling};
    use crate::geometry::test_contour;

    fn naca(code: &str) -> Vec<DVec2> {
        test_contour(code, 161)
    }

    /// A map whose two variables move the upper and the lower surface up.
    fn map_of(points: &[DVec2]) -> NodeMap {
        let a = Analysis::of_points(points, &Paneling::default()).unwrap();
        let base = a.solution.nodes().to_vec();
        let k = a.solution.chord().le_node;
        let up = (0..base.len())
            .map(|i| {
                if i <= k {
                    DVec2::new(0.0, 1.0) * (1.0 - base[i].x) * base[i].x
                } else {
                    DVec2::ZERO
                }
            })
            .collect();
        let down = (0..base.len())
            .map(|i| {
                if i > k {
                    DVec2::new(0.0, 1.0) * (1.0 - base[i].x) * base[i].x
                } else {
                    DVec2::ZERO
                }
            })
            .collect();
        NodeMap {
            base,
            columns: vec![up, down],
        }
    }

    #[test]
    fn the_reference_scores_shapes_and_their_faults() {
        let pts = naca("0012");
        let batch = AeroBatch::new(
            map_of(&pts),
            4.0,
            Objective::MaxCl,
            Constraints {
                min_thickness: Some(0.12),
                cm_min: None,
            },
        )
        .unwrap();
        let start = batch.reference(&[0.0, 0.0]);
        assert_eq!(start.flags, 0, "{start:?}");
        assert!((start.thickness - 0.12).abs() < 2e-3, "{start:?}");
        assert!((start.score + start.cl).abs() < 1e-12);
        // Thinner: a constraint penalty with its shortfall.
        let thin = batch.reference(&[-0.05, 0.0]);
        assert_eq!(thin.flags, flags::THIN, "{thin:?}");
        assert!((thin.score - PENALTY_CONSTRAINT - thin.violation).abs() < 1e-9);
        // Lower surface pushed through the upper: crossing.
        let crossed = batch.reference(&[0.0, 0.6]);
        assert_ne!(crossed.flags & flags::CROSSING, 0, "{crossed:?}");
        assert!(crossed.score >= PENALTY_GEOMETRY);
        // Non-finite offsets.
        let nan = batch.reference(&[f64::NAN, 0.0]);
        assert_eq!(nan.flags, flags::NON_FINITE);
        assert!(nan.score.is_finite());
    }

    #[test]
    fn the_plan_covers_every_row_and_step_within_the_loop_budget() {
        for n in [8, 40, 160, 240] {
            let map = NodeMap {
                base: (0..n)
                    .map(|k| {
                        let a = std::f64::consts::TAU * k as f64 / (n - 1) as f64;
                        DVec2::new(0.5 + 0.5 * a.cos(), 0.06 * a.sin())
                    })
                    .collect(),
                columns: vec![],
            };
            let plan = AeroBatch::new(map, 0.0, Objective::None, Constraints::default())
                .unwrap()
                .kernel()
                .plan();
            let ranges = |phase: u32| -> Vec<(usize, usize)> {
                plan.iter()
                    .filter(|s| s.phase == phase)
                    .map(|s| (s.first as usize, s.last as usize))
                    .collect()
            };
            let assemble = ranges(1);
            assert_eq!(assemble.first().unwrap().0, 0);
            assert_eq!(assemble.last().unwrap().1, n);
            assert!(assemble.windows(2).all(|w| w[0].1 == w[1].0));
            let elim = ranges(2);
            assert_eq!((elim[0].0, elim.last().unwrap().1), (0, n - 1));
            assert!(elim.windows(2).all(|w| w[0].1 == w[1].0));
            for &(a, b) in &elim {
                let cost: usize = (a..b).map(|k| (n - k) * (n - k + 1) + 1).sum();
                assert!(
                    cost <= LOOP_BUDGET || b == a + 1,
                    "n {n}: steps {a}..{b} cost {cost}"
                );
            }
            // Back substitution runs downwards: the first range ends at N − 1.
            let back = ranges(3);
            assert_eq!((back[0].1, back.last().unwrap().0), (n - 1, 0));
            assert!(back.windows(2).all(|w| w[0].0 == w[1].1));
            assert_eq!(plan[0].phase, 0);
            assert_eq!(plan.last().unwrap().phase, 4);
        }
    }

    #[test]
    fn the_inverse_objective_vanishes_on_the_target() {
        let pts = naca("4412");
        let a = Analysis::of_points(&pts, &Paneling::default()).unwrap();
        let target = TargetCp::of(&a.solution, 4.0).unwrap();
        let batch = AeroBatch::new(
            map_of(&pts),
            4.0,
            Objective::Inverse(target),
            Constraints::default(),
        )
        .unwrap();
        let at = batch.reference(&[0.0, 0.0]);
        assert!(at.objective < 1e-5, "{at:?}");
        let off = batch.reference(&[0.02, 0.0]);
        assert!(off.objective > 100.0 * at.objective.max(1e-8), "{off:?}");
    }
}
