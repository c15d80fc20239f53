//! The GPU ensemble engine: `shaders/ensemble.wgsl` on wgpu.
//!
//! One invocation integrates one instance in `f32`. Integration is split into bounded
//! dispatches (state stays in buffers between them) so that no submission holds the GPU for
//! long and a progress bar can move; then the reductions run on the GPU, and only the
//! per-instance results (plus, when asked, the stroboscopic tail) come back.
//!
//! The kernels are specialised with override constants (segment count, bumpers, piezo,
//! which series are recorded); a kernel whose metric is not requested is never created and
//! its buffers are not allocated (a 16-byte placeholder is bound instead).

pub mod layout;

use crate::config::Metric;
use crate::integrate::ensemble::EnsemblePlan;
use crate::model::Chain;
use anyhow::{Context, Result, anyhow, bail};
use layout::{GPU_MAX_SEGMENTS, GpuAccum, GpuControl, GpuInstanceParams};
use serde::Serialize;
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// The WGSL source of the ensemble kernels.
pub const ENSEMBLE_WGSL: &str = include_str!("../../../shaders/ensemble.wgsl");

/// Environment variable that turns "no GPU adapter" from a skip into a test failure.
pub const REQUIRE_GPU_ENV: &str = "PENDULUM_ATLAS_REQUIRE_GPU";

/// A wgpu device ready for the ensemble kernels.
pub struct GpuContext {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Adapter name, e.g. "NVIDIA H100 80GB HBM3" or "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub adapter_name: String,
    /// Backend name (Vulkan, Metal, Dx12).
    pub backend: String,
    /// Whether the adapter is a software rasteriser running on the CPU (lavapipe).
    pub is_software: bool,
    limits: wgpu::Limits,
}

/// Which adapters [`GpuContext::new`] may pick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterChoice {
    /// A hardware GPU if there is one, otherwise a software one.
    Any,
    /// Only a hardware GPU.
    HardwareOnly,
}

impl GpuContext {
    /// Open the best adapter: a discrete GPU, then an integrated one, then a software one
    /// (lavapipe) unless `choice` is [`AdapterChoice::HardwareOnly`].
    pub fn new(choice: AdapterChoice) -> Result<GpuContext> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::PRIMARY,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY));
        let rank = |t: wgpu::DeviceType| match t {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        };
        let adapter = adapters
            .into_iter()
            .filter(|a| {
                choice == AdapterChoice::Any || a.get_info().device_type != wgpu::DeviceType::Cpu
            })
            .min_by_key(|a| rank(a.get_info().device_type))
            .ok_or_else(|| {
                anyhow!(match choice {
                    AdapterChoice::Any => "no GPU adapter found (no Vulkan/Metal/DX12 driver). On Debian/Ubuntu `apt-get install mesa-vulkan-drivers` provides the software adapter lavapipe; or run with --backend cpu",
                    AdapterChoice::HardwareOnly => "no hardware GPU adapter found",
                })
            })?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("pendulum-atlas"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .with_context(|| format!("cannot open GPU device `{}`", info.name))?;
        Ok(GpuContext {
            device,
            queue,
            adapter_name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            is_software: info.device_type == wgpu::DeviceType::Cpu,
            limits,
        })
    }
}

/// Results of a GPU run.
#[derive(Debug, Clone)]
pub struct GpuRun {
    /// Accumulators and reductions per instance.
    pub accum: Vec<GpuAccum>,
    /// Stroboscopic α per instance (`strobe_stride` each), when read back.
    pub strobe: Vec<f32>,
    /// The uniform α series of R per instance (`r_stride` each), when read back.
    pub r_series: Vec<f32>,
    /// Wall time per stage.
    pub timings: GpuTimings,
    /// Dispatches of the integration kernel.
    pub dispatches: u32,
}

/// Wall time of each stage of a GPU run (s).
#[derive(Debug, Clone, Default, Serialize)]
pub struct GpuTimings {
    /// Shader compilation and pipeline creation.
    pub pipelines_s: f64,
    /// Buffer creation and upload.
    pub upload_s: f64,
    /// Integration dispatches.
    pub integrate_s: f64,
    /// Reduction kernels (R, K, period).
    pub reduce_s: f64,
    /// Copy back to the host.
    pub readback_s: f64,
}

/// What to read back besides the per-instance results.
#[derive(Debug, Clone, Copy, Default)]
pub struct GpuReadback {
    /// The stroboscopic samples (bifurcation diagrams, tests).
    pub strobe: bool,
    /// The R series before the reduction overwrites it (tests).
    pub r_series: bool,
}

