//! The real-coded genetic algorithm: tournament selection, simulated binary crossover (SBX),
//! mutation and elitism, over f32 design rows.
//!
//! Each generation copies the `E` best individuals unchanged, then fills the rest of the
//! population pair by pair: two tournament winners, recombined with probability
//! `crossover_rate` (a fraction `line_rate` of the pairs along the line through the parents,
//! the others by SBX variable by variable), then each child mutated one of two ways: with
//! probability `covariance_rate` by a normal step drawn from the covariance of the best
//! `covariance_pool` of the population, else by polynomial mutation (Deb's bounded form) of
//! every variable with probability `mutation_rate`. Pair `k` of generation `g` draws only
//! from its own random stream `(seed, g, k)`, so pairs are bred in parallel and the result
//! does not depend on the number of threads.
//!
//! **Covariance mutation.** The fitting problem's objective is a badly conditioned quadratic
//! near its minimum (its design points are strongly coupled), and steps along the coordinate
//! axes of a fixed size, as polynomial mutation makes, soon either overshoot the valley
//! (most of them: a step of `1/(η_m + 2)` of the bound width) or crawl. The best individuals
//! of the population, though, spread along the valley: a step drawn from their own
//! covariance `C = Σ (x_k - x̄)(x_k - x̄)ᵀ / (μ - 1)` follows the valley's directions and
//! shrinks with the population as it converges, whatever the coordinates. It is drawn as
//! `Σ z_k F_k` with `z_k` standard normal over the rows of a factor `C = FᵀF`: the pool's
//! scaled deviations `(x_k - x̄) / √(μ - 1)` when `μ ≤ n` (the step then lies in the pool's
//! span), else `C`'s scaled eigenvectors (`O(min(μ, n) n)` a child).

use super::objective::{PopulationObjective, Score};
use super::rng::{normal, uniform, Streams};
use crate::error::{Error, Result};
use nalgebra::DMatrix;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Options of the genetic algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaOptions {
    /// Individuals drawn (with replacement) per tournament; the best wins. Default 8.
    pub tournament: usize,
    /// Probability that a pair of parents is recombined (by SBX, or along their line: see
    /// `line_rate`), else copied. Default 1.
    pub crossover_rate: f64,
    /// SBX distribution index `η_c`: larger keeps children closer to their parents.
    /// Default 2.
    pub crossover_eta: f64,
    /// Fraction of the recombined pairs whose children lie on the line through the parents:
    /// SBX with one spread factor for every variable (`c = m ∓ β (b - a) / 2` about the
    /// parents' mean `m`), which keeps the parents' direction, where SBX variable by variable
    /// scatters the children over the box the parents span. The fitting problem's design
    /// points are strongly coupled, and steps along the lines between good designs follow its
    /// valleys. Default 0.3.
    pub line_rate: f64,
    /// Probability that a variable of a child that is not mutated by the covariance step is
    /// mutated by polynomial mutation; `None` is `1 / n` for `n` design variables. Default
    /// `None`.
    pub mutation_rate: Option<f64>,
    /// Polynomial mutation distribution index `η_m`: larger makes smaller mutations (the
    /// mean step is about `1 / (η_m + 2)` of the bound width). Default 200.
    pub mutation_eta: f64,
    /// Fraction of the population carried unchanged into the next generation (the best
    /// individuals; at least one). Default 0.03.
    pub elite_fraction: f64,
    /// Probability that a child is mutated by a normal step with the covariance of the
    /// population's best (see the module notes) instead of by polynomial mutation. Default
    /// 0.8.
    #[serde(default = "default_covariance_rate")]
    pub covariance_rate: f64,
    /// Fraction of the population, the best individuals (at least two), whose covariance the
    /// covariance step has. Default 0.1.
    #[serde(default = "default_covariance_pool")]
    pub covariance_pool: f64,
}

fn default_covariance_rate() -> f64 {
    GaOptions::default().covariance_rate
}

fn default_covariance_pool() -> f64 {
    GaOptions::default().covariance_pool
}

