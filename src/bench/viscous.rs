//! The viscous benchmark behind `bezchain bench --kernel viscous`: a population of shapes around
//! NACA 4412 (smooth random thickness and camber changes of up to ±0.2 % of the chord), each
//! paneled, factored and analysed at α −2…8° at Re 1e6 as a population is
//! ([`polars_around`]): NACA 4412's own polar first, by continuation, then every shape's points
//! started from it at the same angle; timed whole.

use crate::aero::contour::Paneling;
use crate::aero::viscous::{polars_around, Viscous, ViscousOptions};
use crate::aero::Analysis;
use crate::error::Result;
use crate::geometry::{Naca, NacaOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::time::Instant;

/// What to benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct ViscousBenchOptions {
    /// Shapes. Default 256.
    pub population: usize,
    /// Panel nodes per shape. Default 160 (XFOIL's).
    pub nodes: usize,
    /// Chord Reynolds number. Default 1e6.
    pub re: f64,
    /// Seed of the population. Default 1.
    pub seed: u64,
}

impl Default for ViscousBenchOptions {
    fn default() -> Self {
        ViscousBenchOptions {
            population: 256,
            nodes: crate::aero::DEFAULT_NODES,
            re: 1e6,
            seed: 1,
        }
    }
}

/// The benchmark's figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViscousBenchReport {
    /// Always `viscous`.
    pub kernel: String,
    /// Rayon threads.
    pub threads: usize,
    /// Shapes.
    pub population: usize,
    /// Angles per shape (−2…8° by 1°).
    pub angles: usize,
    /// Panel nodes per shape.
    pub nodes: usize,
    /// Chord Reynolds number.
    pub re: f64,
    /// Seconds for the whole population: paneling, factoring, the centre's polar and every
    /// angle's Newton solve.
    pub seconds: f64,
    /// Of which paneling and factoring the shapes.
    pub setup_seconds: f64,
    /// Points that converged.
    pub converged: usize,
    /// Points asked for.
    pub points: usize,
    /// `converged / seconds`.
    pub points_per_second: f64,
    /// Mean Newton iterations per converged point.
    pub mean_iterations: f64,
    /// Mean CD of the converged points (a check that the runs compute what they should).
    pub mean_cd: f64,
}

/// The angles of the benchmark, degrees.
pub const ANGLES: [f64; 11] = [-2.0, -1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];

/// The population's centre: NACA 4412 at 161 points.
fn centre() -> Result<Vec<glam::DVec2>> {
    Naca::parse("4412")?.contour(&NacaOptions {
        points: 161,
        ..NacaOptions::default()
    })
}

/// The population's coordinates: NACA 4412 at 161 points, `y` changed by
/// `Σₖ aₖ sin(kπx) + x bₖ sin(kπx)` (k = 1…3), the coefficients uniform in ±0.002/3.
pub fn shapes(population: usize, seed: u64) -> Result<Vec<Vec<glam::DVec2>>> {
    let base = centre()?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let amp = 0.002 / 3.0;
    Ok((0..population)
        .map(|_| {
            let c: Vec<(f64, f64)> = (0..3)
                .map(|_| {
                    (
                        amp * rng.random_range(-1.0..1.0),
                        amp * rng.random_range(-1.0..1.0),
                    )
                })
                .collect();
            let half = base.len() / 2;
            base.iter()
                .enumerate()
                .map(|(i, p)| {
                    let side = if i <= half { 1.0 } else { -1.0 };
                    let mut dy = 0.0;
                    for (k, (a, b)) in c.iter().enumerate() {
                        let s = ((k + 1) as f64 * std::f64::consts::PI * p.x).sin();
                        dy += side * a * s + b * s;
                    }
                    glam::DVec2::new(p.x, p.y + dy)
                })
                .collect()
        })
        .collect())
}

/// Run the benchmark.
pub fn run(options: &ViscousBenchOptions) -> Result<ViscousBenchReport> {
    super::check_population(options.population, 1 << 16)?;
    let opts = ViscousOptions {
        re: options.re,
        ..ViscousOptions::default()
    };
    opts.check()?;
    let pts = shapes(options.population, options.seed)?;
    let clock = Instant::now();
    let paneling = Paneling::with_nodes(options.nodes);
    let body = |p: &[glam::DVec2]| Viscous::new(Analysis::of_points(p, &paneling)?.solution.nodes());
    let centre = body(&centre()?)?;
    let bodies = {
        use rayon::prelude::*;
        pts.par_iter()
            .map(|p| body(p))
            .collect::<Result<Vec<Viscous>>>()?
    };
    let setup_seconds = clock.elapsed().as_secs_f64();
    let (_, out) = polars_around(&centre, &bodies, &ANGLES, &opts);
    let seconds = clock.elapsed().as_secs_f64();
    let conv: Vec<_> = out.iter().flatten().filter(|p| p.converged).collect();
    let n = conv.len().max(1) as f64;
    Ok(ViscousBenchReport {
        kernel: "viscous".into(),
        threads: rayon::current_num_threads(),
        population: options.population,
        angles: ANGLES.len(),
        nodes: options.nodes,
        re: options.re,
        seconds,
        setup_seconds,
        converged: conv.len(),
        points: options.population * ANGLES.len(),
        points_per_second: conv.len() as f64 / seconds,
        mean_iterations: conv.iter().map(|p| p.iterations as f64).sum::<f64>() / n,
        mean_cd: conv.iter().filter_map(|p| p.cd).sum::<f64>() / n,
    })
}
