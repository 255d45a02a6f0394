//! The GPU path: one wgpu context per process on the Vulkan backend (a service every
//! evaluator shares), the shaders specialised for a layout, and `GpuEvaluator`, which keeps its
//! pipelines and buffers from one population to the next and splits populations beyond the
//! device limits into chunks.

use super::kernel::{point_groups, Gene, Problem};
use super::{Backend, BackendInfo, EvalLayout, Fitness, HoldsProblem, Targets};
use crate::error::{Error, Result};
use std::sync::{Arc, Mutex, OnceLock};
use wgpu::util::DeviceExt;

mod unroll;
pub use unroll::unroll;

/// The WGSL sources, embedded; `tests/shaders.rs` validates them as they stand and specialised.
pub mod source {
    use crate::error::{Error, Result};

    /// `shaders/config.wgsl`: the `Config` uniform block, included by every shader.
    pub const CONFIG: &str = include_str!("../../../shaders/config.wgsl");
    /// `shaders/basis.wgsl`: the Bernstein basis, included by the shaders that evaluate patches.
    pub const BASIS: &str = include_str!("../../../shaders/basis.wgsl");
    /// `shaders/points.wgsl`: how `eval_patch` reads its per-point data, every lane for itself.
    pub const POINTS: &str = include_str!("../../../shaders/points.wgsl");
    /// `shaders/points_subgroup.wgsl`: the same with subgroup broadcasts, spliced in at
    /// `// @include points.wgsl` on devices with subgroup operations.
    pub const POINTS_SUBGROUP: &str = include_str!("../../../shaders/points_subgroup.wgsl");
    /// `shaders/expand.wgsl`.
    pub const EXPAND: &str = include_str!("../../../shaders/expand.wgsl");
    /// `shaders/eval_patch.wgsl`.
    pub const EVAL_PATCH: &str = include_str!("../../../shaders/eval_patch.wgsl");
    /// `shaders/reduce.wgsl`.
    pub const REDUCE: &str = include_str!("../../../shaders/reduce.wgsl");
    /// `shaders/dense_grid.wgsl`.
    pub const DENSE_GRID: &str = include_str!("../../../shaders/dense_grid.wgsl");

    /// The files a shader may include, by name.
    pub const INCLUDES: [(&str, &str); 3] = [
        ("config.wgsl", CONFIG),
        ("basis.wgsl", BASIS),
        ("points.wgsl", POINTS),
    ];

    /// `src` with every line `// @include NAME` replaced by the file of that name (once each;
    /// included files include nothing).
    pub fn expand(src: &str) -> Result<String> {
        expand_with(src, &[])
    }

    /// [`expand`], with `replace` naming files spliced in instead of [`INCLUDES`]' of the same
    /// name (e.g. `("points.wgsl", POINTS_SUBGROUP)`).
    pub fn expand_with(src: &str, replace: &[(&str, &str)]) -> Result<String> {
        let mut out = String::with_capacity(src.len() + CONFIG.len() + BASIS.len());
        for line in src.lines() {
            match line.trim().strip_prefix("// @include ") {
                Some(name) => {
                    let (_, text) = replace
                        .iter()
                        .chain(INCLUDES.iter())
                        .find(|(n, _)| *n == name.trim())
                        .ok_or_else(|| Error::Gpu(format!("shader includes unknown file '{name}'")))?;
                    out.push_str(text);
                }
                None => {
                    out.push_str(line);
                    out.push('\n');
                }
            }
        }
        Ok(out)
    }
}

/// The environment variable that makes every GPU request fail as if no adapter existed.
pub const NO_GPU_ENV: &str = "BEZCHAIN_NO_GPU";

/// Individuals per workgroup along x in every population shader (`@workgroup_size(64)`, or
/// in eval_patch.wgsl 64 / PER invocations of PER individuals each).
pub(crate) const WORKGROUP: usize = 64;

