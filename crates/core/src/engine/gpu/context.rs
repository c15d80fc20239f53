//! The GPU device, opened once by the caller, with the kernels it has compiled: every batch of
//! a search, a bench or a reproduction reuses them.

use crate::engine::error::{EngineError, GpuFaultKind};
use crate::engine::gpu::kernels::{KernelKey, Kernels, shader_source};
use crate::model::ChainShape;
use std::cell::Cell;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Which adapters [`GpuContext::new`] may pick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterChoice {
    /// A hardware GPU if there is one, otherwise a software one.
    Any,
    /// Only a hardware GPU.
    HardwareOnly,
    /// The adapter at this index of [`list_adapters`].
    Index(usize),
}

/// One adapter wgpu sees, as `pendulum-atlas adapters` lists it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AdapterListing {
    /// Its index (`--adapter INDEX`, `--devices I,J`).
    pub index: usize,
    /// Adapter name.
    pub name: String,
    /// Backend (Vulkan, Metal, Dx12).
    pub backend: String,
    /// Discrete, integrated, virtual, other or CPU (software).
    pub device_type: String,
    /// A software adapter running on the CPU (lavapipe).
    pub is_software: bool,
}

fn adapters() -> Vec<wgpu::Adapter> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::PRIMARY,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY))
}

/// Every adapter wgpu finds on this machine, in the order `--adapter` counts them.
pub fn list_adapters() -> Vec<AdapterListing> {
    adapters()
        .iter()
        .enumerate()
        .map(|(index, a)| {
            let info = a.get_info();
            AdapterListing {
                index,
                name: info.name.clone(),
                backend: format!("{:?}", info.backend),
                device_type: format!("{:?}", info.device_type),
                is_software: info.device_type == wgpu::DeviceType::Cpu,
            }
        })
        .collect()
}

/// What the device reported outside an error scope: its loss (the device-lost callback) and
/// the first error no scope caught (the uncaptured-error handler, which otherwise panics).
#[derive(Debug, Default)]
struct Health {
    lost: Option<String>,
    error: Option<String>,
}

/// A wgpu device ready for the ensemble kernels, and the kernels compiled on it so far.
pub struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    /// Adapter name, e.g. "NVIDIA H100 80GB HBM3" or "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub adapter_name: String,
    /// Backend name (Vulkan, Metal, Dx12).
    pub backend: String,
    /// Whether the adapter is a software rasteriser running on the CPU (lavapipe).
    pub is_software: bool,
    /// Whether the device writes timestamps (`Features::TIMESTAMP_QUERY`).
    pub timestamps: bool,
    pub(crate) limits: wgpu::Limits,
    pub(crate) bind_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    /// Whether the kernels are built with wgpu's runtime checks ([`GpuContext::set_runtime_checks`]).
    runtime_checks: bool,
    /// One shader module per segment count (its arrays are sized by N) and runtime checks.
    modules: Mutex<HashMap<(ChainShape, bool), Arc<wgpu::ShaderModule>>>,
    kernels: Mutex<HashMap<KernelKey, Arc<Kernels>>>,
    health: Arc<Mutex<Health>>,
    /// The read-back buffer, kept across dispatches and runs and grown when too small.
    pub(crate) staging: Mutex<Option<wgpu::Buffer>>,
    /// Held around every submit and poll of this device. wgpu-core 30 reads the fence and
    /// then retires finished submissions without a lock between: when one thread's bounded
    /// wait times out just as its submission ends, and another thread's submit or poll retires
    /// it in between, the first thread's poll panics ("the current submission index should be
    /// at least the wait submission index"). Seen with two test threads sharing lavapipe.
    poll_lock: Mutex<()>,
}

thread_local! {
    /// Queue submissions this thread has made (a run's GPU work happens on its calling
    /// thread, so its counts are not mixed with those of runs on other threads sharing the
    /// device).
    static SUBMISSIONS: Cell<u64> = const { Cell::new(0) };
    /// Bytes this thread has copied back to the host.
    static READ_BACK: Cell<u64> = const { Cell::new(0) };
}

/// What the calling thread has done on GPU devices so far: submissions and bytes read back
/// (a run reports the difference over it).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DeviceCounts {
    /// Queue submissions.
    pub submissions: u64,
    /// Bytes copied back to the host.
    pub read_back_bytes: u64,
}

impl DeviceCounts {
    /// The work done since `before`.
    pub fn since(self, before: DeviceCounts) -> DeviceCounts {
        DeviceCounts {
            submissions: self.submissions - before.submissions,
            read_back_bytes: self.read_back_bytes - before.read_back_bytes,
        }
    }
}

