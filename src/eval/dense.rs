//! Dense evaluation of patch grids on a tensor grid of parameters, with normals, for meshes,
//! renders and `bezchain sample`: `shaders/expand.wgsl` then `shaders/dense_grid.wgsl`, or
//! their CPU mirrors.
//!
//! **Accuracy.** The designs arrive in f64; the evaluator subtracts the centre of their
//! bounding box (in f64) before rounding to f32 and adds it back to every position (in f64),
//! so positions are within about `4 · 2⁻²⁴ × extent` of the f64 surface wherever the grid sits
//! (`tests/eval_dense.rs` holds them to 2e-6 of a unit-sized grid; the paper's blade far from
//! the origin agrees as well). A normal is given where the tangents' cross product exceeds
//! [`NORMAL_FLOOR`] of their squared length: below that its f32 rounding noise could turn it.

use super::cpu::{dense_grid as mirror, expand, Lanes, Scratch, Unfused, LANES};
use super::gpu::{prepare, source, Expand, GpuContext};
use super::kernel::{Config, Problem, Sample, Vertex};
use super::{Backend, BackendInfo, EvalLayout, Targets};
use crate::chain::{ChainLayout, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use rayon::prelude::*;

/// Below this sine of the angle between the tangents (times their lengths) a point has no
/// normal of its own (a collapsed edge, a tip): `|∂S/∂u × ∂S/∂v| < NORMAL_FLOOR ·
/// max(|∂S/∂u|², |∂S/∂v|²)`.
pub const NORMAL_FLOOR: f64 = 1e-4;

/// A point of a dense grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensePoint {
    /// The surface point.
    pub position: DVec3,
    /// The unit normal, `∂S/∂u × ∂S/∂v` normalised; `None` where the tangents are (nearly)
    /// parallel or vanish (see [`NORMAL_FLOOR`]).
    pub normal: Option<DVec3>,
}

/// `n` parameters evenly spaced over `[0, 1]` (both ends included; `[0]` for one).
#[must_use]
pub fn uniform(n: usize) -> Vec<f64> {
    match n {
        0 => Vec::new(),
        1 => vec![0.0],
        _ => (0..n).map(|k| k as f64 / (n - 1) as f64).collect(),
    }
}

/// Where a [`DenseEvaluator`] runs.
#[derive(Debug)]
enum Engine {
    Cpu,
    Gpu(Box<DenseGpu>),
}

/// The GPU side: pipelines and the buffers that do not depend on the designs.
#[derive(Debug)]
struct DenseGpu {
    ctx: GpuContext,
    expand: Expand,
    dense: wgpu::ComputePipeline,
    config: wgpu::Buffer,
    samples: wgpu::Buffer,
}

/// Samples patch grids of one layout at fixed parameters, design after design.
#[derive(Debug)]
pub struct DenseEvaluator {
    problem: Problem,
    samples: Vec<Sample>,
    grid_u: usize,
    grid_v: usize,
    engine: Engine,
    info: BackendInfo,
}

/// The samples of one direction: each global parameter located in f64.
fn locate_all(chain: &ChainLayout, ts: &[f64], what: &str) -> Result<Vec<Sample>> {
    if ts.is_empty() {
        return Err(Error::invalid(format!(
            "a dense grid needs at least one {what} sample"
        )));
    }
    if let Some(t) = ts.iter().find(|t| !(0.0..=1.0).contains(*t)) {
        return Err(Error::invalid(format!(
            "dense-grid {what} parameter {t} lies outside [0, 1]"
        )));
    }
    Ok(ts
        .iter()
        .map(|&t| {
            let (index, local) = chain.locate(t);
            Sample {
                index: index as u32,
                t: local as f32,
            }
        })
        .collect())
}

impl DenseEvaluator {
    /// An evaluator of `layout` at every `(u, v)` of `us × vs` (global parameters in
    /// `[0, 1]`) on `backend`; Auto falls back to the CPU as
    /// [`build_evaluator`](super::build_evaluator) does.
    pub fn new(layout: &GridLayout, us: &[f64], vs: &[f64], backend: Backend) -> Result<Self> {
        let (grid_u, grid_v) = (us.len(), vs.len());
        if grid_u
            .checked_mul(grid_v)
            .is_none_or(|n| n > u32::MAX as usize / 2)
        {
            return Err(Error::invalid("dense grid too large"));
        }
        let mut samples = locate_all(&layout.u, us, "u")?;
        samples.extend(locate_all(&layout.v, vs, "v")?);
        // The problem carries the layout and its map; its single target is unused here.
        let targets = Targets::grid(&[DVec3::ZERO], &[DVec2::ZERO])?;
        let problem = Problem::new(&EvalLayout::Grid(layout.clone()), &targets, 0)?;
        let cpu = || BackendInfo {
            backend: Backend::Cpu,
            adapter: format!("CPU: {} rayon threads", rayon::current_num_threads()),
            fallback: None,
        };
        let gpu = |context: Result<GpuContext>| -> Result<(Engine, BackendInfo)> {
            let ctx = context?;
            let gpu = DenseGpu::new(&ctx, &problem, &samples)?;
            let info = ctx.backend_info();
            Ok((Engine::Gpu(Box::new(gpu)), info))
        };
        let (engine, info) = match backend {
            Backend::Cpu => (Engine::Cpu, cpu()),
            Backend::Gpu => gpu(GpuContext::shared())?,
            Backend::Auto => gpu(GpuContext::shared_hardware()).unwrap_or_else(|e| {
                let mut info = cpu();
                info.fallback = Some(e.to_string());
                (Engine::Cpu, info)
            }),
        };
        Ok(DenseEvaluator {
            problem,
            samples,
            grid_u,
            grid_v,
            engine,
            info,
        })
    }

