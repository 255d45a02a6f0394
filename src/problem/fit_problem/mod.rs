//! `FitProblem`: the one fitting problem every solver takes. It owns the data points, the
//! shape (a chain or grid layout), the offset metric, the per-point parameters, the anchors
//! (points tied to fixed parameters), per-point weights, parameter directions held fixed,
//! linear constraints on the design (the aerofoil rule, the span rule), the start design and
//! the box bounds; it gives the objective (sum of squared offsets), its gradient, the
//! per-point residual blocks and linear least squares.
//!
//! The solvers: [`lsq`](crate::optim::lsq::lsq) (the residual structure), Nelder-Mead and BFGS (the
//! [`Objective`] of [`FitProblem::objective_fn`]), the GA and CMA-ES (the population
//! objective of [`crate::fit::population`]).

mod linear;

use linear::GramPattern;

use super::band::BandPlan;
use super::constraint::Constraint;
use super::frame::Frame;
use super::objective::Objective;
use super::offset::{check_points, chord_length_params, corresponding_offsets, Metric, OffsetStats};
use crate::bezier::Vector;
use crate::chain::shape::{Basis, CurveShape, GridShape, Shape};
use crate::chain::{ChainLayout, CurveChain, GridLayout, PatchGrid};
use crate::closest::{closest_all, refine_held, Foot, FootOptions, SampleGrid, CHUNK, PARALLEL_MIN};
use crate::error::{Error, Result};
use rayon::prelude::*;
use std::sync::OnceLock;

/// A fitting problem: data points `q_j`, a shape (chain or grid layout) and a metric.
///
/// The objective is `Σ_j |C(t_j) - q_j|²` over the design points, with `t_j` the foot point
/// (closest point) of `q_j` for [`Metric::Closest`], or the fixed parameter `params()[j]` for
/// [`Metric::Corresponding`]. The fixed parameters also start the closest-point fit.
///
/// *Anchored* points keep their fixed parameter under both metrics. Curve problems anchor the
/// first and last data points at `t = 0` and `t = 1` by default: the chain then spans the
/// data. Without anchors the closest-point objective lets the chain's ends run past the data
/// (the points there only see the part of the chain near them), and on aerofoils the fit
/// drifts towards end segments that loop far outside the contour while the offsets shrink
/// by a few per cent; the optimum is then not a usable shape.
///
/// Optional parts, all kept by every solver that can: per-point *weights* `w_j` (the
/// objective becomes `Σ_j w_j |C(t_j) - q_j|²`; the minimax polish reweights), parameter
/// directions *held* at the given parameters for every point (a sectioned cloud's span
/// parameter), a linear [`Constraint`] on the design points, a start design and box bounds
/// (the evolutionary methods').
#[derive(Clone, Debug)]
pub struct FitProblem<'a, S: Shape<K>, const K: usize> {
    shape: S,
    points: &'a [S::Point],
    metric: Metric,
    params: Vec<[f64; K]>,
    anchored: Vec<bool>,
    weights: Option<Vec<f64>>,
    held: [bool; K],
    constraint: Option<Constraint>,
    start: Option<Vec<S::Point>>,
    start_flat: Vec<f64>,
    bounds: Vec<[f64; 2]>,
    box_extent: f64,
    foot: FootOptions,
    /// The foot-point search's samples, built at the first global search.
    grid: OnceLock<SampleGrid<K>>,
    /// The evolutionary methods' centred frame, made at first use.
    frame: OnceLock<Frame>,
    /// The normal matrix's sparsity, made at the first linear fit.
    gram: OnceLock<GramPattern>,
    /// The band plans of the linear fit's systems ([`FitProblem::band_plans`]), made at the
    /// first linear fit.
    plans: OnceLock<Vec<Option<BandPlan>>>,
    extent: f64,
}

/// A curve through held parameter values ([`FitProblem::held_curve`]).
struct HeldCurve<'s, P, const K: usize> {
    /// The parameters it was made for (`t[1..]` held; `t[0]` runs along it).
    t: [f64; K],
    /// The curve's shape.
    shape: &'s CurveShape<P>,
    /// Its design, prepared for evaluation ([`Shape::prepare`]).
    ctrl: Vec<P>,
}

/// A fitting problem for a chain of curves.
pub type CurveProblem<'a, P> = FitProblem<'a, CurveShape<P>, 1>;
/// A fitting problem for a grid of patches.
pub type GridProblem<'a, P> = FitProblem<'a, GridShape<P>, 2>;

/// The residual of one data point at parameter `t` and its derivatives.
///
/// With `basis` the shape's basis at `t`, the Jacobian block of `r` is `∂r/∂x_i = φ_i I` for
/// each design point `x_i` of the support, and `∂r/∂t_k = tangents[k]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residual<P, const K: usize> {
    /// `C(t) - q`.
    pub r: P,
    /// `∂C/∂t_k` at `t`.
    pub tangents: [P; K],
}

/// Groups the per-point sums of large point sets are split into: each group is summed on its
/// own and the groups are merged in order, so the result does not depend on how rayon
/// schedules the work (the same bits on any number of threads).
const SUM_GROUPS: usize = 16;

