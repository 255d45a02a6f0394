//! `EvoProblem`: what the GA and CMA-ES optimise (a curve or grid layout, its data, anchors,
//! box bounds and start), and `Session`, the population evaluator with the per-point
//! parameters it starts from.

use crate::chain::{ChainLayout, CurveChain, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use crate::eval::nearest::{curve_nearest, grid_nearest};
use crate::eval::{
    build_evaluator, Backend, BackendInfo, EvalLayout, EvalOptions, Fitness, GpuOptions, PopulationEvaluator,
    Targets,
};
use crate::fit::problem::increment_start;
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The data of a problem: plane points for a chain, space points for a grid.
#[derive(Clone, Debug, PartialEq)]
enum Data {
    Curve(Vec<DVec2>),
    Grid(Vec<DVec3>),
}

/// A data point tied to a fixed point of the shape (a chain's end): its squared distance to
/// `Σ w_i x_i` over design points `x_i` replaces its closest-point offset.
#[derive(Clone, Debug, PartialEq)]
struct Anchor {
    /// The data point's index.
    point: usize,
    /// `(design point, weight)` of the shape point it is tied to.
    weights: Vec<(usize, f64)>,
}

/// An evolutionary fitting problem: a layout, its data, the anchored data points, box bounds on
/// every design variable and the start design.
///
/// The objective of an individual (flat design `x0, y0, (z0,) x1, …`) is the sum of squared
/// offsets: closest-point offsets for the free data points, computed by the population
/// evaluator, plus the squared distances of the anchored points to the shape points they are
/// tied to, computed here in f64.
///
/// The problem lives in a frame centred on its data: data, start, bounds and every design it
/// takes or gives are relative to [`origin`](Self::origin) (the centre of the data's box), so
/// the population's f32 rows resolve a shape as finely wherever its data sit;
/// [`absolute`](Self::absolute) moves a design back.
#[derive(Clone, Debug, PartialEq)]
pub struct EvoProblem {
    layout: EvalLayout,
    origin: Vec<f64>,
    data: Data,
    anchors: Vec<Anchor>,
    free: Vec<usize>,
    start: Vec<f64>,
    bounds: Vec<[f64; 2]>,
    extent: f64,
}

/// The smallest box around `coords` (one row per point), each side grown by `margin · extent`,
/// with `extent` the largest side (1 for a single point).
fn grown_box(coords: &[Vec<f64>], dim: usize, margin: f64) -> (Vec<[f64; 2]>, f64) {
    let mut sides = vec![[f64::INFINITY, f64::NEG_INFINITY]; dim];
    for p in coords {
        for (c, s) in sides.iter_mut().enumerate() {
            s[0] = s[0].min(p[c]);
            s[1] = s[1].max(p[c]);
        }
    }
    let extent = sides.iter().map(|s| s[1] - s[0]).fold(0.0, f64::max);
    let extent = if extent > 0.0 { extent } else { 1.0 };
    for s in &mut sides {
        s[0] -= margin * extent;
        s[1] += margin * extent;
    }
    (sides, extent)
}

fn check_margin(margin: f64) -> Result<()> {
    if !(margin >= 0.0) || !margin.is_finite() {
        return Err(Error::invalid(format!(
            "the bounds margin must be a finite number ≥ 0 (a fraction of the data extent), not {margin}"
        )));
    }
    Ok(())
}

impl EvoProblem {
    /// A chain fitted to plane points, started as the paper does (design points picked from
    /// the data at an even increment), bounded by the data's bounding box grown by
    /// `margin` times its largest side on every side. With `anchor_ends` the first and last
    /// data points are tied to the chain's ends (`t = 0` and `t = 1`), as in
    /// [`fit_curve`](crate::fit::fit_curve).
    pub fn curve(points: &[DVec2], layout: ChainLayout, anchor_ends: bool, margin: f64) -> Result<Self> {
        check_margin(margin)?;
        let start = increment_start(points, layout.design_count())?;
        let n = points.len();
        let mut anchors = Vec::new();
        if anchor_ends {
            let map = layout.map();
            for (point, row) in [(0, 0), (n - 1, map.rows() - 1)] {
                let (cols, w) = map.row(row);
                anchors.push(Anchor {
                    point,
                    weights: cols.iter().map(|&c| c as usize).zip(w.iter().copied()).collect(),
                });
            }
        }
        let coords: Vec<Vec<f64>> = points.iter().map(|p| vec![p.x, p.y]).collect();
        let (sides, extent) = grown_box(&coords, 2, margin);
        let m = layout.design_count();
        Self::assemble(
            EvalLayout::Curve(layout),
            Data::Curve(points.to_vec()),
            anchors,
            start.iter().flat_map(|p| [p.x, p.y]).collect(),
            (0..m).flat_map(|_| sides.iter().copied()).collect(),
            extent,
        )
    }

    /// A patch grid fitted to space points from the design net `start` (row-major, e.g. a
    /// least-squares fit at given parameters), bounded by the box around the data and the
    /// start, grown by `margin` times its largest side. No point is anchored.
    pub fn grid(points: &[DVec3], layout: GridLayout, start: &[DVec3], margin: f64) -> Result<Self> {
        check_margin(margin)?;
        let (nu, nv) = layout.design_shape();
        if start.len() != nu * nv {
            return Err(Error::invalid(format!(
                "the start net has {} design points, the layout {nu} x {nv}",
                start.len()
            )));
        }
        if start.iter().any(|p| !p.is_finite()) {
            return Err(Error::invalid("the start net must be finite"));
        }
        let coords: Vec<Vec<f64>> = points.iter().chain(start).map(|p| vec![p.x, p.y, p.z]).collect();
        let (sides, extent) = grown_box(&coords, 3, margin);
        Self::assemble(
            EvalLayout::Grid(layout),
            Data::Grid(points.to_vec()),
            Vec::new(),
            start.iter().flat_map(|p| [p.x, p.y, p.z]).collect(),
            (0..nu * nv).flat_map(|_| sides.iter().copied()).collect(),
            extent,
        )
    }

    /// The problem in the frame centred on the box `bounds` (one pair per coordinate, repeated
    /// per design point).
    fn assemble(
        layout: EvalLayout,
        mut data: Data,
        anchors: Vec<Anchor>,
        mut start: Vec<f64>,
        mut bounds: Vec<[f64; 2]>,
        extent: f64,
    ) -> Result<Self> {
        let dim = match &data {
            Data::Curve(_) => 2,
            Data::Grid(_) => 3,
        };
        let origin: Vec<f64> = bounds[..dim].iter().map(|[lo, hi]| 0.5 * (lo + hi)).collect();
        match &mut data {
            Data::Curve(p) => p.iter_mut().for_each(|q| *q -= DVec2::new(origin[0], origin[1])),
            Data::Grid(p) => p
                .iter_mut()
                .for_each(|q| *q -= DVec3::new(origin[0], origin[1], origin[2])),
        }
        for (k, (x, b)) in start.iter_mut().zip(&mut bounds).enumerate() {
            let o = origin[k % dim];
            *x -= o;
            *b = [b[0] - o, b[1] - o];
        }
        let n = match &data {
            Data::Curve(p) => p.len(),
            Data::Grid(p) => p.len(),
        };
        let finite = match &data {
            Data::Curve(p) => p.iter().all(|q| q.is_finite()),
            Data::Grid(p) => p.iter().all(|q| q.is_finite()),
        };
        if !finite {
            return Err(Error::invalid("data points must be finite"));
        }
        let free: Vec<usize> = (0..n)
            .filter(|j| !anchors.iter().any(|a| a.point == *j))
            .collect();
        if free.is_empty() {
            return Err(Error::invalid(
                "no data points are left to fit once the ends are anchored",
            ));
        }
        debug_assert_eq!(
            start.len(),
            layout.design_variables(),
            "start has one value per variable"
        );
        debug_assert_eq!(bounds.len(), start.len(), "one bound pair per variable");
        Ok(EvoProblem {
            layout,
            origin,
            data,
            anchors,
            free,
            start,
            bounds,
            extent,
        })
    }

    /// The layout.
    #[must_use]
    pub fn layout(&self) -> &EvalLayout {
        &self.layout
    }

    /// Design variables per individual.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.start.len()
    }

    /// Coordinates per design point (2 for a chain, 3 for a grid).
    #[must_use]
    pub fn point_dim(&self) -> usize {
        match self.data {
            Data::Curve(_) => 2,
            Data::Grid(_) => 3,
        }
    }

    /// Number of data points.
    #[must_use]
    pub fn points(&self) -> usize {
        match &self.data {
            Data::Curve(p) => p.len(),
            Data::Grid(p) => p.len(),
        }
    }

    /// Number of data points the population evaluator measures (all but the anchored).
    #[must_use]
    pub fn free_points(&self) -> usize {
        self.free.len()
    }

    /// The point the problem's frame is centred on (the centre of the data's box): data,
    /// start, bounds and designs here are relative to it.
    #[must_use]
    pub fn origin(&self) -> &[f64] {
        &self.origin
    }

    /// `design` (relative to [`origin`](Self::origin)) in model coordinates.
    #[must_use]
    pub fn absolute(&self, design: &[f64]) -> Vec<f64> {
        let dim = self.origin.len();
        design
            .iter()
            .enumerate()
            .map(|(k, &x)| x + self.origin[k % dim])
            .collect()
    }

    /// The start design, flat, relative to [`origin`](Self::origin).
    #[must_use]
    pub fn start(&self) -> &[f64] {
        &self.start
    }

    /// `[lower, upper]` of every design variable, relative to [`origin`](Self::origin).
    #[must_use]
    pub fn bounds(&self) -> &[[f64; 2]] {
        &self.bounds
    }

    /// The largest side of the data's bounding box, in model units.
    #[must_use]
    pub fn extent(&self) -> f64 {
        self.extent
    }

    /// Global closest-point parameters of the free data points on `design` (f64, `samples`
    /// per segment or per patch side), as `(u, v)` pairs (`v = 0` for a chain), with their
    /// squared distances.
    pub fn project(&self, design: &[f64], samples: usize) -> Result<(Vec<[f64; 2]>, Vec<f64>)> {
        match (&self.layout, &self.data) {
            (EvalLayout::Curve(layout), Data::Curve(points)) => {
                let d: Vec<DVec2> = design.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])).collect();
                let chain = CurveChain::new(layout.clone(), d)?;
                let free: Vec<DVec2> = self.free.iter().map(|&j| points[j]).collect();
                let near = curve_nearest(&chain, &free, samples);
                Ok(near.iter().map(|&(t, d2)| ([t, 0.0], d2)).unzip())
            }
            (EvalLayout::Grid(layout), Data::Grid(points)) => {
                let d: Vec<DVec3> = design
                    .chunks_exact(3)
                    .map(|c| DVec3::new(c[0], c[1], c[2]))
                    .collect();
                let grid = PatchGrid::new(layout.clone(), d)?;
                let free: Vec<DVec3> = self.free.iter().map(|&j| points[j]).collect();
                let near = grid_nearest(&grid, &free, samples);
                Ok(near.iter().map(|&(uv, d2)| ([uv.x, uv.y], d2)).unzip())
            }
            _ => Err(Error::invalid("evo problem: layout and data disagree")),
        }
    }

    /// The objective of `design` measured in f64: closest-point squared distances of the free
    /// points (global search, `samples` per segment or patch side) plus the anchors' terms.
    pub fn measure(&self, design: &[f64], samples: usize) -> Result<f64> {
        let (_, d2) = self.project(design, samples)?;
        Ok(d2.iter().sum::<f64>() + self.anchor_sum(design))
    }

    /// `Σ` over the anchors of the squared distance between the anchored data point and its
    /// shape point, for one individual's design (f64 arithmetic).
    fn anchor_sum(&self, design: &[f64]) -> f64 {
        self.anchor_terms(|i, c| design[i * self.point_dim() + c]).0
    }

    /// Sum and largest distance of the anchor terms; `x(i, c)` is coordinate `c` of design
    /// point `i`.
    fn anchor_terms(&self, x: impl Fn(usize, usize) -> f64) -> (f64, f64) {
        let dim = self.point_dim();
        let (mut sum, mut max) = (0.0, 0.0f64);
        for a in &self.anchors {
            let q = self.coords(a.point);
            let mut d2 = 0.0;
            for c in 0..dim {
                let s: f64 = a.weights.iter().map(|&(i, w)| w * x(i, c)).sum();
                d2 += (s - q[c]).powi(2);
            }
            sum += d2;
            max = max.max(d2.sqrt());
        }
        (sum, max)
    }

    /// Coordinates of data point `j` (z = 0 for a plane point).
    fn coords(&self, j: usize) -> [f64; 3] {
        match &self.data {
            Data::Curve(p) => [p[j].x, p[j].y, 0.0],
            Data::Grid(p) => [p[j].x, p[j].y, p[j].z],
        }
    }

    /// A 64-bit FNV-1a fingerprint of the problem: kind, layout, data, anchors, bounds, start.
    #[must_use]
    pub fn fingerprint(&self) -> u64 {
        let mut h = Fnv::new();
        let chain = |h: &mut Fnv, l: &ChainLayout| {
            h.usize(l.degree());
            h.usize(l.continuity().order());
            h.f64s(l.breaks());
        };
        match &self.layout {
            EvalLayout::Curve(l) => {
                h.bytes(b"curve");
                chain(&mut h, l);
            }
            EvalLayout::Grid(g) => {
                h.bytes(b"grid");
                chain(&mut h, &g.u);
                chain(&mut h, &g.v);
            }
        }
        h.usize(self.points());
        for j in 0..self.points() {
            h.f64s(&self.coords(j));
        }
        for a in &self.anchors {
            h.usize(a.point);
            for &(i, w) in &a.weights {
                h.usize(i);
                h.f64s(&[w]);
            }
        }
        for b in &self.bounds {
            h.f64s(b);
        }
        h.f64s(&self.start);
        h.finish()
    }
}