    /// The backend and adapter.
    #[must_use]
    pub fn info(&self) -> &BackendInfo {
        &self.info
    }

    /// Design variables per design (x, y, z per design point, row-major design net).
    #[must_use]
    pub fn design_variables(&self) -> usize {
        self.problem.n_vars
    }

    /// Sample every design of `designs` (rows of [`design_variables`](Self::design_variables)
    /// finite values): point `(d * grid_u + iu) * grid_v + iv` is design `d` at `(us[iu],
    /// vs[iv])`.
    pub fn eval(&mut self, designs: &[f64]) -> Result<Vec<DensePoint>> {
        let n_vars = self.problem.n_vars;
        if designs.is_empty() || !designs.len().is_multiple_of(n_vars) {
            return Err(Error::invalid(format!(
                "{} values are not a whole, non-zero number of designs of {n_vars} variables",
                designs.len()
            )));
        }
        if designs.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid("designs to sample must be finite"));
        }
        // The reference point: the centre of the designs' box. The extraction map's rows are
        // affine (their weights sum to 1), so nets of `x - centre` are the nets less `centre`.
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in designs.chunks_exact(3) {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let centre = [0, 1, 2].map(|c| 0.5 * (lo[c] + hi[c]));
        let shifted: Vec<f32> = designs
            .chunks_exact(3)
            .flat_map(|p| [0, 1, 2].map(|c| (p[c] - centre[c]) as f32))
            .collect();
        let count = designs.len() / n_vars;
        let mut config = self.problem.config(count, LANES, (1, 1));
        config.grid_u = self.grid_u as u32;
        config.grid_v = self.grid_v as u32;
        let vertices = match &self.engine {
            Engine::Cpu => dense_cpu(&config, &self.problem, &self.samples, &shifted),
            Engine::Gpu(gpu) => {
                config.net_stride = count as u32;
                gpu.eval(&config, &self.problem, &shifted)?
            }
        };
        let c = DVec3::from(centre);
        Ok(vertices
            .iter()
            .map(|v| {
                let n = DVec3::new(v.nx.into(), v.ny.into(), v.nz.into());
                let floor = NORMAL_FLOOR * f64::from(v.tangent_sq);
                DensePoint {
                    position: c + DVec3::new(v.px.into(), v.py.into(), v.pz.into()),
                    normal: (n.length() > floor).then(|| n.try_normalize()).flatten(),
                }
            })
            .collect())
    }
}

/// Sample one patch grid at every `(u, v)` of `us × vs` (row-major, `us` along rows), and say
/// where it was computed.
pub fn dense_grid(
    grid: &PatchGrid<DVec3>,
    us: &[f64],
    vs: &[f64],
    backend: Backend,
) -> Result<(Vec<DensePoint>, BackendInfo)> {
    let mut evaluator = DenseEvaluator::new(grid.layout(), us, vs, backend)?;
    let design: Vec<f64> = grid.design().iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let points = evaluator.eval(&design)?;
    Ok((points, evaluator.info().clone()))
}

/// The CPU path: expand each block of designs, then every row of samples of every design in
/// parallel.
fn dense_cpu(config: &Config, problem: &Problem, samples: &[Sample], designs: &[f32]) -> Vec<Vertex> {
    let (gu, gv) = (config.grid_u as usize, config.grid_v as usize);
    let count = config.population as usize;
    let zero = vec![0.0; problem.n_vars];
    let nets: Vec<Vec<Lanes>> = (0..count.div_ceil(LANES))
        .into_par_iter()
        .map(|block| {
            let mut s = Scratch::new(problem);
            expand::expand::<Unfused, f32>(
                config,
                &problem.map_start,
                &problem.map_entries,
                &zero,
                designs,
                block,
                &mut s.design,
                &mut s.net,
            );
            s.net
        })
        .collect();
    let mut out = vec![Vertex::default(); count * gu * gv];
    out.par_chunks_mut(gv).enumerate().for_each(|(row, vertices)| {
        let (d, iu) = (row / gu, row % gu);
        let net = &nets[d / LANES];
        for (iv, v) in vertices.iter_mut().enumerate() {
            *v = mirror::dense_grid::<Unfused>(config, samples, net, d % LANES, iu, iv);
        }
    });
    out
}

