//! The reductions in slices: every reduction pass runs over the instances in dispatches of at
//! most a slice of them, the slice sized so that one dispatch takes about
//! `DISPATCH_TARGET` of wall time, as the integration's dispatches do
//! (a long single dispatch is what a desktop GPU's watchdog kills).
//!
//! 1. **Probe.** Up to `PROBE_INSTANCES` instances a pass is one dispatch, as small as the
//!    probe itself, and every pass of a stage goes in one submission. Above, the first pass
//!    runs alone over the first `PROBE_INSTANCES` instances and is timed.
//! 2. **Slices.** The slice is the instances that time says fit in the target (at least
//!    `MIN_SLICE`); the rest of the first pass, then every later pass, slice by slice, go in
//!    one encoder and one submission. Before each dispatch a copy writes its `(c_index,
//!    slice_first, slice_end)` into the control block (copies and passes run in encoder order).
//!
//! A pass never reads another instance's words, so a slice's results are those of the whole
//! dispatch, bit for bit (tested with slices of three instances, and with a probe of four).

use super::{DISPATCH_TARGET, GpuContext, record_pass, wait};
use crate::engine::error::EngineError;
use crate::engine::gpu::buffers::Buffers;
use crate::engine::gpu::layout::GpuControl;
use std::time::Instant;

/// Instances of the timed first dispatch; a stage with fewer runs unsliced.
pub(crate) const PROBE_INSTANCES: u32 = 16_384;

/// Fewest instances of a slice.
pub(crate) const MIN_SLICE: u32 = 1024;

/// How a stage is sliced, where a caller chooses (tests); by default a stage of more than
/// `PROBE_INSTANCES` instances is probed over that many, a smaller one runs unsliced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slicing {
    /// Dispatches of exactly this many instances.
    Fixed(u32),
    /// The first pass timed over this many instances, the slices sized from it.
    Probe(u32),
}

/// One pass of a stage: its pipeline, workgroup size and the c value it works on.
pub(crate) struct Pass<'a> {
    /// The kernel.
    pub pipeline: &'a wgpu::ComputePipeline,
    /// Its workgroup size.
    pub wg: u32,
    /// `c_index` of the control block (the 0–1 test's c value; 0 elsewhere).
    pub c_index: u32,
}

/// Run `passes` in order over every instance, sliced as `slicing` says (`None`: the default).
pub(crate) fn run_passes(
    ctx: &GpuContext,
    bufs: &Buffers,
    control: &GpuControl,
    passes: &[Pass<'_>],
    slicing: Option<Slicing>,
) -> Result<(), EngineError> {
    let n = control.n_inst;
    let Some(first) = passes.first() else {
        return Ok(());
    };
    let slicing = slicing.unwrap_or(match n <= PROBE_INSTANCES {
        true => Slicing::Fixed(n),
        false => Slicing::Probe(PROBE_INSTANCES),
    });
    let (size, probed) = match slicing {
        Slicing::Fixed(s) => (s.max(1), 0),
        Slicing::Probe(k) => {
            let k = k.clamp(1, n.max(1));
            (probe(ctx, bufs, control, first, k)?, k)
        }
    };
    let mut dispatches = Vec::new();
    for (k, pass) in passes.iter().enumerate() {
        let start = if k == 0 { probed } else { 0 };
        let mut a = start;
        while a < n {
            let b = n.min(a.saturating_add(size));
            dispatches.push((k, [pass.c_index, a, b]));
            a = b;
        }
    }
    let done = record_dispatches(ctx, bufs, control, passes, &dispatches);
    wait(ctx, done)?;
    // The control block as the other kernels expect it: every instance.
    ctx.queue
        .write_buffer(&bufs.control, 0, bytemuck::bytes_of(control));
    Ok(())
}

/// Time `pass` over the first `k` instances alone; the slice that fits in the target.
fn probe(
    ctx: &GpuContext,
    bufs: &Buffers,
    control: &GpuControl,
    pass: &Pass<'_>,
    k: u32,
) -> Result<u32, EngineError> {
    let started = Instant::now();
    let done = record_dispatches(
        ctx,
        bufs,
        control,
        std::slice::from_ref(pass),
        &[(0, [pass.c_index, 0, k])],
    );
    wait(ctx, done)?;
    let per_instance = started.elapsed().as_secs_f64() / f64::from(k);
    let fits = DISPATCH_TARGET.as_secs_f64() / per_instance.max(1e-12);
    Ok(fits
        .max(f64::from(MIN_SLICE))
        .min(f64::from(control.n_inst.max(1))) as u32)
}

/// One encoder and one submission: before each dispatch, a copy of its `(c_index,
/// slice_first, slice_end)` into the control block.
fn record_dispatches(
    ctx: &GpuContext,
    bufs: &Buffers,
    control: &GpuControl,
    passes: &[Pass<'_>],
    dispatches: &[(usize, [u32; 3])],
) -> wgpu::SubmissionIndex {
    let words: Vec<u32> = dispatches.iter().flat_map(|d| d.1).collect();
    let src = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("slices"),
        size: 4 * words.len().max(3) as u64,
        usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.queue
        .write_buffer(&src, 0, bytemuck::cast_slice(&words));
    ctx.queue
        .write_buffer(&bufs.control, 0, bytemuck::bytes_of(control));
    let field = std::mem::offset_of!(GpuControl, c_index) as u64;
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("reduce"),
        });
    for (d, (k, [_, a, b])) in dispatches.iter().enumerate() {
        enc.copy_buffer_to_buffer(&src, 12 * d as u64, &bufs.control, field, 12);
        record_pass(
            &mut enc,
            passes[*k].pipeline,
            &bufs.bind,
            (b - a).div_ceil(passes[*k].wg),
        );
    }
    ctx.submit(enc.finish())
}
