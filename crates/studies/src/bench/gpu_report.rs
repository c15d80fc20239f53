//! Files of `bench --throughput`: `GPU.md` and `gpu_throughput.json`.

use super::gpu_throughput::{GpuPeerRow, LadderRow, MetricRow, ThroughputReport, ThroughputScene};
use pendulum_atlas_core::engine::gpu::kernels::GpuKernel;
use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{create_dir, write_bytes, write_json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Write the study's files into `dir`: `GPU.md`, then the manifest `gpu_throughput.json`.
pub fn write_throughput(dir: &Path, r: &ThroughputReport) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    Ok(vec![
        write_bytes(&dir.join("GPU.md"), markdown(r).as_bytes())?,
        write_json(&dir.join("gpu_throughput.json"), r)?,
    ])
}

fn opt(x: Option<f64>, f: impl Fn(f64) -> String) -> String {
    x.map_or("–".into(), f)
}

fn mib(b: Option<u64>) -> String {
    b.map_or("–".into(), |b| {
        format!("{:.1}", b as f64 / (1024.0 * 1024.0))
    })
}

/// The report in Markdown.
pub fn markdown(r: &ThroughputReport) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Ensemble throughput on {}\n\nMachine: {}. Written by `pendulum-atlas bench \
--throughput` in {:.0} s (row budget {} s).\n",
        r.adapter.as_deref().unwrap_or("the CPU engine"),
        r.machine,
        r.total_s,
        r.row_budget_s
    );
    let _ = writeln!(
        md,
        "FP32 peak: {}.\n",
        r.peak
            .as_ref()
            .map_or("unknown (pass --peak-tflops)".into(), |(p, src)| format!(
                "{:.3} TFLOP/s, from {src}",
                p / 1e12
            ))
    );
    flops_section(&mut md, r);
    ladder_section(&mut md, &r.rows);
    metric_section(&mut md, &r.metrics);
    peer_section(&mut md, r);
    md
}

fn flops_section(md: &mut String, r: &ThroughputReport) {
    md.push_str(
        "## Counted work per step\n\nThe table of crates/studies/src/bench/cost.rs, which the lab counted \
by running the engine's own step (`rk4_step`, `Imex::step_with`) on a number type that counts its \
operations, with a bumper pressed (benches/src/flops.rs, checked at every N to 64); a sin/cos pair \
counts as 26 flop, a division as 1.\n\n\
| method | N | flop per step | flop per segment-step | sin/cos pairs | divisions |\n\
|---|---|---|---|---|---|\n",
    );
    for (m, c) in &r.flops {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.0} | {} | {} |",
            m.name(),
            c.segments,
            c.flop_per_step,
            c.flop_per_segment_step,
            c.sin_cos,
            c.divisions
        );
    }
    md.push('\n');
}

fn ladder_section(md: &mut String, rows: &[LadderRow]) {
    md.push_str(
        "## Integration throughput\n\nOne forcing period per instance from rest in the well \
(the default map's plane at 11-12 Hz; the paper's scene at 7.5-8.5 Hz, 8-10 mm), α range \
only, so the integration kernel is what is timed (one untimed pilot of 64 instances first). \
A rung runs until it ends or passes the row budget; one stopped there (its integration time \
marked with the share of its steps taken) gives the rate of the steps it took, and the larger \
rungs are skipped. \
RK4 on the earlier damping reading (ζ1 = 0.0035), IMEX on the library reading. Memory: the \
per-instance device buffers; a rung they would make larger than the adapter binds runs in \
consecutive batches, and its memory is that of the largest batch.\n\n\
| engine | kernel | scene | N | method | instances | steps/instance | integration (s) | \
instance-steps/s | kernel (s) | instance-steps/s of kernel | segment-steps/s | GFLOP/s | \
of peak | memory (MiB) |\n\
|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        if let Some(why) = &r.skipped {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {:.0} | skipped: {why} ||||||||",
                r.engine,
                kernel_name(r),
                r.scene.name(),
                r.segments,
                r.method.name(),
                r.instances,
                r.steps_per_instance
            );
            continue;
        }
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {:.0} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.engine,
            kernel_name(r),
            r.scene.name(),
            r.segments,
            r.method.name(),
            r.instances,
            r.steps_per_instance,
            opt(r.integrate_s, |v| match r.stopped_at {
                Some(f) => format!("{v:.3} (stopped at {:.0} %)", 100.0 * f),
                None => format!("{v:.3}"),
            }),
            opt(r.instance_steps_per_s, |v| format!("{v:.3e}")),
            opt(r.kernel_s, |v| format!("{v:.3}")),
            opt(r.kernel_instance_steps_per_s, |v| format!("{v:.3e}")),
            opt(r.segment_steps_per_s, |v| format!("{v:.3e}")),
            opt(r.flop_per_s, |v| format!("{:.1}", v / 1e9)),
            opt(r.share_of_peak, |v| format!("{:.1} %", 100.0 * v)),
            mib(r.device_bytes)
        );
    }
    md.push('\n');
    best_section(md, rows);
}

/// The GPU kernel of a row (`-` on the CPU engine).
fn kernel_name(r: &LadderRow) -> &'static str {
    r.kernel.map_or("-", GpuKernel::name)
}

