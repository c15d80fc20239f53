//! Files of `bench --cpu-throughput`: `CPU.md` and `cpu_throughput.json`.

use super::cpu_throughput::{CpuThroughputReport, ThroughputRow};
use pendulum_atlas_core::engine::{CpuLoop, Precision};
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{create_dir, write_bytes, write_json};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Write the study's files into `dir`: `CPU.md`, then the manifest.
pub fn write_cpu_throughput(
    dir: &Path,
    r: &CpuThroughputReport,
) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    let md = write_bytes(&dir.join("CPU.md"), markdown(r).as_bytes())?;
    Ok(vec![md, write_json(&dir.join("cpu_throughput.json"), r)?])
}

fn row(
    r: &CpuThroughputReport,
    n: usize,
    l: CpuLoop,
    p: Precision,
    threads: usize,
) -> Option<&ThroughputRow> {
    r.rows
        .iter()
        .find(|x| x.segments == n && x.cpu_loop == l && x.precision == p && x.threads == threads)
}

fn pct(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| format!("{:.1} %", 100.0 * v))
}

/// The report in Markdown.
pub fn markdown(r: &CpuThroughputReport) -> String {
    let mut md = String::new();
    let ghz = r
        .ceiling
        .ghz
        .map_or("unknown".into(), |g| format!("{g:.2} GHz"));
    let _ = writeln!(
        md,
        "# CPU engine throughput\n\nMachine: {} ({} cores at {ghz} as /proc/cpuinfo reports it). \
Written by `pendulum-atlas bench --cpu-throughput{}` in {:.0} s.\n",
        r.machine,
        r.ceiling.cores,
        if r.peers.is_empty() {
            ""
        } else {
            " --peers DIR"
        },
        r.total_s
    );
    flop_table(&mut md, r);
    grid_table(&mut md, r);
    map_table(&mut md, r);
    peer_table(&mut md, r);
    md
}

fn flop_table(md: &mut String, r: &CpuThroughputReport) {
    let _ = writeln!(
        md,
        "## Flop per step\n\nThe table of `crates/studies/src/bench/cost.rs`, which the lab counted by \
running the engine's RK4 step (`rk4_step`, the function both loops call) on a number type that \
counts its operations (`benches/src/flops.rs`, checked at every N to 64), at a state pressing a \
bumper; a sin/cos pair counts {} flop (the floating-point operations of `wide`'s \
polynomial), a division 1.\n\n| N | add/sub/mul/neg/max | div | sin/cos | flop per step | flop per segment-step |\n|---|---|---|---|---|---|",
        super::cost::SIN_COS_FLOP
    );
    for f in &r.flops {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {:.0} |",
            f.segments,
            f.arithmetic,
            f.divisions,
            f.sin_cos,
            f.flop_per_step,
            f.flop_per_segment_step
        );
    }
    let c = &r.ceiling;
    let ceil = |p: Precision| {
        c.flop_per_s(p, c.cores)
            .map_or("unknown".into(), |v| format!("{v:.3e} flop/s"))
    };
    let _ = writeln!(
        md,
        "\nCeiling: cores × clock × the FMA peak at the engine's vector width ({} flop per cycle and core in f32: 2 FMA units × the f32 lanes × 2; {} in f64) = {} in f32, {} in f64. \
Our arithmetic issues separate multiplies and adds (Rust never fuses them unasked, and the scalar loop \
must stay the reference), so half the FMA peak is the ceiling this code can reach.\n",
        c.f32_flop_per_cycle,
        c.f64_flop_per_cycle,
        ceil(Precision::F32),
        ceil(Precision::F64)
    );
}

