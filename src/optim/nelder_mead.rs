//! Nelder-Mead downhill simplex with dimension-adaptive coefficients (Gao and Han 2012) and
//! restarts, for any [`Objective`].

use super::report::{SolveReport, StopReason};
use crate::problem::Objective;
use std::time::Instant;

/// Options of the Nelder-Mead minimiser.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NelderMeadOptions {
    /// Edge of the initial simplex along every coordinate, in the variables' units (model
    /// units for design points). Default 0.05, which suits unit-chord aerofoils.
    pub initial_step: f64,
    /// Most objective evaluations. Default 200 000.
    pub max_evaluations: usize,
    /// Most simplex transformations. Default 1 000 000.
    pub max_iterations: usize,
    /// A simplex has converged when the spread of its values is at most `ftol` times the
    /// best value and its diameter at most `xtol`. Default 1e-10.
    pub ftol: f64,
    /// Simplex diameter (largest coordinate difference from the best vertex) at convergence,
    /// in the variables' units. Default 1e-9.
    pub xtol: f64,
    /// Restarts from the best vertex with a fresh simplex after convergence; restarting stops
    /// early once a restart improves the best value by less than `ftol` times it. Default 30.
    pub restarts: usize,
    /// Use the dimension-adaptive coefficients of Gao and Han instead of the classic
    /// (1, 2, 1/2, 1/2). Default true.
    pub adaptive: bool,
}

impl Default for NelderMeadOptions {
    fn default() -> Self {
        NelderMeadOptions {
            initial_step: 0.05,
            max_evaluations: 200_000,
            max_iterations: 1_000_000,
            ftol: 1e-10,
            xtol: 1e-9,
            restarts: 30,
            adaptive: true,
        }
    }
}

/// The best point a minimiser found.
#[derive(Clone, Debug, PartialEq)]
pub struct Minimum {
    /// The point.
    pub x: Vec<f64>,
    /// The objective there.
    pub value: f64,
    /// Iterations, evaluations, time, stop reason.
    pub report: SolveReport,
}

