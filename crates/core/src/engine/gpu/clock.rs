//! Kernel time from the adapter's own clock, where it has one (`Features::TIMESTAMP_QUERY`):
//! the device writes a timestamp where each integration dispatch begins and ends, so that a
//! study reports the kernels' time beside the wall time of the dispatch loop, measured as a
//! CUDA event pair around a kernel measures it (`GpuTimings::integrate_kernel_s`).

use super::{GpuContext, read_buffer};
use crate::engine::error::EngineError;

/// The query set and resolve buffer of one run's dispatches, and the time summed so far.
pub(crate) struct KernelClock {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    /// Nanoseconds per tick of the device's timestamps.
    period_ns: f64,
    /// Kernel time summed over the dispatches measured (s).
    pub(crate) total_s: f64,
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
            count: 2,
        });
        let resolved = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kernel clock"),
            size: 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(KernelClock {
            set,
            resolved,
            period_ns: f64::from(ctx.queue.get_timestamp_period()),
            total_s: 0.0,
        })
    }

    /// The pass's timestamps: its beginning and its end.
    pub(crate) fn writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// Resolve the pass's timestamps into the buffer read by [`KernelClock::add`], after the
    /// pass in `enc`.
    pub(crate) fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&self.set, 0..2, &self.resolved, 0);
    }

    /// Add the pass just waited for to the total.
    pub(crate) fn add(&mut self, ctx: &GpuContext) -> Result<(), EngineError> {
        let ticks: Vec<u64> = read_buffer(ctx, &self.resolved, 16)?;
        let elapsed = ticks[1].saturating_sub(ticks[0]) as f64;
        self.total_s += elapsed * self.period_ns * 1e-9;
        Ok(())
    }
}