/// Most individuals per invocation of eval_patch.wgsl on CPU adapters, with parameters held
/// fixed and with Newton steps. On lavapipe each invocation then loads a point's data once for
/// all of them and runs one point loop for all of them. Bicubic patches in space, 1024
/// individuals × 4096 points, CPU time per population: fixed, 4 took 0.39× that of 1 (2:
/// 0.59×); two Newton steps, 2 took 0.90× that of 1 and 4 1.09× (the Newton code of 4
/// individuals spills more than the shared loads save).
const CPU_PER_INVOCATION: [u32; 2] = [4, 2];

/// Most control-point coordinates an invocation holds on a CPU adapter (PER patches of
/// (du + 1)(dv + 1) points in DIM coordinates): that of the measured bicubic case, 4 × 16 × 3,
/// so that larger patches take fewer individuals an invocation rather than more registers
/// than were measured.
const CPU_HELD_FLOATS: u32 = 192;

/// Replace the line `const NAME: u32 = …;` of `src` by the given value, for every pair.
///
/// The shaders declare their degrees and dimension this way so that private arrays get their
/// exact sizes and every loop a constant trip count, which the driver unrolls into registers.
pub fn specialise(src: &str, consts: &[(&str, u32)]) -> Result<String> {
    let mut out = String::with_capacity(src.len());
    let mut found = vec![false; consts.len()];
    for line in src.lines() {
        let hit = consts
            .iter()
            .position(|(name, _)| line.starts_with(&format!("const {name}: u32 = ")));
        match hit {
            Some(k) => {
                found[k] = true;
                out.push_str(&format!("const {}: u32 = {}u;", consts[k].0, consts[k].1));
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    match found.iter().position(|f| !f) {
        Some(k) => Err(Error::Gpu(format!(
            "shader has no line 'const {}: u32 = …;' to specialise",
            consts[k].0
        ))),
        None => Ok(out),
    }
}

/// A shader ready for the driver: its includes spliced in, `consts` specialised, then the
/// `// @unroll` loops unrolled.
pub fn prepare(src: &str, consts: &[(&str, u32)]) -> Result<String> {
    prepare_with(src, consts, &[])
}

/// [`prepare`] with includes replaced as [`source::expand_with`] does.
pub fn prepare_with(src: &str, consts: &[(&str, u32)], replace: &[(&str, &str)]) -> Result<String> {
    unroll(&specialise(&source::expand_with(src, replace)?, consts)?)
}

/// Options of the GPU path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuOptions {
    /// Most individuals per dispatch, on top of the device limits (storage binding size,
    /// workgroups per dimension); bounds buffer sizes and the latency of one submission.
    /// Default: 65 536.
    pub max_chunk: usize,
    /// Individuals per invocation of the population kernel (`PER` in eval_patch.wgsl), a
    /// divisor of 64; `None`: the adapter's for the Newton steps the evaluator is built with
    /// (on CPU adapters such as lavapipe 4 with fixed parameters, 2 with steps, fewer for large
    /// patches; 1 on GPUs). Results do not depend on it. A search with candidate starts
    /// ([`PopulationEvaluator::set_seeds`](super::PopulationEvaluator::set_seeds)) runs with 1
    /// whatever this says. Default: `None`.
    pub per_invocation: Option<u32>,
    /// Read the target points with subgroup operations where the device has them
    /// (shaders/points_subgroup.wgsl). Results do not depend on it. Default: true.
    pub subgroups: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            max_chunk: 1 << 16,
            per_invocation: None,
            subgroups: true,
        }
    }
}

/// A wgpu device and queue on the best Vulkan adapter: one per process, opened on first use
/// by [`GpuContext::shared`] and shared by every evaluator (a clone is a handle to the same
/// device). Device errors are collected in one place and reported by the next evaluator call
/// that checks.
#[derive(Clone, Debug)]
pub struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    adapter: String,
    /// A CPU adapter (lavapipe): each invocation of the population kernel then evaluates
    /// several individuals ([`CPU_PER_INVOCATION`]).
    cpu: bool,
    errors: Arc<Mutex<Option<String>>>,
}