/// Minimise `f` from `x0` by Nelder-Mead.
pub fn nelder_mead<O: Objective>(f: &mut O, x0: &[f64], opts: &NelderMeadOptions) -> Minimum {
    let clock = Instant::now();
    let n = x0.len();
    let nf = n.max(1) as f64;
    let (alpha, gamma, rho, sigma) = if opts.adaptive && n > 2 {
        (1.0, 1.0 + 2.0 / nf, 0.75 - 1.0 / (2.0 * nf), 1.0 - 1.0 / nf)
    } else {
        (1.0, 2.0, 0.5, 0.5)
    };
    let mut evaluations = 0;
    let mut iterations = 0;
    let mut eval = |x: &[f64], evaluations: &mut usize| {
        *evaluations += 1;
        let v = f.value(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let mut best_x = x0.to_vec();
    let mut best_f = eval(x0, &mut evaluations);
    let mut step = opts.initial_step;
    let mut stop = StopReason::Converged;
    'restarts: for restart in 0..=opts.restarts {
        let start_f = best_f;
        // Simplex: the best point and one vertex along each coordinate.
        let mut simplex: Vec<Vec<f64>> = vec![best_x.clone()];
        let mut values = vec![best_f];
        for i in 0..n {
            let mut v = best_x.clone();
            v[i] += step;
            values.push(eval(&v, &mut evaluations));
            simplex.push(v);
        }
        let mut order: Vec<usize> = (0..=n).collect();
        loop {
            order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
            let (b, w, sw) = (order[0], order[n], order[n.saturating_sub(1)]);
            let spread = values[w] - values[b];
            let diameter = simplex
                .iter()
                .flat_map(|v| v.iter().zip(&simplex[b]).map(|(x, y)| (x - y).abs()))
                .fold(0.0, f64::max);
            if spread <= opts.ftol * values[b].abs() && diameter <= opts.xtol.max(opts.ftol * step) {
                break;
            }
            if diameter == 0.0 {
                break;
            }
            if evaluations >= opts.max_evaluations {
                stop = StopReason::MaxEvaluations;
                keep_best(&simplex, &values, b, &mut best_x, &mut best_f);
                break 'restarts;
            }
            if iterations >= opts.max_iterations {
                stop = StopReason::MaxIterations;
                keep_best(&simplex, &values, b, &mut best_x, &mut best_f);
                break 'restarts;
            }
            iterations += 1;
            let mut centroid = vec![0.0; n];
            for &i in &order[..n] {
                for (c, x) in centroid.iter_mut().zip(&simplex[i]) {
                    *c += x / nf;
                }
            }
            let along = |t: f64| -> Vec<f64> {
                centroid
                    .iter()
                    .zip(&simplex[w])
                    .map(|(c, x)| c + t * (c - x))
                    .collect()
            };
            let xr = along(alpha);
            let fr = eval(&xr, &mut evaluations);
            if fr < values[b] {
                let xe = along(alpha * gamma);
                let fe = eval(&xe, &mut evaluations);
                if fe < fr {
                    simplex[w] = xe;
                    values[w] = fe;
                } else {
                    simplex[w] = xr;
                    values[w] = fr;
                }
            } else if fr < values[sw] {
                simplex[w] = xr;
                values[w] = fr;
            } else {
                let (xc, fc) = if fr < values[w] {
                    let xc = along(alpha * rho);
                    let fc = eval(&xc, &mut evaluations);
                    (xc, fc)
                } else {
                    let xc = along(-rho);
                    let fc = eval(&xc, &mut evaluations);
                    (xc, fc)
                };
                if fc < values[w].min(fr) {
                    simplex[w] = xc;
                    values[w] = fc;
                } else {
                    // Shrink towards the best vertex.
                    let xb = simplex[b].clone();
                    for &i in &order[1..] {
                        for (x, y) in simplex[i].iter_mut().zip(&xb) {
                            *x = y + sigma * (*x - y);
                        }
                        values[i] = eval(&simplex[i], &mut evaluations);
                    }
                }
            }
        }
        let b = (0..=n)
            .min_by(|&a, &c| values[a].total_cmp(&values[c]))
            .unwrap_or(0);
        let diameter = simplex
            .iter()
            .flat_map(|v| v.iter().zip(&simplex[b]).map(|(x, y)| (x - y).abs()))
            .fold(0.0, f64::max);
        keep_best(&simplex, &values, b, &mut best_x, &mut best_f);
        // The next simplex is ten times the size of the collapsed one (never larger than the
        // first): big enough to escape a premature collapse, small enough to keep the progress.
        step = (10.0 * diameter).clamp(opts.xtol.max(f64::MIN_POSITIVE), opts.initial_step);
        if restart > 0 && start_f - best_f <= opts.ftol * best_f.abs() {
            break;
        }
    }
    Minimum {
        x: best_x,
        value: best_f,
        report: SolveReport {
            iterations,
            evaluations,
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
    }
}

fn keep_best(simplex: &[Vec<f64>], values: &[f64], b: usize, best_x: &mut Vec<f64>, best_f: &mut f64) {
    if values[b] <= *best_f {
        *best_f = values[b];
        best_x.clone_from(&simplex[b]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::objective::testing::Rosenbrock;

    #[test]
    fn finds_the_rosenbrock_minimum() {
        for n in [2, 4] {
            let x0 = vec![-1.2; n];
            let m = nelder_mead(
                &mut Rosenbrock::new(n),
                &x0,
                &NelderMeadOptions {
                    initial_step: 0.5,
                    ftol: 1e-14,
                    xtol: 1e-10,
                    ..Default::default()
                },
            );
            assert!(m.value < 1e-12, "n={n}: f = {}", m.value);
            assert!(m.x.iter().all(|v| (v - 1.0).abs() < 1e-5), "n={n}: {:?}", m.x);
            assert!(m.report.evaluations > m.report.iterations);
        }
    }

    #[test]
    fn counts_every_evaluation() {
        struct Count(usize);
        impl Objective for Count {
            fn dim(&self) -> usize {
                3
            }
            fn value(&mut self, x: &[f64]) -> f64 {
                self.0 += 1;
                x.iter().map(|v| (v - 0.5) * (v - 0.5)).sum()
            }
            fn value_grad(&mut self, x: &[f64], _: &mut [f64]) -> f64 {
                self.value(x)
            }
        }
        let mut f = Count(0);
        let m = nelder_mead(&mut f, &[0.0; 3], &NelderMeadOptions::default());
        assert_eq!(f.0, m.report.evaluations);
        assert!(m.value < 1e-12);
        let capped = nelder_mead(
            &mut Count(0),
            &[0.0; 3],
            &NelderMeadOptions {
                max_evaluations: 20,
                ..Default::default()
            },
        );
        assert_eq!(capped.report.stop, StopReason::MaxEvaluations);
        assert!(
            capped.report.evaluations <= 20 + 3 + 2,
            "one shrink at most past the limit"
        );
    }
}
