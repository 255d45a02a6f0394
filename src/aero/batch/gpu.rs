//! The GPU host of `shaders/aero.wgsl`: the panel method for populations, one invocation per
//! individual, its working set in one interleaved storage buffer; pipeline and buffers made
//! once and kept, populations beyond the device's binding limits split into chunks. One
//! evaluation is the kernel's plan ([`AeroKernel::plan`]): a few dozen dispatches in one
//! submission, each reading its phase and range from its own slice of a uniform buffer.

use super::kernel::{AeroConfig, AeroEvaluator, AeroKernel, AeroResult, AeroStep, MAX_GPU_NODES};
use crate::error::{Error, Result};
use crate::eval::gpu::WORKGROUP;
use crate::eval::BackendInfo;
use crate::eval::{GpuContext, GpuOptions};

/// `shaders/aero.wgsl`.
pub const SOURCE: &str = include_str!("../../../shaders/aero.wgsl");

const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST);

/// Buffers sized for a number of individuals per chunk, and one bind group per dispatch of the
/// plan.
#[derive(Debug)]
struct Work {
    individuals: usize,
    population: wgpu::Buffer,
    results: wgpu::Buffer,
    staging: wgpu::Buffer,
    binds: Vec<wgpu::BindGroup>,
}

/// The panel method for populations on the GPU.
#[derive(Debug)]
pub struct GpuAero {
    ctx: GpuContext,
    kernel: AeroKernel,
    options: GpuOptions,
    pipeline: wgpu::ComputePipeline,
    config: wgpu::Buffer,
    node_map: wgpu::Buffer,
    node_base: wgpu::Buffer,
    target: wgpu::Buffer,
    plan: Vec<AeroStep>,
    steps: wgpu::Buffer,
    step_stride: u64,
    work: Option<Work>,
    info: BackendInfo,
}

