//! The command-line interface: argument parsing and one function per subcommand.
//! Each command loads a validated scene, calls the library, and writes files.

/// `eprintln!` with what the line quotes from inputs (a CSV cell, a key, a path) made safe
/// for the terminal (`text::printable`): every message of the CLI is printed by it or `say!`.
macro_rules! tell {
    ($($t:tt)*) => {
        eprintln!("{}", pendulum_atlas_core::text::printable(&format!($($t)*)))
    };
}

/// `println!` made safe for the terminal as [`tell!`] is.
macro_rules! say {
    ($($t:tt)*) => {
        println!("{}", pendulum_atlas_core::text::printable(&format!($($t)*)))
    };
}

mod analyze;
mod bench;
mod calibrate;
mod engine;
mod explore;
mod map;
mod modes;
mod reproduce;
mod search;
mod simulate;
mod slurm;

use clap::{Parser, Subcommand};

/// A run that completed and wrote its files, but whose result failed (exit status 3).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct RunFailed(pub String);
use pendulum_atlas_map::output::folder::Product;
use std::path::{Path, PathBuf};

/// Chaos and bifurcation maps of an elastic inverted pendulum with clearance
/// (Łygas et al., Meccanica 2019), with the analysis of the paper.
#[derive(Debug, Parser)]
#[command(
    name = "pendulum-atlas",
    version,
    about,
    long_about = None,
    after_help = "Exit status: 0 on success; 2 on an error (bad input, files, no GPU adapter), \
                  with nothing or nothing complete written; 3 when a run completed and wrote its \
                  files but its result failed (simulate: status not ok; map: no instance ok)."
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Scene selection shared by every command.
#[derive(Debug, clap::Args)]
pub struct SceneArgs {
    /// Scene file (TOML). Omit it to use the embedded paper scene (configs/paper.toml).
    pub scene: Option<PathBuf>,
    /// Override a scene key, e.g. `--set beam.segments=3 --set pivot.mode=clamped`.
    /// Values are TOML values; a bare word is taken as a string. Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// A chaos/bifurcation map over 1–3 scene keys (GPU if present, CPU otherwise).
    Map(map::MapArgs),
    /// The GPU adapters this machine has, with the indices `--adapter` and `--devices` take.
    Adapters,
    /// Merge the shard folders of a map (`map --shard I/N`) into the map's files.
    Merge(map::MergeArgs),
    /// Slurm job-array scripts for a sharded map and its merge (optionally submitted).
    Slurm(slurm::SlurmArgs),
    /// Work-precision study: run time against error for N, dt, precision and backend.
    Bench(bench::BenchArgs),
    /// Integrate one run and write trajectory.csv and run.json.
    Simulate(simulate::SimulateArgs),
    /// Natural frequencies, unstable growth rates and the automatic time step.
    Modes(modes::ModesArgs),
    /// The paper's indicators (K, R, spectra, wavelets) for a measured CSV record.
    Analyze(analyze::AnalyzeArgs),
    /// Reproduce the paper: Table 2, Figs. 3–12 and a report, from one command.
    Reproduce(reproduce::ReproduceArgs),
    /// Broadband-harvesting design search against the linear clamped cantilever.
    Search(search::SearchArgs),
    /// Which values of unknown parameters reproduce observed cases (K, R, period, lines, hops, α).
    Calibrate(calibrate::CalibrateArgs),
    /// A finished map, calibration or search in the browser: heat maps, and a click runs a
    /// cell and shows its motion.
    Explore(explore::ExploreArgs),
}

/// After a command that completed (exit status 0, or 3 for a run that wrote its files but
/// failed): delete the earlier run that `--force` set aside.
pub fn keep_out() {
    if let Err(e) = pendulum_atlas_map::output::process::keep() {
        tell!("warning: the earlier run's files set aside by --force stay aside: {e}");
    }
}

/// After a failed command: put back the earlier run that `--force` set aside, or delete what
/// the run wrote into a folder it created (`output::process::abandon`).
pub fn abandon_out() {
    if let Some(said) = pendulum_atlas_map::output::process::abandon() {
        tell!("{said}");
    }
}

/// Make `out` the command's output folder before any work (see `output::folder`): refused when
/// it holds an earlier run, unless `force`, which deletes that run's files (and says so).
fn claim_out(product: Product, out: &Path, force: bool) -> anyhow::Result<()> {
    claim_out_reading(product, out, force, &[])
}

