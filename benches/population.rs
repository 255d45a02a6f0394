//! Criterion benchmark of population evaluation on both backends (`cargo bench --bench
//! population`): a 2 x 2 bicubic grid, 4096 points, 1024 individuals, newton 0 and 2.

use bezchain::eval::bench::{problem, BenchOptions};
use bezchain::eval::{build_evaluator, Backend, EvalOptions, Fitness};
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
        for backend in [Backend::Cpu, Backend::Gpu] {
            let eval_options = EvalOptions {
                backend,
                newton,
                ..EvalOptions::default()
            };
            let mut evaluator = match build_evaluator(&bench.layout, &bench.targets, &eval_options) {
                Ok(e) => e,
                Err(e) => {
                    eprintln!("population/{backend}: skipped ({e})");
                    continue;
                }
            };
            eprintln!("population/{backend}: {}", evaluator.info());
            let mut out = vec![Fitness::default(); options.population];
            let id = format!(
                "{backend}/newton{newton}/{}x{}",
                options.population, options.points
            );
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

criterion_group!(benches, population);
criterion_main!(benches);