impl GpuAero {
    /// Build the pipeline and upload the node map, base nodes and target.
    pub fn new(ctx: &GpuContext, kernel: AeroKernel, options: &GpuOptions) -> Result<Self> {
        let n = kernel.config.n_nodes as usize;
        if n > MAX_GPU_NODES {
            return Err(Error::invalid(format!(
                "the GPU panel kernel takes at most {MAX_GPU_NODES} nodes, not {n} (lavapipe's loop \
                 limit; the CPU path has none)"
            )));
        }
        let pipeline = ctx.pipeline("aero", SOURCE)?;
        // Each dispatch's step in its own aligned slice of one uniform buffer.
        let plan = kernel.plan();
        let step_stride = u64::from(ctx.limits().min_uniform_buffer_offset_alignment)
            .max(std::mem::size_of::<AeroStep>() as u64);
        let mut bytes = vec![0u8; plan.len() * step_stride as usize];
        for (k, st) in plan.iter().enumerate() {
            let at = k * step_stride as usize;
            bytes[at..at + std::mem::size_of::<AeroStep>()].copy_from_slice(bytemuck::bytes_of(st));
        }
        let steps = ctx.buffer_init("aero steps", &bytes, wgpu::BufferUsages::UNIFORM);
        let config = ctx.buffer(
            "aero config",
            std::mem::size_of::<AeroConfig>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let node_map = ctx.buffer_init("node_map", bytemuck::cast_slice(&kernel.node_map), STORAGE);
        let node_base = ctx.buffer_init("node_base", bytemuck::cast_slice(&kernel.node_base), STORAGE);
        let target = ctx.buffer_init("target_cp", bytemuck::cast_slice(&kernel.target), STORAGE);
        ctx.check()?;
        let info = ctx.backend_info();
        Ok(GpuAero {
            ctx: ctx.clone(),
            kernel,
            options: options.clone(),
            pipeline,
            config,
            node_map,
            node_base,
            target,
            plan,
            steps,
            step_stride,
            work: None,
            info,
        })
    }

    /// Most individuals per chunk: the work buffer within the device's binding and buffer
    /// limits, whole workgroups within the dispatch limit, and [`GpuOptions::max_chunk`].
    pub fn chunk_size(&self) -> Result<usize> {
        let per_individual = (self.kernel.work_words() * 4) as u64;
        self.ctx
            .chunk_size(per_individual, self.options.max_chunk)
            .map_err(|binding| {
                Error::invalid(format!(
                    "one workgroup of the panel method ({} nodes, {per_individual} bytes per \
                     individual) exceeds the device's storage binding limit of {binding} bytes",
                    self.kernel.config.n_nodes
                ))
            })
    }

    /// Make sure the buffers hold `individuals` (a multiple of the workgroup size).
    fn ensure_work(&mut self, individuals: usize) {
        if self.work.as_ref().is_some_and(|w| w.individuals >= individuals) {
            return;
        }
        let ctx = &self.ctx;
        let nv = self.kernel.config.n_vars as usize;
        let population = ctx.buffer("aero population", (individuals * nv.max(1) * 4) as u64, STORAGE);
        let work = ctx.buffer(
            "aero work",
            (individuals * self.kernel.work_words() * 4) as u64,
            wgpu::BufferUsages::STORAGE,
        );
        let bytes = (individuals * std::mem::size_of::<AeroResult>()) as u64;
        let (results, staging) = ctx.read_back("aero results", bytes);
        let layout = self.pipeline.get_bind_group_layout(0);
        let buffers = [
            &self.config,
            &self.node_map,
            &self.node_base,
            &self.target,
            &population,
            &work,
            &results,
        ];
        let binds = (0..self.plan.len())
            .map(|k| {
                let mut entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
                    .iter()
                    .enumerate()
                    .map(|(b, buf)| wgpu::BindGroupEntry {
                        binding: b as u32,
                        resource: buf.as_entire_binding(),
                    })
                    .collect();
                entries.push(wgpu::BindGroupEntry {
                    binding: 7,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &self.steps,
                        offset: k as u64 * self.step_stride,
                        size: wgpu::BufferSize::new(std::mem::size_of::<AeroStep>() as u64),
                    }),
                });
                ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("aero step"),
                    layout: &layout,
                    entries: &entries,
                })
            })
            .collect();
        self.work = Some(Work {
            individuals,
            population,
            results,
            staging,
            binds,
        });
    }
}

impl AeroEvaluator for GpuAero {
    fn evaluate(&mut self, population: &[f32], out: &mut [AeroResult]) -> Result<()> {
        let rows = self.kernel.rows(population, out.len())?;
        if rows == 0 {
            return Ok(());
        }
        let chunk = self.chunk_size()?;
        let padded = rows.min(chunk).next_multiple_of(WORKGROUP);
        self.ensure_work(padded);
        let Some(work) = &self.work else {
            return Err(Error::Gpu("aero work buffers missing".into()));
        };
        let nv = self.kernel.config.n_vars as usize;
        for start in (0..rows).step_by(chunk) {
            let len = chunk.min(rows - start);
            let config = AeroConfig {
                population: len as u32,
                stride: work.individuals as u32,
                ..self.kernel.config
            };
            let queue = &self.ctx.queue;
            queue.write_buffer(&self.config, 0, bytemuck::bytes_of(&config));
            if nv > 0 {
                queue.write_buffer(
                    &work.population,
                    0,
                    bytemuck::cast_slice(&population[start * nv..(start + len) * nv]),
                );
            }
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&self.pipeline);
                for bind in &work.binds {
                    pass.set_bind_group(0, bind, &[]);
                    pass.dispatch_workgroups(len.div_ceil(WORKGROUP) as u32, 1, 1);
                }
            }
            let bytes = (len * std::mem::size_of::<AeroResult>()) as u64;
            encoder.copy_buffer_to_buffer(&work.results, 0, &work.staging, 0, bytes);
            queue.submit([encoder.finish()]);
            self.ctx.read(&work.staging, &mut out[start..start + len])?;
        }
        Ok(())
    }

    fn info(&self) -> &BackendInfo {
        &self.info
    }
}
