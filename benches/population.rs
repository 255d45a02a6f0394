//! Criterion benchmark of population evaluation (`cargo bench --bench population`): a 2 x 2
//! bicubic grid, 4096 points, 1024 individuals, newton 0 and 2, on every CPU kernel set and
//! the GPU; and the quadratic-form shortcut measured against it: at fixed parameters each
//! individual's sum of squares is a quadratic form of its design.
//!
//! **The quadratic form.** With the points' design-basis matrix `B` (N × n design points, the
//! basis weights pushed through the extraction map), the reference `x0` and `r0 = B x0 - q`,
//! an individual `x = x0 + Δ` has `Σ|B x - q|² = Σ|r0|² + 2 Σ_c gᵀΔ_c + Σ_c Δ_cᵀ G Δ_c` with
//! `g = Bᵀ r0` and the Gram matrix `G = Bᵀ B`: 3 n² multiply-adds an individual instead of
//! about 51 N, whatever N. `G` changes whenever the parameters do (every generation of a
//! population method: N n² / 2 multiply-adds), and the form gives no largest offset and no
//! Newton steps. The group times building `G` and the sums of a population, and checks them
//! against the evaluator.

use bezchain::bench::population::{problem, BenchOptions};
use bezchain::bezier::bernstein;
use bezchain::eval::{
    build_evaluator, Backend, CpuEvaluator, EvalLayout, EvalOptions, Fitness, PopulationEvaluator, Simd,
};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn population(c: &mut Criterion) {
    let mut group = c.benchmark_group("population");
    group.sample_size(10);
    for newton in [0, 2] {
        let options = BenchOptions {
            newton,
            ..BenchOptions::default()
        };
        let bench = problem(&options).expect("the benchmark problem builds");
        let evals = (options.population * options.points) as u64;
        group.throughput(Throughput::Elements(evals));
        let mut evaluators: Vec<(String, Box<dyn PopulationEvaluator>)> = Simd::available()
            .into_iter()
            .map(|simd| {
                let ev = CpuEvaluator::with_simd(&bench.layout, &bench.targets, newton, simd)
                    .expect("the CPU evaluator builds");
                (format!("cpu-{simd:?}").to_lowercase(), Box::new(ev) as _)
            })
            .collect();
        let gpu = EvalOptions {
            backend: Backend::Gpu,
            newton,
            ..EvalOptions::default()
        };
        match build_evaluator(&bench.layout, &bench.targets, &gpu) {
            Ok(e) => evaluators.push(("gpu".into(), e)),
            Err(e) => eprintln!("population/gpu: skipped ({e})"),
        }
        for (name, mut evaluator) in evaluators {
            evaluator
                .set_reference(&bench.reference)
                .expect("the reference fits");
            eprintln!("population/{name}: {}", evaluator.info());
            let mut out = vec![Fitness::default(); options.population];
            let id = format!("{name}/newton{newton}/{}x{}", options.population, options.points);
            group.bench_function(id, |b| {
                b.iter(|| {
                    evaluator
                        .evaluate(&bench.population, &mut out)
                        .expect("evaluation runs")
                })
            });
        }
    }
    group.finish();
}

/// `B`: row k holds point k's weight on every design point (n = design points), f64.
#[allow(clippy::needless_range_loop)] // the formula's indices
fn design_basis(layout: &bezchain::chain::GridLayout, params: &[glam::DVec2]) -> (Vec<f64>, usize) {
    let (nu, nv) = layout.design_shape();
    let n = nu * nv;
    let (du, dv) = (layout.u.degree(), layout.v.degree());
    let mut b = vec![0.0; params.len() * n];
    for (k, p) in params.iter().enumerate() {
        let (i, u) = layout.u.locate(p.x);
        let (j, v) = layout.v.locate(p.y);
        let mut bu = [0.0; 8];
        let mut bv = [0.0; 8];
        bernstein(du, u, &mut bu);
        bernstein(dv, v, &mut bv);
        for a in 0..=du {
            let (ru, wu) = layout.u.map().row(i * du + a);
            for bb in 0..=dv {
                let (rv, wv) = layout.v.map().row(j * dv + bb);
                for (&x, &wx) in ru.iter().zip(wu) {
                    for (&y, &wy) in rv.iter().zip(wv) {
                        b[k * n + x as usize * nv + y as usize] += bu[a] * bv[bb] * wx * wy;
                    }
                }
            }
        }
    }
    (b, n)
}