/// Sum `body` over chunks of `0..n`, on rayon's pool when `n` is large (in [`SUM_GROUPS`]
/// fixed groups merged in order, so the result is reproducible).
pub(crate) fn chunked_sum<T: Send>(
    n: usize,
    init: impl Fn() -> T + Sync + Send,
    body: impl Fn(&mut T, std::ops::Range<usize>) + Sync + Send,
    merge: impl Fn(T, T) -> T + Sync + Send,
) -> T {
    if n < PARALLEL_MIN {
        let mut acc = init();
        body(&mut acc, 0..n);
        return acc;
    }
    let groups = n.div_ceil(CHUNK).min(SUM_GROUPS);
    let parts: Vec<T> = (0..groups)
        .into_par_iter()
        .map(|g| {
            let mut acc = init();
            body(&mut acc, g * n / groups..(g + 1) * n / groups);
            acc
        })
        .collect();
    let mut parts = parts.into_iter();
    let first = parts.next().unwrap_or_else(&init);
    parts.fold(first, merge)
}

/// `Ok` when the points are usable ([`check_points`]) and at least the `m` design points they
/// are to determine.
fn check_enough<P: Vector>(points: &[P], m: usize) -> Result<()> {
    check_points(points)?;
    if points.len() < m {
        return Err(Error::invalid(format!(
            "{} data points cannot determine {m} design points: at least {m} are needed",
            points.len()
        )));
    }
    Ok(())
}

