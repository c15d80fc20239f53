//! Files of the stiff-chain study: `stiff.json`, `stiff_work_precision.png`, `STIFF.md`.

use super::stiff::{HorizonRow, Reading, StiffReport, stepping_label};
use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_core::engine::{EngineKind, Precision};
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{create_dir, draw, write_bytes, write_json};
use pendulum_atlas_map::render::{Series, line_chart};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Write the study's files into `dir`.
pub fn write_stiff(dir: &Path, r: &StiffReport) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    let curves = curves(r);
    let series: Vec<Series> = curves
        .iter()
        .map(|(name, x, y)| Series { name, x, y })
        .collect();
    Ok(vec![
        write_json(&dir.join("stiff.json"), r)?,
        draw(&dir.join("stiff_work_precision.png"), |p| {
            line_chart(
                p,
                &format!(
                    "Holder-angle error over {} s against wall time, CPU f64, one instance",
                    r.horizon_s
                ),
                "wall time of the run (s)",
                "max |α − α_ref| (rad)",
                &series,
                true,
                true,
            )
        })?,
        write_bytes(&dir.join("STIFF.md"), markdown(r).as_bytes())?,
    ])
}

/// One curve per (N, reading, method, fixed or adaptive) on the CPU in f64: (wall s, α error)
/// along the steps or the tolerances.
fn curves(r: &StiffReport) -> Vec<(String, Vec<f64>, Vec<f64>)> {
    let mut out: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
    let cpu64 = |h: &&HorizonRow| h.backend == EngineKind::Cpu && h.precision == Precision::F64;
    for h in r.horizon.iter().filter(cpu64) {
        if !(h.alpha_err_rad > 0.0 && h.wall_s > 0.0) {
            continue;
        }
        // Fixed steps along the step, adaptive ones along the tolerance: two curves.
        let adaptive = if h.rtol.is_some() { " adaptive" } else { "" };
        let name = format!(
            "N = {} {:?} {}{adaptive}",
            h.segments,
            h.reading,
            h.method.name()
        );
        match out.iter_mut().find(|c| c.0 == name) {
            Some(c) => {
                c.1.push(h.wall_s);
                c.2.push(h.alpha_err_rad);
            }
            None => out.push((name, vec![h.wall_s], vec![h.alpha_err_rad])),
        }
    }
    out
}

/// The study as a Markdown page.
pub fn markdown(r: &StiffReport) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Stiff chains: RK4 against the IMEX method\n");
    let _ = writeln!(
        s,
        "Written by `pendulum-atlas bench --stiff{}` on {} in {:.0} s. Regenerate with the same \
         command.\n\nScene: Table 1, f = 8 Hz, A = 9 mm, limiter at 20°, started on the positive \
         bumper, with each reading of the damping: **{}** and **{}**. **α error**: max |α − α_ref| \
         over the first {} s (bumper impacts included) against the DOP853 reference with contact \
         events at the same N and damping, i.e. the integration error alone. **Wall time**: the \
         engine run of one instance over that horizon (on the GPU one instance measures latency, \
         not throughput). Fixed steps are multiples of each method's automatic step; adaptive \
         runs (IMEX, `integration.step = \"adaptive\"`) are labelled with their relative \
         tolerance (the absolute one 1/100 of it), and their dt is the ladder's base step.\n",
        if r.quick { " --quick" } else { "" },
        r.machine,
        r.total_s,
        Reading::Earlier.name(),
        Reading::Library.name(),
        r.horizon_s
    );
    same_error_speedups(&mut s, r);
    horizon_table(&mut s, r);
    let _ = writeln!(s, "\n![work-precision](stiff_work_precision.png)\n");
    map_table(&mut s, r);
    s
}