impl DenseGpu {
    fn new(ctx: &GpuContext, problem: &Problem, samples: &[Sample]) -> Result<Self> {
        let consts = [
            ("DIM", problem.dim as u32),
            ("DU", problem.du as u32),
            ("DV", problem.dv as u32),
        ];
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        Ok(DenseGpu {
            ctx: ctx.clone(),
            expand: Expand::new(ctx, problem)?,
            dense: ctx.pipeline("dense_grid", &prepare(source::DENSE_GRID, &consts)?)?,
            config: ctx.buffer(
                "config",
                std::mem::size_of::<Config>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            samples: ctx.buffer_init("samples", bytemuck::cast_slice(samples), storage),
        })
    }

    fn eval(&self, config: &Config, problem: &Problem, designs: &[f32]) -> Result<Vec<Vertex>> {
        let ctx = &self.ctx;
        let limits = ctx.limits();
        let count = config.population as usize;
        let vertices = count * config.grid_u as usize * config.grid_v as usize;
        let bytes = (vertices * std::mem::size_of::<Vertex>()) as u64;
        let binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        let net_bytes = (count * problem.n_ctrl * problem.dim * 4) as u64;
        let dispatch = limits.max_compute_workgroups_per_dimension;
        if bytes > binding
            || net_bytes > binding
            || count > dispatch as usize
            || config.grid_u.div_ceil(8) > dispatch
            || config.grid_v.div_ceil(8) > dispatch
        {
            return Err(Error::invalid(format!(
                "{count} designs of {vertices} vertices exceed the device limits; sample fewer at once"
            )));
        }
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let population = ctx.buffer_init("designs", bytemuck::cast_slice(designs), storage);
        let net = ctx.buffer("net", net_bytes, wgpu::BufferUsages::STORAGE);
        let (out, staging) = ctx.read_back("vertices", bytes);
        let bind_expand = self.expand.bind(ctx, &self.config, &population, &net);
        let bind_dense = ctx.bind(&self.dense, &[&self.config, &self.samples, &net, &out]);
        ctx.queue
            .write_buffer(&self.config, 0, bytemuck::bytes_of(config));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            self.expand.dispatch(&mut pass, &bind_expand, count);
            pass.set_pipeline(&self.dense);
            pass.set_bind_group(0, &bind_dense, &[]);
            pass.dispatch_workgroups(config.grid_u.div_ceil(8), config.grid_v.div_ceil(8), count as u32);
        }
        encoder.copy_buffer_to_buffer(&out, 0, &staging, 0, bytes);
        ctx.queue.submit([encoder.finish()]);
        let mut result = vec![Vertex::default(); vertices];
        ctx.read(&staging, &mut result)?;
        Ok(result)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::Continuity;

    fn wavy(offset: DVec3) -> PatchGrid<DVec3> {
        let g = GridLayout::new(
            ChainLayout::with_breaks(3, vec![0.0, 0.3, 1.0], Continuity::C1).unwrap(),
            ChainLayout::uniform(2, 3, Continuity::C1).unwrap(),
        );
        let design: Vec<DVec3> = g.design_from(|x, y| offset + DVec3::new(x, y, 0.3 * (2.0 * x).sin() * y));
        PatchGrid::new(g, design).unwrap()
    }

    #[test]
    fn cpu_points_match_the_f64_grid_wherever_it_sits() {
        for offset in [DVec3::ZERO, DVec3::new(1000.0, 1000.0, 0.0)] {
            let grid = wavy(offset);
            let (us, vs) = (uniform(9), uniform(7));
            let (points, info) = dense_grid(&grid, &us, &vs, Backend::Cpu).unwrap();
            assert_eq!(info.backend, Backend::Cpu);
            for (k, p) in points.iter().enumerate() {
                let (u, w) = (us[k / 7], vs[k % 7]);
                let (s, su, sv) = grid.partials(u, w);
                let n = su.cross(sv).normalize();
                assert!(
                    (p.position - s).length() < 2e-6,
                    "{offset}: point {k}: {} vs {s}",
                    p.position
                );
                let got = p.normal.expect("a smooth sheet has normals");
                assert!((got - n).length() < 1e-5, "normal {k}: {got} vs {n}");
            }
        }
    }

    #[test]
    fn the_extraction_maps_are_affine() {
        // The dense evaluator moves designs by a point and relies on it moving nets alike.
        let grid = wavy(DVec3::ZERO);
        let l = grid.layout();
        for chain in [&l.u, &l.v] {
            for r in 0..chain.map().rows() {
                let sum: f64 = chain.map().row(r).1.iter().sum();
                assert!((sum - 1.0).abs() < 1e-12, "row {r} sums to {sum}");
            }
        }
    }

    #[test]
    fn bad_samples_are_errors() {
        let grid = wavy(DVec3::ZERO);
        assert!(dense_grid(&grid, &[], &[0.5], Backend::Cpu).is_err());
        assert!(dense_grid(&grid, &[1.5], &[0.5], Backend::Cpu).is_err());
        assert!(dense_grid(&grid, &[f64::NAN], &[0.5], Backend::Cpu).is_err());
        let mut ev = DenseEvaluator::new(grid.layout(), &[0.5], &[0.5], Backend::Cpu).unwrap();
        assert!(ev.eval(&[1.0]).is_err());
        assert!(ev.eval(&vec![f64::NAN; ev.design_variables()]).is_err());
    }
}