impl GpuContext {
    /// The process's context: the best adapter wgpu's Vulkan backend finds (discrete,
    /// integrated, virtual, then CPU adapters such as Mesa lavapipe), opened on the first call;
    /// later calls return it (or the first call's error) at once. Fails with [`Error::Gpu`]
    /// when there is no adapter or when `BEZCHAIN_NO_GPU` is set to anything but `0`.
    pub fn shared() -> Result<Self> {
        if let Ok(v) = std::env::var(NO_GPU_ENV) {
            if !v.is_empty() && v != "0" {
                return Err(Error::Gpu(format!("no adapter: {NO_GPU_ENV}={v} is set")));
            }
        }
        static SHARED: OnceLock<std::result::Result<GpuContext, String>> = OnceLock::new();
        let opened = SHARED.get_or_init(|| {
            Self::open().map_err(|e| match e {
                Error::Gpu(why) => why,
                other => other.to_string(),
            })
        });
        opened.clone().map_err(Error::Gpu)
    }

    /// Open a device on the best adapter.
    fn open() -> Result<Self> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            flags: wgpu::InstanceFlags::empty(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        let adapter = adapters
            .into_iter()
            .min_by_key(rank)
            .ok_or_else(|| Error::Gpu("no adapter: wgpu's Vulkan backend found none".into()))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("bezchain"),
            // Subgroup operations where the adapter has them (eval_patch reads its points
            // with them; see shaders/points_subgroup.wgsl).
            required_features: adapter.features() & wgpu::Features::SUBGROUP,
            // Everything the adapter offers: the chunk size follows the real binding limits.
            required_limits: adapter.limits(),
            memory_hints: wgpu::MemoryHints::Performance,
            ..Default::default()
        }))
        .map_err(|e| Error::Gpu(format!("{}: cannot open the device: {e}", info.name)))?;
        let errors = Arc::new(Mutex::new(None));
        let sink = Arc::clone(&errors);
        // Device errors would otherwise panic; keep the first and report it as Error::Gpu.
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert_with(|| e.to_string());
        }));
        let adapter = format!(
            "{} ({:?}, {} {}, {:?})",
            info.name, info.backend, info.driver, info.driver_info, info.device_type
        );
        Ok(GpuContext {
            device,
            queue,
            adapter,
            cpu: info.device_type == wgpu::DeviceType::Cpu,
            errors,
        })
    }

    /// The context [`Backend::Auto`] takes: [`GpuContext::shared`],
    /// refused with the reason on a software adapter (Mesa lavapipe and other CPU-type
    /// adapters). Such an adapter runs on the same cores as the CPU kernels and slower than
    /// they (`optimise --objective max-cl` 59 s on lavapipe against 0.6 s on the CPU, a GA
    /// fit 3.4 against 0.9 s); `--backend gpu` still runs on it.
    pub fn shared_hardware() -> Result<Self> {
        let ctx = Self::shared()?;
        if ctx.cpu {
            return Err(Error::Gpu(format!(
                "{} is a software adapter, slower than the CPU kernels (--backend gpu runs on it)",
                ctx.adapter
            )));
        }
        Ok(ctx)
    }

    /// Whether the adapter is a software one on the CPU (lavapipe).
    #[must_use]
    pub fn is_software(&self) -> bool {
        self.cpu
    }

    /// The adapter: name, backend, driver and type.
    #[must_use]
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// What an evaluator on this context reports: the GPU backend and this adapter.
    #[must_use]
    pub fn backend_info(&self) -> BackendInfo {
        BackendInfo {
            backend: Backend::Gpu,
            adapter: self.adapter.clone(),
            fallback: None,
        }
    }

    /// Individuals per invocation of the population kernel (`PER` in eval_patch.wgsl) for
    /// patches of `held` control-point coordinates and `newton` steps: 1 on GPUs; on CPU
    /// adapters [`CPU_PER_INVOCATION`]'s, halved until their patches fit [`CPU_HELD_FLOATS`].
    pub(crate) fn per_invocation(&self, held: u32, newton: u32) -> u32 {
        let mut per = if self.cpu {
            CPU_PER_INVOCATION[usize::from(newton > 0)]
        } else {
            1
        };
        while per > 1 && per * held > CPU_HELD_FLOATS {
            per /= 2;
        }
        per
    }

    /// The includes that eval_patch.wgsl takes on this device: the subgroup reads of its
    /// points where the device has subgroup operations.
    pub(crate) fn point_includes(&self) -> Vec<(&'static str, &'static str)> {
        if self.device.features().contains(wgpu::Features::SUBGROUP) {
            vec![("points.wgsl", source::POINTS_SUBGROUP)]
        } else {
            Vec::new()
        }
    }

    /// The device limits in force.
    #[must_use]
    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// The first device error since the last check, as [`Error::Gpu`].
    pub(crate) fn check(&self) -> Result<()> {
        let mut slot = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        match slot.take() {
            Some(e) => Err(Error::Gpu(format!("{}: {e}", self.adapter))),
            None => Ok(()),
        }
    }

    /// A compute pipeline from WGSL `source` (entry point `main`, layout from the shader).
    pub(crate) fn pipeline(&self, label: &str, source: &str) -> Result<wgpu::ComputePipeline> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("{label}: {e}")));
        }
        Ok(pipeline)
    }

    /// A storage buffer holding `contents` (at least 4 bytes, so empty arrays still bind).
    pub(crate) fn buffer_init(
        &self,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        let padded;
        let contents = if contents.len() < 4 {
            padded = [0u8; 4];
            &padded[..]
        } else {
            contents
        };
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    }

    /// An uninitialised (zeroed) buffer of `size` bytes (at least 4).
    pub(crate) fn buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4).next_multiple_of(4),
            usage,
            mapped_at_creation: false,
        })
    }

    /// A result buffer of `size` bytes that a shader writes and its mappable staging copy, for
    /// [`GpuContext::read`].
    pub(crate) fn read_back(&self, label: &str, size: u64) -> (wgpu::Buffer, wgpu::Buffer) {
        let out = self.buffer(
            label,
            size,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let staging = self.buffer(
            &format!("{label} staging"),
            size,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        (out, staging)
    }

    /// Most individuals per dispatch when each takes `per_individual` bytes of its largest
    /// storage buffer: the device's binding and dispatch limits and `max_chunk`, in whole
    /// workgroups of [`WORKGROUP`] (a `max_chunk` below one workgroup is honoured as it is).
    /// `None` when not even one workgroup fits the binding limit (the limit is returned).
    pub(crate) fn chunk_size(
        &self,
        per_individual: u64,
        max_chunk: usize,
    ) -> std::result::Result<usize, u64> {
        let limits = self.limits();
        let binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        let by_memory = usize::try_from(binding / per_individual.max(1)).unwrap_or(usize::MAX);
        let by_dispatch = limits.max_compute_workgroups_per_dimension as usize * WORKGROUP;
        let chunk = by_memory.min(by_dispatch).min(max_chunk.max(1));
        if chunk >= WORKGROUP {
            Ok(chunk / WORKGROUP * WORKGROUP)
        } else if by_memory >= WORKGROUP {
            Ok(chunk)
        } else {
            Err(binding)
        }
    }

    /// A bind group for group 0 of `pipeline` with `buffers` at bindings 0, 1, ….
    pub(crate) fn bind(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
            .iter()
            .enumerate()
            .map(|(k, b)| wgpu::BindGroupEntry {
                binding: k as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    /// Copy the first `out.len()` values of `staging` (mappable) into `out`.
    pub(crate) fn read<T: bytemuck::Pod>(&self, staging: &wgpu::Buffer, out: &mut [T]) -> Result<()> {
        let bytes = std::mem::size_of_val(out) as u64;
        if bytes == 0 {
            return Ok(());
        }
        let slice = staging.slice(0..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            // The receiver waits below; a send can only fail if it is gone, which it is not.
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("{}: {e}", self.adapter)))?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(Error::Gpu(format!("{}: read-back failed: {e}", self.adapter))),
            Err(_) => return Err(Error::Gpu(format!("{}: read-back never completed", self.adapter))),
        }
        {
            let view = slice
                .get_mapped_range()
                .map_err(|e| Error::Gpu(format!("{}: {e}", self.adapter)))?;
            let size = std::mem::size_of::<T>();
            for (o, chunk) in out.iter_mut().zip(view.chunks_exact(size)) {
                *o = bytemuck::pod_read_unaligned(chunk);
            }
        }
        staging.unmap();
        self.check()
    }
}

/// The `expand` stage on the GPU (design rows to control nets through the extraction map):
/// its pipeline and the map's buffers, built once per layout. Population evaluation and dense
/// sampling both start with it.
#[derive(Debug)]
pub(crate) struct Expand {
    pipeline: wgpu::ComputePipeline,
    map_start: wgpu::Buffer,
    map_entries: wgpu::Buffer,
}

impl Expand {
    /// The stage for `problem`'s layout.
    pub(crate) fn new(ctx: &GpuContext, problem: &Problem) -> Result<Self> {
        let dim = [("DIM", problem.dim as u32)];
        Ok(Expand {
            pipeline: ctx.pipeline("expand", &prepare(source::EXPAND, &dim)?)?,
            map_start: ctx.buffer_init("map_start", bytemuck::cast_slice(&problem.map_start), STORAGE),
            map_entries: ctx.buffer_init("map_entries", bytemuck::cast_slice(&problem.map_entries), STORAGE),
        })
    }

    /// Its bind group: the shared `config`, the design rows in, the nets out.
    pub(crate) fn bind(
        &self,
        ctx: &GpuContext,
        config: &wgpu::Buffer,
        rows: &wgpu::Buffer,
        nets: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        ctx.bind(
            &self.pipeline,
            &[config, &self.map_start, &self.map_entries, rows, nets],
        )
    }

    /// Record the stage for `individuals` rows into `pass`.
    pub(crate) fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        bind: &wgpu::BindGroup,
        individuals: usize,
    ) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(individuals.div_ceil(WORKGROUP) as u32, 1, 1);
    }
}

