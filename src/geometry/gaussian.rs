//! Normal (Gaussian) draws: the crate's one sampler of them, for the blade loft's noise and the
//! optimisers' random steps. Each caller seeds its own stream; the sampler only shapes draws.

use rand::Rng;
use rand_distr::{Distribution, Normal, NormalError};

/// Draws of the normal distribution with mean 0 and standard deviation `sd` (rand_distr's
/// ziggurat: `sd · z`, `z` standard normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gaussian(Normal<f64>);

impl Gaussian {
    /// The sampler of standard deviation `sd`; an error when `sd` is not finite.
    pub fn new(sd: f64) -> Result<Self, NormalError> {
        Normal::new(0.0, sd).map(Gaussian)
    }

    /// The standard normal distribution (`sd` 1).
    #[must_use]
    pub fn standard() -> Self {
        Gaussian(Normal::new(0.0, 1.0).expect("1 is a finite standard deviation"))
    }

    /// One draw from `rng`.
    #[inline]
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        self.0.sample(rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// A scaled sampler draws the standard draws times its deviation, bit for bit, and a
    /// deviation that is not finite is refused.
    #[test]
    fn draws_are_the_standard_draws_scaled() {
        let (mut a, mut b) = (ChaCha8Rng::seed_from_u64(3), ChaCha8Rng::seed_from_u64(3));
        let g = Gaussian::new(0.25).unwrap();
        for _ in 0..1000 {
            let z: f64 = StandardNormal.sample(&mut b);
            assert_eq!(g.sample(&mut a).to_bits(), (0.25 * z).to_bits());
        }
        let s = Gaussian::standard();
        for _ in 0..1000 {
            let z: f64 = StandardNormal.sample(&mut b);
            assert_eq!(s.sample(&mut a).to_bits(), z.to_bits());
        }
        assert!(Gaussian::new(f64::NAN).is_err() && Gaussian::new(f64::INFINITY).is_err());
    }
}
