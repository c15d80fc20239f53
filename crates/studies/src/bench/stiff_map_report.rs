//! Files of `bench --stiff-map`: `stiff_map.json`, `stiff_map.csv` (one row per cell) and
//! `STIFF_MAP.md`.

use super::stiff_map::{Agreement, StiffMapReport, TWIN_RATE_DEG_S};
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{
    commit_csv, create_csv, create_dir, csv_error, write_bytes, write_json,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Write the study's files into `dir`.
pub fn write_stiff_map(dir: &Path, r: &StiffMapReport) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    Ok(vec![
        write_cells(&dir.join("stiff_map.csv"), r)?,
        write_bytes(&dir.join("STIFF_MAP.md"), markdown(r).as_bytes())?,
        write_json(&dir.join("stiff_map.json"), r)?,
    ])
}

/// One row per cell: f, A, then K, period and status of every map.
fn write_cells(path: &Path, r: &StiffMapReport) -> Result<PathBuf, OutputError> {
    let mut w = create_csv(path)?;
    let mut header = vec!["frequency_hz".to_string(), "amplitude_m".to_string()];
    for m in &r.maps {
        let tag = format!("{}_{}_{}", m.label, m.backend.name(), m.precision.name());
        header.extend(["K", "period", "status"].map(|q| format!("{q}_{tag}")));
    }
    header.push("settled".into());
    w.write_record(&header).map_err(csv_error(path))?;
    for (c, (f, a)) in r.cells.iter().enumerate() {
        let mut row = vec![f.to_string(), a.to_string()];
        for m in &r.maps {
            row.extend([
                m.k[c].to_string(),
                m.period[c].to_string(),
                m.status[c].to_string(),
            ]);
        }
        row.push(r.settled.contains(&c).to_string());
        w.write_record(&row).map_err(csv_error(path))?;
    }
    commit_csv(w, path)
}

fn pct(n: usize, of: usize) -> String {
    if of == 0 {
        return "–".into();
    }
    format!("{n}/{of} ({:.0} %)", 100.0 * n as f64 / of as f64)
}

fn agreement_rows(s: &mut String, rows: &[Agreement]) {
    let _ = writeln!(
        s,
        "| map | cells | K class agrees | period agrees | both |\n|---|---|---|---|---|"
    );
    for a in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            a.map,
            a.cells,
            pct(a.k_class, a.cells),
            pct(a.period, a.cells),
            pct(a.both, a.cells)
        );
    }
}

/// The study as a Markdown page.
pub fn markdown(r: &StiffMapReport) -> String {
    let mut s = String::new();
    let mm: Vec<String> = r
        .amplitudes_m
        .iter()
        .map(|a| format!("{:.1}", a * 1e3))
        .collect();
    let _ = writeln!(
        s,
        "# Stiff chains: does the IMEX method classify a map as RK4 does?\n\n\
         Written by `pendulum-atlas bench --stiff-map` on {} in {:.0} s. Regenerate with the same \
         command. Per-cell numbers: `stiff_map.csv`.\n\n\
         Grid: f in {:?} Hz × A in [{}] mm ({} cells) at N = {} with the library damping \
         (b = 0.35 N m s/rad, loading), each cell a 2-s transient and 100 forcing periods. \
         The **reference** is RK4 at its automatic (stability-bound) step on the CPU in f64. \
         `imex` runs at the IMEX automatic step; `imex-twin` is the same from a start whose \
         segment rates differ by {} deg/s; `imex-half` at half the IMEX step. K class: K > 0.5.\n",
        r.machine,
        r.total_s,
        r.frequencies_hz,
        mm.join(", "),
        r.cells.len(),
        r.segments,
        TWIN_RATE_DEG_S
    );
    let _ = writeln!(
        s,
        "## Wall time\n\n| map | engine | dt (s) | wall (s) |\n|---|---|---|---|"
    );
    for m in &r.maps {
        let _ = writeln!(
            s,
            "| {} | {} {} | {:.2e} | {:.1} |",
            m.label,
            m.backend.name(),
            m.precision.name(),
            m.dt_s,
            m.wall_s
        );
    }
    let _ = writeln!(s, "\n## Against the reference, every cell RK4 classifies\n");
    agreement_rows(&mut s, &r.over_classified);
    let f = &r.twin_floor;
    let _ = writeln!(
        s,
        "\n**The floor.** `imex` against its own twin over the same cells: K class {}, period \
         {}. Two starts {} deg/s apart disagree this often, whatever the integrator: a single \
         trajectory's class on such a cell is not a property of the cell.\n",
        pct(f.k_class, f.cells),
        pct(f.period, f.cells),
        TWIN_RATE_DEG_S
    );
    let _ = writeln!(
        s,
        "## Against the reference, settled cells\n\n\
         Settled: `imex`, `imex-twin` and `imex-half` agree on K class and period (what a user \
         can check without RK4). {} of {} classified cells.\n",
        r.settled.len(),
        r.classified.len()
    );
    agreement_rows(&mut s, &r.over_settled);
    cell_table(&mut s, r);
    s
}

fn cell_table(s: &mut String, r: &StiffMapReport) {
    let _ = write!(s, "\n## Every cell (K / period)\n\n| f (Hz) | A (mm) |");
    for m in &r.maps {
        let _ = write!(
            s,
            " {} {} {} |",
            m.label,
            m.backend.name(),
            m.precision.name()
        );
    }
    let _ = write!(s, " settled |\n|---|---|");
    for _ in &r.maps {
        s.push_str("---|");
    }
    s.push_str("---|\n");
    for (c, (f, a)) in r.cells.iter().enumerate() {
        let _ = write!(s, "| {f} | {:.1} |", a * 1e3);
        for m in &r.maps {
            let _ = if m.status[c] == pendulum_atlas_core::model::Status::Ok {
                write!(s, " {:.2} / {} |", m.k[c], m.period[c])
            } else {
                write!(s, " {} |", m.status[c])
            };
        }
        let _ = writeln!(s, " {} |", if r.settled.contains(&c) { "yes" } else { "" });
    }
}