/// 64-bit FNV-1a, stable across platforms and compiler versions (unlike `DefaultHasher`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fnv(u64);

impl Fnv {
    pub(crate) fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    pub(crate) fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
    pub(crate) fn usize(&mut self, x: usize) {
        self.bytes(&(x as u64).to_le_bytes());
    }
    pub(crate) fn f64s(&mut self, xs: &[f64]) {
        for x in xs {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
    pub(crate) fn finish(self) -> u64 {
        self.0
    }
}

/// The objective of one individual as the evolutionary methods rank it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// Sum of squared offsets (free points from the evaluator, in f32, plus anchors in f64);
    /// `+∞` when the evaluator returned a non-finite value.
    pub sum_sq: f64,
    /// The largest offset.
    pub max: f64,
}

impl Score {
    /// The worst score, for individuals not yet evaluated.
    pub const WORST: Score = Score {
        sum_sq: f64::INFINITY,
        max: f64::INFINITY,
    };

    /// Total order for ranking: lower sums first, ties by index (so sorting is deterministic).
    #[must_use]
    pub fn before(&self, i: usize, other: &Score, j: usize) -> std::cmp::Ordering {
        self.sum_sq.total_cmp(&other.sum_sq).then(i.cmp(&j))
    }
}

/// Options of the evaluator a [`Session`] builds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SessionOptions {
    pub backend: Backend,
    pub newton: u32,
    pub gpu: GpuOptions,
}

