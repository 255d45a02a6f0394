//! The fast closest-point fit inside the adaptive search: a linear least-squares start at
//! fixed parameters, then tangent-distance Gauss-Newton steps (Wang, Pottmann and Liu 2006)
//! with foot-point projection, and an optional minimax polish by Lawson's reweighting.
//!
//! The search fits hundreds of candidate layouts, so this fit is single-start, warm-started
//! and allocation-light; the design it returns is re-measured with the library's global
//! closest-point search ([`crate::fit::offset_stats`]) before it is reported. Its own
//! distances come from a local Newton search from each point's previous foot point: each is
//! the distance to *some* point of the curve, so never below the true closest distance, and
//! a tolerance met by them is met by the true offsets.

use crate::chain::{ChainLayout, MAX_SUPPORT};
use crate::error::{Error, Result};
use glam::DVec2;

/// How the x coordinates of the design points are stored.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum XRule {
    /// Both coordinates of every design point are free.
    Free,
    /// Aerofoil rule: `x(t) = x_le + (x_te,1 - x_le) (1 - 2t)²` for `t <= 1/2` and
    /// `x_le + (x_te,2 - x_le) (2t - 1)²` after, so only the numbers `θ = (x_le, x_te,1,
    /// x_te,2)` (or `(x_le, x_te)` when both surfaces end at the same x) and the y of every
    /// design point are stored. Row `i` of `rows` holds the weights of `(x_le, x_te,1, x_te,2)`
    /// in design point `i`'s x.
    Aerofoil {
        /// The weights.
        rows: Vec<[f64; 3]>,
        /// One trailing-edge x for both surfaces.
        shared_te: bool,
    },
}

/// A candidate parameterisation: the spline layout and how x is stored.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Model {
    pub layout: ChainLayout,
    pub rule: XRule,
}

/// The break of the leading edge in the aerofoil rule.
pub(crate) const LE_BREAK: f64 = 0.5;

impl Model {
    /// A model with free x.
    pub fn free(layout: ChainLayout) -> Self {
        Model {
            layout,
            rule: XRule::Free,
        }
    }

    /// A model with the aerofoil rule (one trailing-edge x for both surfaces with
    /// `shared_te`); the layout must have a C1 (or C0) break at 1/2 and degree 2 or more.
    pub fn aerofoil(layout: ChainLayout, shared_te: bool) -> Result<Self> {
        let d = layout.degree();
        let le = layout.breaks().iter().position(|&b| b == LE_BREAK);
        match le {
            Some(i) if d >= 2 && layout.orders()[i - 1] <= 1 => {}
            _ => {
                return Err(Error::invalid(
                    "the aerofoil rule needs degree 2 or more and a C1 break at t = 1/2",
                ))
            }
        }
        let rows = rule_rows(&layout);
        Ok(Model {
            layout,
            rule: XRule::Aerofoil { rows, shared_te },
        })
    }

    /// Number of x unknowns.
    pub fn x_unknowns(&self) -> usize {
        match &self.rule {
            XRule::Free => self.layout.design_count(),
            XRule::Aerofoil { shared_te, .. } => 3 - usize::from(*shared_te),
        }
    }

    /// Number of unknowns: x unknowns then one y per design point.
    pub fn unknowns(&self) -> usize {
        self.x_unknowns() + self.layout.design_count()
    }

    /// The design points (B-spline coefficients) from the unknowns.
    pub fn coeffs(&self, z: &[f64]) -> Vec<DVec2> {
        let mx = self.x_unknowns();
        let n = self.layout.design_count();
        (0..n)
            .map(|i| {
                let x = match &self.rule {
                    XRule::Free => z[i],
                    XRule::Aerofoil { rows: r, shared_te } => {
                        if *shared_te {
                            r[i][0] * z[0] + (r[i][1] + r[i][2]) * z[1]
                        } else {
                            r[i][0] * z[0] + r[i][1] * z[1] + r[i][2] * z[2]
                        }
                    }
                };
                DVec2::new(x, z[mx + i])
            })
            .collect()
    }

