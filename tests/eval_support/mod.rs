//! Shared helpers of the eval tests: random problems with fixed seeds, the f64 truth, the GPU
//! context (skipped or required per `BEZCHAIN_REQUIRE_GPU`), and every backend at once.

#![allow(dead_code)]

use bezchain::chain::{ChainLayout, Continuity, CurveChain, GridLayout, PatchGrid};
use bezchain::closest::{chain_feet, grid_feet, FootOptions};
use bezchain::eval::{
    CpuEvaluator, EvalLayout, Fitness, GpuContext, GpuEvaluator, GpuOptions, PopulationEvaluator, Simd,
    Targets,
};
use glam::{DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The GPU context, or `None` (with a note) when there is no adapter. With
/// `BEZCHAIN_REQUIRE_GPU=1` a missing adapter fails the test instead.
pub fn gpu() -> Option<GpuContext> {
    match GpuContext::shared() {
        Ok(ctx) => {
            // Straight to the process's stderr, past the test harness's capture, once per test
            // binary: the CI log shows which adapter ran the shaders.
            static ONCE: std::sync::Once = std::sync::Once::new();
            ONCE.call_once(|| {
                use std::io::Write;
                let _ = writeln!(std::io::stderr(), "GPU tests run on adapter: {}", ctx.adapter());
            });
            Some(ctx)
        }
        Err(e) => {
            let required = std::env::var("BEZCHAIN_REQUIRE_GPU").is_ok_and(|v| v == "1");
            assert!(!required, "BEZCHAIN_REQUIRE_GPU=1 but no GPU: {e}");
            eprintln!("skipping the GPU half of this test: {e}");
            None
        }
    }
}

/// A layout, targets with start parameters, a population and the shape it was drawn around.
pub struct Case {
    pub layout: EvalLayout,
    pub targets: Targets,
    pub population: Vec<f32>,
    pub base: Vec<f64>,
}

impl Case {
    /// Individuals in the population.
    pub fn size(&self) -> usize {
        self.population.len() / self.layout.design_variables()
    }

    /// Individual `k` as f64 design variables (exactly the f32 values).
    pub fn individual(&self, k: usize) -> Vec<f64> {
        let n = self.layout.design_variables();
        self.population[k * n..(k + 1) * n]
            .iter()
            .map(|&x| f64::from(x))
            .collect()
    }
}

/// Breaks from random positive gaps.
fn breaks(rng: &mut ChaCha8Rng, segments: usize) -> Vec<f64> {
    let gaps: Vec<f64> = (0..segments).map(|_| rng.random_range(0.5..1.5)).collect();
    let total: f64 = gaps.iter().sum();
    let mut b = vec![0.0];
    let mut acc = 0.0;
    for g in &gaps[..segments - 1] {
        acc += g / total;
        b.push(acc);
    }
    b.push(1.0);
    b
}

/// A standard normal draw (Box-Muller; enough for test noise).
pub fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let (a, b): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random());
    (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
}

/// A random curve chain around a smooth loop, `points` targets near it at random parameters
/// (normal noise `noise`), and `size` individuals perturbed by `spread`.
#[allow(clippy::too_many_arguments)]
pub fn curve_case(
    seed: u64,
    degree: usize,
    segments: usize,
    continuity: Continuity,
    points: usize,
    size: usize,
    noise: f64,
    spread: f64,
) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let layout = ChainLayout::with_breaks(degree, breaks(&mut rng, segments), continuity).unwrap();
    let n = layout.design_count();
    let design: Vec<DVec2> = (0..n)
        .map(|k| {
            let a = 5.0 * k as f64 / (n - 1) as f64;
            DVec2::new(a.cos() * (1.0 + 0.1 * gauss(&mut rng)), 0.6 * a.sin())
        })
        .collect();
    let chain = CurveChain::new(layout.clone(), design.clone()).unwrap();
    let t: Vec<f64> = (0..points).map(|_| rng.random()).collect();
    let pts: Vec<DVec2> = t
        .iter()
        .map(|&t| chain.eval(t) + DVec2::new(gauss(&mut rng), gauss(&mut rng)) * noise)
        .collect();
    let base: Vec<f64> = design.iter().flat_map(|p| [p.x, p.y]).collect();
    let population = perturb(&mut rng, &base, size, spread);
    Case {
        layout: EvalLayout::Curve(layout),
        targets: Targets::curve(&pts, &t).unwrap(),
        population,
        base,
    }
}