/// Buffers sized for a number of individuals per chunk and of point groups, with their bind
/// groups; rebuilt only when a larger population arrives.
#[derive(Debug)]
struct Work {
    individuals: usize,
    groups: usize,
    population: wgpu::Buffer,
    staging: wgpu::Buffer,
    fitness: wgpu::Buffer,
    bind_expand: wgpu::BindGroup,
    bind_eval: wgpu::BindGroup,
    bind_reduce: wgpu::BindGroup,
}

/// Population evaluation on the GPU: `expand`, `eval_patch` and `reduce` in one submission
/// per chunk of individuals, with pipelines and buffers built once and reused.
#[derive(Debug)]
pub struct GpuEvaluator {
    ctx: GpuContext,
    problem: Problem,
    options: GpuOptions,
    expand: Expand,
    eval: wgpu::ComputePipeline,
    /// Individuals per invocation of `eval`, and the adapter's (or the options') choice.
    per: u32,
    per_chosen: u32,
    /// Whether `eval` was built with candidate starts (`SEEDED`).
    seeded: bool,
    reduce: wgpu::ComputePipeline,
    config: wgpu::Buffer,
    /// The targets and the reference's partials there, interleaved (see [`point_data`]).
    points: wgpu::Buffer,
    breaks: wgpu::Buffer,
    work: Option<Work>,
    /// One chunk's rows as differences from the reference, for upload.
    rows: Vec<f32>,
    info: BackendInfo,
}