/// The defaults were measured on the paper's case 1 (24 variables, P = 1024, G = 500, CPU,
/// sum_sq re-measured in f64): the textbook settings (binary tournaments, crossover rate 0.9,
/// `η_m` = 20) ended at 6.5e-6 for seed 1; tournaments of 8, `η_c` = 2, 30 % of the pairs
/// recombined along the parents' line, 3 % elites and polynomial mutation alone (`η_m` =
/// 200) at 1.3e-6 to 3.4e-6 over seeds 1–6, median 2.0e-6: most mutated children land far
/// outside the valley. With 80 % of the children given the covariance step of the best 10 %
/// instead, seeds 1–6 end at 3.0e-7 to 5.2e-7, median 3.8e-7 (cases 2 and 3: medians 2.7e-7
/// and 2.5e-7 against 2.4e-6 and 1.1e-6). In a trial build (the same operators, another draw
/// order; medians over seeds 1–6) pools of 6 % to 12 % and rates of 0.7 to 0.9 gave 2.6e-7 to
/// 5.8e-7; with a pool of 6 %, steps scaled by 0.85 or 1.2 did no better than unscaled ones
/// (7.0e-7, 4.7e-7 against 4.4e-7); half the children given the step of the best 25 % and
/// polynomial mutation on every child gave 1.3e-6 (seeds 1–3); every child given the step of
/// the best 25 % and none a polynomial one stalled at 4e-3 (that pool spreads over the
/// whole initial population, and its steps stay as wide), of the best 6 % ended at 5.2e-7 and
/// 3.8e-7 (seeds 1, 2); differential
/// steps between two of the pool (`x + F (x_b − x_c)`, `F` = 0.85, pool 6 %) reached a
/// similar median, 3.1e-7, with more outliers (1.4e-6 on case 1, 5.2e-6 on case 3).
impl Default for GaOptions {
    fn default() -> Self {
        GaOptions {
            tournament: 8,
            crossover_rate: 1.0,
            crossover_eta: 2.0,
            line_rate: 0.3,
            mutation_rate: None,
            mutation_eta: 200.0,
            elite_fraction: 0.03,
            covariance_rate: 0.8,
            covariance_pool: 0.1,
        }
    }
}

fn rate(name: &str, x: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&x) {
        return Err(Error::invalid(format!("the {name} must lie in [0, 1], not {x}")));
    }
    Ok(())
}

fn index(name: &str, x: f64) -> Result<()> {
    if !(x >= 0.0) || !x.is_finite() {
        return Err(Error::invalid(format!(
            "the {name} must be a finite number ≥ 0, not {x}"
        )));
    }
    Ok(())
}

impl GaOptions {
    /// Check every field (rates in `[0, 1]`, distribution indices ≥ 0, a tournament of one or
    /// more).
    pub fn check(&self) -> Result<()> {
        if self.tournament == 0 {
            return Err(Error::invalid("a tournament needs at least one individual"));
        }
        rate("crossover rate", self.crossover_rate)?;
        if let Some(m) = self.mutation_rate {
            rate("mutation rate", m)?;
        }
        rate("elite fraction", self.elite_fraction)?;
        rate("line crossover rate", self.line_rate)?;
        rate("covariance mutation rate", self.covariance_rate)?;
        rate("covariance pool", self.covariance_pool)?;
        index("crossover distribution index", self.crossover_eta)?;
        index("mutation distribution index", self.mutation_eta)
    }

    /// Elites kept in a population of `size` (at least one, fewer than `size`).
    #[must_use]
    pub fn elites(&self, size: usize) -> usize {
        ((self.elite_fraction * size as f64).round() as usize).clamp(1, size.saturating_sub(1).max(1))
    }

    /// Individuals whose covariance the covariance step has, in a population of `size` (at
    /// least two, at most `size`).
    #[must_use]
    pub fn pool(&self, size: usize) -> usize {
        ((self.covariance_pool * size as f64).round() as usize).clamp(2.min(size), size)
    }
}

