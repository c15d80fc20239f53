//! `pendulum-atlas-lab`: the studies that fit or check the product (see `lib.rs`).
//!
//! ```text
//! pendulum-atlas-lab verdict --plane forcing --out docs/bench
//! pendulum-atlas-lab verdict-fit docs/bench docs/bench/verdict/clearance docs/bench/verdict/piezo --out docs/bench
//! ```

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};
use pendulum_atlas_core::engine::{Backend, Engine};
use pendulum_atlas_lab::kept::{kept_references, recover_settled};
use pendulum_atlas_lab::nudged::run_nudged;
use pendulum_atlas_lab::planes::{fit_planes, read_plane, write_planes};
use pendulum_atlas_lab::verdict::{
    Kept, Plane, VerdictOptions, reference_durations, run_verdict, thinning,
};
use pendulum_atlas_lab::verdict_report::write_verdict;
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::output::process;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The lab of pendulum-atlas: studies that fit or check the product.
#[derive(Parser)]
#[command(name = "pendulum-atlas-lab", version)]
struct Lab {
    #[command(subcommand)]
    study: Study,
}

#[derive(Subcommand)]
enum Study {
    /// The map's accuracy: a converged reference of a 192-cell subgrid of the plane (CPU f64,
    /// 1000 s and 2000 s at rtol 1e-6, and 1000 s at 1e-7), then the map's settings (duration,
    /// λ1 window, float type, engine, which indicators decide) scored against it, the whole
    /// map's cost with and without the verdict, the reliability of its confidence and settling
    /// (writes VERDICT.md and verdict.json; about half an hour on 2 cores, `--quick` ten
    /// seconds, `--reference-from` minutes).
    Verdict {
        /// The plane: `forcing` (the default map), `clearance` (frequency × the bumpers'
        /// clearance at 9 mm) or `piezo` (the forcing plane with the patch harvesting).
        #[arg(long, value_enum, default_value_t = PlaneArg::Forcing)]
        plane: PlaneArg,
        /// Keep the references of an earlier study of the same plane (its folder, with
        /// verdict.json) instead of running them again: they depend only on the plane.
        #[arg(long, value_name = "DIR")]
        reference_from: Option<PathBuf>,
        /// Score the GPU engine's candidates too (the default adapter; lavapipe where there is
        /// no hardware GPU).
        #[arg(long)]
        gpu: bool,
        /// A twentieth of the reference, a 4 × 3 subgrid, and the map scored and settled at
        /// every 8th value instead of the whole plane: a test of the study, not a result.
        #[arg(long)]
        quick: bool,
        #[command(flatten)]
        out: Out,
    },
    /// The nudged reference of a plane: the verdict study's 2000-s reference run again on both
    /// subgrids, every segment's initial rate raised by 1e-6 deg/s (writes nudged.json; about
    /// ten minutes per plane on 2 cores, `--quick` seconds). Where it agrees with the reference
    /// a cell is predictable (`benches/transients_study.py` scores a map on both kinds).
    Nudged {
        /// The plane, as for `verdict`.
        #[arg(long, value_enum, default_value_t = PlaneArg::Forcing)]
        plane: PlaneArg,
        /// A twentieth of the run on a 4 × 3 subgrid: a test of the study, not a result.
        #[arg(long)]
        quick: bool,
        #[command(flatten)]
        out: Out,
    },
    /// The confidence fitted beyond one plane: read the verdict studies in these folders (one
    /// per plane), fit the confidence tables on all of them and on all but each one, and score
    /// each plane held out (writes PLANES.md and planes.json; seconds).
    VerdictFit {
        /// The studies' folders, one per plane (at least two).
        #[arg(num_args = 2.., value_name = "DIR", required = true)]
        dirs: Vec<PathBuf>,
        #[command(flatten)]
        out: Out,
    },
    /// The flop count of one step, counted afresh on the engine's own RK4 and IMEX steps for
    /// the throughput studies' scenes at every N from 1 to 64, against the table the product
    /// ships (crates/studies/src/bench/cost.rs): prints the counted table, and fails where it
    /// differs (seconds).
    Flops,
    /// The peers' cases (benches/peers/): `peer_case_N{3,9,17}.json`, 16 instances of the
    /// default map each, with the state our f64 engine reaches after 256 RK4 steps (seconds).
    PeerCases {
        /// Output folder (the peers read docs/bench/cpu).
        #[arg(long)]
        out: PathBuf,
    },
}

/// Where a study writes.
#[derive(clap::Args)]
struct Out {
    /// Output folder.
    #[arg(long, default_value = "runs/lab")]
    out: PathBuf,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    force: bool,
}

/// The planes of `verdict`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum PlaneArg {
    /// The embedded default map: frequency × amplitude (configs/maps/default.toml).
    Forcing,
    /// Frequency × clearance at A = 9 mm (configs/maps/verdict_clearance.toml).
    Clearance,
    /// The forcing plane with the piezo patch (configs/maps/verdict_piezo.toml).
    Piezo,
}