/// A random patch grid (a wavy sheet), targets near it, and a perturbed population.
#[allow(clippy::too_many_arguments)]
pub fn grid_case(
    seed: u64,
    degrees: (usize, usize),
    patches: (usize, usize),
    continuity: Continuity,
    points: usize,
    size: usize,
    noise: f64,
    spread: f64,
) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let layout = GridLayout::new(
        ChainLayout::with_breaks(degrees.0, breaks(&mut rng, patches.0), continuity).unwrap(),
        ChainLayout::with_breaks(degrees.1, breaks(&mut rng, patches.1), continuity).unwrap(),
    );
    let (nu, nv) = layout.design_shape();
    let design: Vec<DVec3> = (0..nu * nv)
        .map(|k| {
            let (x, y) = (
                (k / nv) as f64 / (nu - 1) as f64,
                (k % nv) as f64 / (nv - 1) as f64,
            );
            DVec3::new(
                x,
                y,
                0.3 * (3.0 * x).sin() * (2.0 * y).cos() + 0.02 * gauss(&mut rng),
            )
        })
        .collect();
    let grid = PatchGrid::new(layout.clone(), design.clone()).unwrap();
    let uv: Vec<DVec2> = (0..points)
        .map(|_| DVec2::new(rng.random(), rng.random()))
        .collect();
    let pts: Vec<DVec3> = uv
        .iter()
        .map(|p| grid.eval(p.x, p.y) + DVec3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * noise)
        .collect();
    let base: Vec<f64> = design.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let population = perturb(&mut rng, &base, size, spread);
    Case {
        layout: EvalLayout::Grid(layout),
        targets: Targets::grid(&pts, &uv).unwrap(),
        population,
        base,
    }
}

fn perturb(rng: &mut ChaCha8Rng, base: &[f64], size: usize, spread: f64) -> Vec<f32> {
    (0..size)
        .flat_map(|_| {
            base.iter()
                .map(|&x| (x + spread * gauss(rng)) as f32)
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Re-target `case` at the f64 foot points of its points on the base shape (what the `eval`
/// door does with the first individual).
pub fn foot_points_on_base(case: &mut Case) {
    match &case.layout {
        EvalLayout::Curve(l) => {
            let chain = CurveChain::new(
                l.clone(),
                case.base
                    .chunks_exact(2)
                    .map(|c| DVec2::new(c[0], c[1]))
                    .collect(),
            )
            .unwrap();
            let pts: Vec<DVec2> = case.targets.points().iter().map(|p| p.truncate()).collect();
            let t: Vec<f64> = chain_feet(&chain, &pts, &samples(32))
                .iter()
                .map(|f| f.t[0])
                .collect();
            case.targets = Targets::curve(&pts, &t).unwrap();
        }
        EvalLayout::Grid(g) => {
            let grid = PatchGrid::new(
                g.clone(),
                case.base
                    .chunks_exact(3)
                    .map(|c| DVec3::new(c[0], c[1], c[2]))
                    .collect(),
            )
            .unwrap();
            let uv: Vec<DVec2> = grid_feet(&grid, case.targets.points(), &samples(12))
                .iter()
                .map(|f| DVec2::from_array(f.t))
                .collect();
            case.targets = Targets::grid(case.targets.points(), &uv).unwrap();
        }
    }
}

/// The f64 `(sum_sq, max)` of every individual with each point at its given parameters.
pub fn truth_fixed(case: &Case) -> Vec<(f64, f64)> {
    (0..case.size())
        .map(|k| {
            let d = case.individual(k);
            let offsets: Vec<f64> = match &case.layout {
                EvalLayout::Curve(l) => {
                    let chain = CurveChain::new(
                        l.clone(),
                        d.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])).collect(),
                    )
                    .unwrap();
                    case.targets
                        .points()
                        .iter()
                        .zip(case.targets.params())
                        .map(|(q, t)| (chain.eval(t.x) - q.truncate()).length_squared())
                        .collect()
                }
                EvalLayout::Grid(g) => {
                    let grid = PatchGrid::new(
                        g.clone(),
                        d.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect(),
                    )
                    .unwrap();
                    case.targets
                        .points()
                        .iter()
                        .zip(case.targets.params())
                        .map(|(q, t)| (grid.eval(t.x, t.y) - *q).length_squared())
                        .collect()
                }
            };
            summarise(&offsets)
        })
        .collect()
}

/// The f64 `(sum_sq, max)` of every individual with true closest-point offsets.
pub fn truth_closest(case: &Case) -> Vec<(f64, f64)> {
    (0..case.size())
        .map(|k| {
            let d = case.individual(k);
            let offsets: Vec<f64> = match &case.layout {
                EvalLayout::Curve(l) => {
                    let chain = CurveChain::new(
                        l.clone(),
                        d.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])).collect(),
                    )
                    .unwrap();
                    let pts: Vec<DVec2> = case.targets.points().iter().map(|p| p.truncate()).collect();
                    chain_feet(&chain, &pts, &samples(32))
                        .iter()
                        .map(|f| f.dist_sq)
                        .collect()
                }
                EvalLayout::Grid(g) => {
                    let grid = PatchGrid::new(
                        g.clone(),
                        d.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect(),
                    )
                    .unwrap();
                    grid_feet(&grid, case.targets.points(), &samples(12))
                        .iter()
                        .map(|f| f.dist_sq)
                        .collect()
                }
            };
            summarise(&offsets)
        })
        .collect()
}