fn grid_table(md: &mut String, r: &CpuThroughputReport) {
    let _ = writeln!(
        md,
        "## Scalar against SIMD, f64 against f32, one thread against all\n\nA slice of the default map \
at each N (`cpu_throughput::workload`): RK4 on the earlier reading of the damping (ζ1 = 0.0035, so that \
RK4's step at N = 17 is 3.5 µs rather than 0.22 µs), instances spread over the forcing plane; \
integration wall time, median of {} runs (the reductions are not timed here). Share of ceiling: achieved \
flop/s against the FMA peak of the threads used.\n\n| N | precision | loop | threads | instances | instance-steps | median (s) | instance-steps/s | segment-steps/s | flop/s | share of ceiling | SIMD / scalar |\n|---|---|---|---|---|---|---|---|---|---|---|---|",
        r.rows.first().map_or(0, |f| f.runs_s.len())
    );
    for x in &r.rows {
        let speedup = match x.cpu_loop {
            CpuLoop::Simd => row(r, x.segments, CpuLoop::Scalar, x.precision, x.threads)
                .map_or("–".into(), |s| {
                    format!("{:.1}×", x.instance_steps_per_s / s.instance_steps_per_s)
                }),
            CpuLoop::Scalar => String::new(),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {:.2e} | {:.3} | {:.3e} | {:.3e} | {:.3e} | {} | {} |",
            x.segments,
            x.precision.name(),
            x.cpu_loop.name(),
            x.threads,
            x.instances,
            x.instance_steps as f64,
            x.median_s,
            x.instance_steps_per_s,
            x.segment_steps_per_s,
            x.flop_per_s,
            pct(x.share_of_ceiling),
            speedup
        );
    }
    let _ = writeln!(md);
}

fn map_table(md: &mut String, r: &CpuThroughputReport) {
    let _ = writeln!(
        md,
        "## The default map\n\n`pendulum-atlas map` on the embedded default scene ({} instances, N = 3, all six metrics), \
one run per engine. Reductions: K, R, period and the rest on the host (CPU engine, rayon) or on the device (GPU engine).\n\n\
| engine | integration (s) | reductions (s) | whole map (s) | instance-steps/s | reductions' share |\n|---|---|---|---|---|---|",
        r.default_map.first().map_or(0, |m| m.instances)
    );
    for m in &r.default_map {
        let _ = writeln!(
            md,
            "| {} | {:.2} | {:.2} | {:.2} | {:.3e} | {} |",
            m.engine,
            m.integrate_s,
            m.reduce_s,
            m.total_s,
            m.instance_steps_per_s,
            pct(Some(m.reduce_share))
        );
    }
    let _ = writeln!(md);
}

fn peer_table(md: &mut String, r: &CpuThroughputReport) {
    if r.peers.is_empty() {
        let _ = writeln!(
            md,
            "## Peers\n\nNo peer results given (`benches/peers/README.md` runs the JAX peer and passes its folder with `--peers`).\n"
        );
        return;
    }
    let _ = writeln!(
        md,
        "## Peers on the same CPU\n\nThe JAX peer (`benches/peers/jax_cpu.py`, jit + vmap) integrates the same model (the case files \
`peer_case_N*.json`: its f64 state after the check steps against ours in the last column), RK4 at the same steps. \
Ours: the SIMD loop on all threads in the same precision and N, from the table above.\n\n\
| N | precision | peer | instances × steps | instance-steps/s | ours | ours / peer | check max abs err |\n|---|---|---|---|---|---|---|---|"
    );
    for p in &r.peers {
        let prec = if p.precision == "f32" {
            Precision::F32
        } else {
            Precision::F64
        };
        let ours = row(r, p.segments, CpuLoop::Simd, prec, r.ceiling.cores);
        let _ = writeln!(
            md,
            "| {} | {} | {} {} | {} × {} | {:.3e} | {} | {} | {:.1e} |",
            p.segments,
            p.precision,
            p.peer,
            p.variant,
            p.instances,
            p.steps,
            p.instance_steps_per_s,
            ours.map_or("–".into(), |o| format!("{:.3e}", o.instance_steps_per_s)),
            ours.map_or("–".into(), |o| format!(
                "{:.1}×",
                o.instance_steps_per_s / p.instance_steps_per_s
            )),
            p.check_max_abs_err
        );
    }
    let _ = writeln!(md);
}