/// The initial population: row 0 is the start, every other variable the start plus a normal
/// deviation of `spread` (model units), clamped to the bounds. Row `k` draws from stream
/// `(seed, 0, k)`.
pub(crate) fn initial_population(
    problem: &dyn PopulationObjective,
    size: usize,
    spread: f64,
    streams: &Streams,
) -> Vec<f32> {
    let n = problem.dim();
    let mut pop = vec![0.0f32; size * n];
    pop.par_chunks_mut(n)
        .enumerate()
        .with_min_len(64)
        .for_each(|(k, row)| {
            let mut rng = streams.at(0, k as u64);
            for (i, x) in row.iter_mut().enumerate() {
                let [lo, hi] = problem.bounds()[i];
                let dev = if k == 0 { 0.0 } else { spread * normal(&mut rng) };
                *x = to_f32((problem.start()[i] + dev).clamp(lo, hi), lo, hi);
            }
        });
    pop
}

/// `x` rounded to f32 and kept inside `[lo, hi]` (rounding may step just outside).
#[inline]
pub(crate) fn to_f32(x: f64, lo: f64, hi: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < lo {
        next_up(y)
    } else if f64::from(y) > hi {
        next_down(y)
    } else {
        y
    }
}

fn next_up(y: f32) -> f32 {
    if y.is_nan() || y == f32::INFINITY {
        return y;
    }
    if y == 0.0 {
        return f32::from_bits(1);
    }
    let b = y.to_bits();
    f32::from_bits(if y > 0.0 { b + 1 } else { b - 1 })
}

fn next_down(y: f32) -> f32 {
    -next_up(-y)
}

/// The GA's population, its scores and the buffer the next generation is bred into.
#[derive(Clone, Debug)]
pub(crate) struct Ga {
    /// Current individuals, row-major.
    pub population: Vec<f32>,
    /// Their scores.
    pub scores: Vec<Score>,
    /// The next generation, while it is bred and evaluated.
    pub next: Vec<f32>,
    /// Its scores.
    pub next_scores: Vec<Score>,
    order: Vec<u32>,
    /// A factor of the covariance pool's covariance (see [`covariance_factor`]).
    factor: Vec<f64>,
}

impl Ga {
    /// A GA state from an evaluated population.
    pub(crate) fn new(population: Vec<f32>, scores: Vec<Score>) -> Self {
        let len = population.len();
        let size = scores.len();
        Ga {
            population,
            scores,
            next: vec![0.0; len],
            next_scores: vec![Score::WORST; size],
            order: Vec::new(),
            factor: Vec::new(),
        }
    }

