//! Dense sampling of patch grids (`shaders/dense_grid.wgsl` and its mirror) against the f64
//! grid, on every backend.

mod eval_support;

use bezchain::chain::{ChainLayout, Continuity, GridLayout, PatchGrid};
use bezchain::eval::dense::{dense_grid, DenseEvaluator};
use bezchain::eval::{Backend, Vertex};
use eval_support::gpu;
use glam::DVec3;

/// Positions within this distance of the f64 grid (model units; the grid spans ~1).
const POSITION_TOL: f64 = 2e-6;
/// Unit normals within this distance of the f64 normals.
const NORMAL_TOL: f64 = 1e-4;

fn grid(tip: bool) -> PatchGrid<DVec3> {
    let layout = GridLayout::new(
        ChainLayout::with_breaks(3, vec![0.0, 0.35, 0.7, 1.0], Continuity::C1).unwrap(),
        ChainLayout::uniform(3, 2, Continuity::C1).unwrap(),
    );
    let (nu, nv) = layout.design_shape();
    let design = (0..nu * nv)
        .map(|k| {
            let (i, j) = (k / nv, k % nv);
            let (x, y) = (i as f64 / (nu - 1) as f64, j as f64 / (nv - 1) as f64);
            // With `tip`, the last row collapses to a point (the blade's closed tip).
            let scale = if tip && i == nu - 1 { 0.0 } else { 1.0 };
            DVec3::new(x, scale * y, scale * 0.2 * (4.0 * y).sin() + 0.1 * x * x)
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

fn check(grid: &PatchGrid<DVec3>, vertices: &[Vertex], gu: usize, gv: usize, backend: Backend) {
    assert_eq!(vertices.len(), gu * gv);
    for (k, v) in vertices.iter().enumerate() {
        let (u, w) = (
            (k / gv) as f64 / (gu - 1) as f64,
            (k % gv) as f64 / (gv - 1) as f64,
        );
        let (p, pu, pv) = grid.partials(u, w);
        let got = DVec3::new(v.px.into(), v.py.into(), v.pz.into());
        assert!(
            (got - p).length() < POSITION_TOL,
            "{backend} vertex {k}: {got} vs {p}"
        );
        let n = pu.cross(pv);
        let gn = DVec3::new(v.nx.into(), v.ny.into(), v.nz.into());
        if n.length() > 1e-3 {
            assert!(
                (gn - n.normalize()).length() < NORMAL_TOL,
                "{backend} normal {k}: {gn}"
            );
        } else {
            // Degenerate (the closed tip): a zero or unit normal, never NaN.
            assert!(gn.is_finite() && (gn.length() < 1e-6 || (gn.length() - 1.0).abs() < 1e-5));
        }
    }
}

#[test]
fn dense_grids_match_the_f64_surface_on_every_backend() {
    for tip in [false, true] {
        let g = grid(tip);
        for backend in backends() {
            let (vertices, info) = dense_grid(&g, 33, 17, backend).unwrap();
            eprintln!("dense grid (tip {tip}) on {info}");
            assert_eq!(info.backend, backend);
            check(&g, &vertices, 33, 17, backend);
        }
    }
}

#[test]
fn several_designs_come_back_in_order() {
    let (a, b) = (grid(false), grid(true));
    let flat = |g: &PatchGrid<DVec3>| -> Vec<f32> {
        g.design()
            .iter()
            .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect()
    };
    let designs: Vec<f32> = [flat(&a), flat(&b)].concat();
    for backend in backends() {
        let mut ev = DenseEvaluator::new(a.layout(), 9, 5, backend).unwrap();
        let vertices = ev.eval(&designs).unwrap();
        check(&a, &vertices[..45], 9, 5, backend);
        check(&b, &vertices[45..], 9, 5, backend);
        assert!(ev.eval(&designs[1..]).is_err());
    }
    assert!(DenseEvaluator::new(a.layout(), 1, 5, Backend::Cpu).is_err());
    if let Some(ctx) = gpu() {
        let mut shared = DenseEvaluator::on_gpu(&ctx, a.layout(), 9, 5).unwrap();
        check(&a, &shared.eval(&flat(&a)).unwrap(), 9, 5, Backend::Gpu);
    }
}