    /// The unknowns of design points that follow the model (x from the rule is not checked).
    pub fn unknowns_of(&self, coeffs: &[DVec2], theta: Option<&[f64]>) -> Vec<f64> {
        let mut z = match (&self.rule, theta) {
            (XRule::Aerofoil { .. }, Some(t)) => t.to_vec(),
            _ => coeffs.iter().map(|p| p.x).collect(),
        };
        z.extend(coeffs.iter().map(|p| p.y));
        z
    }

    /// The x entries `(unknown, weight)` of a point with basis `value` from design `first`.
    #[inline]
    fn x_entries(&self, first: usize, value: &[f64], out: &mut [(usize, f64); MAX_SUPPORT]) -> usize {
        let d = self.layout.degree();
        match &self.rule {
            XRule::Free => {
                for a in 0..=d {
                    out[a] = (first + a, value[a]);
                }
                d + 1
            }
            XRule::Aerofoil { rows: r, shared_te } => {
                let mut g = [0.0; 3];
                for a in 0..=d {
                    for k in 0..3 {
                        g[k] += value[a] * r[first + a][k];
                    }
                }
                if *shared_te {
                    out[0] = (0, g[0]);
                    out[1] = (1, g[1] + g[2]);
                    2
                } else {
                    for k in 0..3 {
                        out[k] = (k, g[k]);
                    }
                    3
                }
            }
        }
    }
}

/// The weights of `θ = (x_le, x_te,1, x_te,2)` in every coefficient of the layout: the
/// B-spline coefficients of the rule's three piecewise quadratics, by blossoming (the
/// coefficient of basis function `i` is the blossom of the polynomial piece at the knots
/// `τ_{i+1} … τ_{i+d}`; the pieces agree wherever the window spans the leading edge).
fn rule_rows(layout: &ChainLayout) -> Vec<[f64; 3]> {
    let d = layout.degree();
    let knots = layout.knots();
    let pairs = (d * (d - 1) / 2) as f64;
    (0..layout.design_count())
        .map(|i| {
            let args = &knots[i + 1..=i + d];
            // Blossom of 4 (t - 1/2)²: 4 Σ_{a<b} (x_a - 1/2)(x_b - 1/2) / C(d, 2).
            let mut s = 0.0;
            for a in 0..d {
                for b in a + 1..d {
                    s += (args[a] - LE_BREAK) * (args[b] - LE_BREAK);
                }
            }
            let q = 4.0 * s / pairs;
            let left = args.iter().any(|&x| x < LE_BREAK);
            let (up, lo) = if left { (q, 0.0) } else { (0.0, q) };
            [1.0 - up - lo, up, lo]
        })
        .collect()
}

/// A fitted state of a model: unknowns, design points, one parameter and one distance per
/// data point.
#[derive(Clone, Debug)]
pub(crate) struct State {
    pub z: Vec<f64>,
    pub coeffs: Vec<DVec2>,
    pub params: Vec<f64>,
    /// Distance of each data point to the curve at its parameter (an upper bound of the true
    /// closest distance).
    pub dist: Vec<f64>,
}

impl State {
    /// The largest distance.
    pub fn max(&self) -> f64 {
        self.dist.iter().fold(0.0, |m, &d| m.max(d))
    }

    /// Root mean square of the distances.
    pub fn rms(&self) -> f64 {
        (self.dist.iter().map(|d| d * d).sum::<f64>() / self.dist.len().max(1) as f64).sqrt()
    }
}

