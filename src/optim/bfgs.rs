//! BFGS quasi-Newton minimisation with a strong-Wolfe line search, for any [`Objective`]
//! with a gradient.

use super::nelder_mead::Minimum;
use super::report::{SolveReport, StopReason};
use crate::problem::Objective;
use std::time::Instant;

/// Options of the BFGS minimiser.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BfgsOptions {
    /// Length of the first step (largest coordinate change), in the variables' units (model
    /// units for design points). Default 0.01.
    pub initial_step: f64,
    /// Most iterations (line searches). Default 5000.
    pub max_iterations: usize,
    /// Most objective evaluations (each with its gradient). Default 50 000.
    pub max_evaluations: usize,
    /// Converged when three iterations in a row each lower the value by less than this
    /// fraction of it. Default 1e-12.
    pub ftol: f64,
    /// Converged when the largest gradient component falls below this. Default 0 (off).
    pub gtol: f64,
    /// Sufficient-decrease constant of the Wolfe conditions. Default 1e-4.
    pub c1: f64,
    /// Curvature constant of the strong Wolfe conditions. Default 0.9.
    pub c2: f64,
}

impl Default for BfgsOptions {
    fn default() -> Self {
        BfgsOptions {
            initial_step: 0.01,
            max_iterations: 5000,
            max_evaluations: 50_000,
            ftol: 1e-12,
            gtol: 0.0,
            c1: 1e-4,
            c2: 0.9,
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A point on the search line with its value and gradient.
struct LinePoint {
    alpha: f64,
    x: Vec<f64>,
    f: f64,
    g: Vec<f64>,
    slope: f64,
}

/// Counts evaluations and maps NaN to +∞ so that comparisons reject it.
struct Counted<'o, O: Objective> {
    f: &'o mut O,
    evaluations: usize,
}

impl<O: Objective> Counted<'_, O> {
    fn at(&mut self, x: &[f64], p: &[f64], alpha: f64) -> LinePoint {
        let xa: Vec<f64> = x.iter().zip(p).map(|(a, b)| a + alpha * b).collect();
        let mut g = vec![0.0; xa.len()];
        self.evaluations += 1;
        let mut f = self.f.value_grad(&xa, &mut g);
        if !f.is_finite() || g.iter().any(|v| !v.is_finite()) {
            f = f64::INFINITY;
        }
        let slope = dot(&g, p);
        LinePoint {
            alpha,
            x: xa,
            f,
            g,
            slope,
        }
    }
}

/// Strong-Wolfe line search (Nocedal and Wright, algorithms 3.5 and 3.6) along `p` from `x`
/// with value `f0` and slope `d0 < 0`. Returns the accepted point, or the best point with
/// sufficient decrease when the evaluation budget runs out, or `None`.
fn line_search<O: Objective>(
    f: &mut Counted<'_, O>,
    x: &[f64],
    f0: f64,
    d0: f64,
    p: &[f64],
    alpha0: f64,
    opts: &BfgsOptions,
) -> Option<LinePoint> {
    const MAX_TRIES: usize = 40;
    let armijo = |pt: &LinePoint| pt.f <= f0 + opts.c1 * pt.alpha * d0;
    let curvature = |pt: &LinePoint| pt.slope.abs() <= -opts.c2 * d0;
    let mut prev = LinePoint {
        alpha: 0.0,
        x: x.to_vec(),
        f: f0,
        g: Vec::new(),
        slope: d0,
    };
    let mut alpha = alpha0;
    let mut bracket = None;
    for i in 0..MAX_TRIES {
        let pt = f.at(x, p, alpha);
        if !armijo(&pt) || (i > 0 && pt.f >= prev.f) {
            bracket = Some((prev, pt));
            break;
        }
        if curvature(&pt) {
            return Some(pt);
        }
        if pt.slope >= 0.0 {
            bracket = Some((pt, prev));
            break;
        }
        prev = pt;
        alpha *= 2.0;
    }
    let (mut lo, mut hi) = bracket?;
    // `lo` satisfies sufficient decrease and has the lowest value seen; the minimum lies
    // between `lo` and `hi`.
    for _ in 0..MAX_TRIES {
        let (a, b) = (lo.alpha.min(hi.alpha), lo.alpha.max(hi.alpha));
        if b - a <= 1e-16 * b.max(1e-300) {
            break;
        }
        let trial = interpolate(&lo, &hi).clamp(a + 0.1 * (b - a), b - 0.1 * (b - a));
        let pt = f.at(x, p, trial);
        if !armijo(&pt) || pt.f >= lo.f {
            hi = pt;
        } else {
            if curvature(&pt) {
                return Some(pt);
            }
            if pt.slope * (hi.alpha - lo.alpha) >= 0.0 {
                hi = lo;
            }
            lo = pt;
        }
    }
    (lo.alpha > 0.0 && lo.f < f0).then_some(lo)
}

/// The minimiser of the cubic through two points with values and slopes (the midpoint when
/// the cubic has none).
fn interpolate(a: &LinePoint, b: &LinePoint) -> f64 {
    let d1 = a.slope + b.slope - 3.0 * (a.f - b.f) / (a.alpha - b.alpha);
    let disc = d1 * d1 - a.slope * b.slope;
    if !(disc >= 0.0) || !a.f.is_finite() || !b.f.is_finite() {
        return 0.5 * (a.alpha + b.alpha);
    }
    let d2 = (b.alpha - a.alpha).signum() * disc.sqrt();
    let t = b.alpha - (b.alpha - a.alpha) * (b.slope + d2 - d1) / (b.slope - a.slope + 2.0 * d2);
    if t.is_finite() {
        t
    } else {
        0.5 * (a.alpha + b.alpha)
    }
}

/// Minimise `f` from `x0` by BFGS (inverse-Hessian update, scaled identity start).
pub fn bfgs<O: Objective>(f: &mut O, x0: &[f64], opts: &BfgsOptions) -> Minimum {
    let clock = Instant::now();
    let n = x0.len();
    let mut f = Counted { f, evaluations: 0 };
    let mut x = x0.to_vec();
    let mut g = vec![0.0; n];
    f.evaluations += 1;
    let mut fx = f.f.value_grad(&x, &mut g);
    // Inverse Hessian, row-major; `None` until the first step sets its scale.
    let mut h: Option<Vec<f64>> = None;
    let mut iterations = 0;
    let mut small = 0;
    let mut resets = 0;
    let stop = loop {
        let gmax = g.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        if !fx.is_finite() || gmax == 0.0 || gmax <= opts.gtol {
            break StopReason::Converged;
        }
        if iterations >= opts.max_iterations {
            break StopReason::MaxIterations;
        }
        if f.evaluations >= opts.max_evaluations {
            break StopReason::MaxEvaluations;
        }
        iterations += 1;
        let (p, alpha0) = match &h {
            Some(h) => (
                (0..n)
                    .map(|i| -dot(&h[i * n..(i + 1) * n], &g))
                    .collect::<Vec<f64>>(),
                1.0,
            ),
            None => (g.iter().map(|v| -v).collect(), opts.initial_step / gmax),
        };
        let d0 = dot(&p, &g);
        if !(d0 < 0.0) {
            // Not a descent direction (rounding in H): restart from steepest descent.
            h = None;
            resets += 1;
            if resets > 3 {
                break StopReason::NoProgress;
            }
            continue;
        }
        let Some(pt) = line_search(&mut f, &x, fx, d0, &p, alpha0, opts) else {
            if h.is_some() && resets < 3 {
                h = None;
                resets += 1;
                continue;
            }
            break StopReason::NoProgress;
        };
        let s: Vec<f64> = pt.x.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = pt.g.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-300 {
            let hm = h.get_or_insert_with(|| {
                let scale = sy / dot(&y, &y);
                let mut m = vec![0.0; n * n];
                for i in 0..n {
                    m[i * n + i] = scale;
                }
                m
            });
            // H <- (I - ρ s yᵀ) H (I - ρ y sᵀ) + ρ s sᵀ, expanded.
            let rho = 1.0 / sy;
            let hy: Vec<f64> = (0..n).map(|i| dot(&hm[i * n..(i + 1) * n], &y)).collect();
            let yhy = dot(&y, &hy);
            for i in 0..n {
                for j in 0..n {
                    hm[i * n + j] += rho * ((1.0 + rho * yhy) * s[i] * s[j] - hy[i] * s[j] - s[i] * hy[j]);
                }
            }
        }
        let decrease = fx - pt.f;
        if decrease <= opts.ftol * fx.abs() {
            small += 1;
        } else {
            small = 0;
        }
        x = pt.x;
        g = pt.g;
        fx = pt.f;
        if small >= 3 {
            break StopReason::Converged;
        }
    };
    Minimum {
        x,
        value: fx,
        report: SolveReport {
            iterations,
            evaluations: f.evaluations,
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::objective::testing::Rosenbrock;

    #[test]
    fn finds_the_rosenbrock_minimum_superlinearly() {
        for n in [2, 10] {
            let mut f = Rosenbrock::new(n);
            let m = bfgs(&mut f, &vec![-1.2; n], &BfgsOptions::default());
            assert!(m.value < 1e-20, "n={n}: {}", m.value);
            assert!(m.x.iter().all(|v| (v - 1.0).abs() < 1e-9));
            assert_eq!(f.evaluations, m.report.evaluations, "every evaluation counted");
            assert!(
                m.report.iterations < 200,
                "n={n}: {} iterations",
                m.report.iterations
            );
        }
    }

    #[test]
    fn a_quadratic_takes_about_n_steps() {
        struct Quad;
        impl Objective for Quad {
            fn dim(&self) -> usize {
                5
            }
            fn value(&mut self, x: &[f64]) -> f64 {
                x.iter()
                    .enumerate()
                    .map(|(i, v)| (i + 1) as f64 * (v - 1.0).powi(2))
                    .sum()
            }
            fn value_grad(&mut self, x: &[f64], g: &mut [f64]) -> f64 {
                for (i, v) in x.iter().enumerate() {
                    g[i] = 2.0 * (i + 1) as f64 * (v - 1.0);
                }
                self.value(x)
            }
        }
        let m = bfgs(&mut Quad, &[0.0; 5], &BfgsOptions::default());
        assert!(m.value < 1e-20, "{}", m.value);
        assert!(m.report.iterations <= 20, "{}", m.report.iterations);
    }
}