/// [`claim_out`] for a command that reads `inputs`, refused when one of them would be
/// deleted or overwritten as an output. From here on, Ctrl-C stops the command cleanly
/// ([`catch_interrupts`]).
fn claim_out_reading(
    product: Product,
    out: &Path,
    force: bool,
    inputs: &[&Path],
) -> anyhow::Result<()> {
    install_interrupt_handler();
    let aside = pendulum_atlas_map::output::process::claim(product, out, force, inputs)?;
    if aside > 0 {
        tell!(
            "--force: {aside} file(s) of an earlier `{}` run in {} set aside, deleted once this run is complete",
            product.command(),
            out.display()
        );
    }
    Ok(())
}

/// Set by the first Ctrl-C. In a command whose engines stop at their next progress report
/// ([`catch_interrupts`]: map, simulate, calibrate), the run then fails as cancelled; in the
/// others, and on a second Ctrl-C, the handler abandons the output folder itself and ends the
/// process. Either way the exit status is 130 and nothing of the run is kept, an earlier run
/// that `--force` set aside coming back.
static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether the command's engines stop on [`INTERRUPTED`] by themselves.
static COOPERATIVE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Let Ctrl-C stop this command's engines at their next progress report: called by the
/// commands whose engines report progress (map, simulate, calibrate), before they claim their
/// folder.
fn catch_interrupts() {
    COOPERATIVE.store(true, std::sync::atomic::Ordering::SeqCst);
    install_interrupt_handler();
}

/// The Ctrl-C handler of [`INTERRUPTED`], installed once.
fn install_interrupt_handler() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        if let Err(e) = ctrlc::set_handler(on_interrupt) {
            tell!("warning: Ctrl-C will end the process without cleaning up: {e}");
        }
    });
}

/// What Ctrl-C does (see [`INTERRUPTED`]).
fn on_interrupt() {
    use std::sync::atomic::Ordering::SeqCst;
    let again = INTERRUPTED.swap(true, SeqCst);
    if COOPERATIVE.load(SeqCst) && !again {
        eprintln!("\ninterrupted: stopping at the next step (Ctrl-C again quits at once)");
        return;
    }
    abandon_out();
    eprintln!("\ninterrupted by Ctrl-C: nothing of this run is kept");
    std::process::exit(130);
}

/// Fail the command as interrupted once Ctrl-C was pressed: `main` exits 130, and what this
/// run wrote goes, an earlier run that `--force` set aside coming back ([`abandon_out`]).
/// Called where a run that an engine stopped early would otherwise be saved as complete.
fn stop_if_interrupted(what: &str) -> anyhow::Result<()> {
    if interrupted() {
        anyhow::bail!("interrupted by Ctrl-C {what}: nothing of this run is kept");
    }
    Ok(())
}

/// Whether Ctrl-C was pressed.
pub fn interrupted() -> bool {
    INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst)
}

/// `Break` once Ctrl-C was pressed: an engine's progress callback stops the run there.
fn go_on() -> std::ops::ControlFlow<()> {
    match interrupted() {
        true => std::ops::ControlFlow::Break(()),
        false => std::ops::ControlFlow::Continue(()),
    }
}

/// An engine progress callback that only stops the run on Ctrl-C.
fn until_interrupted(
    _: u64,
    _: u64,
    _: pendulum_atlas_core::engine::ProgressUnit,
) -> std::ops::ControlFlow<()> {
    go_on()
}

/// A progress bar in `template` (hidden when `quiet`), for the ensemble commands.
fn progress_bar(quiet: bool, template: &str) -> indicatif::ProgressBar {
    let bar = if quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(1)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar
}

/// An engine progress callback that moves `bar` (its prefix names the unit counted).
fn bar_progress(
    bar: &indicatif::ProgressBar,
) -> impl Fn(u64, u64, pendulum_atlas_core::engine::ProgressUnit) -> std::ops::ControlFlow<()> + Sync + '_
{
    move |done, total, unit| {
        bar.set_length(total);
        bar.set_position(done);
        bar.set_prefix(unit.name());
        go_on()
    }
}

/// Run the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Map(a) => map::run(a),
        Command::Merge(a) => map::merge(a),
        Command::Adapters => map::adapters(),
        Command::Slurm(a) => slurm::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Modes(a) => modes::run(a),
        Command::Analyze(a) => analyze::run(a),
        Command::Reproduce(a) => reproduce::run(a),
        Command::Search(a) => search::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Explore(a) => explore::run(a),
    }
}

impl SceneArgs {
    /// Load and validate the scene with its overrides.
    /// Its remarks (keys given but not used) are printed as warnings.
    pub fn load(&self) -> anyhow::Result<pendulum_atlas_core::config::Scene> {
        let scene = pendulum_atlas_core::config::load_scene(self.scene.as_deref(), &self.sets)?;
        for note in &scene.notes {
            tell!("warning: {note}");
        }
        Ok(scene)
    }
}
