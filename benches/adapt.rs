//! Adaptive-search benchmarks: `bezchain adapt` on a 400-point NACA 4412 (the issue's
//! 100 ms case) and on the paper's 82-point NACA 4413, at 1e-3 and 1e-4 of the chord.
//! Run with `cargo bench --bench adapt`.

use bezchain::adaptive::{adapt_curve, AdaptOptions};
use bezchain::geometry::{Naca, NacaOptions};
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use glam::DVec2;

fn naca(code: &str, points: usize) -> Vec<DVec2> {
    Naca::parse(code)
        .and_then(|n| {
            n.contour(&NacaOptions {
                points,
                ..NacaOptions::default()
            })
        })
        .expect("NACA contour")
}

fn adapt(c: &mut Criterion) {
    let mut group = c.benchmark_group("adapt");
    group.sample_size(20);
    for (name, pts) in [
        ("naca4412_400", naca("4412", 400)),
        ("naca4413_82", naca("4413", 82)),
    ] {
        for tol in [1e-3, 1e-4] {
            let opts = AdaptOptions {
                tol,
                ..AdaptOptions::default()
            };
            group.bench_with_input(BenchmarkId::new(name, format!("{tol:e}")), &pts, |b, pts| {
                b.iter(|| adapt_curve(black_box(pts), &opts).expect("adapt"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, adapt);
criterion_main!(benches);