/// Per (N, reading): RK4 at its automatic step against the cheapest IMEX run (CPU f64) whose
/// α error is no larger.
fn same_error_speedups(s: &mut String, r: &StiffReport) {
    let _ = writeln!(
        s,
        "## Wall time at the same α error (CPU, f64)\n\n\
         RK4 at its automatic step (bound by stability: its α error is what that step gives) \
         against the cheapest IMEX step whose α error is at most 1e-4 rad (or RK4's, where that \
         is larger).\n\n\
         | N | damping | RK4 dt (s) | RK4 α error | RK4 wall (s) | IMEX dt (s) | IMEX α error | IMEX wall (s) | RK4 / IMEX wall |\n\
         |---|---|---|---|---|---|---|---|---|"
    );
    let cpu64 = |h: &&HorizonRow| h.backend == EngineKind::Cpu && h.precision == Precision::F64;
    let mut keys: Vec<(usize, Reading)> =
        r.horizon.iter().map(|h| (h.segments, h.reading)).collect();
    keys.dedup();
    for (n, reading) in keys {
        let of = |m: Method| {
            r.horizon
                .iter()
                .filter(cpu64)
                .filter(move |h| h.segments == n && h.reading == reading && h.method == m)
                .filter(|h| h.rtol.is_none())
        };
        let Some(rk4) = of(Method::Rk4).next() else {
            continue;
        };
        // RK4's step is bound by stability, not accuracy: its error is what it is. The IMEX
        // run must meet 1e-4 rad (or RK4's error, where that is larger).
        let target = rk4.alpha_err_rad.max(1e-4);
        let imex = of(Method::Imex)
            .filter(|h| h.alpha_err_rad <= target)
            .min_by(|a, b| a.wall_s.total_cmp(&b.wall_s));
        let Some(imex) = imex else {
            let _ = writeln!(
                s,
                "| {n} | {reading:?} | {:.2e} | {:.1e} | {:.3} | none as accurate | | | |",
                rk4.dt_s, rk4.alpha_err_rad, rk4.wall_s
            );
            continue;
        };
        let _ = writeln!(
            s,
            "| {n} | {reading:?} | {:.2e} | {:.1e} | {:.3} | {:.2e} | {:.1e} | {:.4} | {:.0}× |",
            rk4.dt_s,
            rk4.alpha_err_rad,
            rk4.wall_s,
            imex.dt_s,
            imex.alpha_err_rad,
            imex.wall_s,
            rk4.wall_s / imex.wall_s
        );
    }
}

fn horizon_table(s: &mut String, r: &StiffReport) {
    let _ = writeln!(
        s,
        "\n## Every run\n\n\
         | N | damping | method | dt (× auto) | dt (s) | steps | engine | α error (rad) | wall (s) | status |\n\
         |---|---|---|---|---|---|---|---|---|---|"
    );
    for h in &r.horizon {
        let _ = writeln!(
            s,
            "| {} | {:?} | {} | {:.3} | {:.2e} | {} | {} {} | {:.1e} | {:.4} | {} |",
            h.segments,
            h.reading,
            stepping_label(h.method, h.rtol),
            h.dt_factor,
            h.dt_s,
            h.steps,
            h.backend.name(),
            h.precision.name(),
            h.alpha_err_rad,
            h.wall_s,
            h.status
        );
    }
}

fn map_table(s: &mut String, r: &StiffReport) {
    let _ = writeln!(
        s,
        "## Maps at the library damping\n\n\
         Grid: {}. The reference is RK4 at its automatic step on the CPU in f64; each IMEX map \
         runs at the IMEX automatic step, or at adaptive steps (the default tolerances). Agreement is counted on the cells the reference \
         classifies (status ok): same K class (K > 0.5) and same period.\n\n\
         | method | engine | dt (s) | wall (s) | cells | K class agrees | period agrees | failed |\n\
         |---|---|---|---|---|---|---|---|",
        r.map_grid
    );
    for m in &r.maps {
        let _ = writeln!(
            s,
            "| {} | {} {} | {:.2e} | {:.2} | {} | {:.0} % | {:.0} % | {} |",
            stepping_label(m.method, m.rtol),
            m.backend.name(),
            m.precision.name(),
            m.dt_s,
            m.wall_s,
            m.cells,
            100.0 * m.k_class_agree,
            100.0 * m.period_agree,
            m.failed
        );
    }
}