    /// Breed generation `generation` into `next` from the current population and scores.
    pub(crate) fn breed(
        &mut self,
        problem: &dyn PopulationObjective,
        opts: &GaOptions,
        streams: &Streams,
        generation: u64,
    ) {
        let n = problem.dim();
        let size = self.scores.len();
        let elites = opts.elites(size);
        let pool = opts.pool(size);
        // The pool's best, then the E best among them in rank order (ties by index:
        // deterministic).
        self.order.clear();
        self.order.extend(0..size as u32);
        let scores = &self.scores;
        let cmp =
            |a: &u32, b: &u32| scores[*a as usize].before(*a as usize, &scores[*b as usize], *b as usize);
        let ranked = elites.max(pool);
        if ranked < size {
            self.order.select_nth_unstable_by(ranked, cmp);
        }
        if elites < ranked {
            self.order[..ranked].select_nth_unstable_by(elites, cmp);
        }
        self.order[..elites].sort_unstable_by(cmp);
        for (slot, &k) in self.order[..elites].iter().enumerate() {
            let k = k as usize;
            self.next[slot * n..(slot + 1) * n].copy_from_slice(&self.population[k * n..(k + 1) * n]);
        }
        // The pool in index order, so that its sums do not depend on the selection's order.
        // Without covariance steps (rate 0) no child reads the factor.
        if opts.covariance_rate > 0.0 {
            let mut members: Vec<usize> = self.order[..pool].iter().map(|&k| k as usize).collect();
            members.sort_unstable();
            covariance_factor(&self.population, n, &members, &mut self.factor);
        }
        let factor = &self.factor;
        let pm = opts.mutation_rate.unwrap_or(1.0 / n as f64);
        let spread = Sbx::new(opts.crossover_eta);
        let parents = &self.population;
        let bounds = problem.bounds();
        self.next[elites * n..]
            .par_chunks_mut(2 * n)
            .enumerate()
            .with_min_len(16)
            .for_each_init(
                || [vec![0.0; n], vec![0.0; n]],
                |kids, (pair, children)| {
                    let mut rng = streams.at(generation, pair as u64);
                    let a = tournament(scores, opts.tournament, &mut rng);
                    let b = tournament(scores, opts.tournament, &mut rng);
                    let (pa, pb) = (&parents[a * n..(a + 1) * n], &parents[b * n..(b + 1) * n]);
                    let cross = uniform(&mut rng) < opts.crossover_rate;
                    // Along the parents' line: one spread factor β for every variable, drawn
                    // as SBX draws it far from the bounds (α = 2).
                    let line = (cross && uniform(&mut rng) < opts.line_rate)
                        .then(|| spread.betaq(2.0, uniform(&mut rng)));
                    let [k1, k2] = kids;
                    for i in 0..n {
                        let [lo, hi] = bounds[i];
                        let (x1, x2) = (f64::from(pa[i]), f64::from(pb[i]));
                        (k1[i], k2[i]) = match line {
                            Some(beta) => {
                                let (m, h) = (0.5 * (x1 + x2), 0.5 * beta * (x2 - x1));
                                ((m - h).clamp(lo, hi), (m + h).clamp(lo, hi))
                            }
                            None if cross => sbx(x1, x2, lo, hi, &spread, &mut rng),
                            None => (x1, x2),
                        };
                    }
                    // The last pair of an odd count has room for one child only.
                    let (c1, c2) = children.split_at_mut(n);
                    for (kid, child) in [(&mut *k1, c1), (&mut *k2, c2)] {
                        if child.is_empty() {
                            break;
                        }
                        if uniform(&mut rng) < opts.covariance_rate {
                            covariance_step(kid, factor, &mut rng);
                            for (i, (c, &y)) in child.iter_mut().zip(kid.iter()).enumerate() {
                                let [lo, hi] = bounds[i];
                                *c = to_f32(y.clamp(lo, hi), lo, hi);
                            }
                        } else {
                            for (i, (c, &y)) in child.iter_mut().zip(kid.iter()).enumerate() {
                                let [lo, hi] = bounds[i];
                                *c = to_f32(mutate(y, lo, hi, pm, opts.mutation_eta, &mut rng), lo, hi);
                            }
                        }
                    }
                },
            );
    }

    /// Make the evaluated next generation the current one.
    pub(crate) fn advance(&mut self) {
        std::mem::swap(&mut self.population, &mut self.next);
        std::mem::swap(&mut self.scores, &mut self.next_scores);
    }
}

/// The winner of a tournament of `size` individuals drawn with replacement.
fn tournament(scores: &[Score], size: usize, rng: &mut ChaCha8Rng) -> usize {
    let draw = |rng: &mut ChaCha8Rng| ((uniform(rng) * scores.len() as f64) as usize).min(scores.len() - 1);
    let mut best = draw(rng);
    for _ in 1..size {
        let k = draw(rng);
        if scores[k].before(k, &scores[best], best).is_lt() {
            best = k;
        }
    }
    best
}

/// A factor `F` of the pool's sample covariance `C = FᵀF` (`C` of the rows `members` of
/// `population`, `n` values each) into `out`, row-major, `min(μ, n)` rows of `n`: `Σ_k z_k F_k`
/// with standard normal `z_k` is then distributed as `N(0, C)`. For `μ ≤ n` the rows are the
/// members' deviations from their mean over `√(μ - 1)`; for larger pools `C`'s eigenvectors
/// scaled by the roots of their eigenvalues, so that a step draws `n` normal numbers, not `μ`.
fn covariance_factor(population: &[f32], n: usize, members: &[usize], out: &mut Vec<f64>) {
    let mu = members.len();
    let mut mean = vec![0.0; n];
    for &k in members {
        for (m, &x) in mean.iter_mut().zip(&population[k * n..(k + 1) * n]) {
            *m += f64::from(x);
        }
    }
    mean.iter_mut().for_each(|m| *m /= mu as f64);
    let scale = 1.0 / ((mu.max(2) - 1) as f64).sqrt();
    out.clear();
    for &k in members {
        out.extend(
            population[k * n..(k + 1) * n]
                .iter()
                .zip(&mean)
                .map(|(&x, m)| (f64::from(x) - m) * scale),
        );
    }
    if mu <= n {
        return;
    }
    let deviations = DMatrix::from_row_slice(mu, n, out);
    let eig = (deviations.transpose() * &deviations).symmetric_eigen();
    out.clear();
    for (k, &value) in eig.eigenvalues.iter().enumerate() {
        let root = value.max(0.0).sqrt();
        out.extend(eig.eigenvectors.column(k).iter().map(|b| b * root));
    }
}

