//! Inviscid aerofoil aerodynamics for shape optimisation: XFOIL's linear-vorticity panel
//! method as an f64 reference, its analytic truth, and the batched form that the population
//! evaluator runs.
//!
//! - [`analysis`]: [`Analysis`], a contour paneled and solved: its polar and pressures.
//! - [`panel`]: [`PanelSolution`], the panel method on given nodes (two unit solutions, CL,
//!   CM about the quarter chord, Cp at every node).
//! - [`contour`]: [`Contour`] (a chain, a spline through raw coordinates) and
//!   [`panel_params`], XFOIL's `PANE` node placement as fixed parameters on a contour.
//! - [`design`]: [`DesignSpace`], an adapted encoding's stored numbers as bounded offsets,
//!   and their linear map to panel nodes.
//! - [`batch`]: [`AeroBatch`], the panel method for populations: a node map linear in the
//!   design offsets, the objective and constraints, the f32 kernel's data and evaluators
//!   (`shaders/aero.wgsl` and its CPU mirror), and the f64 reference.
//! - [`optimise`]: [`Optimisation`], the GA and CMA-ES over a design space, every generation
//!   one call of the panel-method evaluator (or, for viscous objectives, of the viscous
//!   analysis with rayon), with checkpoints.
//! - [`objectives`]: the objectives (`max-ld`, `min-cd`, `multipoint:FILE`, `inverse:TARGET`,
//!   `max-cl`), one file each behind one trait, registered in one list.
//! - [`operating`]: [`ViscousGoal`], a viscous objective's weighted operating points (an angle
//!   or a design CL at a Reynolds number) and a shape's score on them; the multipoint file.
//! - [`constraints`]: [`ExtraConstraints`], the constraints checked in f64 after the kernel
//!   (thickness at stations, trailing-edge angle, area, CL), and the active ones of a result.
//! - [`study`]: an optimisation from files to results and its report, as `bezchain optimise`
//!   runs it.
//! - [`input`]: an aerofoil as the commands name one, a coordinate file or a curve report.
//! - [`viscous`]: [`Viscous`], the panel method coupled to an integral boundary layer (XFOIL's
//!   closures, e^N transition, global Newton): viscous polars.
//! - [`karman_trefftz`]: [`KarmanTrefftz`], the aerofoil whose potential flow is known in
//!   closed form.

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod analysis;
pub mod batch;
pub mod constraints;
pub mod contour;
pub mod design;
pub mod input;
pub mod karman_trefftz;
pub mod objectives;
pub mod operating;
pub mod optimise;
pub mod panel;
pub mod study;
pub mod viscous;

pub use crate::optim::Method;
pub use analysis::{check_polar, AeroInput, AeroReport, Analysis, ChordReport, Pressure};
pub use batch::{
    build_aero_evaluator, AeroBatch, AeroEval, AeroEvaluator, AeroKernel, AeroResult, Constraints, NodeMap,
    Objective, TargetCp,
};
pub use constraints::ExtraConstraints;
pub use contour::{leading_edge_param, panel_params, Contour, Paneling, SplineContour, DEFAULT_NODES};
pub use design::{DesignSpace, Hold};
pub use input::{analyse_input, Aerofoil};
pub use karman_trefftz::{KarmanTrefftz, TruthErrors};
pub use objectives::Conditions;
pub use objectives::{About, AeroObjective, Request, OBJECTIVES};
pub use operating::{Condition, Goal, OperatingPoint, ViscousGoal};
pub use optimise::{AeroProblem, Optimisation, OptimiseOptions, OptimiseResult, Reasons, ViscousScoring};
pub use panel::{integrate, Chord, Coefficients, PanelSolution};
pub use study::{OptimiseReport, Outcome, Setup, Study};
pub use viscous::{polars, Viscous, ViscousOptions, ViscousPoint};