impl GpuContext {
    /// Open the best adapter: a discrete GPU, then an integrated one, then a software one
    /// (lavapipe) unless `choice` is [`AdapterChoice::HardwareOnly`].
    pub fn new(choice: AdapterChoice) -> Result<GpuContext, EngineError> {
        let adapter = pick_adapter(choice)?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        // The adapter's own clock, where it has one (`clock.rs`): kernel time beside wall time.
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("pendulum-atlas"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| EngineError::DeviceOpen {
            adapter: info.name.clone(),
            message: e.to_string(),
        })?;
        let health = Arc::new(Mutex::new(Health::default()));
        watch_health(&device, &health);
        let bind_layout = bind_group_layout(&device);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ensemble"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        Ok(GpuContext {
            device,
            queue,
            adapter_name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            is_software: info.device_type == wgpu::DeviceType::Cpu,
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
            limits,
            bind_layout,
            pipeline_layout,
            runtime_checks: false,
            modules: Mutex::new(HashMap::new()),
            kernels: Mutex::new(HashMap::new()),
            health,
            staging: Mutex::new(None),
            poll_lock: Mutex::new(()),
        })
    }

    /// Submit `commands` to the queue, counted; the index to wait for.
    pub(crate) fn submit(&self, commands: wgpu::CommandBuffer) -> wgpu::SubmissionIndex {
        SUBMISSIONS.with(|c| c.set(c.get() + 1));
        let _held = self.poll_lock.lock().unwrap_or_else(|e| e.into_inner());
        self.queue.submit([commands])
    }

    /// Poll the device as `poll` says, alone among this process's submits and polls of it
    /// (see `poll_lock`).
    pub(crate) fn poll(&self, poll: wgpu::PollType) -> Result<wgpu::PollStatus, wgpu::PollError> {
        let _held = self.poll_lock.lock().unwrap_or_else(|e| e.into_inner());
        self.device.poll(poll)
    }

    /// Count `bytes` copied back to the host.
    pub(crate) fn count_read_back(&self, bytes: u64) {
        READ_BACK.with(|c| c.set(c.get() + bytes));
    }

    /// Submissions and bytes read back by the calling thread so far.
    pub fn counts(&self) -> DeviceCounts {
        DeviceCounts {
            submissions: SUBMISSIONS.with(Cell::get),
            read_back_bytes: READ_BACK.with(Cell::get),
        }
    }

    /// The device's loss or an uncaptured error, as a fault (sized by the caller).
    pub(crate) fn health(&self) -> Result<(), EngineError> {
        let h = self.health.lock().unwrap_or_else(|e| e.into_inner());
        let fault = |kind, message: &String| EngineError::GpuFault {
            adapter: self.adapter_name.clone(),
            kind,
            message: message.clone(),
            instances: 0,
            segments: 0,
            mib: 0.0,
        };
        if let Some(m) = &h.lost {
            return Err(fault(GpuFaultKind::Lost, m));
        }
        if let Some(m) = &h.error {
            let kind = if m.contains("out of memory") || m.contains("Out of Memory") {
                GpuFaultKind::OutOfMemory
            } else {
                GpuFaultKind::Validation
            };
            return Err(fault(kind, m));
        }
        Ok(())
    }

    /// A fault of `kind` on this device (sized by the caller).
    pub(crate) fn fault(&self, kind: GpuFaultKind, message: String) -> EngineError {
        EngineError::GpuFault {
            adapter: self.adapter_name.clone(),
            kind,
            message,
            instances: 0,
            segments: 0,
            mib: 0.0,
        }
    }

    /// Lose the device on purpose (the `lose_device` failpoint): wgpu destroys it, and its
    /// device-lost callback and every later wait see a lost device.
    pub(crate) fn lose(&self) {
        self.device.destroy();
    }

    /// Build the kernels with wgpu's runtime checks (`on`: bounds checks on every index and
    /// loops bounded by the compiler), or without them (the default, see
    /// `GpuContext::module`). The engine suite runs maps both ways and compares them.
    pub(crate) fn set_runtime_checks(&mut self, on: bool) {
        self.runtime_checks = on;
    }

    /// Whether the kernels are built with wgpu's runtime checks.
    pub fn runtime_checks(&self) -> bool {
        self.runtime_checks
    }

    /// The kernels of `key`, compiled on first use and cached.
    pub fn kernels(&self, key: &KernelKey) -> Arc<Kernels> {
        let mut cache = self.kernels.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(*key)
            .or_insert_with(|| {
                let module = self.module(key.chain, key.runtime_checks);
                Arc::new(Kernels::compile(
                    &self.device,
                    &self.pipeline_layout,
                    &module,
                    key,
                ))
            })
            .clone()
    }

    /// The shader module of chains of `segments` segments, compiled on first use,
    /// with wgpu's runtime checks where `checked`.
    ///
    /// Without them (the default) the module is trusted: wgpu adds no bounds check to an index
    /// and no bound to a loop. That is sound because every index of the kernels is in range
    /// by construction, and every loop ends:
    /// - the per-invocation arrays are sized by the scene's N (`MAX_SEG`, the generated
    ///   header) and indexed by segment loops `i < N_SEG` (N_SEG = N) or the lever count
    ///   (the contact segment + 1, at most N: `ContactParams::on_chain`);
    /// - the cooperative kernel's workgroup arrays are sized by `MAX_SEG` too, and indexed by
    ///   its owners' loops `i = lane; i < N_SEG; i += WGC`, lane 0's loops `i < N_SEG`, and
    ///   stage indices below 4 (`w_fth[j]`, j a stage of the four);
    /// - each storage buffer is indexed by instance `i < n_inst` (the `live` list holds
    ///   instances of the batch only) and, per instance, by sample `j` below the stride the
    ///   buffer was sized with (`Sizes`: the plan's largest strobe, R and early-stop counts);
    /// - the IMEX matrices by `P.imex_offset` plus rows and columns below N, within the
    ///   buffer's sets (`InstancePlan::imex_key`);
    /// - every loop runs over a counter to a bound read from the plan, the control block or a
    ///   constant, and the insertion sort of `k_final` moves down to index 0 at most.
    ///
    /// The engine suite runs maps with the checks on and off and requires the same bits.
    fn module(&self, shape: ChainShape, checked: bool) -> Arc<wgpu::ShaderModule> {
        let mut modules = self.modules.lock().unwrap_or_else(|e| e.into_inner());
        modules
            .entry((shape, checked))
            .or_insert_with(|| {
                let desc = wgpu::ShaderModuleDescriptor {
                    label: Some("ensemble kernels"),
                    source: wgpu::ShaderSource::Wgsl(shader_source(shape).into()),
                };
                Arc::new(if checked {
                    self.device.create_shader_module(desc)
                } else {
                    // SAFETY: every index of the kernels is in range and every loop ends, by
                    // construction (see above); the checked build gives the same results.
                    unsafe {
                        self.device.create_shader_module_trusted(
                            desc,
                            wgpu::ShaderRuntimeChecks::unchecked(),
                        )
                    }
                })
            })
            .clone()
    }

    /// Number of distinct kernel sets compiled so far.
    pub fn compiled_kernel_sets(&self) -> usize {
        self.kernels.lock().map_or(0, |c| c.len())
    }
}