impl<'a, S: Shape<K>, const K: usize> FitProblem<'a, S, K> {
    /// A problem from a shape, data points, one parameter per point in `[0, 1]^K` (the
    /// corresponding parameters, also the start of a closest-point fit), a metric and the
    /// foot-point search options.
    pub fn new(
        shape: S,
        points: &'a [S::Point],
        params: Vec<[f64; K]>,
        metric: Metric,
        foot: FootOptions,
    ) -> Result<Self> {
        check_enough(points, shape.design_count())?;
        if params.len() != points.len() {
            return Err(Error::invalid(format!(
                "{} parameters given for {} data points",
                params.len(),
                points.len()
            )));
        }
        if params.iter().flatten().any(|t| !(0.0..=1.0).contains(t)) {
            return Err(Error::invalid("data point parameters must lie in [0, 1]"));
        }
        if foot.samples == 0 {
            return Err(Error::invalid(
                "foot-point search needs at least one sample per cell",
            ));
        }
        let mut extent: f64 = 0.0;
        for c in 0..S::Point::DIM {
            let (lo, hi) = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
                (lo.min(p.coord(c)), hi.max(p.coord(c)))
            });
            extent = extent.max(hi - lo);
        }
        let grid = OnceLock::new();
        let anchored = vec![false; points.len()];
        let extent = if extent > 0.0 { extent } else { 1.0 };
        Ok(FitProblem {
            shape,
            points,
            metric,
            params,
            anchored,
            weights: None,
            held: [false; K],
            constraint: None,
            start: None,
            start_flat: Vec::new(),
            bounds: Vec::new(),
            box_extent: extent,
            foot,
            grid,
            frame: OnceLock::new(),
            gram: OnceLock::new(),
            plans: OnceLock::new(),
            extent,
        })
    }

    /// The problem with weight `weights[j]` on data point `j` (finite, at least 0), or none
    /// (all 1).
    pub fn with_weights(mut self, weights: Option<Vec<f64>>) -> Result<Self> {
        self.set_weights(weights)?;
        Ok(self)
    }

    /// Replace the weights (see [`FitProblem::with_weights`]).
    pub fn set_weights(&mut self, weights: Option<Vec<f64>>) -> Result<()> {
        if let Some(w) = &weights {
            if w.len() != self.points.len() {
                return Err(Error::invalid(format!(
                    "{} weights given for {} data points",
                    w.len(),
                    self.points.len()
                )));
            }
            if w.iter().any(|&x| !(x >= 0.0) || !x.is_finite()) {
                return Err(Error::invalid("weights must be finite and at least 0"));
            }
        }
        self.weights = weights;
        Ok(())
    }

    /// The weight of data point `j` (1 without weights).
    #[inline]
    #[must_use]
    pub fn weight(&self, j: usize) -> f64 {
        self.weights.as_ref().map_or(1.0, |w| w[j])
    }

    /// The problem with the parameter directions marked in `held` kept at every point's given
    /// parameter (e.g. a sectioned cloud's span parameter `v`): only the others move.
    #[must_use]
    pub fn with_held(mut self, held: [bool; K]) -> Self {
        self.held = held;
        self
    }

    /// The parameter directions held at the given parameters.
    #[must_use]
    pub fn held(&self) -> [bool; K] {
        self.held
    }

    /// The problem with the design points constrained to `constraint`.
    pub fn with_constraint(mut self, constraint: Constraint) -> Result<Self> {
        constraint.check(S::Point::DIM, self.design_count())?;
        self.constraint = Some(constraint);
        self.plans = OnceLock::new();
        Ok(self)
    }

    /// The linear constraint on the design, if any.
    #[must_use]
    pub fn constraint(&self) -> Option<&Constraint> {
        self.constraint.as_ref()
    }

    /// The problem with `start` as its start design (the paper's start for curves; the
    /// evolutionary methods start from it).
    pub fn with_start(mut self, start: Vec<S::Point>) -> Result<Self> {
        if start.len() != self.design_count() {
            return Err(Error::invalid(format!(
                "the start has {} design points, the layout {}",
                start.len(),
                self.design_count()
            )));
        }
        if start.iter().any(|p| !p.is_finite_point()) {
            return Err(Error::invalid("the start design must be finite"));
        }
        self.start_flat = Self::to_flat(&start);
        self.start = Some(start);
        self.frame = OnceLock::new();
        Ok(self)
    }

    /// The start design, if one was given.
    #[must_use]
    pub fn start_design(&self) -> Option<&[S::Point]> {
        self.start.as_deref()
    }

    /// The start design flat (`x0, y0, (z0,) x1, …`; empty without one).
    #[must_use]
    pub fn start_flat(&self) -> &[f64] {
        &self.start_flat
    }

    /// The problem with box bounds on every design variable: the bounding box of the data and
    /// the start design, each side grown by `margin` times its largest side (the evolutionary
    /// methods' search box).
    pub fn with_bounds(mut self, margin: f64) -> Result<Self> {
        if !(margin >= 0.0) || !margin.is_finite() {
            return Err(Error::invalid(format!(
                "the bounds margin must be a finite number ≥ 0 (a fraction of the data extent), not {margin}"
            )));
        }
        let dim = S::Point::DIM;
        let mut sides = vec![[f64::INFINITY, f64::NEG_INFINITY]; dim];
        for p in self.points.iter().chain(self.start.iter().flatten()) {
            for (c, s) in sides.iter_mut().enumerate() {
                s[0] = s[0].min(p.coord(c));
                s[1] = s[1].max(p.coord(c));
            }
        }
        let extent = sides.iter().map(|s| s[1] - s[0]).fold(0.0, f64::max);
        let extent = if extent > 0.0 { extent } else { 1.0 };
        for s in &mut sides {
            s[0] -= margin * extent;
            s[1] += margin * extent;
        }
        self.bounds = (0..self.design_count())
            .flat_map(|_| sides.iter().copied())
            .collect();
        self.box_extent = extent;
        self.frame = OnceLock::new();
        Ok(self)
    }

    /// The frame the evolutionary methods see the problem in: the start and bounds less the
    /// centre of the bounds' box (see [`Frame`]).
    pub(crate) fn frame(&self) -> &Frame {
        self.frame
            .get_or_init(|| Frame::new(&self.start_flat, &self.bounds, S::Point::DIM))
    }

    /// `[lower, upper]` of every flat design variable (empty until [`FitProblem::with_bounds`]).
    #[must_use]
    pub fn bounds(&self) -> &[[f64; 2]] {
        &self.bounds
    }

    /// The largest side of the box the bounds were grown from (data and start), model units.
    #[must_use]
    pub fn box_extent(&self) -> f64 {
        self.box_extent
    }

    /// The problem with the given data points anchored at their fixed parameters (replacing
    /// any earlier anchors).
    pub fn with_anchors(mut self, anchors: &[usize]) -> Result<Self> {
        self.anchored.fill(false);
        for &j in anchors {
            match self.anchored.get_mut(j) {
                Some(a) => *a = true,
                None => {
                    return Err(Error::invalid(format!(
                        "anchor {j} is not a data point index (there are {})",
                        self.points.len()
                    )))
                }
            }
        }
        Ok(self)
    }

    /// True when data point `j` keeps its fixed parameter.
    #[must_use]
    pub fn is_anchored(&self, j: usize) -> bool {
        self.anchored[j]
    }

    /// The anchored data points, with the design points (and weights) of the shape point each
    /// is tied to (its basis at its fixed parameter, zero weights left out).
    #[must_use]
    pub fn anchors(&self) -> Vec<(usize, Vec<(usize, f64)>)> {
        let mut b = Basis::new();
        (0..self.points.len())
            .filter(|&j| self.anchored[j])
            .map(|j| {
                self.shape.basis(self.params[j], 0, &mut b);
                let weights = self
                    .shape
                    .support(b.cell)
                    .iter()
                    .zip(&b.value)
                    .filter(|(_, &w)| w != 0.0)
                    .map(|(&i, &w)| (i as usize, w))
                    .collect();
                (j, weights)
            })
            .collect()
    }

    /// The shape.
    #[must_use]
    pub fn shape(&self) -> &S {
        &self.shape
    }

    /// The data points.
    #[must_use]
    pub fn points(&self) -> &'a [S::Point] {
        self.points
    }

    /// The offset metric.
    #[must_use]
    pub fn metric(&self) -> Metric {
        self.metric
    }

    /// The fixed parameter of every data point.
    #[must_use]
    pub fn params(&self) -> &[[f64; K]] {
        &self.params
    }

    /// The foot-point search options.
    #[must_use]
    pub fn foot_options(&self) -> &FootOptions {
        &self.foot
    }

    /// Replace the foot-point search options (e.g. fewer Newton steps for a polish); the
    /// global search's samples are rebuilt when their count changes.
    pub fn set_foot_options(&mut self, foot: FootOptions) -> Result<()> {
        if foot.samples == 0 {
            return Err(Error::invalid(
                "foot-point search needs at least one sample per cell",
            ));
        }
        if foot.samples != self.foot.samples {
            self.grid = OnceLock::new();
        }
        self.foot = foot;
        Ok(())
    }

    /// The largest side of the data's bounding box, in model units (1 for a single point).
    #[must_use]
    pub fn extent(&self) -> f64 {
        self.extent
    }

    /// Number of design points.
    #[must_use]
    pub fn design_count(&self) -> usize {
        self.shape.design_count()
    }

    /// Number of scalar design variables: design points times coordinates.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.design_count() * S::Point::DIM
    }

    /// Design points as a flat vector `x0, y0, (z0,) x1, …`.
    #[must_use]
    pub fn to_flat(design: &[S::Point]) -> Vec<f64> {
        design
            .iter()
            .flat_map(|p| (0..S::Point::DIM).map(move |c| p.coord(c)))
            .collect()
    }

    /// Design points from a flat vector `x0, y0, (z0,) x1, …`.
    #[must_use]
    pub fn from_flat(x: &[f64]) -> Vec<S::Point> {
        x.chunks_exact(S::Point::DIM).map(S::Point::from_coords).collect()
    }

    /// The residual of data point `j` at parameter `t`, leaving the basis at `t` (with first
    /// derivatives) in `basis`.
    pub fn residual(
        &self,
        design: &[S::Point],
        j: usize,
        t: [f64; K],
        basis: &mut Basis<K>,
    ) -> Residual<S::Point, K> {
        let prepared = self.shape.prepare(design);
        self.residual_at(&prepared, design, j, t, basis)
    }

    /// [`FitProblem::residual`] with the design also prepared ([`Shape::prepare`]).
    pub fn residual_at(
        &self,
        prepared: &S::Prepared<'_>,
        design: &[S::Point],
        j: usize,
        t: [f64; K],
        basis: &mut Basis<K>,
    ) -> Residual<S::Point, K> {
        let jet = self.shape.basis_and_jet(prepared, design, t, basis);
        Residual {
            r: jet.point - self.points[j],
            tangents: jet.d1,
        }
    }

    /// The objective's foot point of every data point: the closest point (global search;
    /// `warm` holds optional starts), or the fixed parameter for anchored points.
    #[must_use]
    pub fn feet(&self, design: &[S::Point], warm: Option<&[[f64; K]]>) -> Vec<Foot<K>> {
        let mut feet = self.true_feet(design, warm);
        let mut b = Basis::new();
        for (j, f) in feet.iter_mut().enumerate() {
            if self.anchored[j] {
                let t = self.params[j];
                self.shape.basis(t, 0, &mut b);
                let dist_sq = (self.shape.jet(&b, design, 0).point - self.points[j]).length_squared();
                *f = Foot { t, dist_sq };
            }
        }
        feet
    }

    /// The true closest point of every data point, anchors ignored.
    fn true_feet(&self, design: &[S::Point], warm: Option<&[[f64; K]]>) -> Vec<Foot<K>> {
        let mut feet = vec![
            Foot {
                t: [0.0; K],
                dist_sq: 0.0
            };
            self.points.len()
        ];
        closest_all(
            &self.shape,
            self.grid
                .get_or_init(|| SampleGrid::new(&self.shape, self.foot.samples)),
            design,
            self.points,
            warm,
            &self.foot,
            &mut feet,
        );
        feet
    }

    /// Move every parameter but the anchored ones (and the held directions) to the local
    /// closest point by Newton's method started from it, returning `Σ w_j |C(t_j) - q_j|²` at
    /// the new parameters.
    pub fn project(&self, design: &[S::Point], params: &mut [[f64; K]]) -> f64 {
        self.project_max(design, params).0
    }

    /// [`FitProblem::project`], with the largest distance `|C(t_j) - q_j|` of any point.
    pub fn project_max(&self, design: &[S::Point], params: &mut [[f64; K]]) -> (f64, f64) {
        debug_assert_eq!(
            params.len(),
            self.points.len(),
            "project: one parameter per point"
        );
        let prepared = self.shape.prepare(design);
        let run = |offset: usize, ts: &mut [[f64; K]]| {
            let mut b = Basis::new();
            let mut b1 = Basis::<1>::new();
            // With every parameter but the first held (a sectioned cloud's points move along
            // their section), each point's search runs on the curve through its held values.
            let mut cache = None;
            let (mut sum, mut max) = (0.0, 0.0_f64);
            for (j, t) in ts.iter_mut().enumerate() {
                let q = self.points[offset + j];
                let curve = self.held_curve(design, *t, &mut cache);
                let d2 = if self.anchored[offset + j] {
                    self.shape.basis(*t, 0, &mut b);
                    (self.shape.jet(&b, design, 0).point - q).length_squared()
                } else if let Some(h) = curve {
                    let f = refine_held(h.shape, &h.ctrl, q, [t[0]], [false], &self.foot, &mut b1);
                    t[0] = f.t[0];
                    f.dist_sq
                } else {
                    let f = refine_held(&self.shape, &prepared, q, *t, self.held, &self.foot, &mut b);
                    *t = f.t;
                    f.dist_sq
                };
                sum += self.weight(offset + j) * d2;
                max = max.max(d2);
            }
            (sum, max)
        };
        let (sum, max) = if params.len() < PARALLEL_MIN {
            run(0, params)
        } else {
            // Per-chunk sums added in order: the same bits on any number of threads.
            let parts: Vec<(f64, f64)> = params
                .par_chunks_mut(CHUNK)
                .enumerate()
                .map(|(c, ts)| run(c * CHUNK, ts))
                .collect();
            parts
                .iter()
                .fold((0.0, 0.0_f64), |(s, m), &(a, b)| (s + a, m.max(b)))
        };
        (sum, max.sqrt())
    }

    /// The distance `|C(t_j) - q_j|` of every data point at its parameter.
    #[must_use]
    pub fn distances(&self, design: &[S::Point], params: &[[f64; K]]) -> Vec<f64> {
        let mut b = Basis::new();
        let mut b1 = Basis::<1>::new();
        let prepared = self.shape.prepare(design);
        // As in `project_max`: on the curves through the held values, where there are such.
        let mut cache = None;
        params
            .iter()
            .zip(self.points)
            .map(|(&t, &q)| {
                let p = match self.held_curve(design, t, &mut cache) {
                    Some(h) => h.shape.jet_at(&h.ctrl, [t[0]], 0, &mut b1).point,
                    None => self.shape.jet_at(&prepared, t, 0, &mut b).point,
                };
                (p - q).length()
            })
            .collect()
    }

    /// Every parameter but the first held: a sectioned cloud's points, whose searches and
    /// evaluations run on the shape's curves through their held values
    /// ([`Shape::first_curve`]).
    fn along_first(&self) -> bool {
        K > 1 && !self.held[0] && self.held[1..].iter().all(|&h| h)
    }

    /// The curve through `t`'s held values ([`Shape::first_curve`]) with its prepared design,
    /// kept in `cache` and made again only when they change (a run of points of one
    /// section shares it); `None` unless [`FitProblem::along_first`] and the shape has one.
    fn held_curve<'c>(
        &'a self,
        design: &[S::Point],
        t: [f64; K],
        cache: &'c mut Option<HeldCurve<'a, S::Point, K>>,
    ) -> Option<&'c HeldCurve<'a, S::Point, K>> {
        if !self.along_first() {
            return None;
        }
        if cache.as_ref().is_none_or(|c| c.t[1..] != t[1..]) {
            *cache = self.shape.first_curve(design, t).map(|(shape, row)| HeldCurve {
                t,
                shape,
                ctrl: shape.prepare(&row),
            });
        }
        cache.as_ref()
    }

    /// `Σ w_j |C(t_j) - q_j|²` at the given parameters.
    #[must_use]
    pub fn sum_sq_at(&self, design: &[S::Point], params: &[[f64; K]]) -> f64 {
        chunked_sum(
            self.points.len(),
            || (0.0, Basis::new()),
            |(acc, b), range| {
                for j in range {
                    self.shape.basis(params[j], 0, b);
                    *acc += self.weight(j)
                        * (self.shape.jet(b, design, 0).point - self.points[j]).length_squared();
                }
            },
            |a, b| (a.0 + b.0, a.1),
        )
        .0
    }

    /// The objective: the sum of squared offsets under the problem's metric.
    ///
    /// For the closest-point metric, `cache` holds the foot points of the previous call (empty
    /// at first) as warm starts and is updated; the result is still the global closest point.
    pub fn objective(&self, design: &[S::Point], cache: &mut Vec<[f64; K]>) -> f64 {
        match self.metric {
            Metric::Corresponding => self.sum_sq_at(design, &self.params),
            Metric::Closest => {
                let warm = (cache.len() == self.points.len()).then_some(cache.as_slice());
                let feet = self.feet(design, warm);
                cache.clear();
                cache.extend(feet.iter().map(|f| f.t));
                feet.iter()
                    .enumerate()
                    .map(|(j, f)| self.weight(j) * f.dist_sq)
                    .sum()
            }
        }
    }

    /// The objective and its gradient with respect to the design points, written to `grad`.
    ///
    /// At the foot points the envelope theorem gives
    /// `∂/∂x_i Σ_j |C(t_j) - q_j|² = Σ_j 2 φ_i(t_j) (C(t_j) - q_j)` with `t_j` held fixed.
    pub fn objective_grad(
        &self,
        design: &[S::Point],
        cache: &mut Vec<[f64; K]>,
        grad: &mut [S::Point],
    ) -> f64 {
        debug_assert_eq!(
            grad.len(),
            design.len(),
            "gradient has one entry per design point"
        );
        let value = self.objective(design, cache);
        let params: &[[f64; K]] = match self.metric {
            Metric::Corresponding => &self.params,
            Metric::Closest => cache,
        };
        let m = design.len();
        let g = chunked_sum(
            self.points.len(),
            || (vec![S::Point::ZERO; m], Basis::new()),
            |(g, b), range| {
                for j in range {
                    self.shape.basis(params[j], 0, b);
                    let r = (self.shape.jet(b, design, 0).point - self.points[j]) * self.weight(j);
                    for (&i, &w) in self.shape.support(b.cell).iter().zip(&b.value) {
                        g[i as usize] += r * (2.0 * w);
                    }
                }
            },
            |mut a, b| {
                for (x, y) in a.0.iter_mut().zip(b.0) {
                    *x += y;
                }
                a
            },
        )
        .0;
        grad.copy_from_slice(&g);
        value
    }

    /// Offsets of the data from `design` under the problem's metric (closest points by the
    /// global search), with the parameters they were measured at.
    #[must_use]
    pub fn stats(&self, design: &[S::Point]) -> (OffsetStats<S::Point>, Vec<[f64; K]>) {
        match self.metric {
            Metric::Closest => self.closest_stats(design, None),
            Metric::Corresponding => {
                // Lengths were checked when the problem was built.
                let stats = corresponding_offsets(&self.shape, design, self.points, &self.params);
                match stats {
                    Ok(s) => (s, self.params.clone()),
                    Err(_) => self.closest_stats(design, None),
                }
            }
        }
    }

    /// True closest-point offsets of the data from `design` (global search, optional warm
    /// starts; anchors play no part).
    #[must_use]
    pub fn closest_stats(
        &self,
        design: &[S::Point],
        warm: Option<&[[f64; K]]>,
    ) -> (OffsetStats<S::Point>, Vec<[f64; K]>) {
        let feet = self.true_feet(design, warm);
        let d2: Vec<f64> = feet.iter().map(|f| f.dist_sq).collect();
        (
            OffsetStats::from_dist_sq(Metric::Closest, &d2, self.points),
            feet.iter().map(|f| f.t).collect(),
        )
    }

    /// This problem as an [`Objective`] over flat design vectors, for the general minimisers.
    #[must_use]
    pub fn objective_fn(&self) -> ProblemObjective<'_, 'a, S, K> {
        ProblemObjective {
            problem: self,
            cache: Vec::new(),
            grad: Vec::new(),
        }
    }
}

