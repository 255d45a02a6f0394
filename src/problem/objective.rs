//! What a general-purpose minimiser sees of a problem: [`Objective`], a scalar function of a
//! flat vector with its gradient.

/// A scalar function of a flat vector, with its gradient: what Nelder-Mead and BFGS minimise.
///
/// Methods take `&mut self` so that an objective may keep caches between calls (the fitting
/// problem keeps the last foot points as warm starts).
pub trait Objective {
    /// Number of variables.
    fn dim(&self) -> usize;

    /// The value at `x`.
    fn value(&mut self, x: &[f64]) -> f64;

    /// The value at `x`, with the gradient written to `grad` (`dim()` long).
    fn value_grad(&mut self, x: &[f64], grad: &mut [f64]) -> f64;
}

/// Test objectives and checks shared by the solvers' and the problems' tests.
#[cfg(test)]
pub(crate) mod testing {
    use super::Objective;

    /// The Rosenbrock function in `dim` dimensions, minimum 0 at `(1, …, 1)`; it counts its
    /// evaluations.
    pub(crate) struct Rosenbrock {
        pub dim: usize,
        pub evaluations: usize,
    }

    impl Rosenbrock {
        pub(crate) fn new(dim: usize) -> Self {
            Rosenbrock { dim, evaluations: 0 }
        }
    }

    impl Objective for Rosenbrock {
        fn dim(&self) -> usize {
            self.dim
        }
        fn value(&mut self, x: &[f64]) -> f64 {
            self.evaluations += 1;
            x.windows(2)
                .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
                .sum()
        }
        fn value_grad(&mut self, x: &[f64], g: &mut [f64]) -> f64 {
            g.fill(0.0);
            for i in 0..x.len() - 1 {
                let a = x[i + 1] - x[i] * x[i];
                g[i] += -400.0 * x[i] * a - 2.0 * (1.0 - x[i]);
                g[i + 1] += 200.0 * a;
            }
            self.value(x)
        }
    }

    /// Assert that `f`'s gradient at `x` matches central differences (step 1e-6) within
    /// `1e-7 (1 + |fd|)` per variable.
    pub(crate) fn assert_gradient_matches(f: &mut impl Objective, x: &[f64], label: &str) {
        let mut g = vec![0.0; x.len()];
        let v = f.value_grad(x, &mut g);
        assert!(
            (v - f.value(x)).abs() < 1e-15 * v.max(1.0),
            "{label}: value_grad's value"
        );
        let h = 1e-6;
        for i in 0..x.len() {
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[i] += h;
            xm[i] -= h;
            let fd = (f.value(&xp) - f.value(&xm)) / (2.0 * h);
            assert!(
                (g[i] - fd).abs() < 1e-7 * (1.0 + fd.abs()),
                "{label} var {i}: {} vs {fd}",
                g[i]
            );
        }
    }
}
