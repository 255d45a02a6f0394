//! Dense evaluation of patch grids on a regular `grid_u × grid_v` grid of global parameters,
//! with unit normals, for meshes and renders: `shaders/expand.wgsl` then
//! `shaders/dense_grid.wgsl`, or their CPU mirrors.

use super::cpu::{self, Lanes, Scratch, Simd, LANES};
use super::gpu::{prepare, source, GpuContext};
use super::kernel::{Config, Problem, Vertex};
use super::{Backend, BackendInfo, EvalLayout, Targets};
use crate::chain::{GridLayout, PatchGrid};
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use rayon::prelude::*;

/// Where a [`DenseEvaluator`] runs.
#[derive(Debug)]
enum Engine {
    Cpu(Simd),
    Gpu(Box<DenseGpu>),
}

/// The GPU side: pipelines and the buffers that do not depend on the designs.
#[derive(Debug)]
struct DenseGpu {
    ctx: GpuContext,
    expand: wgpu::ComputePipeline,
    dense: wgpu::ComputePipeline,
    config: wgpu::Buffer,
    breaks: wgpu::Buffer,
    map_start: wgpu::Buffer,
    map_entries: wgpu::Buffer,
}

/// Samples patch grids of one layout on a fixed grid, design after design.
#[derive(Debug)]
pub struct DenseEvaluator {
    problem: Problem,
    grid_u: usize,
    grid_v: usize,
    engine: Engine,
    info: BackendInfo,
}

impl DenseEvaluator {
    /// An evaluator of `layout` on `grid_u × grid_v` samples (each at least 2) on `backend`;
    /// Auto falls back to the CPU as [`build_evaluator`](super::build_evaluator) does.
    pub fn new(layout: &GridLayout, grid_u: usize, grid_v: usize, backend: Backend) -> Result<Self> {
        Self::build(layout, grid_u, grid_v, backend, None)
    }

    /// The same on the GPU of an existing context (shared with population evaluators).
    pub fn on_gpu(ctx: &GpuContext, layout: &GridLayout, grid_u: usize, grid_v: usize) -> Result<Self> {
        Self::build(layout, grid_u, grid_v, Backend::Gpu, Some(ctx))
    }