const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST);

/// eval_patch.wgsl's `points` binding: per target its [`Target`](super::Target) (eight
/// words) then its [`RefJet`](super::RefJet) (sixteen), so that a point is six `vec4`s in one
/// place.
fn point_data(problem: &Problem) -> Vec<[u32; 24]> {
    problem
        .targets
        .iter()
        .zip(&problem.jets)
        .map(|(t, j)| {
            let mut row = [0u32; 24];
            row[..8].copy_from_slice(bytemuck::cast_slice(std::slice::from_ref(t)));
            row[8..].copy_from_slice(bytemuck::cast_slice(std::slice::from_ref(j)));
            row
        })
        .collect()
}

/// Individuals per invocation of the population kernel: `chosen` (the options' or the
/// adapter's), except 1 with candidate starts on. On lavapipe, two an invocation gave wrong
/// sums with them (measured: 30-40 % low on a bicubic grid and on partly filled workgroups of
/// curves, from `seed` alone, its result unused); one gives the CPU mirror's sums to the bit.
fn per_for(seeds: u32, chosen: u32) -> u32 {
    if seeds != 0 {
        1
    } else {
        chosen
    }
}

/// The population kernel for `problem` with `per` individuals per invocation, reading its
/// points with subgroup operations where `subgroups` asks and the device has them.
fn eval_pipeline(
    ctx: &GpuContext,
    problem: &Problem,
    per: u32,
    subgroups: bool,
) -> Result<wgpu::ComputePipeline> {
    let includes = if subgroups {
        ctx.point_includes()
    } else {
        Vec::new()
    };
    let consts = [
        ("DIM", problem.dim as u32),
        ("DU", problem.du as u32),
        ("DV", problem.dv as u32),
        ("CROSS", u32::from(problem.cross)),
        ("SEEDED", u32::from(problem.seeds != 0)),
        ("PER", per),
    ];
    let src = prepare_with(source::EVAL_PATCH, &consts, &includes)?;
    ctx.pipeline("eval_patch", &src)
}