/// A [`FitProblem`] seen as an [`Objective`] of the flat design vector; keeps the foot points
/// of the last evaluation as warm starts.
#[derive(Debug)]
pub struct ProblemObjective<'p, 'a, S: Shape<K>, const K: usize> {
    problem: &'p FitProblem<'a, S, K>,
    cache: Vec<[f64; K]>,
    grad: Vec<S::Point>,
}

impl<S: Shape<K>, const K: usize> Objective for ProblemObjective<'_, '_, S, K> {
    fn dim(&self) -> usize {
        self.problem.dim()
    }

    fn value(&mut self, x: &[f64]) -> f64 {
        let design = FitProblem::<S, K>::from_flat(x);
        self.problem.objective(&design, &mut self.cache)
    }

    fn value_grad(&mut self, x: &[f64], grad: &mut [f64]) -> f64 {
        let design = FitProblem::<S, K>::from_flat(x);
        self.grad.resize(design.len(), S::Point::ZERO);
        let v = self
            .problem
            .objective_grad(&design, &mut self.cache, &mut self.grad);
        for (i, p) in self.grad.iter().enumerate() {
            for c in 0..S::Point::DIM {
                grad[i * S::Point::DIM + c] = p.coord(c);
            }
        }
        v
    }
}

impl<'a, P: Vector> FitProblem<'a, CurveShape<P>, 1> {
    /// A chain-fitting problem; every point gets its normalised chord-length parameter (see
    /// [`chord_length_params`]), the first and last points are anchored at `t = 0` and
    /// `t = 1`, the start is the paper's ([`increment_start`]), and the foot-point search
    /// has its default options.
    pub fn curve(layout: ChainLayout, points: &'a [P], metric: Metric) -> Result<Self> {
        Self::curve_with(layout, points, metric, FootOptions::default(), true)
    }