impl From<PlaneArg> for Plane {
    fn from(p: PlaneArg) -> Plane {
        match p {
            PlaneArg::Forcing => Plane::Forcing,
            PlaneArg::Clearance => Plane::Clearance,
            PlaneArg::Piezo => Plane::Piezo,
        }
    }
}

fn main() -> ExitCode {
    let lab = Lab::parse();
    match run(lab.study) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(study: Study) -> anyhow::Result<()> {
    match study {
        Study::Verdict {
            plane,
            reference_from,
            gpu,
            quick,
            out,
        } => in_out(Product::BenchVerdict, &out, &[], || {
            verdict(
                plane.into(),
                reference_from.as_deref(),
                gpu,
                quick,
                &out.out,
            )
        }),
        Study::Flops => flops(),
        Study::PeerCases { out } => {
            for path in pendulum_atlas_lab::peer_case::write_peer_cases(&out)? {
                println!("wrote {}", path.display());
            }
            Ok(())
        }
        Study::Nudged { plane, quick, out } => in_out(Product::BenchNudged, &out, &[], || {
            let report = run_nudged(plane.into(), quick, &|line| eprintln!("{line}"))?;
            let path = out.out.join("nudged.json");
            pendulum_atlas_map::output::files::write_json(&path, &report)?;
            eprintln!("nudged: wrote {}", path.display());
            Ok(())
        }),
        Study::VerdictFit { dirs, out } => {
            let inputs: Vec<&Path> = dirs.iter().map(PathBuf::as_path).collect();
            in_out(Product::BenchPlanes, &out, &inputs, || {
                verdict_fit(&dirs, &out.out)
            })
        }
    }
}

/// Run `work` with `out` claimed for `product` (locked; with `--force`, an earlier run's files
/// set aside, deleted once `work` succeeds and put back when it fails or Ctrl-C stops it, as
/// the command line does: `output::process`).
fn in_out(
    product: Product,
    out: &Out,
    inputs: &[&Path],
    work: impl FnOnce() -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let stopped = ctrlc::set_handler(|| {
        process::abandon();
        eprintln!("\ninterrupted by Ctrl-C: nothing of this run is kept");
        std::process::exit(130);
    });
    if let Err(e) = stopped {
        eprintln!("warning: Ctrl-C will end the study without cleaning up: {e}");
    }
    process::claim(product, &out.out, out.force, inputs)?;
    match work() {
        Ok(()) => process::keep().context("deleting the earlier run's files"),
        Err(err) => {
            if let Some(said) = process::abandon() {
                eprintln!("{said}");
            }
            Err(err)
        }
    }
}

/// `flops`.
fn flops() -> anyhow::Result<()> {
    let (text, same) = pendulum_atlas_lab::flops::table_report()?;
    print!("{text}");
    anyhow::ensure!(
        same,
        "the counted table differs from crates/studies/src/bench/cost.rs: count it again there"
    );
    println!("the shipped table is the count");
    Ok(())
}

/// `verdict`.
fn verdict(
    plane: Plane,
    reference_from: Option<&Path>,
    gpu: bool,
    quick: bool,
    out: &Path,
) -> anyhow::Result<()> {
    let kept = match reference_from {
        Some(dir) => Some(kept(dir, plane, quick)?),
        None => None,
    };
    let gpu = match gpu {
        true => Some(Engine::open(Backend::Gpu, None)?),
        false => None,
    };
    let report = run_verdict(
        &VerdictOptions {
            quick,
            gpu: gpu.as_ref(),
            plane,
            kept,
        },
        &|line| eprintln!("{line}"),
    )?;
    let files = write_verdict(out, &report)?;
    eprintln!(
        "verdict: {} candidates in {:.0} s; wrote {} files to {}",
        report.scores.len(),
        report.total_s,
        files.len(),
        out.display()
    );
    Ok(())
}

/// The references kept from the study in `dir`, their settled flags recovered where the study
/// predates them.
fn kept(dir: &Path, plane: Plane, quick: bool) -> anyhow::Result<Kept> {
    let thin = thinning(quick);
    let (mut a, mut b) = kept_references(dir, plane, thin, reference_durations(quick))?;
    let from = dir.display().to_string();
    for (r, offset) in [(&mut a, 0), (&mut b, thin / 2)] {
        if recover_settled((plane, thin, offset), r, &from)? {
            eprintln!(
                "recovered the settled flags of a reference in {from} (its shorter run again)"
            );
        }
    }
    Ok(Kept { from, a, b })
}

/// `verdict-fit`.
fn verdict_fit(dirs: &[PathBuf], out: &Path) -> anyhow::Result<()> {
    let planes = dirs
        .iter()
        .map(|d| read_plane(d))
        .collect::<Result<Vec<_>, _>>()?;
    let report = fit_planes(&planes, dirs)?;
    let files = write_planes(out, &report)?;
    for t in &report.tables {
        for h in &t.held_out {
            eprintln!(
                "{} held out of {}: {} of {} settled cells firm, {} right",
                h.plane.name(),
                t.which.table(),
                h.firm.cells,
                h.firm.settled,
                h.firm.right
            );
        }
    }
    eprintln!("wrote {} files to {}", files.len(), out.display());
    Ok(())
}