fn quadratic_form(c: &mut Criterion) {
    let options = BenchOptions::default();
    let bench = problem(&options).expect("the benchmark problem builds");
    let EvalLayout::Grid(layout) = &bench.layout else {
        unreachable!("the bench problem is a grid")
    };
    let (b, n) = design_basis(layout, bench.targets.params());
    let points = bench.targets.points();
    let x0 = &bench.reference;
    // The form's pieces, in f64 (once per generation of a population method).
    let build = || {
        let mut g = vec![0.0f64; n * n];
        let mut lin = vec![0.0f64; n * 3];
        let mut c0 = 0.0f64;
        for (k, q) in points.iter().enumerate() {
            let row = &b[k * n..(k + 1) * n];
            let mut r = [-q.x, -q.y, -q.z];
            for (d, &w) in row.iter().enumerate() {
                for (c, rc) in r.iter_mut().enumerate() {
                    *rc += w * x0[d * 3 + c];
                }
            }
            c0 += r.iter().map(|x| x * x).sum::<f64>();
            for (d, &w) in row.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                for c in 0..3 {
                    lin[d * 3 + c] += w * r[c];
                }
                for (e, &we) in row.iter().enumerate().skip(d) {
                    g[d * n + e] += w * we;
                }
            }
        }
        for d in 0..n {
            for e in 0..d {
                g[d * n + e] = g[e * n + d];
            }
        }
        (g, lin, c0)
    };
    let (g, lin, c0) = build();
    let g32: Vec<f32> = g.iter().map(|&x| x as f32).collect();
    let lin32: Vec<f32> = lin.iter().map(|&x| x as f32).collect();
    let rows = options.population;
    // Per individual, on every thread: Δ per coordinate, then 2 gᵀΔ_c + Δ_cᵀ G Δ_c.
    let sums = |out: &mut [f64]| {
        use rayon::prelude::*;
        out.par_iter_mut()
            .zip(bench.population.par_chunks_exact(n * 3))
            .for_each(|(s, row)| {
                let mut acc = 0.0f32;
                let mut dx = vec![0.0f32; n];
                for c in 0..3 {
                    for (d, x) in dx.iter_mut().enumerate() {
                        *x = (f64::from(row[d * 3 + c]) - x0[d * 3 + c]) as f32;
                    }
                    // y = G Δ_c as a sum of G's rows (vectorises over the row), then Δ_cᵀ y.
                    let mut y = vec![0.0f32; n];
                    for (&xd, grow) in dx.iter().zip(g32.chunks_exact(n)) {
                        for (yi, &gi) in y.iter_mut().zip(grow) {
                            *yi += xd * gi;
                        }
                    }
                    let quad: f32 = y.iter().zip(&dx).map(|(a, b)| a * b).sum();
                    let linear: f32 = (0..n).map(|d| lin32[d * 3 + c] * dx[d]).sum();
                    acc += 2.0 * linear + quad;
                }
                *s = c0 + f64::from(acc);
            });
    };
    // Agreement with the evaluator (fixed parameters, same reference).
    let mut ev = CpuEvaluator::new(&bench.layout, &bench.targets, 0).expect("the evaluator builds");
    ev.set_reference(x0).expect("the reference fits");
    let mut fit = vec![Fitness::default(); rows];
    ev.evaluate(&bench.population, &mut fit).expect("evaluates");
    let mut form = vec![0.0; rows];
    sums(&mut form);
    let worst = fit
        .iter()
        .zip(&form)
        .map(|(f, s)| (f64::from(f.sum_sq) - s).abs() / s)
        .fold(0.0, f64::max);
    eprintln!("quadratic form: sums within {worst:.1e} of the evaluator's");
    assert!(worst < 1e-4, "the form and the evaluator disagree by {worst:e}");
    let mut group = c.benchmark_group("quadratic_form");
    group.sample_size(10);
    group.bench_function(format!("gram_matrix/{}x{n}", options.points), |bch| {
        bch.iter(build)
    });
    group.throughput(Throughput::Elements((rows * options.points) as u64));
    group.bench_function(format!("sums/{rows}x{}", options.points), |bch| {
        bch.iter(|| sums(&mut form))
    });
    group.finish();
}

criterion_group!(benches, population, quadratic_form);
criterion_main!(benches);