    /// [`FitProblem::curve`] with explicit foot-point options, and the ends anchored or not.
    pub fn curve_with(
        layout: ChainLayout,
        points: &'a [P],
        metric: Metric,
        foot: FootOptions,
        anchor_ends: bool,
    ) -> Result<Self> {
        let m = layout.design_count();
        check_enough(points, m)?;
        let params = chord_length_params(points)?.into_iter().map(|t| [t]).collect();
        let start = increment_start(points, m)?;
        let problem = Self::new(CurveShape::new(layout), points, params, metric, foot)?.with_start(start)?;
        if anchor_ends {
            problem.with_anchors(&[0, points.len() - 1])
        } else {
            Ok(problem)
        }
    }

    /// The chain with the given design points.
    pub fn chain(&self, design: &[P]) -> Result<CurveChain<P>> {
        CurveChain::new(self.shape.layout().clone(), design.to_vec())
    }

    /// The paper's start: design points picked from the data at an even increment.
    pub fn increment_start(&self) -> Result<Vec<P>> {
        increment_start(self.points, self.design_count())
    }
}

impl<'a, P: Vector> FitProblem<'a, GridShape<P>, 2> {
    /// A grid-fitting problem with one `(u, v)` parameter per point and the default foot-point
    /// options (8 samples per patch side).
    pub fn grid(layout: GridLayout, points: &'a [P], params: Vec<[f64; 2]>, metric: Metric) -> Result<Self> {
        let foot = FootOptions {
            samples: 8,
            ..FootOptions::default()
        };
        Self::new(GridShape::new(layout), points, params, metric, foot)
    }