/// Effort limits of one fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Effort {
    /// Gauss-Newton iterations at most.
    pub iterations: usize,
    /// Stop when an iteration lowers the sum of squares by less than this fraction.
    pub ftol: f64,
    /// Lawson reweighting rounds of the minimax polish (0: none).
    pub minimax: usize,
    /// From iteration `give_up_after` on, give up when the largest distance, shrunk at the
    /// last iteration's rate over the iterations left, would stay above this (the layout
    /// cannot come near the tolerance the caller cares about); `INFINITY` never gives up.
    pub give_up: f64,
    /// See `give_up`.
    pub give_up_after: usize,
    /// Stop once the largest distance improved by less than 1% over this many iterations (the
    /// sum of squares may still creep along a valley where the design points slide along the
    /// curve, which changes the shape no more); 0 never stops for this.
    pub max_stall: usize,
}

/// The data: points in order, the first and last tied to the curve's ends.
pub(crate) struct Data<'a> {
    pub points: &'a [DVec2],
}

impl Data<'_> {
    fn anchored(&self, j: usize) -> bool {
        j == 0 || j + 1 == self.points.len()
    }
}

/// A dense symmetric system `M z = v`, filled by weighted rank-one updates (lower triangle).
struct Normal {
    m: usize,
    mat: Vec<f64>,
    rhs: Vec<f64>,
}

impl Normal {
    fn new(m: usize) -> Self {
        Normal {
            m,
            mat: vec![0.0; m * m],
            rhs: vec![0.0; m],
        }
    }

    /// Add `w (rᵀ z - target)²` for the sparse row `r` (indices ascending). Only the lower
    /// triangle of `M` is kept: the solve reads nothing else.
    #[inline]
    fn add(&mut self, row: &[(usize, f64)], w: f64, target: f64) {
        for (p, &(i, a)) in row.iter().enumerate() {
            let wa = w * a;
            self.rhs[i] += wa * target;
            let line = &mut self.mat[i * self.m..i * self.m + i + 1];
            for &(j, b) in &row[..=p] {
                line[j] += wa * b;
            }
        }
    }

    /// Add `(A z - q)ᵀ W (A z - q)` for a point whose x is `xs · z` and y is `ys · z` (every
    /// y index above every x index, each list ascending): `M += Aᵀ W A`, `v += Aᵀ W q`.
    #[inline]
    fn add_point(&mut self, xs: &[(usize, f64)], ys: &[(usize, f64)], w: [[f64; 2]; 2], q: DVec2) {
        let g = DVec2::new(w[0][0] * q.x + w[0][1] * q.y, w[1][0] * q.x + w[1][1] * q.y);
        let m = self.m;
        for (p, &(i, a)) in xs.iter().enumerate() {
            self.rhs[i] += a * g.x;
            let line = &mut self.mat[i * m..i * m + i + 1];
            let wa = w[0][0] * a;
            for &(j, b) in &xs[..=p] {
                line[j] += wa * b;
            }
        }
        for (p, &(i, a)) in ys.iter().enumerate() {
            self.rhs[i] += a * g.y;
            let line = &mut self.mat[i * m..i * m + i + 1];
            let wx = w[1][0] * a;
            for &(j, b) in xs {
                line[j] += wx * b;
            }
            let wy = w[1][1] * a;
            for &(j, b) in &ys[..=p] {
                line[j] += wy * b;
            }
        }
    }

    /// Add `lambda diag(M) (z - z0)²` (Marquardt's scaling; zero diagonals get the mean).
    fn damp(&mut self, lambda: f64, z0: &[f64]) {
        let m = self.m;
        let mean = (0..m).map(|i| self.mat[i * m + i]).sum::<f64>() / m.max(1) as f64;
        for i in 0..m {
            let dg = self.mat[i * m + i];
            let dg = if dg > 0.0 { dg } else { mean };
            self.mat[i * m + i] += lambda * dg;
            self.rhs[i] += lambda * dg * z0[i];
        }
    }

    /// Solve by Cholesky; a singular system gets a small ridge towards `fallback`.
    fn solve(mut self, fallback: &[f64]) -> Option<Vec<f64>> {
        if let Some(z) = cholesky_solve(&self.mat, &self.rhs, self.m) {
            return Some(z);
        }
        let scale = (0..self.m).map(|i| self.mat[i * self.m + i]).fold(0.0, f64::max);
        let mu = 1e-10 * scale.max(f64::MIN_POSITIVE);
        for i in 0..self.m {
            self.mat[i * self.m + i] += mu;
            self.rhs[i] += mu * fallback.get(i).copied().unwrap_or(0.0);
        }
        cholesky_solve(&self.mat, &self.rhs, self.m)
    }
}