/// The population evaluator of a problem, with the per-point start parameters it holds, and
/// the effort spent in it.
pub(crate) struct Session {
    evaluator: Box<dyn PopulationEvaluator>,
    params: Vec<[f64; 2]>,
    fitness: Vec<Fitness>,
    /// Seconds spent in the evaluator.
    pub eval_seconds: f64,
    /// Individual × point evaluations done.
    pub point_evals: u64,
}

impl Session {
    /// An evaluator for `problem` with start parameters `params` (one per free point).
    pub(crate) fn new(problem: &EvoProblem, params: Vec<[f64; 2]>, options: &SessionOptions) -> Result<Self> {
        if params.len() != problem.free.len() {
            return Err(Error::invalid(format!(
                "{} parameters for {} free data points",
                params.len(),
                problem.free.len()
            )));
        }
        let targets = match &problem.data {
            Data::Curve(p) => {
                let pts: Vec<DVec2> = problem.free.iter().map(|&j| p[j]).collect();
                let t: Vec<f64> = params.iter().map(|t| t[0]).collect();
                Targets::curve(&pts, &t)?
            }
            Data::Grid(p) => {
                let pts: Vec<DVec3> = problem.free.iter().map(|&j| p[j]).collect();
                let uv: Vec<DVec2> = params.iter().map(|t| DVec2::new(t[0], t[1])).collect();
                Targets::grid(&pts, &uv)?
            }
        };
        let mut evaluator = build_evaluator(
            &problem.layout,
            &targets,
            &EvalOptions {
                backend: options.backend,
                newton: options.newton,
                cross_patches: true,
                gpu: options.gpu.clone(),
            },
        )?;
        evaluator.set_reference(problem.start())?;
        Ok(Session {
            evaluator,
            params,
            fitness: Vec::new(),
            eval_seconds: 0.0,
            point_evals: 0,
        })
    }

