//! `pendulum-atlas search`: the broadband-harvesting design search over a harvester scene.

use super::engine::EngineArgs;
use pendulum_atlas_design::harvest::{load_search, run_search, verify_design, write_search};
use pendulum_atlas_map::output::folder::Product;
use std::path::PathBuf;

/// Arguments of `search`.
#[derive(Debug, clap::Args)]
pub struct SearchArgs {
    /// Search scene (TOML with a \[search\] section; see configs/harvest/). Omit it to run the
    /// embedded default search (configs/harvest/default.toml).
    pub scene: Option<PathBuf>,
    /// Override a scene or search key, e.g. `--set search.band.base_acceleration_m_s2=5 --set search.refine.rounds=0`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Output folder.
    #[arg(long, default_value = "runs/harvest")]
    pub out: PathBuf,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    pub force: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Run `search`.
pub fn run(a: SearchArgs) -> anyhow::Result<()> {
    let spec = load_search(a.scene.as_deref(), &a.sets)?;
    let origin = a.scene.as_ref().map_or_else(
        || "configs/harvest/default.toml (embedded)".to_string(),
        |p| p.display().to_string(),
    );
    for note in &spec.scene.notes {
        tell!("warning: {note}");
    }
    let engine = a.engine.open(&spec.scene)?;
    let inputs: Vec<&std::path::Path> = a.scene.iter().map(|p| p.as_path()).collect();
    super::claim_out_reading(Product::Search, &a.out, a.force, &inputs)?;
    let bar = super::progress_bar(
        a.quiet,
        "{spinner} {msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})",
    );
    let progress = |stage: &str, done: u64, total: u64| {
        if bar.message() != stage {
            bar.set_message(stage.to_string());
            bar.reset();
        }
        bar.set_length(total);
        bar.set_position(done);
    };
    let run = run_search(&spec, &engine, &progress)?;
    let verification = if spec.verify {
        bar.set_message("re-simulating the best design with the simulate engine");
        bar.set_length(1);
        bar.set_position(0);
        Some(verify_design(&spec, run.best())?)
    } else {
        None
    };
    bar.finish_and_clear();
    let files = write_search(&a.out, &spec, &run, verification.as_ref(), &origin)?;
    for st in &run.stages {
        for w in &st.warnings {
            tell!("warning ({}): {w}", st.stage);
        }
        say!(
            "{}: {} designs, {} instances, {:.2e} instance-steps in {:.1} s ({:.3e} instance-steps/s)",
            st.stage,
            st.designs,
            st.instances,
            st.instance_steps as f64,
            st.wall_s,
            st.instance_steps_per_s
        );
    }
    let best = run.best();
    let b = &run.baseline.metrics;
    let word = spec.weighting.name();
    let m = best.ranked(spec.weighting).0;
    say!(
        "ranked by {}",
        spec.weighting.describe(spec.initial_states.len())
    );
    say!(
        "search on {} [{}]: {} designs in {:.1} s; best #{}: {word} bandwidth {:.2} Hz (baseline {:.2} Hz), {word} band-averaged power {:.3e} W (baseline {:.3e} W)",
        run.engine.kind.name(),
        run.engine.device,
        run.designs.len(),
        run.total_s,
        best.id,
        m.bandwidth_hz,
        b.bandwidth_hz,
        m.band_average_w,
        b.band_average_w
    );
    if let Some(line) = top_attractor_line(best, &spec) {
        say!("{line}");
    }
    if let Some(v) = &verification {
        say!(
            "re-simulated with the simulate engine: {word} band-averaged power {:.3e} W vs {:.3e} W from the search (median point {:.2} %, largest {:.1} % at {} Hz)",
            v.simulate_band_average_w,
            v.search_band_average_w,
            100.0 * v.median_rel_diff,
            100.0 * v.max_rel_diff,
            v.max_rel_diff_at_hz
        );
    }
    say!("wrote {} files to {}", files.len(), a.out.display());
    if !run.usable() {
        return Err(super::RunFailed(format!(
            "no instance of any of the {} designs ended ok (every one diverged, turned non-finite or escaped): the ranking means nothing; see designs.csv in {}",
            run.designs.len(),
            a.out.display()
        ))
        .into());
    }
    Ok(())
}

/// With the expected weighting: where the best design's high-power attractor is most likely,
/// in one line (its power and basin fraction at that frequency).
fn top_attractor_line(
    best: &pendulum_atlas_design::harvest::DesignResult,
    spec: &pendulum_atlas_design::harvest::SearchSpec,
) -> Option<String> {
    let f = &spec.band.frequencies_hz;
    let (j, t) = best
        .top_attractor
        .iter()
        .enumerate()
        .filter(|(_, t)| t.power_w.is_finite())
        .max_by(|a, b| a.1.power_w.total_cmp(&b.1.power_w))?;
    Some(format!(
        "best design's high-power attractor: {:.3e} W at {} Hz, reached from {:.0} % of the starts (basin fraction {:.2})",
        t.power_w,
        pendulum_atlas_core::text::num(f[j]),
        100.0 * t.basin_fraction,
        t.basin_fraction
    ))
}
