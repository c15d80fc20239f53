//! `pendulum-atlas map`: a chaos/bifurcation map over 1–3 scene keys on the GPU or the CPU,
//! whole or one shard of it; `pendulum-atlas merge`: shards back into one map.

use super::engine::{EngineArgs, hint};
use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, MapSpec, map_from_toml, scene_text};
use pendulum_atlas_core::engine::gpu::list_adapters;
use pendulum_atlas_core::engine::{Backend, Engine, EngineInfo, EngineKind};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_map::map::hardware_default::hardware_default;
use pendulum_atlas_map::map::settle::settle;
use pendulum_atlas_map::map::size::check_map_size;
use pendulum_atlas_map::map::{
    MapRun, check_host_memory, check_shardable, run_map, run_map_on_devices, run_map_shard,
};
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::output::map::write_map;
use pendulum_atlas_map::shard::{Shard, merge_shards, write_shard};
use std::path::PathBuf;

/// Arguments of `map`.
#[derive(Debug, clap::Args)]
pub struct MapArgs {
    /// Map scene (TOML with a \[map\] section; see configs/maps/). Omit it to run the embedded
    /// default map (configs/maps/default.toml).
    pub scene: Option<PathBuf>,
    /// Override a scene or map key, e.g. `--set beam.segments=5 --set map.samples_per_period=32`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Output folder.
    #[arg(long, default_value = "runs/map")]
    pub out: PathBuf,
    /// Integrate only shard I of N (0-based, e.g. 0/4; instances k with k mod N = I) and write
    /// its results to --out for `pendulum-atlas merge`.
    #[arg(long, value_name = "I/N", conflicts_with = "devices")]
    pub shard: Option<Shard>,
    /// Split the map over several GPU adapters in this process: `all` (every hardware GPU)
    /// or indices from `pendulum-atlas adapters`, e.g. `0,1`.
    #[arg(long, value_name = "all|I,J,...", conflicts_with = "adapter")]
    pub devices: Option<String>,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    pub force: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Run a huge map (over a million runs, 4 GiB of memory or 1e11 instance-steps), which
    /// is otherwise refused with its estimated size and time (same as map.accept_huge = true).
    #[arg(long)]
    pub yes: bool,
}

/// Arguments of `merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shard folders (`map ... --shard I/N --out DIR`), every index exactly once.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Output folder of the merged map.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace an earlier map in --out (its files only).
    #[arg(long)]
    pub force: bool,
    /// Leave the cells whose verdict is not firm as the shards computed them, instead of
    /// running them on (the settling stage, `map.settle_max_s`, on the shards' engine).
    #[arg(long)]
    pub no_settle: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Run `map`.
pub fn run(a: MapArgs) -> anyhow::Result<()> {
    super::catch_interrupts();
    let mut sets = a.sets.clone();
    if a.yes {
        sets.push("map.accept_huge=true".into());
    }
    let (text, mut spec) = read_map(a.scene.as_deref(), &sets)?;
    check_host_memory(&spec).map_err(hint)?;
    if let Some(s) = a.shard {
        check_shard_count("--shard", s.count, &spec)?;
    }
    if a.shard.is_some() || a.devices.is_some() {
        check_shardable(&spec).map_err(hint)?;
    }
    if let Some(d) = &a.devices {
        return run_on_devices(&a, d, &spec);
    }
    let engine = a.engine.open(&spec.scene)?;
    let shards = a.shard.map_or(1, |s| s.count);
    check_size(&spec, shards, &engine)?;
    let hardware = a.scene.is_none() && a.shard.is_none() && engine.is_hardware_gpu();
    if let Some(choice) = hardware
        .then(|| hardware_default(&engine, &sets))
        .transpose()?
        .flatten()
    {
        tell!("{}", choice.reason);
        let sets = [sets.clone(), choice.sets].concat();
        spec = pendulum_atlas_core::config::load_map(None, &sets)?;
    }
    let product = if a.shard.is_some() {
        Product::Shard
    } else {
        Product::Map
    };
    pendulum_atlas_map::output::budget::check_map_fits(&spec, shards, &a.out)?;
    let inputs: Vec<&std::path::Path> = a.scene.iter().map(|p| p.as_path()).collect();
    super::claim_out_reading(product, &a.out, a.force, &inputs)?;
    let bar = super::progress_bar(
        a.quiet,
        "{spinner} {msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})",
    );
    let progress = super::bar_progress(&bar);
    let (run, files) = match a.shard {
        Some(s) => {
            bar.set_message(format!("shard {}/{} of a map", s.index, s.count));
            let run = run_map_shard(&spec, s, &engine, &progress).map_err(hint)?;
            let files = write_shard(&a.out, &spec, &text, &sets, s, &run)?;
            (run, files)
        }
        None => {
            bar.set_message(format!("map of {} instances", spec.instances()));
            let run = run_map(&spec, &engine, &progress).map_err(hint)?;
            // The orbit stage runs no engine steps: a Ctrl-C during it is seen here.
            super::stop_if_interrupted("during the map's last stage")?;
            let files = write_map(&a.out, &spec, &run)?;
            (run, files)
        }
    };
    bar.finish_and_clear();
    report(&run, files.len(), &a.out)
}