/// Solve the symmetric positive definite `a x = b` (`a` row-major `m x m`); `None` when not
/// positive definite or the result is not finite.
fn cholesky_solve(a: &[f64], b: &[f64], m: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; m * m];
    let scale = (0..m).map(|i| a[i * m + i].abs()).fold(0.0, f64::max);
    if !(scale > 0.0) || !scale.is_finite() {
        return None;
    }
    for i in 0..m {
        for j in 0..=i {
            let mut s = a[i * m + j];
            for p in 0..j {
                s -= l[i * m + p] * l[j * m + p];
            }
            if i == j {
                if s <= 1e-15 * scale {
                    return None;
                }
                l[i * m + i] = s.sqrt();
            } else {
                l[i * m + j] = s / l[j * m + j];
            }
        }
    }
    let mut y = vec![0.0; m];
    for i in 0..m {
        let mut s = b[i];
        for p in 0..i {
            s -= l[i * m + p] * y[p];
        }
        y[i] = s / l[i * m + i];
    }
    for i in (0..m).rev() {
        let mut s = y[i];
        for p in i + 1..m {
            s -= l[p * m + i] * y[p];
        }
        y[i] = s / l[i * m + i];
    }
    y.iter().all(|v| v.is_finite()).then_some(y)
}

/// The local foot point of `q` from `t0`: Newton's method on the squared distance, clamped to
/// `[0, 1]`, each step accepted only if the distance does not grow. Returns `(t, distance²)`.
pub(crate) fn foot(layout: &ChainLayout, coeffs: &[DVec2], q: DVec2, t0: f64) -> (f64, f64) {
    let mut t = t0.clamp(0.0, 1.0);
    let [mut p, mut d1, mut d2] = layout.jet(coeffs, t);
    let mut e = (p - q).length_squared();
    for _ in 0..16 {
        let r = p - q;
        let f = r.dot(d1);
        let gn = d1.length_squared();
        let mut fp = gn + r.dot(d2);
        if !(fp > 0.0) {
            fp = gn;
        }
        if !(fp > 0.0) {
            break;
        }
        let mut step = -f / fp;
        // A step moving the point along the curve by less than this changes the distance by
        // its square over the curvature radius: nothing.
        if (step * step) * gn < 1e-20 * (1.0 + e) {
            break;
        }
        let mut moved = false;
        for _ in 0..6 {
            let tn = (t + step).clamp(0.0, 1.0);
            if tn == t {
                break;
            }
            let [pn, d1n, d2n] = layout.jet(coeffs, tn);
            let en = (pn - q).length_squared();
            if en <= e {
                moved = (tn - t).abs() > 1e-14;
                t = tn;
                (p, d1, d2, e) = (pn, d1n, d2n, en);
                break;
            }
            step *= 0.5;
        }
        if !moved {
            break;
        }
    }
    (t, e)
}

/// Project every parameter (but the anchored ends) to its local foot point; returns the
/// distances.
fn project(layout: &ChainLayout, coeffs: &[DVec2], data: &Data<'_>, params: &mut [f64]) -> Vec<f64> {
    let n = data.points.len();
    let mut dist = vec![0.0; n];
    for j in 0..n {
        let q = data.points[j];
        if data.anchored(j) {
            params[j] = if j == 0 { 0.0 } else { 1.0 };
            dist[j] = (layout.eval(coeffs, params[j]) - q).length();
        } else {
            let (t, e) = foot(layout, coeffs, q, params[j]);
            params[j] = t;
            dist[j] = e.sqrt();
        }
    }
    dist
}

