//! Fitting benchmarks: the paper's three NACA 4413 cases by least squares (the `bezchain fit`
//! default), one least-squares start alone, BFGS on case 1, and the plain alternation the
//! joint method replaces. Run with `cargo bench --bench fit`.

use bezchain::chain::{ChainLayout, Continuity};
use bezchain::fit::{fit_curve, FitOptions, Method};
use bezchain::geometry::{Naca, NacaOptions};
use bezchain::optim::{lsq, LsqHooks, LsqMethod, LsqOptions, Start};
use bezchain::problem::{CurveProblem, Metric};
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use glam::DVec2;

fn naca4413() -> Vec<DVec2> {
    Naca::parse("4413")
        .and_then(|n| n.contour(&NacaOptions::default()))
        .expect("NACA 4413 contour")
}

/// (name, degree, segments) of the paper's cases.
const CASES: [(&str, usize, usize); 3] = [("case1_d3s5", 3, 5), ("case2_d4s3", 4, 3), ("case3_d5s3", 5, 3)];

fn paper_cases(c: &mut Criterion) {
    let pts = naca4413();
    let mut group = c.benchmark_group("fit_lsq");
    group.sample_size(30);
    for (name, d, s) in CASES {
        let layout = ChainLayout::uniform(d, s, Continuity::C1).expect("layout");
        group.bench_with_input(BenchmarkId::from_parameter(name), &layout, |b, layout| {
            b.iter(|| fit_curve(black_box(&pts), layout.clone(), &FitOptions::default()).expect("fit"))
        });
    }
    group.finish();
}

fn single_start_and_baselines(c: &mut Criterion) {
    let pts = naca4413();
    let layout = ChainLayout::uniform(3, 5, Continuity::C1).expect("layout");
    let problem = CurveProblem::curve(layout.clone(), &pts, Metric::Closest).expect("problem");
    let mut group = c.benchmark_group("fit_case1");
    group.sample_size(20);
    let start = [Start::Params(problem.params().to_vec())];
    group.bench_function("lsq_one_start", |b| {
        b.iter(|| {
            lsq(
                black_box(&problem),
                &start,
                &LsqOptions::default(),
                LsqHooks::default(),
            )
            .expect("lsq")
        })
    });
    let alternate = LsqOptions {
        method: LsqMethod::Alternate,
        max_iterations: 300,
        ..LsqOptions::default()
    };
    group.bench_function("alternation_300_rounds", |b| {
        b.iter(|| lsq(black_box(&problem), &start, &alternate, LsqHooks::default()).expect("alternate"))
    });
    group.sample_size(10);
    group.bench_function("bfgs", |b| {
        let opts = FitOptions {
            method: Method::Bfgs,
            ..FitOptions::default()
        };
        b.iter(|| fit_curve(black_box(&pts), layout.clone(), &opts).expect("fit"))
    });
    group.finish();
}

criterion_group!(benches, paper_cases, single_start_and_baselines);
criterion_main!(benches);