/// Refuse a huge map (or each of `shards` shards) that is not accepted (`--yes`), with its
/// figures; say them when accepted.
fn check_size(spec: &MapSpec, shards: u32, engine: &Engine) -> anyhow::Result<()> {
    if let Some(accepted) = check_map_size(spec, shards, engine).map_err(hint)? {
        tell!("{accepted}");
    }
    Ok(())
}

/// `map --devices`: one process, one engine per adapter, one shard each, assembled.
fn run_on_devices(a: &MapArgs, devices: &str, spec: &MapSpec) -> anyhow::Result<()> {
    let indices = device_indices(devices)?;
    check_shard_count("--devices", indices.len() as u32, spec)?;
    let engines: Vec<Engine> = indices
        .iter()
        .map(|&i| Engine::gpu_adapter(i).map_err(hint))
        .collect::<Result<_, _>>()?;
    check_size(spec, engines.len() as u32, &engines[0])?;
    pendulum_atlas_map::output::budget::check_map_fits(spec, 1, &a.out)?;
    let inputs: Vec<&std::path::Path> = a.scene.iter().map(|p| p.as_path()).collect();
    super::claim_out_reading(Product::Map, &a.out, a.force, &inputs)?;
    if !a.quiet {
        tell!(
            "map of {} instances over {} devices: {}",
            spec.instances(),
            engines.len(),
            engines
                .iter()
                .map(|e| e.info().device.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let run = run_map_on_devices(spec, &engines, &super::until_interrupted).map_err(hint)?;
    super::stop_if_interrupted("during the map's last stage")?;
    let files = write_map(&a.out, spec, &run)?;
    report(&run, files.len(), &a.out)
}

/// `all` (every hardware adapter) or a comma-separated list of adapter indices.
fn device_indices(devices: &str) -> anyhow::Result<Vec<usize>> {
    if devices == "all" {
        let hw: Vec<usize> = list_adapters()
            .into_iter()
            .filter(|l| !l.is_software)
            .map(|l| l.index)
            .collect();
        if hw.is_empty() {
            anyhow::bail!(
                "--devices all: no hardware GPU adapter here (`pendulum-atlas adapters` lists what there is); use --backend gpu for a software one"
            );
        }
        return Ok(hw);
    }
    devices
        .split(',')
        .map(|s| {
            s.trim().parse::<usize>().map_err(|_| {
                anyhow::anyhow!(
                    "--devices `{devices}`: give `all` or adapter indices separated by commas, e.g. 0,1"
                )
            })
        })
        .collect()
}

/// `pendulum-atlas adapters`: the GPU adapters wgpu finds, with their indices.
pub fn adapters() -> anyhow::Result<()> {
    let list = list_adapters();
    if list.is_empty() {
        say!("no GPU adapter (install a Vulkan driver, or mesa-vulkan-drivers for lavapipe)");
    }
    for l in list {
        say!(
            "{}: {} ({}, {}{})",
            l.index,
            l.name,
            l.backend,
            l.device_type,
            if l.is_software { ", software" } else { "" }
        );
    }
    Ok(())
}

/// The map scene's text (kept by shards and Slurm jobs) and the validated map.
pub(super) fn read_map(
    scene: Option<&std::path::Path>,
    sets: &[String],
) -> anyhow::Result<(String, MapSpec)> {
    let (text, origin) = scene_text(scene, DEFAULT_MAP_TOML, "configs/maps/default.toml")?;
    let spec = map_from_toml(&text, &origin, sets)?;
    for note in &spec.notes {
        tell!("warning: {note}");
    }
    Ok((text, spec))
}

/// No more shards than instances (`flag` names the option in the message).
pub(super) fn check_shard_count(flag: &str, count: u32, spec: &MapSpec) -> anyhow::Result<()> {
    pendulum_atlas_map::map::check_shardable(spec).map_err(|e| anyhow::anyhow!("{flag}: {e}"))?;
    if count as usize > spec.instances() {
        anyhow::bail!(
            "{flag}: {count} shards of a map of {} instances; use at most {} shards",
            spec.instances(),
            spec.instances()
        );
    }
    Ok(())
}

/// Run `merge`.
pub fn merge(a: MergeArgs) -> anyhow::Result<()> {
    super::catch_interrupts();
    super::claim_out(Product::Map, &a.out, a.force)?;
    let mut merged = merge_shards(&a.shards)?;
    pendulum_atlas_map::output::budget::check_map_fits(&merged.spec, 1, &a.out)?;
    if a.no_settle {
        merged.spec.settle_max_s = None;
        merged.spec.transients = None;
    }
    if merged.spec.settle_max_s.is_some() {
        let engine = shards_engine(&merged.run.engine)?;
        let bar = super::progress_bar(
            a.quiet,
            "{spinner} {msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})",
        );
        bar.set_message("settling the merged map");
        let progress = super::bar_progress(&bar);
        settle(&merged.spec, &mut merged.run, &engine, &progress).map_err(hint)?;
        bar.finish_and_clear();
    }
    pendulum_atlas_map::map::orbits::find_orbits(&merged.spec, &mut merged.run);
    super::stop_if_interrupted("during the merged map's orbit stage")?;
    let files = write_map(&a.out, &merged.spec, &merged.run)?;
    say!(
        "merged {} shards of {} instances",
        merged.run.shards.len(),
        merged.spec.instances()
    );
    report(&merged.run, files.len(), &a.out)
}

/// The engine the shards ran on (its kind, float type and CPU loop), opened here for the
/// settling stage, so that a merged map settles as the whole map does.
fn shards_engine(info: &EngineInfo) -> anyhow::Result<Engine> {
    let mut engine = match info.kind {
        EngineKind::Cpu => Engine::cpu(info.precision),
        EngineKind::Gpu => Engine::open(Backend::Gpu, Some(info.precision)).map_err(|e| {
            anyhow::anyhow!(
                "the shards ran on the GPU ({}), and the merge runs their unsettled cells on with the same engine, but it does not open here: {e} [merge on a machine with a GPU, or add --no-settle]",
                info.device
            )
        })?,
    };
    if let Some(l) = info.cpu_loop {
        engine.set_cpu_loop(l);
    }
    Ok(engine)
}

/// One line on a map run by continuation: its axis and directions, restarts, and the bands
/// where up and down differ.
fn continuation_summary(c: &pendulum_atlas_map::map::continuation::ContinuationRun) -> String {
    use pendulum_atlas_core::text::num;
    let dirs: Vec<&str> = c.legs.iter().map(|l| l.direction.name()).collect();
    let restarted: usize = c.legs.iter().map(|l| l.restarted).sum();
    let mut line = format!(
        "continuation along {} ({})",
        c.spec.key,
        dirs.join(", then ")
    );
    if restarted > 0 {
        line += &format!(
            ", {restarted} cells restarted from the scene's state after a failed neighbour"
        );
    }
    if let Some(h) = &c.hysteresis {
        let unit = pendulum_atlas_core::config::key_unit(&c.spec.key).unwrap_or("");
        let bands: Vec<String> = h
            .bands
            .iter()
            .take(4)
            .map(|b| format!("{}–{} {unit}", num(b.from), num(b.to)))
            .collect();
        line += &match h.cells {
            0 => ": up and down agree on every cell (no hysteresis at this resolution)".to_string(),
            n => format!(
                ": up and down differ on {n} cells, in {} ({}{}; hysteresis.npy, map.json)",
                plural(h.bands.len(), "band"),
                bands.join(", "),
                if h.bands.len() > 4 { ", ..." } else { "" }
            ),
        };
    }
    line
}

/// "1 band", "3 bands".
fn plural(n: usize, word: &str) -> String {
    if n == 1 {
        format!("1 {word}")
    } else {
        format!("{n} {word}s")
    }
}

/// What ran and where it went; exit status 3 when no instance ended ok.
fn report(run: &MapRun, files: usize, out: &std::path::Path) -> anyhow::Result<()> {
    let ok = run
        .results
        .iter()
        .filter(|r| r.status == Status::Ok)
        .count();
    let runs = match (&run.runs, &run.attractors) {
        (Some(c), Some(a)) if a.starts > 1 => format!(
            " from {} starts each: {} runs ({} ok), {} attractor families",
            a.starts,
            c.runs,
            c.ok,
            a.families.len()
        ),
        (_, Some(a)) => format!(
            ", a basin picture of {} attractor families",
            a.families.len()
        ),
        _ => String::new(),
    };
    let steps = run.runs.map_or(run.plan.total_steps, |c| c.planned_steps);
    say!(
        "map: {} instances ({} ok){runs} on {} [{}], N = {}, {:.2e} instance-steps in {:.1} s ({:.3e} instance-steps/s, {:.3e} segment-steps/s)",
        run.results.len(),
        ok,
        run.engine.kind.name(),
        run.engine.device,
        run.plan.segments,
        steps as f64,
        run.timings.total_s,
        run.instance_steps_per_s(),
        run.segment_steps_per_s()
    );
    for w in &run.plan.warnings {
        tell!("warning: {w}");
    }
    say!(
        "method: {} ({}), dt {:.3e}..{:.3e} s",
        run.plan.method.name(),
        run.plan.method_reason,
        run.plan.dt_range_s.0,
        run.plan.dt_range_s.1
    );
    if let Some(c) = &run.continuation {
        say!("{}", continuation_summary(c));
    }
    if let Some(s) = &run.settle {
        say!(
            "settled: {} cells below confidence {} ran on to {} s ({} continued from the map's end, {} rerun from their start; {} stopped on a confirmed orbit); {} verdicts changed, {} chaotic cells settled, in {:.1} s",
            s.cells,
            s.firm,
            s.max_s,
            s.continued,
            s.rerun,
            s.stopped_early,
            s.changed,
            s.chaos_settled,
            s.wall_s
        );
    }
    if let Some(t) = &run.transients {
        say!(
            "copies: {} cells still not firm ran {} nudged copies each from their end; {} took the copies' orbit (a chaotic transient, transient_s.npy), the start decides {} (start_sensitivity.npy), in {:.1} s",
            t.cells,
            t.copies,
            t.took_orbit,
            t.start_decides,
            t.wall_s
        );
    }
    say!("wrote {files} files to {}", out.display());
    if ok == 0 {
        return Err(super::RunFailed(format!(
            "no instance of the map ended ok ({} failed; see status_counts in map.json)",
            run.results.len()
        ))
        .into());
    }
    Ok(())
}