    fn build(
        layout: &GridLayout,
        grid_u: usize,
        grid_v: usize,
        backend: Backend,
        shared: Option<&GpuContext>,
    ) -> Result<Self> {
        if grid_u < 2 || grid_v < 2 {
            return Err(Error::invalid("a dense grid needs at least 2 samples each way"));
        }
        if grid_u
            .checked_mul(grid_v)
            .is_none_or(|n| n > u32::MAX as usize / 2)
        {
            return Err(Error::invalid("dense grid too large"));
        }
        // The problem carries the layout; its single target is unused here.
        let targets = Targets::grid(&[DVec3::ZERO], &[DVec2::ZERO])?;
        let problem = Problem::new(&EvalLayout::Grid(layout.clone()), &targets, 0)?;
        let cpu = || {
            let simd = Simd::detect();
            let info = BackendInfo {
                backend: Backend::Cpu,
                adapter: format!("CPU: {} rayon threads", rayon::current_num_threads()),
                fallback: None,
            };
            (Engine::Cpu(simd), info)
        };
        let gpu = || -> Result<(Engine, BackendInfo)> {
            let ctx = match shared {
                Some(ctx) => ctx.clone(),
                None => GpuContext::new()?,
            };
            let gpu = DenseGpu::new(&ctx, &problem)?;
            let info = BackendInfo {
                backend: Backend::Gpu,
                adapter: ctx.adapter().to_owned(),
                fallback: None,
            };
            Ok((Engine::Gpu(Box::new(gpu)), info))
        };
        let (engine, info) = match backend {
            Backend::Cpu => cpu(),
            Backend::Gpu => gpu()?,
            Backend::Auto => gpu().unwrap_or_else(|e| {
                let (engine, mut info) = cpu();
                info.fallback = Some(e.to_string());
                (engine, info)
            }),
        };
        Ok(DenseEvaluator {
            problem,
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
    /// values): vertex `(d * grid_u + iu) * grid_v + iv` is design `d` at global
    /// `(iu / (grid_u - 1), iv / (grid_v - 1))`.
    pub fn eval(&mut self, designs: &[f32]) -> Result<Vec<Vertex>> {
        let n_vars = self.problem.n_vars;
        if designs.is_empty() || !designs.len().is_multiple_of(n_vars) {
            return Err(Error::invalid(format!(
                "{} values are not a whole, non-zero number of designs of {n_vars} variables",
                designs.len()
            )));
        }
        let count = designs.len() / n_vars;
        let mut config = self.problem.config(count, LANES, (1, 1));
        config.grid_u = self.grid_u as u32;
        config.grid_v = self.grid_v as u32;
        match &self.engine {
            Engine::Cpu(simd) => Ok(dense_cpu(*simd, &config, &self.problem, designs)),
            Engine::Gpu(gpu) => {
                config.net_stride = count as u32;
                gpu.eval(&config, &self.problem, designs)
            }
        }
    }
}

/// Sample one patch grid: its vertices, row-major `grid_u × grid_v`, and where they were
/// computed.
pub fn dense_grid(
    grid: &PatchGrid<DVec3>,
    grid_u: usize,
    grid_v: usize,
    backend: Backend,
) -> Result<(Vec<Vertex>, BackendInfo)> {
    let mut evaluator = DenseEvaluator::new(grid.layout(), grid_u, grid_v, backend)?;
    let design: Vec<f32> = grid
        .design()
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let vertices = evaluator.eval(&design)?;
    Ok((vertices, evaluator.info().clone()))
}

/// The CPU path: expand each block of designs, then every vertex of every design in it.
fn dense_cpu(simd: Simd, config: &Config, problem: &Problem, designs: &[f32]) -> Vec<Vertex> {
    let (gu, gv) = (config.grid_u as usize, config.grid_v as usize);
    let per = gu * gv;
    let count = config.population as usize;
    let mut out = vec![Vertex::default(); count * per];
    out.par_chunks_mut(LANES * per).enumerate().for_each_init(
        || Scratch::new(problem),
        |scratch, (block, chunk)| match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Simd::Avx2` comes from `Simd::detect`, which saw AVX2.
            Simd::Avx2 => unsafe { dense_block_avx2(config, problem, designs, block, scratch, chunk) },
            _ => dense_block(config, problem, designs, block, scratch, chunk),
        },
    );
    out
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn dense_block_avx2(
    config: &Config,
    problem: &Problem,
    designs: &[f32],
    block: usize,
    scratch: &mut Scratch,
    out: &mut [Vertex],
) {
    dense_block(config, problem, designs, block, scratch, out);
}

#[inline(always)]
fn dense_block(
    config: &Config,
    problem: &Problem,
    designs: &[f32],
    block: usize,
    scratch: &mut Scratch,
    out: &mut [Vertex],
) {
    cpu::expand::expand(
        config,
        &problem.map_start,
        &problem.map_entries,
        designs,
        block,
        &mut scratch.design,
        &mut scratch.net,
    );
    let (gu, gv) = (config.grid_u as usize, config.grid_v as usize);
    let net: &[Lanes] = &scratch.net;
    for (lane, vertices) in out.chunks_exact_mut(gu * gv).enumerate() {
        for (k, v) in vertices.iter_mut().enumerate() {
            *v = cpu::dense_grid::dense_grid(config, &problem.breaks, net, lane, k / gv, k % gv);
        }
    }
}

impl DenseGpu {
    fn new(ctx: &GpuContext, problem: &Problem) -> Result<Self> {
        let consts = [
            ("DIM", problem.dim as u32),
            ("DU", problem.du as u32),
            ("DV", problem.dv as u32),
        ];
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        Ok(DenseGpu {
            ctx: ctx.clone(),
            expand: ctx.pipeline("expand", &prepare(source::EXPAND, &consts[..1])?)?,
            dense: ctx.pipeline("dense_grid", &prepare(source::DENSE_GRID, &consts)?)?,
            config: ctx.buffer(
                "config",
                std::mem::size_of::<Config>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            breaks: ctx.buffer_init("breaks", bytemuck::cast_slice(&problem.breaks), storage),
            map_start: ctx.buffer_init("map_start", bytemuck::cast_slice(&problem.map_start), storage),
            map_entries: ctx.buffer_init("map_entries", bytemuck::cast_slice(&problem.map_entries), storage),
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
        if bytes > binding
            || net_bytes > binding
            || count > limits.max_compute_workgroups_per_dimension as usize
        {
            return Err(Error::invalid(format!(
                "{count} designs of {vertices} vertices exceed the device limits; sample fewer at once"
            )));
        }
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let population = ctx.buffer_init("designs", bytemuck::cast_slice(designs), storage);
        let net = ctx.buffer("net", net_bytes, wgpu::BufferUsages::STORAGE);
        let out = ctx.buffer(
            "vertices",
            bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let staging = ctx.buffer(
            "staging",
            bytes,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let bind_expand = ctx.bind(
            &self.expand,
            &[
                &self.config,
                &self.map_start,
                &self.map_entries,
                &population,
                &net,
            ],
        );
        let bind_dense = ctx.bind(&self.dense, &[&self.config, &self.breaks, &net, &out]);
        ctx.queue
            .write_buffer(&self.config, 0, bytemuck::bytes_of(config));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.expand);
            pass.set_bind_group(0, &bind_expand, &[]);
            pass.dispatch_workgroups(count.div_ceil(64) as u32, 1, 1);
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
    use crate::chain::{ChainLayout, Continuity};

    #[test]
    fn cpu_vertices_match_the_f64_grid() {
        let g = GridLayout::new(
            ChainLayout::with_breaks(3, vec![0.0, 0.3, 1.0], Continuity::C1).unwrap(),
            ChainLayout::uniform(2, 3, Continuity::C1).unwrap(),
        );
        let (nu, nv) = g.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|k| {
                let (x, y) = (
                    (k / nv) as f64 / (nu - 1) as f64,
                    (k % nv) as f64 / (nv - 1) as f64,
                );
                DVec3::new(x, y, 0.3 * (2.0 * x).sin() * y)
            })
            .collect();
        let grid = PatchGrid::new(g, design).unwrap();
        let (vertices, info) = dense_grid(&grid, 9, 7, Backend::Cpu).unwrap();
        assert_eq!(info.backend, Backend::Cpu);
        for (k, v) in vertices.iter().enumerate() {
            let (u, w) = ((k / 7) as f64 / 8.0, (k % 7) as f64 / 6.0);
            let (p, pu, pv) = grid.partials(u, w);
            let n = pu.cross(pv).normalize();
            let got = DVec3::new(v.px.into(), v.py.into(), v.pz.into());
            let gn = DVec3::new(v.nx.into(), v.ny.into(), v.nz.into());
            assert!((got - p).length() < 1e-6, "vertex {k}: {got} vs {p}");
            assert!((gn - n).length() < 1e-5, "normal {k}: {gn} vs {n}");
        }
    }
}
