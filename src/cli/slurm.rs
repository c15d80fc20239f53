//! `pendulum-atlas slurm`: the sbatch scripts of a sharded map, and optionally their submission.

use super::engine::{BackendArg, hint};
use pendulum_atlas_map::map::size::MapSize;
use pendulum_atlas_map::output::files::{create_dir, write_bytes, write_json};
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::shard::{SlurmJob, check_partition, check_time};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Arguments of `slurm`.
#[derive(Debug, clap::Args)]
pub struct SlurmArgs {
    /// Map scene (as for `map`; omit it for the embedded default map).
    pub scene: Option<PathBuf>,
    /// Override a scene or map key, passed on to every shard.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Number of shards: array tasks 0..N-1.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub shards: u32,
    /// GPUs each array task asks for (`--gres=gpu:G`); 0 for CPU-only tasks.
    #[arg(long, default_value_t = 0)]
    pub gpus_per_shard: u32,
    /// Slurm partition.
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit of each task (Slurm format, e.g. 1:00:00).
    #[arg(long)]
    pub time: Option<String>,
    /// Engine of every shard, pinned in each shard's command with its precision: `gpu` (f32),
    /// `cpu` (f64), or `auto`: the GPU where --gpus-per-shard > 0, else the CPU engine in f64.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// Job folder: scripts, logs, shard folders and the merged map (DIR/map).
    #[arg(long)]
    pub out: PathBuf,
    /// Submit the array and the merge job (needs `sbatch` on the PATH).
    #[arg(long)]
    pub submit: bool,
    /// Replace the scripts of an earlier `slurm` run in --out.
    #[arg(long)]
    pub force: bool,
    /// Shards that are huge (see `map --yes`) run: every shard gets map.accept_huge = true.
    #[arg(long)]
    pub yes: bool,
}

/// Run `slurm`.
pub fn run(mut a: SlurmArgs) -> anyhow::Result<()> {
    if a.yes {
        a.sets.push("map.accept_huge=true".into());
    }
    let (text, spec) = super::map::read_map(a.scene.as_deref(), &a.sets)?;
    super::map::check_shard_count("--shards", a.shards, &spec)?;
    let size = MapSize::of_shard(&spec, a.shards).map_err(hint)?;
    if size.is_huge() {
        let verdict = size.verdict(spec.accept_huge, None);
        if !spec.accept_huge {
            return Err(hint(verdict));
        }
        tell!("{verdict}");
    }
    if let Some(p) = &a.partition {
        check_partition(p)?;
    }
    if let Some(t) = &a.time {
        check_time(t)?;
    }
    if a.gpus_per_shard > 1 {
        tell!(
            "warning: --gpus-per-shard {}: a shard runs on one GPU; use more shards to use more GPUs",
            a.gpus_per_shard
        );
    }
    let job = job(&a)?;
    let (array, merge, submit) = (
        job.array_script()?,
        job.merge_script()?,
        job.submit_commands()?,
    );
    let inputs: Vec<&std::path::Path> = a.scene.iter().map(|p| p.as_path()).collect();
    super::claim_out_reading(Product::Slurm, &a.out, a.force, &inputs)?;
    create_dir(&job.dir.join("logs"))?;
    write_bytes(&job.dir.join("scene.toml"), text.as_bytes())?;
    write_bytes(&job.dir.join("array.sbatch"), array.as_bytes())?;
    write_bytes(&job.dir.join("merge.sbatch"), merge.as_bytes())?;
    say!(
        "{} shards of {} instances; scripts in {}",
        a.shards,
        spec.instances(),
        job.dir.display()
    );
    let manifest = |jobs: serde_json::Value| {
        write_json(
            &job.dir.join("slurm.json"),
            &serde_json::json!({
                "shards": a.shards,
                "instances": spec.instances(),
                "submit": submit,
                "jobs": jobs,
                "merged_map": job.dir.join("map"),
            }),
        )
    };
    manifest(serde_json::Value::Null)?;
    if !a.submit {
        say!("submit with:\n  {submit}");
        return Ok(());
    }
    let (array, merge) = submit_both(&job).map_err(|e| {
        e.context(format!(
            "the scripts are written; submit them by hand with: {submit}"
        ))
    })?;
    manifest(serde_json::json!({"array": array, "merge": merge}))?;
    Ok(())
}

fn job(a: &SlurmArgs) -> anyhow::Result<SlurmJob> {
    let dir = std::path::absolute(&a.out)?;
    let binary = std::env::current_exe()?;
    let mut map_args: Vec<String> = a
        .sets
        .iter()
        .flat_map(|s| ["--set".to_string(), s.clone()])
        .collect();
    map_args.extend(shard_engine(a.backend, a.gpus_per_shard));
    Ok(SlurmJob {
        dir,
        binary,
        shards: a.shards,
        gpus_per_shard: a.gpus_per_shard,
        partition: a.partition.clone(),
        time: a.time.clone(),
        map_args,
    })
}

/// The engine and precision every shard's command pins, so that each shard computes the same
/// numbers wherever Slurm places it and the merged map equals the map run whole: `auto` is
/// the GPU (f32) where the tasks ask for GPUs, else the CPU engine in f64.
fn shard_engine(backend: BackendArg, gpus_per_shard: u32) -> [String; 4] {
    let gpu = match backend {
        BackendArg::Auto => gpus_per_shard > 0,
        BackendArg::Gpu => true,
        BackendArg::Cpu => false,
    };
    let (engine, precision) = if gpu { ("gpu", "f32") } else { ("cpu", "f64") };
    ["--backend", engine, "--precision", precision].map(String::from)
}

/// `sbatch --parsable` on a script, with extra flags; the job id.
fn sbatch(flags: &[String], script: &Path) -> anyhow::Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(flags)
        .arg(script)
        .output()
        .map_err(|e| {
            anyhow::anyhow!(
                "cannot run sbatch ({e}); --submit needs Slurm's sbatch on the PATH: run the printed commands on the cluster's login node instead"
            )
        })?;
    if !out.status.success() {
        anyhow::bail!(
            "sbatch {} failed: {}",
            script.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let id = String::from_utf8_lossy(&out.stdout)
        .trim()
        .split(';')
        .next()
        .unwrap_or_default()
        .to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        anyhow::bail!("sbatch {} printed no job id: `{id}`", script.display());
    }
    Ok(id)
}

/// Submit the array, then the merge after it; both job ids.
fn submit_both(job: &SlurmJob) -> anyhow::Result<(String, String)> {
    let array = sbatch(&[], &job.dir.join("array.sbatch"))?;
    let merge = sbatch(
        &[format!("--dependency=afterok:{array}")],
        &job.dir.join("merge.sbatch"),
    )?;
    say!(
        "submitted: array job {array} ({} tasks), merge job {merge} after it",
        job.shards
    );
    Ok((array, merge))
}
