//! CMA-ES: the (μ/μ_w, λ) covariance matrix adaptation evolution strategy with cumulative
//! step-size adaptation, rank-one and rank-μ updates (Hansen, "The CMA Evolution Strategy: A
//! Tutorial", 2016, the defaults of its Table 1 with positive weights only).
//!
//! Sample `k` of generation `g` is `x = m + σ B D Bᵀ z` with `z ~ N(0, I)` from its own random
//! stream `(seed, g, k)`; a sample outside the box bounds is drawn again from the same stream
//! (up to [`CmaesOptions::resample`] times), then clamped. The strategy learns from the
//! samples as evaluated (rounded to f32, clamped): `y = (x - m) / σ`. The eigendecomposition
//! `C = B D² Bᵀ` (nalgebra) is refreshed every `max(1, ⌊1 / (10 n (c₁ + c_μ))⌋)` generations,
//! Hansen's lazy schedule. Sums over samples run in fixed chunks summed in order, so the
//! result does not depend on the number of threads.

use super::ga::to_f32;
use super::objective::{PopulationObjective, Score};
use super::rng::{normal, Streams};
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Options of CMA-ES (population size, seed, initial step: see [`super::EvoOptions`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CmaesOptions {
    /// Draws of a sample that falls outside the bounds before it is clamped. Default 10.
    pub resample: usize,
    /// Stop when `σ` times the square root of `C`'s largest eigenvalue falls below this
    /// fraction of the data extent: no sample then differs from the mean by more than f32
    /// resolution at unit size. Default 1e-8.
    pub tol_x: f64,
    /// Stop when `C`'s condition number exceeds this. Default 1e14.
    pub max_condition: f64,
    /// Stop when the generation-best sums of squares of the last `10 + ⌈30 n / λ⌉`
    /// generations, and the sums of the last generation, lie within this many times the
    /// evaluator's resolution at their least (Hansen's TolFun, with the evaluator's f32
    /// rounding at that level as the unit, see `PopulationEvaluator::resolution`): the
    /// objective no longer changes by more than the evaluator can tell. Default 1.
    pub tol_fun: f64,
    /// Restarts: after a convergence stop (flatness, step size or condition) with generations
    /// left, the strategy starts again from where this CMA-ES run began (its origin and initial
    /// step), up to this many times, on fresh random streams (they follow the generation); the
    /// best individual of all of them is the result. A run that found one of several minima
    /// then gets further draws at the others within its generation budget. Default 0.
    pub restarts: usize,
}

impl Default for CmaesOptions {
    fn default() -> Self {
        CmaesOptions {
            resample: 10,
            tol_x: 1e-8,
            max_condition: 1e14,
            tol_fun: 1.0,
            restarts: 0,
        }
    }
}

impl CmaesOptions {
    /// Check every field.
    pub fn check(&self) -> Result<()> {
        Error::check_non_negative("the CMA-ES step tolerance", self.tol_x)?;
        Error::check_non_negative("the CMA-ES objective tolerance", self.tol_fun)?;
        if !(self.max_condition > 1.0) {
            return Err(Error::invalid(format!(
                "the CMA-ES condition limit must exceed 1, not {}",
                self.max_condition
            )));
        }
        Ok(())
    }
}

/// The default population size `4 + ⌊3 ln n⌋` for `n` variables.
#[must_use]
pub fn default_lambda(n: usize) -> usize {
    4 + (3.0 * (n.max(1) as f64).ln()).floor() as usize
}

/// Generations of the flatness test: `10 + ⌈30 n / λ⌉`.
fn flat_window(n: usize, lambda: usize) -> usize {
    10 + (30 * n).div_ceil(lambda.max(1))
}

/// Strategy constants of Hansen's Table 1 for `n` variables and `λ` samples.
#[derive(Clone, Debug, PartialEq)]
struct Constants {
    mu: usize,
    weights: Vec<f64>,
    mu_eff: f64,
    c_sigma: f64,
    d_sigma: f64,
    c_c: f64,
    c_1: f64,
    c_mu: f64,
    chi_n: f64,
    eigen_every: usize,
}

impl Constants {
    fn new(n: usize, lambda: usize) -> Self {
        let nf = n as f64;
        let mu = lambda / 2;
        let raw: Vec<f64> = (1..=mu)
            .map(|i| ((lambda as f64 + 1.0) / 2.0).ln() - (i as f64).ln())
            .collect();
        let total: f64 = raw.iter().sum();
        let weights: Vec<f64> = raw.iter().map(|w| w / total).collect();
        let mu_eff = 1.0 / weights.iter().map(|w| w * w).sum::<f64>();
        let c_sigma = (mu_eff + 2.0) / (nf + mu_eff + 5.0);
        let d_sigma = 1.0 + 2.0 * (((mu_eff - 1.0) / (nf + 1.0)).sqrt() - 1.0).max(0.0) + c_sigma;
        let c_c = (4.0 + mu_eff / nf) / (nf + 4.0 + 2.0 * mu_eff / nf);
        let c_1 = 2.0 / ((nf + 1.3).powi(2) + mu_eff);
        let c_mu = (1.0 - c_1).min(2.0 * (mu_eff - 2.0 + 1.0 / mu_eff) / ((nf + 2.0).powi(2) + mu_eff));
        let chi_n = nf.sqrt() * (1.0 - 1.0 / (4.0 * nf) + 1.0 / (21.0 * nf * nf));
        let eigen_every = ((1.0 / (10.0 * nf * (c_1 + c_mu))).floor() as usize).max(1);
        Constants {
            mu,
            weights,
            mu_eff,
            c_sigma,
            d_sigma,
            c_c,
            c_1,
            c_mu,
            chi_n,
            eigen_every,
        }
    }
}

/// The state of the strategy between generations (what a checkpoint stores).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CmaesState {
    /// The mean `m`.
    pub mean: Vec<f64>,
    /// The step size `σ`, in model units.
    pub sigma: f64,
    /// The covariance `C`, row-major `n × n`.
    pub cov: Vec<f64>,
    /// Eigenvectors `B` of `C` at the last decomposition, row-major, one per column.
    pub basis: Vec<f64>,
    /// Square roots `D` of `C`'s eigenvalues at the last decomposition.
    pub scales: Vec<f64>,
    /// The evolution path of `C`, `p_c`.
    pub path_c: Vec<f64>,
    /// The evolution path of `σ`, `p_σ`.
    pub path_sigma: Vec<f64>,
    /// Generations completed.
    pub generation: u64,
    /// The generation of the last decomposition.
    pub decomposed_at: u64,
    /// The best sum of squares of each of the last generations, oldest first (at most the
    /// flatness window `10 + ⌈30 n / λ⌉`).
    pub recent: Vec<f64>,
    /// Where this CMA-ES run began (the mean a restart starts from).
    pub origin: Vec<f64>,
    /// The step size it began with (the step a restart starts with).
    pub initial_sigma: f64,
    /// Restarts done ([`CmaesOptions::restarts`]).
    pub restarts: u64,
    /// The best mean an earlier run of a restarted strategy converged to (empty before the
    /// first restart): the mean is often better than any sample the evaluator scored, so the
    /// result's candidates keep it.
    pub kept_mean: Vec<f64>,
    /// Its objective re-measured in f64 (infinite while `kept_mean` is empty).
    pub kept_sum_sq: f64,
}

impl CmaesState {
    /// The start: mean `start`, step `sigma`, `C = I`.
    #[must_use]
    pub fn new(start: &[f64], sigma: f64) -> Self {
        let n = start.len();
        let eye: Vec<f64> = (0..n * n)
            .map(|k| if k / n == k % n { 1.0 } else { 0.0 })
            .collect();
        CmaesState {
            mean: start.to_vec(),
            sigma,
            cov: eye.clone(),
            basis: eye,
            scales: vec![1.0; n],
            path_c: vec![0.0; n],
            path_sigma: vec![0.0; n],
            generation: 0,
            decomposed_at: 0,
            recent: Vec::new(),
            origin: start.to_vec(),
            initial_sigma: sigma,
            restarts: 0,
            kept_mean: Vec::new(),
            kept_sum_sq: f64::INFINITY,
        }
    }

    /// The state of the next restart: the start of this run again (its origin and initial
    /// step, `C = I`), with the restart counted and the better of the kept mean and this
    /// run's converged mean (whose objective re-measured in f64 is `sum_sq`) kept.
    #[must_use]
    pub fn restarted(&self, sum_sq: f64) -> Self {
        let (kept_mean, kept_sum_sq) = if sum_sq < self.kept_sum_sq {
            (self.mean.clone(), sum_sq)
        } else {
            (self.kept_mean.clone(), self.kept_sum_sq)
        };
        CmaesState {
            restarts: self.restarts + 1,
            kept_mean,
            kept_sum_sq,
            ..CmaesState::new(&self.origin, self.initial_sigma)
        }
    }

    /// `σ · max D`: the largest standard deviation of the sampling distribution.
    #[must_use]
    pub fn spread(&self) -> f64 {
        self.sigma * self.scales.iter().fold(0.0f64, |a, &d| a.max(d))
    }

    /// `(max D / min D)²`: the condition number of `C` at the last decomposition.
    #[must_use]
    pub fn condition(&self) -> f64 {
        let max = self.scales.iter().fold(0.0f64, |a, &d| a.max(d));
        let min = self.scales.iter().fold(f64::INFINITY, |a, &d| a.min(d));
        (max / min).powi(2)
    }

    /// True when the flatness window is full and its bests, and the sums `last` of the last
    /// generation, lie within `tol(least)` of their least: `tol` gives the tolerance (model
    /// units squared) at a level.
    #[must_use]
    pub fn flat(&self, n: usize, lambda: usize, last: &[f64], tol: impl Fn(f64) -> f64) -> bool {
        let window = flat_window(n, lambda);
        if self.recent.len() < window {
            return false;
        }
        let all = || self.recent.iter().chain(last);
        let lo = all().fold(f64::INFINITY, |a, &b| a.min(b));
        let hi = all().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
        lo.is_finite() && hi.is_finite() && hi - lo <= tol(lo)
    }

    /// Check the shapes against `n` variables (a checkpoint read from disk).
    pub(crate) fn check(&self, n: usize) -> Result<()> {
        let ok = self.mean.len() == n
            && self.cov.len() == n * n
            && self.basis.len() == n * n
            && self.scales.len() == n
            && self.path_c.len() == n
            && self.path_sigma.len() == n
            && self.origin.len() == n
            && (self.kept_mean.is_empty() || self.kept_mean.len() == n)
            && self.sigma.is_finite()
            && self.sigma > 0.0
            && self.initial_sigma.is_finite()
            && self.initial_sigma > 0.0;
        if ok {
            Ok(())
        } else {
            Err(Error::invalid(format!(
                "the CMA-ES state does not fit {n} design variables"
            )))
        }
    }
}

/// Samples per chunk of the parallel sums: fixed, so sums do not depend on the thread count.
const CHUNK: usize = 64;

/// CMA-ES with its sample buffer.
#[derive(Clone, Debug)]
pub(crate) struct Cmaes {
    /// The strategy.
    pub state: CmaesState,
    /// The samples of the current generation, row-major f32.
    pub samples: Vec<f32>,
    /// Their scores.
    pub scores: Vec<Score>,
    consts: Constants,
    order: Vec<u32>,
}

impl Cmaes {
    /// CMA-ES with `lambda` samples per generation from `state`.
    pub(crate) fn new(state: CmaesState, lambda: usize) -> Self {
        let n = state.mean.len();
        Cmaes {
            consts: Constants::new(n, lambda),
            samples: vec![0.0; lambda * n],
            scores: vec![Score::WORST; lambda],
            state,
            order: Vec::new(),
        }
    }

    /// Draw the samples of generation `generation` into `samples`.
    pub(crate) fn sample(
        &mut self,
        problem: &dyn PopulationObjective,
        opts: &CmaesOptions,
        streams: &Streams,
        generation: u64,
    ) {
        let n = problem.dim();
        let st = &self.state;
        let bounds = problem.bounds();
        // C^½ = B D Bᵀ, row-major: sample rows are then plain dot products. The symmetric root
        // (Hansen's tutorial writes B D z, the same distribution) does not depend on which
        // eigenvectors the decomposition picks inside an eigenspace of repeated eigenvalues
        // (C starts as I): two runs whose covariances differ by rounding draw nearly the same
        // samples, instead of samples in unrelated directions.
        let mut bd = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                let v: f64 = (0..n)
                    .map(|k| st.basis[i * n + k] * st.scales[k] * st.basis[j * n + k])
                    .sum();
                bd[i * n + j] = v;
                bd[j * n + i] = v;
            }
        }
        self.samples
            .par_chunks_mut(n)
            .enumerate()
            .with_min_len(32)
            .for_each_init(
                || (vec![0.0; n], vec![0.0; n]),
                |(z, x), (k, row)| {
                    let mut rng = streams.at(generation, k as u64);
                    for attempt in 0..=opts.resample {
                        for zi in z.iter_mut() {
                            *zi = normal(&mut rng);
                        }
                        let mut inside = true;
                        for (i, (row, xi)) in bd.chunks_exact(n).zip(x.iter_mut()).enumerate() {
                            let y = row.iter().zip(z.iter()).fold(0.0, |y, (b, z)| y + b * z);
                            *xi = st.mean[i] + st.sigma * y;
                            let [lo, hi] = bounds[i];
                            inside &= (lo..=hi).contains(xi);
                        }
                        if inside || attempt == opts.resample {
                            break;
                        }
                    }
                    for i in 0..n {
                        let [lo, hi] = bounds[i];
                        row[i] = to_f32(x[i].clamp(lo, hi), lo, hi);
                    }
                },
            );
    }

    /// Update the strategy from the evaluated samples (`scores`).
    pub(crate) fn update(&mut self) {
        let n = self.state.mean.len();
        let lambda = self.scores.len();
        let c = &self.consts;
        let mu = c.mu.max(1);
        // The μ best, in rank order.
        self.order.clear();
        self.order.extend(0..lambda as u32);
        let scores = &self.scores;
        let cmp =
            |a: &u32, b: &u32| scores[*a as usize].before(*a as usize, &scores[*b as usize], *b as usize);
        if mu < lambda {
            self.order.select_nth_unstable_by(mu, cmp);
        }
        self.order[..mu].sort_unstable_by(cmp);
        let st = &mut self.state;
        let window = flat_window(n, lambda);
        st.recent.push(scores[self.order[0] as usize].sum_sq);
        if st.recent.len() > window {
            let extra = st.recent.len() - window;
            st.recent.drain(..extra);
        }
        let samples = &self.samples;
        let mean = st.mean.clone();
        let sigma = st.sigma;
        let y_of = |k: usize, i: usize| (f64::from(samples[k * n + i]) - mean[i]) / sigma;
        // Weighted mean step ⟨y⟩_w and the rank-μ sum Σ w_i y_i y_iᵀ, over fixed chunks.
        let ranks: Vec<(usize, f64)> = self.order[..mu]
            .iter()
            .zip(&c.weights)
            .map(|(&k, &w)| (k as usize, w))
            .collect();
        let partial: Vec<(Vec<f64>, Vec<f64>)> = ranks
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut yw = vec![0.0; n];
                let mut rank_mu = vec![0.0; n * n];
                let mut y = vec![0.0; n];
                for &(k, w) in chunk {
                    for i in 0..n {
                        y[i] = y_of(k, i);
                        yw[i] += w * y[i];
                    }
                    for i in 0..n {
                        let wy = w * y[i];
                        let row = &mut rank_mu[i * n..=i * n + i];
                        row.iter_mut().zip(&y[..=i]).for_each(|(r, &yj)| *r += wy * yj);
                    }
                }
                (yw, rank_mu)
            })
            .collect();
        let mut yw = vec![0.0; n];
        let mut rank_mu = vec![0.0; n * n];
        for (a, b) in partial {
            yw.iter_mut().zip(a).for_each(|(x, y)| *x += y);
            rank_mu.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
        // Mean.
        for i in 0..n {
            st.mean[i] += sigma * yw[i];
        }
        // C^{-1/2} ⟨y⟩_w = B D⁻¹ Bᵀ ⟨y⟩_w.
        let mut bt_y = vec![0.0; n];
        for j in 0..n {
            let mut s = 0.0;
            for i in 0..n {
                s += st.basis[i * n + j] * yw[i];
            }
            bt_y[j] = s / st.scales[j];
        }
        let norm_ps = {
            let a = (c.c_sigma * (2.0 - c.c_sigma) * c.mu_eff).sqrt();
            let mut sq = 0.0;
            for i in 0..n {
                let mut s = 0.0;
                for j in 0..n {
                    s += st.basis[i * n + j] * bt_y[j];
                }
                st.path_sigma[i] = (1.0 - c.c_sigma) * st.path_sigma[i] + a * s;
                sq += st.path_sigma[i] * st.path_sigma[i];
            }
            sq.sqrt()
        };
        st.generation += 1;
        let g = st.generation as f64;
        let h_sigma = norm_ps / (1.0 - (1.0 - c.c_sigma).powf(2.0 * g)).sqrt()
            < (1.4 + 2.0 / (n as f64 + 1.0)) * c.chi_n;
        let hs = if h_sigma { 1.0 } else { 0.0 };
        let a = (c.c_c * (2.0 - c.c_c) * c.mu_eff).sqrt();
        for i in 0..n {
            st.path_c[i] = (1.0 - c.c_c) * st.path_c[i] + hs * a * yw[i];
        }
        let delta = (1.0 - hs) * c.c_c * (2.0 - c.c_c);
        let keep = 1.0 + c.c_1 * delta - c.c_1 - c.c_mu;
        for i in 0..n {
            for j in 0..=i {
                let v = keep * st.cov[i * n + j]
                    + c.c_1 * st.path_c[i] * st.path_c[j]
                    + c.c_mu * rank_mu[i * n + j];
                st.cov[i * n + j] = v;
                st.cov[j * n + i] = v;
            }
        }
        st.sigma *= ((c.c_sigma / c.d_sigma) * (norm_ps / c.chi_n - 1.0)).exp();
        if st.generation - st.decomposed_at >= c.eigen_every as u64 {
            decompose(st);
        }
    }

    /// Generations between decompositions.
    #[cfg(test)]
    fn eigen_every(&self) -> usize {
        self.consts.eigen_every
    }
}

