//! Dense sampling of patch grids (`shaders/dense_grid.wgsl` and its mirror) against the f64
//! grid, on every backend, near the origin and far from it, and CPU against GPU.

mod eval_support;

use bezchain::chain::{ChainLayout, Continuity, GridLayout, PatchGrid};
use bezchain::eval::dense::{dense_grid, uniform, DenseEvaluator, DensePoint};
use bezchain::eval::Backend;
use eval_support::gpu;
use glam::DVec3;

/// Positions within this fraction of the grid's extent of the f64 grid (f32 re-centred).
const POSITION_TOL: f64 = 2e-6;
/// Unit normals within this distance of the f64 normals.
const NORMAL_TOL: f64 = 1e-4;
/// CPU against GPU, as a fraction of the extent.
const PARITY_TOL: f64 = 1e-6;

/// A 3 × 2 bicubic grid of extent about 1 at `offset`; with `tip`, the last row collapses to a
/// point (the blade's closed tip).
fn grid(tip: bool, offset: DVec3) -> PatchGrid<DVec3> {
    let layout = GridLayout::new(
        ChainLayout::with_breaks(3, vec![0.0, 0.35, 0.7, 1.0], Continuity::C1).unwrap(),
        ChainLayout::uniform(3, 2, Continuity::C1).unwrap(),
    );
    let (nu, nv) = layout.design_shape();
    let design = (0..nu * nv)
        .map(|k| {
            let (i, j) = (k / nv, k % nv);
            let (x, y) = (i as f64 / (nu - 1) as f64, j as f64 / (nv - 1) as f64);
            let scale = if tip && i == nu - 1 { 0.0 } else { 1.0 };
            offset + DVec3::new(x, scale * y, scale * 0.2 * (4.0 * y).sin() + 0.1 * x * x)
        })
        .collect();
    PatchGrid::new(layout, design).unwrap()
}

fn backends() -> Vec<Backend> {
    let mut b = vec![Backend::Cpu];
    if gpu().is_some() {
        b.push(Backend::Gpu);
    }
    b
}

fn check(grid: &PatchGrid<DVec3>, points: &[DensePoint], us: &[f64], vs: &[f64], what: &str) {
    assert_eq!(points.len(), us.len() * vs.len());
    for (k, p) in points.iter().enumerate() {
        let (u, w) = (us[k / vs.len()], vs[k % vs.len()]);
        let (s, pu, pv) = grid.partials(u, w);
        assert!(
            (p.position - s).length() < POSITION_TOL,
            "{what} point {k}: {} vs {s}",
            p.position
        );
        let n = pu.cross(pv);
        match p.normal {
            Some(got) => assert!(
                (got - n.normalize()).length() < NORMAL_TOL,
                "{what} normal {k}: {got}"
            ),
            // Only where the f64 tangents are (nearly) parallel: the closed tip.
            None => assert!(n.length() < 1e-3, "{what} point {k} lost its normal {n}"),
        }
    }
}

#[test]
fn dense_grids_match_the_f64_surface_on_every_backend_wherever_they_sit() {
    let (us, vs) = (uniform(33), uniform(17));
    for offset in [DVec3::ZERO, DVec3::new(1000.0, 1000.0, 0.0)] {
        for tip in [false, true] {
            let g = grid(tip, offset);
            let mut first: Option<Vec<DensePoint>> = None;
            for backend in backends() {
                let (points, info) = dense_grid(&g, &us, &vs, backend).unwrap();
                eprintln!("dense grid (tip {tip}, at {offset}) on {info}");
                assert_eq!(info.backend, backend);
                check(&g, &points, &us, &vs, &format!("{backend} at {offset}"));
                match &first {
                    None => first = Some(points),
                    Some(f) => {
                        let d = f
                            .iter()
                            .zip(&points)
                            .map(|(a, b)| (a.position - b.position).length())
                            .fold(0.0, f64::max);
                        assert!(d <= PARITY_TOL, "cpu and {backend} differ by {d:e}");
                    }
                }
            }
        }
    }
}

#[test]
fn several_designs_come_back_in_order() {
    let (a, b) = (grid(false, DVec3::ZERO), grid(true, DVec3::ZERO));
    let flat =
        |g: &PatchGrid<DVec3>| -> Vec<f64> { g.design().iter().flat_map(|p| [p.x, p.y, p.z]).collect() };
    let designs: Vec<f64> = [flat(&a), flat(&b)].concat();
    // Break-aligned samples, as meshes take them.
    let us = [0.0, 0.2, 0.35, 0.5, 0.7, 1.0];
    let vs = [0.0, 0.25, 0.5, 0.75, 1.0];
    for backend in backends() {
        let mut ev = DenseEvaluator::new(a.layout(), &us, &vs, backend).unwrap();
        let points = ev.eval(&designs).unwrap();
        check(&a, &points[..30], &us, &vs, "first design");
        check(&b, &points[30..], &us, &vs, "second design");
        assert!(ev.eval(&designs[1..]).is_err());
    }
    assert!(DenseEvaluator::new(a.layout(), &[], &vs, Backend::Cpu).is_err());
}
