//! `Backend::Auto` takes the CPU, and says why, when no adapter exists; forced here with
//! `BEZCHAIN_NO_GPU=1`, which this file (its own test binary, one test) sets for itself.

use bezchain::chain::{ChainLayout, Continuity, CurveChain, GridLayout, PatchGrid};
use bezchain::eval::dense::{dense_grid, uniform, DenseEvaluator};
use bezchain::eval::{build_evaluator, Backend, EvalLayout, EvalOptions, Fitness, GpuContext, Targets};
use bezchain::Error;
use glam::{DVec2, DVec3};

#[test]
fn auto_falls_back_to_the_cpu_and_says_why() {
    // Edition 2021: setting the variable is safe; this binary runs this one test only.
    std::env::set_var("BEZCHAIN_NO_GPU", "1");

    let ctx = GpuContext::shared();
    assert!(
        matches!(ctx, Err(Error::Gpu(ref m)) if m.contains("BEZCHAIN_NO_GPU")),
        "{ctx:?}"
    );

    let layout = EvalLayout::Curve(ChainLayout::uniform(3, 2, Continuity::C1).unwrap());
    let targets = Targets::curve(&[DVec2::new(0.5, 0.1), DVec2::new(1.5, -0.1)], &[0.25, 0.75]).unwrap();
    let auto = EvalOptions::default();
    let mut ev = build_evaluator(&layout, &targets, &auto).unwrap();
    let info = ev.info().clone();
    eprintln!("Auto without an adapter: {info}");
    assert_eq!(info.backend, Backend::Cpu);
    assert!(info
        .fallback
        .as_deref()
        .is_some_and(|w| w.contains("BEZCHAIN_NO_GPU")));
    assert!(info.to_string().contains("auto took the CPU"));

    // The fallback evaluates, as the f64 chain says.
    let design: Vec<f32> = (0..6).flat_map(|k| [k as f32 * 0.4, 0.0]).collect();
    let mut out = [Fitness::default()];
    ev.evaluate(&design, &mut out).unwrap();
    let EvalLayout::Curve(chain_layout) = &layout else {
        unreachable!()
    };
    let chain = CurveChain::new(
        chain_layout.clone(),
        design
            .chunks_exact(2)
            .map(|c| DVec2::new(c[0].into(), c[1].into()))
            .collect(),
    )
    .unwrap();
    let e: Vec<f64> = [(0.25, DVec2::new(0.5, 0.1)), (0.75, DVec2::new(1.5, -0.1))]
        .iter()
        .map(|&(t, q)| (chain.eval(t) - q).length_squared())
        .collect();
    assert!(
        (f64::from(out[0].sum_sq) - (e[0] + e[1])).abs() < 1e-6,
        "{out:?} vs {e:?}"
    );
    assert!((f64::from(out[0].max) - e[0].max(e[1]).sqrt()).abs() < 1e-6);

    let gpu = EvalOptions {
        backend: Backend::Gpu,
        ..EvalOptions::default()
    };
    assert!(matches!(
        build_evaluator(&layout, &targets, &gpu),
        Err(Error::Gpu(_))
    ));

    let g = GridLayout::new(
        ChainLayout::uniform(2, 1, Continuity::C1).unwrap(),
        ChainLayout::uniform(2, 1, Continuity::C1).unwrap(),
    );
    let net: Vec<DVec3> = (0..9)
        .map(|k| DVec3::new((k / 3) as f64, (k % 3) as f64, 0.0))
        .collect();
    let (_, dense_info) = dense_grid(
        &PatchGrid::new(g.clone(), net).unwrap(),
        &uniform(3),
        &uniform(3),
        Backend::Auto,
    )
    .unwrap();
    assert_eq!(dense_info.backend, Backend::Cpu);
    assert!(dense_info.fallback.is_some());
    assert!(DenseEvaluator::new(&g, &uniform(3), &uniform(3), Backend::Gpu).is_err());
}
