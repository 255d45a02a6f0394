//! Surface-fitting scale: fit time of a noisy, shuffled (unordered) cloud of the paper's blade
//! against its size, 10k, 100k and 1M points, bicubic 8 x 11 patches ending at the stations.
//! Run with `cargo bench --bench surface`.
//!
//! Every size takes the same two stages (a subsample of about 5,000 points fitted to
//! convergence, then joint iterations on the whole cloud), so the subsample stage costs about
//! the same at every size and the rest (initial parameters, whole-cloud iterations, final
//! closest points) grows with the cloud. Criterion times the whole fit; after each size the
//! bench prints the median seconds of the two parts over the same runs.

use bezchain::chain::Continuity;
use bezchain::fit::{fit_surface, Breaks, SurfaceLayout, SurfaceOptions};
use bezchain::geometry::{Blade, LoftOptions};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::DVec3;
use std::path::Path;
use std::time::Duration;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn scale(c: &mut Criterion) {
    let blade = Blade::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("data/blade_paper.json"))
        .expect("data/blade_paper.json");
    let layout = SurfaceLayout {
        breaks_v: Breaks::Span(blade.stations.iter().map(|s| s.radius).collect()),
        ..SurfaceLayout::uniform([3, 3], [8, 11], [Continuity::C1, Continuity::C1])
    };
    let opts = SurfaceOptions {
        subsample: 5000,
        ..SurfaceOptions::default()
    };
    let mut group = c.benchmark_group("fit_surface");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(500));
    for (per_section, sections) in [(100, 100), (250, 400), (1000, 1000)] {
        let n = per_section * sections;
        let cloud: Vec<DVec3> = blade
            .loft(&LoftOptions {
                points_per_section: Some(per_section),
                sections: Some(sections),
                noise: 1e-4,
                shuffle: true,
                seed: 3,
            })
            .expect("loft")
            .points;
        let (mut first, mut rest) = (Vec::new(), Vec::new());
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &cloud, |b, cloud| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let fit = fit_surface(cloud, None, &layout, &opts, &mut |_| {}).expect("fit");
                    let sub = fit.stages.first().map_or(0.0, |s| s.report.seconds);
                    first.push(sub);
                    rest.push(fit.report.seconds - sub);
                    total += Duration::from_secs_f64(fit.report.seconds);
                }
                total
            })
        });
        eprintln!(
            "fit_surface/{n}: median over {} fits: subsample stage {:.3} s, whole-cloud part {:.3} s ({:.1} ns/point)",
            first.len(),
            median(first.clone()),
            median(rest.clone()),
            1e9 * median(rest) / n as f64
        );
    }
    group.finish();
}

criterion_group!(benches, scale);
criterion_main!(benches);