/// Add to `y` a normal step with the pool's covariance: `Σ_k z_k d_k` over the rows `d_k` of
/// `factor` (see [`covariance_factor`]).
fn covariance_step(y: &mut [f64], factor: &[f64], rng: &mut ChaCha8Rng) {
    for d in factor.chunks_exact(y.len()) {
        let z = normal(rng);
        for (y, d) in y.iter_mut().zip(d) {
            *y += z * d;
        }
    }
}

/// Simulated binary crossover with distribution index `eta`, its constants computed once.
#[derive(Clone, Copy, Debug)]
struct Sbx {
    eta: f64,
    /// `1 / (η + 1)`.
    e: f64,
    /// Above this spread factor `β^-(η+1) < 2^-60`, and `α = 2 - β^-(η+1)` rounds to 2.
    big: f64,
}

impl Sbx {
    fn new(eta: f64) -> Self {
        Sbx {
            eta,
            e: 1.0 / (eta + 1.0),
            big: 2f64.powf(60.0 / (eta + 1.0)),
        }
    }

    /// `α = 2 - β^-(η+1)`; exactly 2 when the bound is far (the common case, without a
    /// `powf`: the same value the formula rounds to).
    fn alpha(&self, beta: f64) -> f64 {
        if beta > self.big {
            2.0
        } else {
            2.0 - beta.powf(-(self.eta + 1.0))
        }
    }

    /// The spread `β_q` for the uniform draw `u`.
    fn betaq(&self, alpha: f64, u: f64) -> f64 {
        if u <= 1.0 / alpha {
            (u * alpha).powf(self.e)
        } else {
            (1.0 / (2.0 - u * alpha)).powf(self.e)
        }
    }
}

/// Simulated binary crossover of one variable (Deb and Agrawal 1995; the bounded form of
/// Deb's NSGA-II code): each variable is recombined with probability 1/2, the children's
/// spread around the parents' mean follows a polynomial of index `eta`, and the bounds reshape
/// it so no child leaves `[lo, hi]`.
fn sbx(x1: f64, x2: f64, lo: f64, hi: f64, sbx: &Sbx, rng: &mut ChaCha8Rng) -> (f64, f64) {
    let swap = uniform(rng) < 0.5;
    let recombine = uniform(rng) < 0.5;
    let u = uniform(rng);
    if !recombine || (x1 - x2).abs() <= 1e-14 * (1.0 + x1.abs()) {
        return (x1, x2);
    }
    let (y1, y2) = if x1 < x2 { (x1, x2) } else { (x2, x1) };
    let d = y2 - y1;
    let a1 = sbx.alpha(1.0 + 2.0 * (y1 - lo) / d);
    let a2 = sbx.alpha(1.0 + 2.0 * (hi - y2) / d);
    let q1 = sbx.betaq(a1, u);
    let q2 = if a2 == a1 { q1 } else { sbx.betaq(a2, u) };
    let c1 = 0.5 * ((y1 + y2) - q1 * d);
    let c2 = 0.5 * ((y1 + y2) + q2 * d);
    let (c1, c2) = (c1.clamp(lo, hi), c2.clamp(lo, hi));
    if swap {
        (c2, c1)
    } else {
        (c1, c2)
    }
}