/// Settings of the reductions, from the map scene.
#[derive(Debug, Clone)]
pub struct ReduceSettings {
    /// c values of the 0–1 test (rad).
    pub c_values: Vec<f64>,
    /// R in the paper's convention.
    pub paper_convention: bool,
    /// Longest period searched.
    pub period_max: u32,
    /// Trailing samples that must repeat.
    pub period_window: u32,
    /// Tolerance (rad).
    pub period_tol_rad: f64,
}

/// Loop iterations one invocation may run on a software adapter (lavapipe stops at 65535).
const SOFTWARE_LOOP_BUDGET: usize = 60_000;

/// Target wall time of one integration dispatch.
const DISPATCH_TARGET: Duration = Duration::from_millis(100);

/// Integrate and reduce every instance of `plan` on the GPU.
pub fn run_gpu(
    ctx: &GpuContext,
    plan: &EnsemblePlan,
    reduce: &ReduceSettings,
    readback: GpuReadback,
    progress: &dyn Fn(u64, u64),
) -> Result<GpuRun> {
    let n_inst = plan.instances.len();
    let n_seg = plan.segments;
    if n_seg > GPU_MAX_SEGMENTS {
        bail!(
            "the GPU kernel holds at most {GPU_MAX_SEGMENTS} segments, the scene has {n_seg}: use --backend cpu"
        );
    }
    if n_inst == 0 {
        bail!("the map has no instances");
    }
    let dev = &ctx.device;
    let mut timings = GpuTimings::default();
    let want_k = plan.metrics.contains(&Metric::K);
    let want_period = plan.metrics.contains(&Metric::Period);
    let run_k_kernel = want_k || want_period;
    let want_r = plan.want_rseries;
    let want_strobe = plan.want_strobe;

    // ---- sizes, checked against the device before anything is allocated ---------------
    let n_c = reduce.c_values.len().max(1);
    let strobe_stride = plan.strobe_stride.max(1);
    let n_cut_max = (plan.strobe_stride + 5) / 10;
    let rwork_stride = (if want_r { 2 * plan.r_stride } else { 0 }).max(if want_k {
        plan.strobe_stride + n_cut_max
    } else {
        0
    });
    let max_lever = plan
        .instances
        .iter()
        .map(|p| p.params.contact.as_ref().map_or(0, |c| c.levers_m.len()))
        .max()
        .unwrap_or(0);
    // lavapipe ends any shader invocation after 65535 loop iterations (all loops together):
    // bound every kernel's work per invocation on software adapters, or refuse clearly.
    let software_steps = if ctx.is_software {
        let per_step = 4 * (max_lever + 2 * n_seg + 2) + 3 * n_seg + 2 * max_lever + 8;
        let r_n = plan.r_stride as usize;
        let r_loops = 11 * r_n + r_n * (r_n.max(2).ilog2() as usize);
        let s_n = plan.strobe_stride as usize;
        let k_loops = s_n + s_n * n_cut_max as usize + 2 * n_cut_max as usize;
        let f_loops =
            n_c * n_c / 2 + n_c + (reduce.period_max as usize + 1) * reduce.period_window as usize;
        if want_r && r_loops > SOFTWARE_LOOP_BUDGET {
            bail!(
                "the software GPU adapter ({}) stops a shader after 65535 loop iterations; R on {r_n} samples needs about {r_loops}: set map.r_max_samples <= 1024, or use --backend cpu",
                ctx.adapter_name
            );
        }
        if want_k && k_loops > SOFTWARE_LOOP_BUDGET {
            bail!(
                "the software GPU adapter ({}) stops a shader after 65535 loop iterations; the 0-1 test on {s_n} stroboscopic samples needs about {k_loops}: shorten the run (fewer forcing periods after the transient) or use --backend cpu",
                ctx.adapter_name
            );
        }
        if run_k_kernel && f_loops > SOFTWARE_LOOP_BUDGET {
            bail!(
                "the software GPU adapter ({}) stops a shader after 65535 loop iterations: map.k_n_c = {n_c} is too many, use --backend cpu",
                ctx.adapter_name
            );
        }
        Some(((SOFTWARE_LOOP_BUDGET / per_step) as u64).max(1))
    } else {
        None
    };
    let state_len = 2 * n_seg + 1;
    let bytes = |count: usize, size: usize| -> Result<u64> {
        let b = (count as u64)
            .checked_mul(size as u64)
            .ok_or_else(|| anyhow!("buffer size overflows"))?;
        if b > ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size)
        {
            bail!(
                "the map needs a {b}-byte GPU buffer, more than the adapter allows ({} bytes): use a smaller grid, fewer map.r_max_samples or a shorter run",
                ctx.limits.max_storage_buffer_binding_size
            );
        }
        Ok(b.max(16))
    };
    let params_bytes = bytes(n_inst, std::mem::size_of::<GpuInstanceParams>())?;
    let state_bytes = bytes(n_inst * state_len, 4)?;
    let accum_bytes = bytes(n_inst, std::mem::size_of::<GpuAccum>())?;
    let strobe_bytes = if want_strobe {
        bytes(n_inst * strobe_stride as usize, 4)?
    } else {
        16
    };
    let rwork_bytes = if want_r || want_k {
        bytes(n_inst * rwork_stride as usize, 8)?
    } else {
        16
    };

    // ---- pipelines ---------------------------------------------------------------------
    let t0 = Instant::now();
    let wg: u32 = 64;
    let wg_k: u32 = ((16384 / (4 * n_c)) as u32).clamp(1, 64);
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    let constants: Vec<(&str, f64)> = vec![
        ("N_SEG", n_seg as f64),
        ("HAS_CONTACT", flag(plan.has_contact)),
        ("HAS_PIEZO", flag(plan.has_piezo)),
        ("WANT_STROBE", flag(want_strobe)),
        ("WANT_RSERIES", flag(want_r)),
        ("WANT_K", flag(want_k)),
        ("PAPER_CONVENTION", flag(reduce.paper_convention)),
        ("WG", wg as f64),
        ("WG_K", wg_k as f64),
        ("N_C", n_c as f64),
    ];
    let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("ensemble.wgsl"),
        source: wgpu::ShaderSource::Wgsl(ENSEMBLE_WGSL.into()),
    });
    let storage = |binding: u32, read_only: bool| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let bgl = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("ensemble"),
        entries: &[
            storage(0, true),
            storage(1, false),
            storage(2, false),
            storage(3, false),
            storage(4, false),
            storage(5, true),
            storage(7, false),
            wgpu::BindGroupLayoutEntry {
                binding: 6,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
        ],
    });
    let layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("ensemble"),
        bind_group_layouts: &[Some(&bgl)],
        immediate_size: 0,
    });
    let pipeline = |entry: &str| {
        dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        })
    };
    let integrate = pipeline("integrate");
    let reduce_r = want_r.then(|| [pipeline("r_alpha"), pipeline("r_cart"), pipeline("r_phase")]);
    let k_pass = want_k.then(|| pipeline("k_pass"));
    let k_final = run_k_kernel.then(|| pipeline("k_final"));
    timings.pipelines_s = t0.elapsed().as_secs_f64();

    // ---- buffers -----------------------------------------------------------------------
    let t0 = Instant::now();
    let gp: Vec<GpuInstanceParams> = plan
        .instances
        .iter()
        .map(GpuInstanceParams::from_plan)
        .collect();
    let mut state = vec![0f32; n_inst * state_len];
    let mut accum = Vec::with_capacity(n_inst);
    for (i, p) in plan.instances.iter().enumerate() {
        for (j, &v) in p.y0.iter().enumerate() {
            state[j * n_inst + i] = v as f32;
        }
        let chain: Chain<f32> = Chain::new(&p.params);
        let mut ws = chain.workspace();
        let y: Vec<f32> = p.y0.iter().map(|&v| v as f32).collect();
        let (r, l) = chain.touching(&mut ws, &y);
        accum.push(GpuAccum::initial(u32::from(r) | (u32::from(l) << 1)));
    }
    let turns: Vec<u32> = if want_k {
        reduce
            .c_values
            .iter()
            .map(|c| {
                let t = (c / std::f64::consts::TAU * 4294967296.0).round();
                t as u64 as u32
            })
            .collect()
    } else {
        vec![0; 4]
    };
    let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
        dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    let sto = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    debug_assert!(params_bytes >= 16 && state_bytes >= 16 && accum_bytes >= 16);
    let params_buf = init("params", bytemuck::cast_slice(&gp), sto);
    let state_buf = init("state", bytemuck::cast_slice(&state), sto);
    let accum_buf = init("accum", bytemuck::cast_slice(&accum), sto);
    let empty = |label: &str, size: u64| {
        dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: sto,
            mapped_at_creation: false,
        })
    };
    let strobe_buf = empty("strobe", strobe_bytes);
    let rwork_buf = empty("rwork", rwork_bytes);
    let kc_buf = empty("kc", if want_k { bytes(n_inst * n_c, 4)? } else { 16 });
    let turns_buf = init("c_turns", bytemuck::cast_slice(&turns), sto);
    let mut control = GpuControl {
        n_inst: n_inst as u32,
        steps_per_dispatch: 64,
        strobe_stride,
        rwork_stride,
        period_max: reduce.period_max,
        period_window: reduce.period_window,
        period_tol: reduce.period_tol_rad as f32,
        c_index: 0,
    };
    let control_buf = init(
        "control",
        bytemuck::bytes_of(&control),
        wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    );
    let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("ensemble"),
        layout: &bgl,
        entries: &[
            entry(0, &params_buf),
            entry(1, &state_buf),
            entry(2, &accum_buf),
            entry(3, &strobe_buf),
            entry(4, &rwork_buf),
            entry(5, &turns_buf),
            entry(6, &control_buf),
            entry(7, &kc_buf),
        ],
    });
    timings.upload_s = t0.elapsed().as_secs_f64();

    // ---- integration in bounded dispatches --------------------------------------------
    let t0 = Instant::now();
    let groups = (n_inst as u32).div_ceil(wg);
    let max_steps = plan
        .instances
        .iter()
        .map(|p| p.total_steps())
        .max()
        .unwrap_or(0);
    let mut done: u64 = 0;
    let mut chunk: u64 = 64;
    let mut dispatches = 0u32;
    while done < max_steps {
        let this = chunk
            .min(max_steps - done)
            .min(software_steps.unwrap_or(u64::MAX));
        control.steps_per_dispatch = this as u32;
        ctx.queue
            .write_buffer(&control_buf, 0, bytemuck::bytes_of(&control));
        let started = Instant::now();
        submit(ctx, &integrate, &bind, groups);
        wait(ctx)?;
        let took = started.elapsed();
        dispatches += 1;
        done += this;
        progress(done, max_steps);
        // Aim each dispatch at DISPATCH_TARGET, growing at most 4× at a time.
        let scale = DISPATCH_TARGET.as_secs_f64() / took.as_secs_f64().max(1e-6);
        chunk = ((this as f64 * scale.clamp(0.25, 4.0)) as u64).clamp(16, 1 << 22);
    }
    timings.integrate_s = t0.elapsed().as_secs_f64();

    // ---- series for tests, then reductions ---------------------------------------------
    let t0 = Instant::now();
    let r_series = if readback.r_series && want_r {
        let raw: Vec<[f32; 2]> = read_buffer(ctx, &rwork_buf, rwork_bytes)?;
        let mut out = vec![f32::NAN; n_inst * plan.r_stride as usize];
        for i in 0..n_inst {
            for j in 0..plan.r_stride as usize {
                out[i * plan.r_stride as usize + j] = raw[i * rwork_stride as usize + j][0];
            }
        }
        out
    } else {
        Vec::new()
    };
    let strobe = if readback.strobe && want_strobe {
        read_buffer::<f32>(ctx, &strobe_buf, strobe_bytes)?
    } else {
        Vec::new()
    };
    timings.readback_s += t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    if let Some(kernels) = &reduce_r {
        for p in kernels {
            submit(ctx, p, &bind, groups);
        }
        wait(ctx)?;
    }
    if let Some(p) = &k_pass {
        for ci in 0..n_c as u32 {
            control.c_index = ci;
            ctx.queue
                .write_buffer(&control_buf, 0, bytemuck::bytes_of(&control));
            submit(ctx, p, &bind, groups);
        }
        wait(ctx)?;
    }
    if let Some(p) = &k_final {
        submit(ctx, p, &bind, (n_inst as u32).div_ceil(wg_k));
        wait(ctx)?;
    }
    timings.reduce_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let accum: Vec<GpuAccum> = read_buffer(ctx, &accum_buf, accum_bytes)?;
    timings.readback_s += t0.elapsed().as_secs_f64();
    Ok(GpuRun {
        accum: accum[..n_inst].to_vec(),
        strobe,
        r_series,
        timings,
        dispatches,
    })
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

fn submit(ctx: &GpuContext, pipeline: &wgpu::ComputePipeline, bind: &wgpu::BindGroup, groups: u32) {
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(groups, 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
}

fn wait(ctx: &GpuContext) -> Result<()> {
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| anyhow!("GPU wait failed: {e}"))?;
    Ok(())
}

/// Copy a storage buffer to the host.
fn read_buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    src: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<T>> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    enc.copy_buffer_to_buffer(src, 0, &staging, 0, size);
    ctx.queue.submit([enc.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    wait(ctx)?;
    rx.recv()
        .map_err(|_| anyhow!("GPU readback was dropped"))?
        .map_err(|e| anyhow!("GPU readback failed: {e}"))?;
    let view = staging
        .get_mapped_range(..)
        .map_err(|e| anyhow!("GPU readback failed: {e:?}"))?;
    let out = bytemuck::cast_slice::<u8, T>(&view).to_vec();
    drop(view);
    staging.unmap();
    Ok(out)
}