    /// The patch grid with the given design net.
    pub fn patch_grid(&self, design: &[P]) -> Result<PatchGrid<P>> {
        PatchGrid::new(self.shape.layout(), design.to_vec())
    }
}

/// The paper's start for a chain of `count` design points: data points picked at an even
/// increment along the data, `points[round(i (n - 1) / (count - 1))]` for `i = 0 … count - 1`,
/// so the first and last data points are always taken.
pub fn increment_start<P: Vector>(points: &[P], count: usize) -> Result<Vec<P>> {
    check_points(points)?;
    let n = points.len();
    if count < 2 {
        return Err(Error::invalid("a chain has at least two design points"));
    }
    if n < count {
        return Err(Error::invalid(format!(
            "{n} data points cannot provide {count} distinct start points"
        )));
    }
    Ok((0..count)
        .map(|i| points[((i * (n - 1)) as f64 / (count - 1) as f64).round() as usize])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::super::objective::testing::assert_gradient_matches;
    use super::*;
    use crate::chain::Continuity;
    use glam::{DVec2, DVec3};

    pub(super) fn sample_chain() -> (CurveChain<DVec2>, Vec<DVec2>) {
        let layout = ChainLayout::with_breaks(3, vec![0.0, 0.3, 0.55, 1.0], Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * 0.3, 0.5 * (1.3 * i as f64).sin()))
            .collect();
        let chain = CurveChain::new(layout, design).unwrap();
        let pts = (0..50)
            .map(|i| {
                let t = i as f64 / 49.0;
                chain.eval(t) + DVec2::new(0.02 * (9.0 * t).sin(), 0.03 * (11.0 * t).cos())
            })
            .collect();
        (chain, pts)
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let (chain, pts) = sample_chain();
        for metric in [Metric::Closest, Metric::Corresponding] {
            let p = FitProblem::curve(chain.layout().clone(), &pts, metric).unwrap();
            let x = CurveProblem::<DVec2>::to_flat(chain.design());
            assert_gradient_matches(&mut p.objective_fn(), &x, &metric.to_string());
        }
    }

    #[test]
    fn residual_jacobian_matches_finite_differences() {
        let (chain, pts) = sample_chain();
        let p = FitProblem::curve(chain.layout().clone(), &pts, Metric::Closest).unwrap();
        let design = chain.design().to_vec();
        let mut b = Basis::new();
        let h = 1e-6;
        for j in [0, 7, 23, 49] {
            let t = [p.params()[j][0].clamp(0.01, 0.99)];
            let res = p.residual(&design, j, t, &mut b);
            let support = p.shape().support(b.cell).to_vec();
            let phi = b.value.clone();
            // d r / d t
            let mut bb = Basis::new();
            let rp = p.residual(&design, j, [t[0] + h], &mut bb).r;
            let rm = p.residual(&design, j, [t[0] - h], &mut bb).r;
            assert!((res.tangents[0] - (rp - rm) * (0.5 / h)).length() < 1e-7);
            // d r / d x_i for every design point: phi_i on the support, zero elsewhere.
            for i in 0..design.len() {
                let mut dp = design.clone();
                dp[i].y += h;
                let d = (p.residual(&dp, j, t, &mut bb).r - res.r) * (1.0 / h);
                let expect = support
                    .iter()
                    .position(|&s| s as usize == i)
                    .map_or(0.0, |a| phi[a]);
                assert!(
                    (d.y - expect).abs() < 1e-8 && d.x.abs() < 1e-8,
                    "point {j} design {i}"
                );
            }
        }
    }

    #[test]
    fn too_few_points_and_bad_input_are_refused() {
        let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
        let pts: Vec<DVec2> = (0..11).map(|i| DVec2::new(i as f64, 0.0)).collect();
        let err = FitProblem::curve(layout.clone(), &pts, Metric::Closest).unwrap_err();
        assert!(matches!(err, Error::Invalid(_)));
        assert!(err.to_string().contains("12 design points"), "{err}");
        let same = vec![DVec2::new(0.5, 0.5); 30];
        assert!(matches!(
            FitProblem::curve(layout.clone(), &same, Metric::Closest),
            Err(Error::Invalid(_))
        ));
        let mut bad: Vec<DVec2> = (0..30).map(|i| DVec2::new(i as f64, 0.0)).collect();
        bad[4].y = f64::INFINITY;
        assert!(FitProblem::curve(layout, &bad, Metric::Closest).is_err());
    }

    #[test]
    fn increment_start_takes_both_ends() {
        let pts: Vec<DVec2> = (0..82).map(|i| DVec2::new(i as f64, 0.0)).collect();
        let s = increment_start(&pts, 12).unwrap();
        assert_eq!(s.len(), 12);
        assert_eq!((s[0].x, s[11].x), (0.0, 81.0));
        assert!(s.windows(2).all(|w| w[1].x > w[0].x));
        assert!(increment_start(&pts[..5], 12).is_err());
    }

    #[test]
    fn grid_gradient_matches_finite_differences() {
        let layout = GridLayout::uniform((2, 2), (2, 2), Continuity::C1).unwrap();
        let (nu, nv) = layout.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|i| {
                let (a, b) = ((i / nv) as f64 / 3.0, (i % nv) as f64 / 3.0);
                DVec3::new(a, b, 0.3 * (2.0 * a + b).sin())
            })
            .collect();
        // Interior points off the surface, and a few beyond its borders (feet clamped there).
        // Points exactly on a border with zero offset are avoided: there the squared distance
        // is only C1 (like max(0, s)²) and central differences are off by O(h).
        let mut params: Vec<[f64; 2]> = (0..64)
            .map(|i| {
                [
                    0.03 + 0.94 * (i / 8) as f64 / 7.0,
                    0.04 + 0.93 * (i % 8) as f64 / 7.0,
                ]
            })
            .collect();
        let grid = PatchGrid::new(layout.clone(), design.clone()).unwrap();
        let mut pts: Vec<DVec3> = params
            .iter()
            .map(|t| grid.eval(t[0], t[1]) + DVec3::new(0.0, 0.0, 0.01 + 0.01 * (t[0] * 13.0).sin()))
            .collect();
        for (t, q) in [
            ([0.0, 0.5], DVec3::new(-0.2, 0.4, 0.1)),
            ([1.0, 0.2], DVec3::new(1.3, 0.3, -0.1)),
        ] {
            params.push(t);
            pts.push(q);
        }
        let p = FitProblem::grid(layout, &pts, params, Metric::Closest).unwrap();
        let x = GridProblem::<DVec3>::to_flat(&design);
        assert_gradient_matches(&mut p.objective_fn(), &x, "grid");
    }

    /// A sectioned cloud off the wavy grid of `grid_gradient_matches_finite_differences`'s
    /// layout: 9 sections at fixed v, 23 points each.
    pub(super) fn sectioned() -> (GridLayout, Vec<DVec3>, Vec<[f64; 2]>) {
        let u = ChainLayout::with_breaks(3, vec![0.0, 0.3, 0.45, 1.0], Continuity::C2).unwrap();
        let v = ChainLayout::with_breaks(2, vec![0.0, 0.6, 1.0], Continuity::C1).unwrap();
        let layout = GridLayout::new(u, v);
        let mut pts = Vec::new();
        let mut params = Vec::new();
        for k in 0..9 {
            let v = k as f64 / 8.0;
            for i in 0..23 {
                let u = (i as f64 / 22.0).powf(1.3);
                pts.push(DVec3::new(
                    u,
                    (3.0 * u).sin() * (1.0 + v),
                    v + 0.1 * (5.0 * u * v).cos(),
                ));
                params.push([(u + 0.01 * (7.0 * u).sin()).clamp(0.0, 1.0), v]);
            }
        }
        (layout, pts, params)
    }

    #[test]
    fn a_search_along_u_at_held_v_finds_the_grid_search_feet() {
        let (layout, pts, params) = sectioned();
        let p = FitProblem::grid(layout.clone(), &pts, params.clone(), Metric::Closest)
            .unwrap()
            .with_held([false, true]);
        let design = p.linear_fit(&params).unwrap();
        let mut moved = params.clone();
        let (_, max) = p.project_max(&design, &mut moved);
        // The same searches on the grid itself.
        let shape = GridShape::<DVec3>::new(layout);
        let mut b = Basis::new();
        let mut worst = 0.0_f64;
        for ((t, q), got) in params.iter().zip(&pts).zip(&moved) {
            let f = refine_held(
                &shape,
                &design.as_slice(),
                *q,
                *t,
                [false, true],
                p.foot_options(),
                &mut b,
            );
            assert_eq!(got[1], t[1], "v is held");
            assert!((got[0] - f.t[0]).abs() < 1e-9, "{got:?} against {:?}", f.t);
            worst = worst.max(f.dist_sq.sqrt());
        }
        assert!((max - worst).abs() < 1e-12, "{max} against {worst}");
        // The distances at held v, on the rows, are the grid's.
        let grid = PatchGrid::new(shape.layout(), design.clone()).unwrap();
        for ((d, t), q) in p.distances(&design, &moved).iter().zip(&moved).zip(&pts) {
            assert!((d - (grid.eval(t[0], t[1]) - *q).length()).abs() < 1e-12);
        }
    }

    #[test]
    fn large_sums_do_not_depend_on_the_thread_count() {
        let n = 50_000;
        let x: Vec<f64> = (0..n)
            .map(|i| ((i as f64) * 0.73).sin() * 1e-3 + 1.0 / (1.0 + i as f64))
            .collect();
        let sum = || {
            chunked_sum(
                n,
                || 0.0,
                |acc, range| {
                    for j in range {
                        *acc += x[j];
                    }
                },
                |a, b| a + b,
            )
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(sum);
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(sum);
        assert_eq!(one.to_bits(), three.to_bits());
    }
}