/// `C = B D² Bᵀ`; non-positive eigenvalues (rounding) are floored at a tiny fraction of the
/// largest. When `C`'s largest eigenvalue has drifted far from 1, its scale moves into `σ`
/// (`σ √s`, `C / s`, `p_c / √s`): the sampling distribution and every later update are the
/// same, and neither `σ` nor `C` drifts out of floating-point range (with large populations
/// the rank-μ update shrinks `C` while cumulative step-size adaptation grows `σ`).
fn decompose(st: &mut CmaesState) {
    let n = st.mean.len();
    let cov = DMatrix::from_row_slice(n, n, &st.cov);
    let eig = cov.symmetric_eigen();
    let mut top = eig.eigenvalues.iter().fold(0.0f64, |a, &v| a.max(v));
    let mut eig = eig;
    if top.is_finite() && top > 0.0 && !(1e-4..=1e4).contains(&top) {
        let root = top.sqrt();
        st.sigma *= root;
        st.cov.iter_mut().for_each(|c| *c /= top);
        st.path_c.iter_mut().for_each(|p| *p /= root);
        eig.eigenvalues.iter_mut().for_each(|v| *v /= top);
        top = 1.0;
    }
    let floor = (top * 1e-20).max(f64::MIN_POSITIVE);
    let values: DVector<f64> = eig.eigenvalues.map(|v| v.max(floor));
    for i in 0..n {
        for j in 0..n {
            st.basis[i * n + j] = eig.eigenvectors[(i, j)];
        }
        st.scales[i] = values[i].sqrt();
    }
    st.decomposed_at = st.generation;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_match_hansens_table() {
        // n = 10, λ = 10: μ = 5, μ_eff ≈ 3.17 (Hansen's tutorial, Table 1 formulas).
        let c = Constants::new(10, default_lambda(10));
        assert_eq!(default_lambda(10), 10);
        assert_eq!(c.mu, 5);
        assert!((c.weights.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!(c.weights.windows(2).all(|w| w[0] > w[1]));
        assert!((c.mu_eff - 3.1672).abs() < 1e-3, "{}", c.mu_eff);
        assert!((c.c_1 - 2.0 / (11.3f64.powi(2) + c.mu_eff)).abs() < 1e-15);
        assert!((c.chi_n - 3.0844).abs() < 1e-3, "{}", c.chi_n);
        assert_eq!(default_lambda(24), 13);
        assert_eq!(default_lambda(1), 4);
    }

    #[test]
    fn decomposition_reproduces_the_covariance() {
        let mut st = CmaesState::new(&[0.0; 3], 1.0);
        st.cov = vec![4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0];
        decompose(&mut st);
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3)
                    .map(|k| st.basis[i * 3 + k] * st.scales[k].powi(2) * st.basis[j * 3 + k])
                    .sum();
                assert!((v - st.cov[i * 3 + j]).abs() < 1e-12);
            }
        }
        assert!(st.condition() > 1.0);
        let c = Cmaes::new(st, 64);
        assert!(c.eigen_every() >= 1);
    }
}