impl GpuEvaluator {
    /// Build the pipelines for `layout` and upload `targets`, the breaks and the extraction
    /// map; population buffers follow on the first evaluation.
    pub fn new(
        ctx: &GpuContext,
        layout: &EvalLayout,
        targets: &Targets,
        newton: u32,
        cross: bool,
        options: &GpuOptions,
    ) -> Result<Self> {
        GpuEvaluator::with_seeds(ctx, layout, targets, (newton, cross, 0), options)
    }

    /// [`new`](Self::new) with the foot-point search's candidate starts set from the start
    /// (`(newton, cross, seeds)`), so that the kernel is built once, as they need it.
    pub fn with_seeds(
        ctx: &GpuContext,
        layout: &EvalLayout,
        targets: &Targets,
        (newton, cross, seeds): (u32, bool, u32),
        options: &GpuOptions,
    ) -> Result<Self> {
        let mut problem = Problem::new(layout, targets, newton)?;
        problem.cross = cross;
        problem.seeds = seeds;
        let held = ((problem.du + 1) * (problem.dv + 1) * problem.dim) as u32;
        let per_chosen = options
            .per_invocation
            .unwrap_or_else(|| ctx.per_invocation(held, newton));
        if !(WORKGROUP as u32).is_multiple_of(per_chosen) {
            return Err(Error::invalid(format!(
                "{per_chosen} individuals per invocation: must divide {WORKGROUP}"
            )));
        }
        let per = per_for(seeds, per_chosen);
        let expand = Expand::new(ctx, &problem)?;
        let eval = eval_pipeline(ctx, &problem, per, options.subgroups)?;
        let reduce = ctx.pipeline("reduce", &prepare(source::REDUCE, &[])?)?;
        let config = ctx.buffer(
            "config",
            std::mem::size_of::<super::Config>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let data = point_data(&problem);
        let points = ctx.buffer_init("points", bytemuck::cast_slice(&data), STORAGE);
        let breaks = ctx.buffer_init("breaks", bytemuck::cast_slice(&problem.breaks), STORAGE);
        let limit = ctx.limits().max_storage_buffer_binding_size;
        if std::mem::size_of_val(&data[..]) as u64 > limit {
            return Err(Error::invalid(format!(
                "{} target points exceed the device's storage binding limit of {limit} bytes",
                problem.n_points()
            )));
        }
        ctx.check()?;
        let info = ctx.backend_info();
        Ok(GpuEvaluator {
            ctx: ctx.clone(),
            problem,
            options: options.clone(),
            expand,
            eval,
            per,
            per_chosen,
            seeded: seeds != 0,
            reduce,
            config,
            points,
            breaks,
            work: None,
            rows: Vec::new(),
            info,
        })
    }

    /// The context this evaluator runs on (to share it, e.g. with a dense-grid evaluator).
    #[must_use]
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Most individuals per chunk with `groups` point groups: the device's binding and
    /// dispatch limits and [`GpuOptions::max_chunk`], in whole workgroups.
    pub fn chunk_size(&self, groups: usize) -> Result<usize> {
        let p = &self.problem;
        let per_individual = [p.n_vars * 4, p.n_ctrl * p.dim * 4, groups * 8, 8]
            .into_iter()
            .max()
            .unwrap_or(8) as u64;
        self.ctx
            .chunk_size(per_individual, self.options.max_chunk)
            .map_err(|binding| {
                Error::invalid(format!(
                    "one workgroup of this layout ({per_individual} bytes per individual) exceeds \
                     the device's storage binding limit of {binding} bytes"
                ))
            })
    }

    /// Make sure the work buffers hold `individuals` (a multiple of the workgroup size) and
    /// `groups` point groups.
    fn ensure_work(&mut self, individuals: usize, groups: usize) {
        if let Some(w) = &self.work {
            if w.individuals >= individuals && w.groups >= groups {
                return;
            }
        }
        let (individuals, groups) = match &self.work {
            Some(w) => (individuals.max(w.individuals), groups.max(w.groups)),
            None => (individuals, groups),
        };
        let ctx = &self.ctx;
        let p = &self.problem;
        let f32s = 4u64;
        let population = ctx.buffer("population", (individuals * p.n_vars) as u64 * f32s, STORAGE);
        let net = ctx.buffer(
            "net",
            (individuals * p.n_ctrl * p.dim) as u64 * f32s,
            wgpu::BufferUsages::STORAGE,
        );
        let partials = ctx.buffer(
            "partials",
            (individuals * groups * 8) as u64,
            wgpu::BufferUsages::STORAGE,
        );
        let (fitness, staging) = ctx.read_back("fitness", (individuals * 8) as u64);
        let bind_expand = self.expand.bind(ctx, &self.config, &population, &net);
        let bind_eval = ctx.bind(
            &self.eval,
            &[&self.config, &self.points, &self.breaks, &net, &partials],
        );
        let bind_reduce = ctx.bind(&self.reduce, &[&self.config, &partials, &fitness]);
        self.work = Some(Work {
            individuals,
            groups,
            population,
            staging,
            fitness,
            bind_expand,
            bind_eval,
            bind_reduce,
        });
    }
}

impl GpuEvaluator {
    /// Upload the per-target arrays after the parameters or the reference changed.
    fn upload_targets(&self) {
        let data = point_data(&self.problem);
        self.ctx
            .queue
            .write_buffer(&self.points, 0, bytemuck::cast_slice(&data));
    }
}

impl HoldsProblem for GpuEvaluator {
    fn problem(&self) -> &Problem {
        &self.problem
    }