fn summarise(offsets_sq: &[f64]) -> (f64, f64) {
    (
        offsets_sq.iter().sum(),
        offsets_sq.iter().fold(0.0f64, |m, &e| m.max(e)).sqrt(),
    )
}

/// Every backend on `case`: the CPU on its best kernels (`cpu`), on every other kernel set
/// this CPU runs (`cpu-avx2`, `cpu-portable`), and the GPU when `ctx` is given (`gpu`).
pub fn evaluators(
    case: &Case,
    newton: u32,
    cross: bool,
    ctx: Option<&GpuContext>,
    gpu: &GpuOptions,
) -> Vec<(String, Box<dyn PopulationEvaluator>)> {
    let best = Simd::detect();
    let mut out: Vec<(String, Box<dyn PopulationEvaluator>)> = Vec::new();
    for simd in Simd::available() {
        let name = if simd == best {
            "cpu".to_string()
        } else {
            format!("cpu-{}", format!("{simd:?}").to_lowercase())
        };
        let ev = CpuEvaluator::with_simd(&case.layout, &case.targets, newton, simd)
            .unwrap()
            .crossing(cross);
        out.push((name, Box::new(ev)));
    }
    if let Some(ctx) = ctx {
        out.push((
            "gpu".into(),
            Box::new(GpuEvaluator::new(ctx, &case.layout, &case.targets, newton, cross, gpu).unwrap()),
        ));
    }
    out
}

/// Evaluate the whole population of `case` on `evaluator`.
pub fn run(evaluator: &mut dyn PopulationEvaluator, population: &[f32]) -> Vec<Fitness> {
    let mut out = vec![Fitness::default(); population.len() / evaluator.design_variables()];
    evaluator.evaluate(population, &mut out).unwrap();
    out
}

/// |a - b| / max(|a|, |b|), 0 when both are 0.
pub fn rel(a: f64, b: f64) -> f64 {
    let scale = a.abs().max(b.abs());
    if scale == 0.0 {
        0.0
    } else {
        (a - b).abs() / scale
    }
}

/// The largest relative difference of `sum_sq` and of `max` against f64 values.
pub fn worst_against(got: &[Fitness], want: &[(f64, f64)]) -> (f64, f64) {
    assert_eq!(got.len(), want.len());
    got.iter().zip(want).fold((0.0f64, 0.0f64), |(s, m), (g, w)| {
        (s.max(rel(g.sum_sq.into(), w.0)), m.max(rel(g.max.into(), w.1)))
    })
}

/// The library's closest-point search with `n` samples per segment or patch side.
fn samples(n: usize) -> FootOptions {
    FootOptions {
        samples: n,
        ..FootOptions::default()
    }
}