/// The linear least-squares design for fixed parameters (both coordinates' residuals).
pub(crate) fn linear_fit(
    model: &Model,
    data: &Data<'_>,
    params: &[f64],
    weights: Option<&[f64]>,
) -> Option<Vec<f64>> {
    let mx = model.x_unknowns();
    let mut normal = Normal::new(model.unknowns());
    let mut xs = [(0usize, 0.0); MAX_SUPPORT];
    let mut ys = [(0usize, 0.0); MAX_SUPPORT];
    let d = model.layout.degree();
    for (j, (&q, &t)) in data.points.iter().zip(params).enumerate() {
        let b = model.layout.basis(t, 0);
        let (first, value) = (b.first, b.value);
        let w = weights.map_or(1.0, |w| w[j]);
        let nx = model.x_entries(first, &value, &mut xs);
        for a in 0..=d {
            ys[a] = (mx + first + a, value[a]);
        }
        normal.add(&xs[..nx], w, q.x);
        normal.add(&ys[..=d], w, q.y);
    }
    let centroid = data.points.iter().fold(DVec2::ZERO, |a, &p| a + p) / data.points.len() as f64;
    let mut fallback = vec![centroid.x; mx];
    fallback.extend(std::iter::repeat_n(centroid.y, model.layout.design_count()));
    normal.solve(&fallback)
}

/// A state from unknowns and starting parameters, projected.
pub(crate) fn state(model: &Model, data: &Data<'_>, z: Vec<f64>, mut params: Vec<f64>) -> State {
    let coeffs = model.coeffs(&z);
    let dist = project(&model.layout, &coeffs, data, &mut params);
    State {
        z,
        coeffs,
        params,
        dist,
    }
}

/// Weight of the tangential residual beside the normal one in a Gauss-Newton step. The
/// tangent-distance model alone lets the curve slide along itself for free and diverges;
/// the tangential term (zero at the foot points, so it moves no fixed point) holds it.
const TANGENT_WEIGHT: f64 = 0.0;

/// One damped tangent-distance solve at `s`: the unknowns minimising the weighted squared
/// distances of the points to their tangent lines, plus [`TANGENT_WEIGHT`] times the
/// tangential residuals (anchored points and feet clamped at an end: their full residual),
/// plus `lambda` times the Marquardt-scaled distance from the current unknowns.
fn tdm_solve(model: &Model, data: &Data<'_>, s: &State, weights: &[f64], lambda: f64) -> Option<Vec<f64>> {
    let layout = &model.layout;
    let mx = model.x_unknowns();
    let d = layout.degree();
    let mut normal = Normal::new(model.unknowns());
    let mut xs = [(0usize, 0.0); MAX_SUPPORT];
    let mut ys = [(0usize, 0.0); MAX_SUPPORT];
    for (j, &q) in data.points.iter().enumerate() {
        let t = s.params[j];
        let b = layout.basis(t, 0);
        let (first, value) = (b.first, b.value);
        let nx = model.x_entries(first, &value, &mut xs);
        for a in 0..=d {
            ys[a] = (mx + first + a, value[a]);
        }
        let w = weights[j];
        let tangent = layout.jet(&s.coeffs, t)[1];
        let end = t <= 0.0 || t >= 1.0;
        // The point's 2 x 2 weight: w (n nᵀ + tw t tᵀ), or w I for its full residual.
        let weight = if data.anchored(j) || end || tangent.length_squared() == 0.0 {
            [[w, 0.0], [0.0, w]]
        } else {
            let tan = tangent.normalize();
            let nrm = DVec2::new(-tan.y, tan.x);
            let tw = TANGENT_WEIGHT.max(lambda / (1.0 + lambda));
            let outer = |a: DVec2, b: DVec2| [[a.x * b.x, a.x * b.y], [a.y * b.x, a.y * b.y]];
            let (n2, t2) = (outer(nrm, nrm), outer(tan, tan));
            let mut m = [[0.0; 2]; 2];
            for r in 0..2 {
                for c in 0..2 {
                    m[r][c] = w * (n2[r][c] + tw * t2[r][c]);
                }
            }
            m
        };
        normal.add_point(&xs[..nx], &ys[..=d], weight, q);
    }
    if lambda > 0.0 {
        normal.damp(lambda, &s.z);
    }
    normal.solve(&s.z)
}