    fn problem_mut(&mut self) -> &mut Problem {
        &mut self.problem
    }

    fn problem_changed(&mut self) {
        self.upload_targets();
    }

    /// The kernel is specialised on whether candidate starts are on (`SEEDED`) and takes
    /// [`per_for`] individuals an invocation: rebuilt when either changes.
    fn seeds_changed(&mut self) -> Result<()> {
        let seeded = self.problem.seeds != 0;
        let per = per_for(self.problem.seeds, self.per_chosen);
        if per != self.per || seeded != self.seeded {
            self.eval = eval_pipeline(&self.ctx, &self.problem, per, self.options.subgroups)?;
            self.per = per;
            self.seeded = seeded;
            // Bind groups belong to the pipeline they were made for.
            self.work = None;
        }
        Ok(())
    }

    fn backend_info(&self) -> &BackendInfo {
        &self.info
    }

    fn run<T: Gene>(&mut self, population: &[T], out: &mut [Fitness]) -> Result<()> {
        let rows = self.problem.rows(population.len(), out.len())?;
        if rows == 0 {
            return Ok(());
        }
        let groups = point_groups(rows, self.problem.n_points());
        let chunk = self.chunk_size(groups.1)?;
        self.ensure_work(rows.min(chunk).next_multiple_of(WORKGROUP), groups.1);
        let Some(work) = &self.work else {
            return Err(Error::Gpu("work buffers missing".into()));
        };
        let n_vars = self.problem.n_vars;
        for start in (0..rows).step_by(chunk) {
            let len = chunk.min(rows - start);
            // Lanes past `len` in the last workgroup compute on the padding of the net.
            let config = self.problem.config(len, len.next_multiple_of(WORKGROUP), groups);
            self.problem.differences(
                &population[start * n_vars..(start + len) * n_vars],
                &mut self.rows,
            );
            let queue = &self.ctx.queue;
            queue.write_buffer(&self.config, 0, bytemuck::bytes_of(&config));
            queue.write_buffer(&work.population, 0, bytemuck::cast_slice(&self.rows));
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                let workgroups = len.div_ceil(WORKGROUP) as u32;
                self.expand.dispatch(&mut pass, &work.bind_expand, len);
                pass.set_pipeline(&self.eval);
                pass.set_bind_group(0, &work.bind_eval, &[]);
                pass.dispatch_workgroups(workgroups, groups.1 as u32, 1);
                pass.set_pipeline(&self.reduce);
                pass.set_bind_group(0, &work.bind_reduce, &[]);
                pass.dispatch_workgroups(workgroups, 1, 1);
            }
            encoder.copy_buffer_to_buffer(&work.fitness, 0, &work.staging, 0, (len * 8) as u64);
            queue.submit([encoder.finish()]);
            self.ctx.read(&work.staging, &mut out[start..start + len])?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specialise_rewrites_the_named_constants_only() {
        let src = "const DU: u32 = 3u;\nconst DV: u32 = 3u;\nconst DUX: u32 = 1u;\nfn f() {}\n";
        let out = specialise(src, &[("DU", 5), ("DV", 0)]).unwrap();
        assert_eq!(
            out,
            "const DU: u32 = 5u;\nconst DV: u32 = 0u;\nconst DUX: u32 = 1u;\nfn f() {}\n"
        );
        assert!(specialise(src, &[("DIM", 2)]).is_err());
    }

    #[test]
    fn includes_are_spliced_and_unknown_ones_refused() {
        let out = source::expand("const A: u32 = 1u;\n// @include config.wgsl\nfn f() {}\n").unwrap();
        assert!(out.contains("struct Config {") && out.ends_with("fn f() {}\n"));
        assert!(source::expand("// @include nothing.wgsl\n").is_err());
    }

    #[test]
    fn every_shader_declares_what_the_evaluator_specialises() {
        let consts = [("DIM", 3), ("DU", 2), ("DV", 4), ("CROSS", 1), ("SEEDED", 1)];
        assert!(prepare(source::EVAL_PATCH, &consts).is_ok());
        assert!(prepare(source::DENSE_GRID, &consts[..3]).is_ok());
        assert!(prepare(source::EXPAND, &consts[..1]).is_ok());
    }
}