/// Polynomial mutation of one variable with probability `pm` (Deb's bounded form): a step of
/// at most the bound width, distributed as a polynomial of index `eta` that vanishes at the
/// bounds.
fn mutate(y: f64, lo: f64, hi: f64, pm: f64, eta: f64, rng: &mut ChaCha8Rng) -> f64 {
    let go = uniform(rng) < pm;
    let r = uniform(rng);
    let width = hi - lo;
    if !go || !(width > 0.0) {
        return y;
    }
    let (d1, d2) = ((y - lo) / width, (hi - y) / width);
    let p = 1.0 / (eta + 1.0);
    let dq = if r < 0.5 {
        let v = 2.0 * r + (1.0 - 2.0 * r) * (1.0 - d1).powf(eta + 1.0);
        v.powf(p) - 1.0
    } else {
        let v = 2.0 * (1.0 - r) + 2.0 * (r - 0.5) * (1.0 - d2).powf(eta + 1.0);
        1.0 - v.powf(p)
    };
    (y + dq * width).clamp(lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn rng() -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(11)
    }

    #[test]
    fn sbx_keeps_the_mean_and_the_bounds() {
        let mut r = rng();
        let (mut n, mut spread) = (0, 0.0);
        for _ in 0..20_000 {
            let (a, b) = sbx(0.3, 0.5, 0.0, 1.0, &Sbx::new(15.0), &mut r);
            assert!((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b));
            if (a - 0.3).abs() > 1e-15 && (a - 0.5).abs() > 1e-15 {
                n += 1;
                spread += (a - b).abs();
                // Far from the bounds the children are symmetric about the parents' mean (the
                // bounded form skews them slightly: β^-(η+1) is 4^-16 and 6^-16 here).
                assert!((a + b - 0.8).abs() < 1e-5, "{a} {b}");
            }
        }
        // About half the variables recombine; children spread about as far as the parents.
        assert!((8_000..12_000).contains(&n), "{n}");
        let mean_spread = spread / n as f64;
        assert!((0.15..0.25).contains(&mean_spread), "{mean_spread}");
        // Near a bound the children stay inside it.
        for _ in 0..2_000 {
            let (a, b) = sbx(0.001, 0.9, 0.0, 1.0, &Sbx::new(2.0), &mut r);
            assert!(a >= 0.0 && b <= 1.0);
        }
    }

    #[test]
    fn polynomial_mutation_is_bounded_and_centred() {
        let mut r = rng();
        let ys: Vec<f64> = (0..20_000)
            .map(|_| mutate(0.5, 0.0, 1.0, 1.0, 20.0, &mut r))
            .collect();
        assert!(ys.iter().all(|y| (0.0..=1.0).contains(y)));
        let mean = ys.iter().sum::<f64>() / ys.len() as f64;
        let mad = ys.iter().map(|y| (y - 0.5).abs()).sum::<f64>() / ys.len() as f64;
        // E|δ| = 1/(η+2) for the unbounded polynomial distribution.
        assert!(
            mean.abs() - 0.5 < 0.003 && (mad - 1.0 / 22.0).abs() < 0.003,
            "{mean} {mad}"
        );
        assert!((0..100).all(|_| mutate(0.5, 0.0, 1.0, 0.0, 20.0, &mut r) == 0.5));
        assert!((0..2000).all(|_| {
            let y = mutate(0.999, 0.0, 1.0, 1.0, 1.0, &mut r);
            (0.0..=1.0).contains(&y)
        }));
    }

    #[test]
    fn tournaments_favour_the_better() {
        let scores: Vec<Score> = (0..10)
            .map(|k| Score {
                sum_sq: k as f64,
                max: 0.0,
            })
            .collect();
        let mut r = rng();
        let wins = (0..10_000).filter(|_| tournament(&scores, 2, &mut r) < 5).count();
        // P(best of two in the better half) = 1 - 1/4.
        assert!((7_200..7_800).contains(&wins), "{wins}");
        assert!((0..100).all(|_| tournament(&scores, 50, &mut r) == 0));
    }

    #[test]
    fn options_are_checked() {
        assert!(GaOptions::default().check().is_ok());
        let bad = [
            GaOptions {
                crossover_rate: -0.1,
                ..GaOptions::default()
            },
            GaOptions {
                mutation_rate: Some(1.5),
                ..GaOptions::default()
            },
            GaOptions {
                crossover_eta: -1.0,
                ..GaOptions::default()
            },
            GaOptions {
                tournament: 0,
                ..GaOptions::default()
            },
            GaOptions {
                line_rate: 1.5,
                ..GaOptions::default()
            },
            GaOptions {
                elite_fraction: f64::NAN,
                ..GaOptions::default()
            },
            GaOptions {
                covariance_rate: 1.1,
                ..GaOptions::default()
            },
            GaOptions {
                covariance_pool: -0.5,
                ..GaOptions::default()
            },
        ];
        for o in bad {
            assert!(matches!(o.check(), Err(Error::Invalid(_))), "{o:?}");
        }
        assert_eq!(GaOptions::default().elites(1024), 31);
        assert_eq!(GaOptions::default().elites(16), 1);
        assert_eq!(GaOptions::default().pool(1024), 102);
        assert_eq!(GaOptions::default().pool(4), 2);
    }

    /// The covariance step of a pool spread along a tilted line (a valley at 30° to the axes,
    /// ten times longer than wide) has the pool's covariance, for a pool larger than the
    /// dimension (the eigenvector factor) and one as large (the deviations): its steps follow
    /// the valley.
    #[test]
    fn the_covariance_step_has_the_pools_covariance() {
        let n = 2;
        let mut r = rng();
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let population: Vec<f32> = (0..400)
            .flat_map(|_| {
                let (a, b) = (normal(&mut r), 0.1 * normal(&mut r));
                [(0.5 + c * a - s * b) as f32, (-0.2 + s * a + c * b) as f32]
            })
            .collect();
        for members in [(0..400).collect::<Vec<usize>>(), vec![3, 7]] {
            let mu = members.len();
            let mut factor = Vec::new();
            covariance_factor(&population, n, &members, &mut factor);
            assert_eq!(factor.len(), mu.min(n) * n);
            // The pool's sample covariance, from its rows directly.
            let row = |k: usize| [f64::from(population[k * n]), f64::from(population[k * n + 1])];
            let mut mean = [0.0; 2];
            for &k in &members {
                (0..2).for_each(|i| mean[i] += row(k)[i] / mu as f64);
            }
            let mut pool = [[0.0; 2]; 2];
            for &k in &members {
                for i in 0..2 {
                    for j in 0..2 {
                        pool[i][j] += (row(k)[i] - mean[i]) * (row(k)[j] - mean[j]) / (mu - 1) as f64;
                    }
                }
            }
            // The steps' covariance about zero.
            let draws = 40_000;
            let mut steps = [[0.0; 2]; 2];
            for _ in 0..draws {
                let mut y = [0.0; 2];
                covariance_step(&mut y, &factor, &mut r);
                for i in 0..2 {
                    for j in 0..2 {
                        steps[i][j] += y[i] * y[j] / f64::from(draws);
                    }
                }
            }
            let size = pool[0][0] + pool[1][1];
            for i in 0..2 {
                for j in 0..2 {
                    assert!(
                        (steps[i][j] - pool[i][j]).abs() < 0.03 * size,
                        "{mu}: {steps:?} against {pool:?}"
                    );
                }
            }
            if mu > n {
                // Along the valley the steps are about ten times longer than across it.
                let along = c * c * steps[0][0] + 2.0 * c * s * steps[0][1] + s * s * steps[1][1];
                let across = s * s * steps[0][0] - 2.0 * c * s * steps[0][1] + c * c * steps[1][1];
                assert!((along / across).sqrt() > 8.0, "{along} {across}");
            }
        }
    }

    #[test]
    fn rounding_stays_inside_the_bounds() {
        let lo = 0.1f64;
        let y = to_f32(lo, lo, 1.0);
        assert!(f64::from(y) >= lo);
        let hi = 0.3f64;
        assert!(f64::from(to_f32(hi, 0.0, hi)) <= hi);
        assert_eq!(to_f32(0.5, 0.0, 1.0), 0.5);
        assert!(f64::from(to_f32(-0.1, -0.1, 0.0)) >= -0.1);
    }
}