fn weighted_sq(s: &State, w: &[f64]) -> f64 {
    s.dist.iter().zip(w).map(|(d, w)| w * d * d).sum()
}

/// Damped Gauss-Newton (Levenberg-Marquardt) on the weighted sum of squared distances from
/// `s`; each trial is judged by its projected distances.
fn descend(model: &Model, data: &Data<'_>, mut s: State, weights: &[f64], effort: &Effort) -> State {
    let mut obj = weighted_sq(&s, weights);
    let mut lambda = 0.1;
    let mut tries = 0;
    let mut iterations = 0;
    let mut maxes = vec![s.max()];
    while iterations < effort.iterations && tries < 3 * effort.iterations {
        tries += 1;
        let Some(z) = tdm_solve(model, data, &s, weights, lambda) else {
            lambda *= 10.0;
            if lambda > 1e8 {
                break;
            }
            continue;
        };
        let trial = state(model, data, z, s.params.clone());
        let o = weighted_sq(&trial, weights);
        if o < obj {
            iterations += 1;
            let gain = (obj - o) / obj.max(f64::MIN_POSITIVE);
            s = trial;
            obj = o;
            lambda = (lambda / 4.0).max(1e-12);
            // Far from the caller's tolerance and no longer converging fast: not worth more.
            if gain < effort.ftol {
                break;
            }
            // Give up when, at the rate of the last iteration, the remaining ones would not
            // bring the largest distance (about the square root of the sum) to the target.
            if iterations >= effort.give_up_after && effort.give_up.is_finite() {
                let rest = effort.iterations.saturating_sub(iterations) as f64;
                if s.max() * (1.0 - gain).max(0.0).powf(0.5 * rest) > effort.give_up {
                    break;
                }
            }
            maxes.push(s.max());
            let k = effort.max_stall;
            if k > 0 && maxes.len() > k && maxes[maxes.len() - 1] > 0.99 * maxes[maxes.len() - 1 - k] {
                break;
            }
        } else {
            lambda *= 8.0;
            if lambda > 1e8 {
                break;
            }
        }
    }
    s
}

/// Fit `model` from unknowns `z` (or, when `None`, the linear fit at `params`) and starting
/// parameters: Gauss-Newton on the sum of squares, then the minimax polish if asked, keeping
/// whichever state has the smaller largest distance.
pub(crate) fn fit(
    model: &Model,
    data: &Data<'_>,
    z: Option<Vec<f64>>,
    params: Vec<f64>,
    effort: &Effort,
) -> Option<State> {
    let z = match z {
        Some(z) => z,
        None => linear_fit(model, data, &params, None)?,
    };
    let s = state(model, data, z, params);
    let ones = vec![1.0; data.points.len()];
    let s = descend(model, data, s, &ones, effort);
    if effort.minimax == 0 {
        return Some(s);
    }
    Some(minimax(model, data, s, effort))
}