/// The best rate per engine, kernel, N and method (default scene).
fn best_section(md: &mut String, rows: &[LadderRow]) {
    md.push_str("Best rate of the default scene per engine, kernel, N and method:\n\n");
    let mut seen: Vec<(&str, &str, usize, Method)> = Vec::new();
    for r in rows.iter().filter(|r| r.scene == ThroughputScene::Default) {
        let key = (r.engine.as_str(), kernel_name(r), r.segments, r.method);
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        let best = rows
            .iter()
            .filter(|x| {
                x.scene == ThroughputScene::Default
                    && (x.engine.as_str(), kernel_name(x), x.segments, x.method) == key
            })
            .filter(|x| x.instance_steps_per_s.is_some())
            .max_by(|a, b| {
                a.instance_steps_per_s
                    .partial_cmp(&b.instance_steps_per_s)
                    .unwrap()
            });
        if let Some(b) = best {
            let _ = writeln!(
                md,
                "- {}{}, N = {}, {}: {} instance-steps/s at {} instances{}",
                b.engine,
                b.kernel
                    .map_or(String::new(), |k| format!(" ({} kernel)", k.name())),
                b.segments,
                b.method.name(),
                opt(b.instance_steps_per_s, |v| format!("{v:.3e}")),
                b.instances,
                b.share_of_peak.map_or(String::new(), |s| format!(
                    " ({:.1} % of the FP32 peak)",
                    100.0 * s
                ))
            );
        }
    }
    md.push('\n');
}

fn metric_section(md: &mut String, rows: &[MetricRow]) {
    md.push_str(
        "## Metrics a scene does not need: K only against all metrics\n\n256 instances \
spread over the default map at its own horizon (34 s, 10 s of transient), the method auto \
picks; warm (one untimed run first), median of 3. All metrics are K, R, period, hops, impacts \
and α range. K needs the same integration as every other metric and is itself the costliest \
reduction (n_c = 100 passes of an O(n · n/10) sum per instance), so K only can save no more \
than the integration's bookkeeping of the R series plus the R and period reductions. The \
last column is the measured speed-up: the all-metrics run over the K-only run.\n\n\
| engine | N | method | integration all / K (s) | reductions all / K (s) | all metrics (s) | \
K only (s) | speed-up |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        match (&r.all, &r.k_only, &r.skipped) {
            (Some(a), Some(k), _) => {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {:.3} / {:.3} | {:.3} / {:.3} | {:.3} | {:.3} | {:.2}x |",
                    r.engine,
                    r.segments,
                    r.method.name(),
                    a.integrate_s,
                    k.integrate_s,
                    a.reduce_s,
                    k.reduce_s,
                    a.total_s(),
                    k.total_s(),
                    a.total_s() / k.total_s()
                );
            }
            (_, _, Some(why)) => {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | skipped: {why} |||||",
                    r.engine,
                    r.segments,
                    r.method.name()
                );
            }
            _ => {}
        }
    }
    md.push('\n');
}

fn peer_section(md: &mut String, r: &ThroughputReport) {
    md.push_str("## Peers on the same device\n\n");
    if r.peers.is_empty() {
        md.push_str("No peer results given (`--peers DIR`, see benches/peers/README.md).\n");
        return;
    }
    md.push_str(
        "Each peer integrates the peer case of its N (`peer_case_N*.json` of `pendulum-atlas-lab \
peer-cases`, tiled) with RK4 in f32; its check is the largest |Δy| against our f64 \
state after the case's steps. Ours: the best ladder rate of the default scene with RK4 on the \
same engine at the same N and instance count, where measured.\n\n\
| peer | variant | device | N | instances | steps | instance-steps/s | check | ours / peer | \
ours by kernel time / peer |\n\
|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for p in &r.peers {
        let ours = ours_for(r, p, |x| x.instance_steps_per_s);
        let kernel = ours_for(r, p, |x| x.kernel_instance_steps_per_s);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {:.3e} | {:.1e} | {} | {} |",
            p.peer,
            p.variant,
            p.device,
            p.segments,
            p.instances,
            p.steps,
            p.instance_steps_per_s,
            p.check_max_abs_err,
            opt(ours, |o| format!("{:.2}x", o / p.instance_steps_per_s)),
            opt(kernel, |o| format!("{:.2}x", o / p.instance_steps_per_s))
        );
    }
    md.push('\n');
}

/// Our rate for a peer's row (`rate` of the row: by wall or by kernel time): the GPU ladder's
/// default scene, RK4, thread kernel, same N and instances.
fn ours_for(
    r: &ThroughputReport,
    p: &GpuPeerRow,
    rate: impl Fn(&LadderRow) -> Option<f64>,
) -> Option<f64> {
    r.rows
        .iter()
        .filter(|x| {
            Some(&x.engine) == r.adapter.as_ref()
                && x.scene == ThroughputScene::Default
                && x.kernel == Some(GpuKernel::Thread)
                && x.method == Method::Rk4
                && x.segments == p.segments
                && x.instances == p.instances
        })
        .find_map(rate)
}
