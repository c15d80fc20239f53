//! Files of a study: `bench.json`, `work_precision.png`, `map_error.png`, `BENCHMARKS.md`.

use super::{BenchReport, ConfigResult};
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{create_dir, draw, write_bytes, write_json};
use pendulum_atlas_map::render::{Series, line_chart};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Write the study's files into `dir`.
pub fn write_bench(dir: &Path, r: &BenchReport) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    let title = format!(
        "Holder-angle error over {} s vs N = 17 DOP853 (points: N = 1, 3, 5, 9, 17 from the left)",
        r.horizon_s
    );
    let err = Curves::new(r, |c| (c.cost_per_instance_s, c.alpha_err_rad));
    let dk = Curves::new(r, |c| (c.cost_per_instance_s, c.mean_abs_dk.max(1e-4)));
    let x_label = "wall time per instance and simulated second on this machine (s/s)";
    Ok(vec![
        write_json(&dir.join("bench.json"), r)?,
        draw(&dir.join("work_precision.png"), |p| {
            line_chart(
                p,
                &title,
                x_label,
                "max |α − α_ref| (rad)",
                &err.series(),
                true,
                true,
            )
        })?,
        draw(&dir.join("map_error.png"), |p| {
            line_chart(
                p,
                "Indicator error on the reference map vs N = 17 f64 (floor 1e-4)",
                x_label,
                "mean |K − K_ref|",
                &dk.series(),
                true,
                true,
            )
        })?,
        write_bytes(&dir.join("BENCHMARKS.md"), markdown(r).as_bytes())?,
    ])
}

/// One curve per configuration family, points along N (positive values only).
struct Curves {
    names: Vec<String>,
    points: Vec<(Vec<f64>, Vec<f64>)>,
}

impl Curves {
    fn new(r: &BenchReport, f: fn(&ConfigResult) -> (f64, f64)) -> Curves {
        let mut families: BTreeMap<String, Vec<&ConfigResult>> = BTreeMap::new();
        for c in &r.configs {
            families.entry(c.config.family()).or_default().push(c);
        }
        Curves {
            names: families.keys().cloned().collect(),
            points: families
                .values()
                .map(|v| {
                    v.iter()
                        .map(|c| f(c))
                        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
                        .unzip()
                })
                .collect(),
        }
    }

    fn series(&self) -> Vec<Series<'_>> {
        self.names
            .iter()
            .zip(&self.points)
            .map(|(n, (x, y))| Series { name: n, x, y })
            .collect()
    }
}

/// The study as a Markdown page.
pub fn markdown(r: &BenchReport) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Benchmarks: run time against error\n");
    intro(&mut s, r);
    configurations(&mut s, r);
    let _ = writeln!(
        s,
        "\n![work-precision](work_precision.png)\n\n![map error](map_error.png)\n"
    );
    scaling(&mut s, r);
    metrics_a_scene_does_not_need(&mut s, r);
    s
}

/// How the page was made, and what the errors and the cost are measured against.
fn intro(s: &mut String, r: &BenchReport) {
    let _ = writeln!(
        s,
        "Written by `pendulum-atlas bench{}` on {} in {:.0} s. Regenerate with the same command.\n",
        if r.quick { " --quick" } else { "" },
        r.machine,
        r.total_s
    );
    let _ = writeln!(
        s,
        "Scene: Table 1, f = 8 Hz, A = 9 mm, limiter at 20°, started on the positive bumper. \
         **α error**: max |α − α_ref| over the first {} s (bumper impacts included), against the \
         DOP853 reference with contact events at N = 17 ({:.1} s of wall time). **Map error**: on \
         the reference map ({}), against the f64 RK4 engine at N = 17 and its automatic step \
         ({:.1} s); K on stroboscopic samples, R standard convention, period of the section. \
         **Cost**: wall time of the map's integration and reductions divided by the simulated \
         instance-seconds, on all the machine's cores.\n",
        r.horizon_s, r.reference_wall_s, r.reference_map, r.reference_map_wall_s
    );
}