/// Lawson's iteration towards the minimax fit: each round multiplies every point's weight by
/// its distance (normalised, floored at `1e-6` of the largest) and takes one Gauss-Newton
/// step; the state with the smallest largest distance is kept.
pub(crate) fn minimax(model: &Model, data: &Data<'_>, s: State, effort: &Effort) -> State {
    let n = data.points.len();
    let mut w = vec![1.0 / n as f64; n];
    let mut best = s.clone();
    let mut cur = s;
    let one = Effort {
        iterations: 1,
        ..*effort
    };
    for _ in 0..effort.minimax {
        let mut total = 0.0;
        for (wj, d) in w.iter_mut().zip(&cur.dist) {
            *wj *= d.max(1e-300);
            total += *wj;
        }
        if !(total > 0.0) || !total.is_finite() {
            break;
        }
        let top = w.iter().fold(0.0_f64, |m, &x| m.max(x)) / total;
        for wj in &mut w {
            *wj = (*wj / total).max(1e-6 * top);
        }
        cur = descend(model, data, cur, &w, &one);
        if cur.max() < best.max() {
            best = cur.clone();
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eff() -> Effort {
        Effort {
            iterations: 50,
            ftol: 1e-12,
            minimax: 0,
            give_up: f64::INFINITY,
            give_up_after: 0,
            max_stall: 0,
        }
    }

    #[test]
    fn rule_rows_reproduce_the_quadratic_x_rule() {
        for (d, orders) in [
            (2, vec![1]),
            (3, vec![2, 1, 2]),
            (5, vec![4, 1, 3]),
            (4, vec![1, 1, 1]),
        ] {
            let breaks = match orders.len() {
                1 => vec![0.0, 0.5, 1.0],
                _ => vec![0.0, 0.2, 0.5, 0.9, 1.0],
            };
            let l = ChainLayout::with_orders(d, breaks, orders).unwrap();
            let m = Model::aerofoil(l.clone(), false).unwrap();
            let theta = [0.01, 1.02, 0.98];
            let z = m.unknowns_of(&vec![DVec2::ZERO; l.design_count()], Some(&theta));
            let c = m.coeffs(&z);
            for i in 0..=200 {
                let t = i as f64 / 200.0;
                let x = l.eval(&c, t).x;
                let expect = if t <= 0.5 {
                    theta[0] + (theta[1] - theta[0]) * (1.0 - 2.0 * t).powi(2)
                } else {
                    theta[0] + (theta[2] - theta[0]) * (2.0 * t - 1.0).powi(2)
                };
                assert!((x - expect).abs() < 1e-14, "d={d} t={t}: {x} vs {expect}");
            }
        }
        let no_le = ChainLayout::with_order(3, vec![0.0, 0.4, 1.0], 1).unwrap();
        assert!(Model::aerofoil(no_le, false).is_err());
        let c2_le = ChainLayout::with_order(3, vec![0.0, 0.5, 1.0], 2).unwrap();
        assert!(Model::aerofoil(c2_le, true).is_err());
    }

    #[test]
    fn recovers_a_curve_sampled_off_its_parameters() {
        let l = ChainLayout::with_orders(4, vec![0.0, 0.35, 0.6, 1.0], vec![3, 1]).unwrap();
        let truth: Vec<DVec2> = (0..l.design_count())
            .map(|i| DVec2::new(i as f64 * 0.2, 0.3 * (1.3 * i as f64).sin()))
            .collect();
        let pts: Vec<DVec2> = (0..150)
            .map(|i| l.eval(&truth, (i as f64 / 149.0).powf(1.3)))
            .collect();
        let data = Data { points: &pts };
        let model = Model::free(l);
        let params: Vec<f64> = (0..150).map(|i| i as f64 / 149.0).collect();
        let s = fit(&model, &data, None, params, &eff()).unwrap();
        assert!(s.max() < 1e-10, "max {}", s.max());
    }

    #[test]
    fn minimax_lowers_the_largest_distance() {
        let l = ChainLayout::with_order(3, vec![0.0, 0.5, 1.0], 2).unwrap();
        let pts: Vec<DVec2> = (0..120)
            .map(|i| {
                let a = i as f64 / 119.0 * 3.0;
                DVec2::new(a, (2.0 * a).sin() * 0.4)
            })
            .collect();
        let data = Data { points: &pts };
        let model = Model::free(l);
        let params: Vec<f64> = (0..120).map(|i| i as f64 / 119.0).collect();
        let l2 = fit(&model, &data, None, params.clone(), &eff()).unwrap();
        let mm = fit(&model, &data, None, params, &Effort { minimax: 40, ..eff() }).unwrap();
        assert!(mm.max() < 0.8 * l2.max(), "{} vs {}", mm.max(), l2.max());
    }
}
