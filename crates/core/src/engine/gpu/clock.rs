//! Kernel time from the adapter's own clock, where it has one (`Features::TIMESTAMP_QUERY`):
//! the device writes a timestamp where each integration dispatch begins and ends, so that a
//! study reports the kernels' time beside the wall time of the dispatch loop, measured as a
//! CUDA event pair around a kernel measures it (`GpuTimings::integrate_kernel_s`).
//!
//! The timestamps of up to [`PAIRS`] dispatches are kept on the device and read back together,
//! so that the clock adds no round trip per dispatch to the loop it measures.

use super::{GpuContext, read_buffer};
use crate::engine::error::EngineError;

/// Dispatches whose timestamps the device holds before they are read back.
const PAIRS: u32 = 64;

/// The query set and resolve buffer of one run's dispatches, and the time summed so far.
pub(crate) struct KernelClock {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    /// Nanoseconds per tick of the device's timestamps.
    period_ns: f64,
    /// Dispatches timed on the device and not yet read back (< [`PAIRS`]).
    held: u32,
    /// Kernel time summed over the dispatches read back (s).
    total_s: f64,
}

impl KernelClock {
    /// A clock on `ctx`'s device, or `None` where the adapter has no timestamps.
    pub(crate) fn new(ctx: &GpuContext) -> Option<KernelClock> {
        if !ctx.timestamps {
            return None;
        }
        let set = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel clock"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * PAIRS,
        });
        let resolved = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kernel clock"),
            size: 16 * u64::from(PAIRS),
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(KernelClock {
            set,
            resolved,
            period_ns: f64::from(ctx.queue.get_timestamp_period()),
            held: 0,
            total_s: 0.0,
        })
    }

    /// The next pass's timestamps: where it begins and where it ends.
    pub(crate) fn writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(2 * self.held),
            end_of_pass_write_index: Some(2 * self.held + 1),
        }
    }

    /// Count the pass just submitted; read the held timestamps back once [`PAIRS`] are held.
    pub(crate) fn add(&mut self, ctx: &GpuContext) -> Result<(), EngineError> {
        self.held += 1;
        match self.held {
            PAIRS => self.read(ctx),
            _ => Ok(()),
        }
    }

    /// The kernel time of every pass counted, read back once the last has finished (s).
    pub(crate) fn finish(mut self, ctx: &GpuContext) -> Result<f64, EngineError> {
        self.read(ctx)?;
        Ok(self.total_s)
    }

    /// Resolve the held timestamps, read them and add their spans to the total.
    fn read(&mut self, ctx: &GpuContext) -> Result<(), EngineError> {
        if self.held == 0 {
            return Ok(());
        }
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        enc.resolve_query_set(&self.set, 0..2 * self.held, &self.resolved, 0);
        ctx.submit(enc.finish());
        let ticks: Vec<u64> = read_buffer(ctx, &self.resolved, 16 * u64::from(self.held))?;
        let elapsed: u64 = ticks
            .chunks_exact(2)
            .map(|t| t[1].saturating_sub(t[0]))
            .sum();
        self.total_s += elapsed as f64 * self.period_ns * 1e-9;
        self.held = 0;
        Ok(())
    }
}