/// One row per configuration: step, errors, cost and throughput.
fn configurations(s: &mut String, r: &BenchReport) {
    let _ = writeln!(
        s,
        "| N | engine | dt (s) | α error (rad) | cost (s/s) | instance-steps/s | segment-steps/s | mean \\|ΔK\\| | mean \\|ΔR\\| | K class changed | period changed | failed |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for c in &r.configs {
        let _ = writeln!(
            s,
            "| {} | {} | {:.2e} | {:.1e} | {:.2e} | {:.2e} | {:.2e} | {:.3} | {:.3} | {:.0} % | {:.0} % | {} |",
            c.config.segments,
            c.config.family(),
            c.dt_s,
            c.alpha_err_rad,
            c.cost_per_instance_s,
            c.instance_steps_per_s,
            c.segment_steps_per_s,
            c.mean_abs_dk,
            c.mean_abs_dr,
            100.0 * c.k_class_changed,
            100.0 * c.period_changed,
            c.failed
        );
    }
}

/// "Scaling": cost per step against N, map wall time against grid size and run length,
/// threads, and the GPU's best throughput.
fn scaling(s: &mut String, r: &BenchReport) {
    let _ = writeln!(s, "## Scaling\n");
    let _ = writeln!(
        s,
        "Per RK4 step, one instance, f64, one thread, fixed dt = 1 µs, no dampers:\n"
    );
    let _ = writeln!(
        s,
        "| N | ns per step | ns per step and segment |\n|---|---|---|"
    );
    for (n, a, b) in &r.scaling.per_step_vs_segments {
        let _ = writeln!(s, "| {n} | {a:.0} | {b:.0} |");
    }
    let _ = writeln!(
        s,
        "\nMap wall time against grid size (N = 3, 4 s, CPU f64):\n"
    );
    let _ = writeln!(s, "| instances | wall (s) |\n|---|---|");
    for (n, w) in &r.scaling.wall_vs_instances {
        let _ = writeln!(s, "| {n} | {w:.2} |");
    }
    let _ = writeln!(s, "\nAgainst run length (64 instances):\n");
    let _ = writeln!(s, "| duration (s) | wall (s) |\n|---|---|");
    for (d, w) in &r.scaling.wall_vs_duration {
        let _ = writeln!(s, "| {d} | {w:.2} |");
    }
    if let Some((t1, t2, sp)) = r.scaling.threads {
        let _ = writeln!(
            s,
            "\nCPU threads (128 instances): 1 thread {t1:.2} s, 2 threads {t2:.2} s, speed-up {sp:.2}x."
        );
    }
    if let Some((name, v)) = &r.scaling.gpu {
        let _ = writeln!(
            s,
            "\nGPU `{name}`: up to {v:.3e} segment-steps/s in the table above."
        );
    }
}

/// "Metrics a scene does not need": a K-only map against one with every metric, per engine.
fn metrics_a_scene_does_not_need(s: &mut String, r: &BenchReport) {
    let _ = writeln!(
        s,
        "\n## Metrics a scene does not need\n\nAn 8 x 8 map at N = 3, 20 s (K, R, period, hops, impacts, α range against K alone). \
         A K-only scene records no R series and neither compiles nor runs the R kernels; a scene \
         without K or period records no stroboscopic samples. Both sides are timed warm (one untimed run \
         first, so that no first use of a kernel specialisation is timed), median of 3. Integration costs the same for both, so the speed-up \
         is bounded by the share of the reductions K does not need (R, the period search).\n\n| engine | all metrics (s) | K only (s) | speed-up |\n|---|---|---|---|"
    );
    for k in &r.k_only {
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.2} | {:.2}x |",
            k.backend.name(),
            k.all_metrics_s,
            k.k_only_s,
            k.speedup
        );
    }
}