/// Record the device's loss and the errors no scope catches in `health`, instead of wgpu's
/// default handler (a panic).
fn watch_health(device: &wgpu::Device, health: &Arc<Mutex<Health>>) {
    let h = health.clone();
    device.set_device_lost_callback(move |reason, message| {
        let mut h = h.lock().unwrap_or_else(|e| e.into_inner());
        let reason = match reason {
            wgpu::DeviceLostReason::Destroyed => "the device was destroyed",
            _ => "the driver reported the device lost",
        };
        h.lost.get_or_insert(if message.is_empty() {
            reason.to_string()
        } else {
            format!("{reason}: {message}")
        });
    });
    let h = health.clone();
    device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
        let mut h = h.lock().unwrap_or_else(|e| e.into_inner());
        h.error.get_or_insert(error.to_string());
    }));
}

/// The adapter of highest rank that `choice` allows.
fn pick_adapter(choice: AdapterChoice) -> Result<wgpu::Adapter, EngineError> {
    let adapters = adapters();
    if let AdapterChoice::Index(i) = choice {
        let count = adapters.len();
        return adapters
            .into_iter()
            .nth(i)
            .ok_or(EngineError::NoSuchAdapter { index: i, count });
    }
    let rank = |t: wgpu::DeviceType| match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    adapters
        .into_iter()
        .filter(|a| {
            choice == AdapterChoice::Any || a.get_info().device_type != wgpu::DeviceType::Cpu
        })
        .min_by_key(|a| rank(a.get_info().device_type))
        .ok_or(EngineError::NoAdapter {
            hardware_only: choice == AdapterChoice::HardwareOnly,
        })
}

/// Bindings 0–12 of the kernels (see `shaders/common.wgsl`; 12 the contact levers).
fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
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
    let uniform = wgpu::BindGroupLayoutEntry {
        binding: 6,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("ensemble"),
        entries: &[
            storage(0, true),
            storage(1, false),
            storage(2, false),
            storage(3, false),
            storage(4, false),
            storage(5, true),
            storage(7, false),
            storage(8, true),
            storage(9, false),
            storage(10, false),
            storage(11, false),
            storage(12, true),
            storage(13, false),
            uniform,
        ],
    })
}