    /// The backend that runs the evaluations.
    pub(crate) fn info(&self) -> &BackendInfo {
        self.evaluator.info()
    }

    /// The current start parameters.
    pub(crate) fn params(&self) -> &[[f64; 2]] {
        &self.params
    }

    /// Replace the start parameters.
    pub(crate) fn set_params(&mut self, params: Vec<[f64; 2]>) -> Result<()> {
        self.evaluator.set_params(&params)?;
        self.params = params;
        Ok(())
    }

    /// Project the data onto `design` in f64 and start every later evaluation there.
    pub(crate) fn reproject(&mut self, problem: &EvoProblem, design: &[f64], samples: usize) -> Result<()> {
        let (params, _) = problem.project(design, samples)?;
        self.set_params(params)
    }

    /// The evaluator's resolution at `sum_sq` (see [`PopulationEvaluator::resolution`]).
    pub(crate) fn resolution(&self, sum_sq: f64) -> f64 {
        self.evaluator.resolution(sum_sq)
    }

    /// Re-anchor the evaluator's reference design at `design` (the best so far): the kernels
    /// then compute only each individual's small difference from it in f32.
    pub(crate) fn anchor(&mut self, design: &[f64]) -> Result<()> {
        self.evaluator.set_reference(design)
    }

    /// Score every row of `population` into `scores`.
    pub(crate) fn evaluate(
        &mut self,
        problem: &EvoProblem,
        population: &[f32],
        scores: &mut [Score],
    ) -> Result<()> {
        let n = problem.dim();
        debug_assert_eq!(population.len(), scores.len() * n, "one score per individual");
        self.fitness.resize(scores.len(), Fitness::default());
        let clock = Instant::now();
        self.evaluator.evaluate(population, &mut self.fitness)?;
        self.eval_seconds += clock.elapsed().as_secs_f64();
        self.point_evals += (scores.len() * problem.free.len()) as u64;
        let dim = problem.point_dim();
        for (k, (s, f)) in scores.iter_mut().zip(&self.fitness).enumerate() {
            let row = &population[k * n..(k + 1) * n];
            let (a_sum, a_max) = problem.anchor_terms(|i, c| f64::from(row[i * dim + c]));
            let sum_sq = f64::from(f.sum_sq) + a_sum;
            *s = if sum_sq.is_finite() && f.max.is_finite() {
                Score {
                    sum_sq,
                    max: f64::from(f.max).max(a_max),
                }
            } else {
                Score::WORST
            };
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::Continuity;

    fn arc(n: usize) -> Vec<DVec2> {
        (0..n)
            .map(|i| {
                let a = std::f64::consts::PI * i as f64 / (n - 1) as f64;
                DVec2::new(a.cos(), 0.5 * a.sin())
            })
            .collect()
    }

    #[test]
    fn curve_problem_anchors_the_ends_and_bounds_the_box() {
        // 41 points: the arc's top (0, 0.5) is one of them.
        let pts = arc(41);
        let layout = ChainLayout::uniform(3, 3, Continuity::C1).unwrap();
        let p = EvoProblem::curve(&pts, layout.clone(), true, 0.1).unwrap();
        assert_eq!(p.dim(), 2 * layout.design_count());
        assert_eq!(p.free_points(), 39);
        assert!((p.extent() - 2.0).abs() < 1e-12);
        let b = p.bounds()[0];
        assert!((b[0] + 1.2).abs() < 1e-12 && (b[1] - 1.2).abs() < 1e-12, "{b:?}");
        // y spans [0, 0.5], grown to [-0.2, 0.7], centred on 0.25.
        let b = p.bounds()[1];
        assert!(
            (b[0] + 0.45).abs() < 1e-12 && (b[1] - 0.45).abs() < 1e-12,
            "{b:?}"
        );
        assert!(p.origin()[0] == 0.0 && (p.origin()[1] - 0.25).abs() < 1e-15);
        assert!((p.absolute(&[1.0, 1.0])[1] - 1.25).abs() < 1e-15);
        // The start takes both end points: the anchor terms vanish there.
        assert_eq!(p.anchor_sum(p.start()), 0.0);
        let mut moved = p.start().to_vec();
        moved[0] += 0.3;
        assert!((p.anchor_sum(&moved) - 0.09).abs() < 1e-12);
        let free = EvoProblem::curve(&pts, layout, false, 0.1).unwrap();
        assert_eq!(free.free_points(), 41);
        assert_ne!(p.fingerprint(), free.fingerprint());
    }

    #[test]
    fn measure_matches_the_library_closest_point_offsets() {
        let pts = arc(60);
        let layout = ChainLayout::uniform(3, 4, Continuity::C1).unwrap();
        let p = EvoProblem::curve(&pts, layout.clone(), false, 0.1).unwrap();
        let design: Vec<DVec2> = p
            .absolute(p.start())
            .chunks(2)
            .map(|c| DVec2::new(c[0], c[1]))
            .collect();
        let chain = CurveChain::new(layout, design).unwrap();
        let truth = crate::fit::offset_stats(&chain, &pts).unwrap().sum_sq;
        let m = p.measure(p.start(), 48).unwrap();
        assert!((m - truth).abs() <= 1e-9 * truth, "{m} vs {truth}");
    }

    #[test]
    fn bad_margins_and_nets_are_refused() {
        let pts = arc(20);
        let layout = ChainLayout::uniform(2, 2, Continuity::C1).unwrap();
        assert!(matches!(
            EvoProblem::curve(&pts, layout.clone(), true, -0.1),
            Err(Error::Invalid(_))
        ));
        assert!(matches!(
            EvoProblem::curve(&pts, layout.clone(), true, f64::NAN),
            Err(Error::Invalid(_))
        ));
        let grid = GridLayout::new(layout.clone(), layout);
        let cloud: Vec<DVec3> = (0..30).map(|i| DVec3::new(i as f64, 0.0, 1.0)).collect();
        assert!(matches!(
            EvoProblem::grid(&cloud, grid, &[DVec3::ZERO; 3], 0.1),
            Err(Error::Invalid(_))
        ));
    }
}
