//! Who owns an output folder. Each command writes into a folder of its own, so that nothing in it
//! is left from an earlier run (an old `R.npy` of another shape beside a new `K.npy`):
//!
//! - a folder that does not exist is created;
//! - a folder holding files this command writes (its [`Product`]'s names and patterns) is refused,
//!   unless `--force`, which replaces those files and nothing else, once the new run is
//!   complete (`earlier.rs`: they are set aside and put back if the new run fails);
//! - a folder holding another command's manifest (say `map.json` where `simulate` is asked to
//!   write) is refused even with `--force`: the two runs would mix.
//!
//! The check runs before any work, so a bad `--out` costs nothing. A run holds an advisory
//! lock on its folder ([`FolderLock`], the file `.pendulum-atlas.lock`) from the check to its
//! exit, so that a second run into the same folder is refused instead of mixing its files in.

use super::earlier::{self, Replacement, RunFiles};
use super::error::OutputError;
pub use super::held::check_held;
use super::held::hold;
use std::path::{Path, PathBuf};

/// What a command writes into its folder: a manifest written last, fixed file names, and
/// extensions of which it writes files with varying names (pictures and arrays).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Product {
    /// `simulate`: `trajectory.csv`, `run.json` and the analysis of the run.
    Simulate,
    /// `map` (and `merge`): `grid.csv`, `map_scene.toml`, `.npy` arrays, PNG maps, `map.json`.
    Map,
    /// `map --shard I/N`: the shard's results, its scene, `shard.json`.
    Shard,
    /// `slurm`: the sbatch scripts, the scene, `slurm.json`.
    Slurm,
    /// `analyze`: the analysis of a record and `analysis.json`.
    Analyze,
    /// `reproduce`: Table 2, the experiments, figures, `REPORT.md`, `summary.json`.
    Reproduce,
    /// `search`: designs, instances, the best design, figures, `search.json`.
    Search,
    /// `calibrate`: candidates, the best scene, the report, `calibrate.json`.
    Calibrate,
    /// `bench` (the work-precision study): `BENCHMARKS.md`, its figures, `bench.json`.
    Bench,
    /// `bench --stiff`: `STIFF.md`, its figure, `stiff.json`.
    BenchStiff,
    /// `bench --stiff-map`: `STIFF_MAP.md`, `stiff_map.csv`, `stiff_map.json`.
    BenchStiffMap,
    /// `bench --cpu-throughput`: `CPU.md`, `cpu_throughput.json`.
    BenchCpu,
    /// `bench --throughput`: `GPU.md`, `gpu_throughput.json`.
    BenchGpu,
    /// `pendulum-atlas-lab verdict` (the lab, `benches/`): `VERDICT.md`, `verdict.json`.
    BenchVerdict,
    /// `bench --refine`: `REFINE.md`, `refine.json`.
    BenchRefine,
    /// `pendulum-atlas-lab verdict-fit`: `PLANES.md`, `planes.json`.
    BenchPlanes,
    /// `pendulum-atlas-lab nudged`: `nudged.json`.
    BenchNudged,
}

impl Product {
    /// Every product, for finding whose manifest a folder holds.
    pub const ALL: [Product; 17] = [
        Product::Simulate,
        Product::Map,
        Product::Shard,
        Product::Slurm,
        Product::Analyze,
        Product::Reproduce,
        Product::Search,
        Product::Calibrate,
        Product::Bench,
        Product::BenchStiff,
        Product::BenchStiffMap,
        Product::BenchCpu,
        Product::BenchGpu,
        Product::BenchVerdict,
        Product::BenchRefine,
        Product::BenchPlanes,
        Product::BenchNudged,
    ];

    /// The command that writes it (the bench studies, the lab's among them, share one and
    /// may share a folder).
    pub fn command(self) -> &'static str {
        match self {
            Product::Simulate => "simulate",
            Product::Map => "map",
            Product::Shard => "map --shard",
            Product::Slurm => "slurm",
            Product::Analyze => "analyze",
            Product::Reproduce => "reproduce",
            Product::Search => "search",
            Product::Calibrate => "calibrate",
            Product::Bench
            | Product::BenchStiff
            | Product::BenchStiffMap
            | Product::BenchCpu
            | Product::BenchGpu
            | Product::BenchVerdict
            | Product::BenchRefine
            | Product::BenchPlanes
            | Product::BenchNudged => "bench",
        }
    }

    /// The file written last: its presence means the folder is complete.
    pub fn manifest(self) -> &'static str {
        match self {
            Product::Simulate => "run.json",
            Product::Map => "map.json",
            Product::Shard => "shard.json",
            Product::Slurm => "slurm.json",
            Product::Analyze => "analysis.json",
            Product::Reproduce => "summary.json",
            Product::Search => "search.json",
            Product::Calibrate => "calibrate.json",
            Product::Bench => "bench.json",
            Product::BenchStiff => "stiff.json",
            Product::BenchStiffMap => "stiff_map.json",
            Product::BenchCpu => "cpu_throughput.json",
            Product::BenchGpu => "gpu_throughput.json",
            Product::BenchVerdict => "verdict.json",
            Product::BenchRefine => "refine.json",
            Product::BenchPlanes => "planes.json",
            Product::BenchNudged => "nudged.json",
        }
    }

    /// File names it writes besides the manifest.
    fn names(self) -> &'static [&'static str] {
        match self {
            Product::Simulate => &["trajectory.csv", "time_series.png"],
            Product::Map => &["grid.csv", "map_scene.toml", "bifurcation.png"],
            Product::Shard => &["scene.toml", "shard_results.npy", "shard_strobe.npy"],
            Product::Slurm => &["array.sbatch", "merge.sbatch", "scene.toml"],
            Product::Analyze => &[],
            Product::Reproduce => &[
                "table2.csv",
                "table2.md",
                "experiments.csv",
                "earlier_reading.csv",
                "REPORT.md",
            ],
            Product::Search => &[
                "pareto.png",
                "power_vs_frequency.png",
                "designs.csv",
                "instances.csv",
                "verification.csv",
                "best_design.toml",
                "best.md",
                "search_scene.toml",
            ],
            Product::Calibrate => &[
                "candidates.csv",
                "best_scene.toml",
                "REPORT.md",
                "calibrate_scene.toml",
            ],
            Product::Bench => &["BENCHMARKS.md", "work_precision.png", "map_error.png"],
            Product::BenchStiff => &["STIFF.md", "stiff_work_precision.png"],
            Product::BenchStiffMap => &["STIFF_MAP.md", "stiff_map.csv"],
            Product::BenchCpu => &["CPU.md"],
            Product::BenchGpu => &["GPU.md"],
            Product::BenchVerdict => &["VERDICT.md"],
            Product::BenchRefine => &["REFINE.md"],
            Product::BenchPlanes => &["PLANES.md"],
            Product::BenchNudged => &[],
        }
    }

    /// Whether `name` is one of the files it writes beyond its fixed names: the analysis of a
    /// record (simulate, analyze), a map's arrays and pictures (named by its metrics), the
    /// paper's figures, the agreement pictures of a calibration. Nothing else matches, so a user's `rig_photo.png` is never
    /// taken for one.
    fn writes_varying(self, name: &str) -> bool {
        match self {
            Product::Simulate | Product::Analyze => ANALYSIS_FILES.contains(&name),
            Product::Map => is_map_file(name),
            Product::Reproduce => name.starts_with("fig") && name.ends_with(".png"),
            Product::Calibrate => name.starts_with("agreement_") && name.ends_with(".png"),
            _ => false,
        }
    }

    /// Whether a file of this name is one this product writes (or the temporary file of one,
    /// left by a killed run: `.NAME.tmp-PID.EXT`).
    pub fn writes(self, name: &str) -> bool {
        let name = temp_target(name).unwrap_or_else(|| name.to_string());
        name == self.manifest()
            || self.names().contains(&name.as_str())
            || self.writes_varying(&name)
    }

    /// The files of `dir` this product writes, sorted by name.
    pub fn files_in(self, dir: &Path) -> Result<Vec<PathBuf>, OutputError> {
        let mut found: Vec<PathBuf> = plain_files(dir)?
            .into_iter()
            .filter(|p| file_name(p).is_some_and(|n| self.writes(&n)))
            .collect();
        found.sort();
        Ok(found)
    }

    /// Make `dir` this product's: create it and lock it for this run, then check that it
    /// holds no earlier run (see the module's rules); with `force`, set the earlier run's
    /// files aside. Returns the lock, to hold until the run ends, and the earlier run set
    /// aside, to keep or undo when the run ends (`earlier.rs`).
    pub fn claim(
        self,
        dir: &Path,
        force: bool,
    ) -> Result<(FolderLock, Option<Replacement>), OutputError> {
        if dir.exists() && !dir.is_dir() {
            return Err(OutputError::NotAFolder(dir.display().to_string()));
        }
        if !dir.exists() {
            super::files::create_dir(dir)?;
        }
        let lock = FolderLock::take(dir, self.command())?;
        Ok((lock, self.clear(dir, force)?))
    }

    /// The check of [`Product::claim`] on a locked folder.
    fn clear(self, dir: &Path, force: bool) -> Result<Option<Replacement>, OutputError> {
        earlier::recover(dir, &self)?;
        if let Some(other) = self.foreign_manifest(dir) {
            return Err(OutputError::OtherRun {
                dir: dir.display().to_string(),
                manifest: other.manifest(),
                other: other.command(),
                command: self.command(),
            });
        }
        self.refuse_blocked(dir)?;
        let ours = self.earlier_run(dir)?;
        if ours.is_empty() {
            return Ok(None);
        }
        if !force {
            return Err(OutputError::FolderInUse {
                dir: dir.display().to_string(),
                command: self.command(),
                count: ours.len(),
                examples: examples(&ours, self.manifest()),
            });
        }
        Replacement::set_aside(dir, Box::new(self), &ours).map(Some)
    }

    /// Refuse an entry of `dir` that is not a regular file (a folder, a symlink, a FIFO) under
    /// a name this product writes: the write would fail only after the whole run.
    fn refuse_blocked(self, dir: &Path) -> Result<(), OutputError> {
        let entries = std::fs::read_dir(dir).map_err(|e| OutputError::io(dir, e))?;
        for entry in entries.filter_map(Result::ok) {
            let name = entry.file_name().to_string_lossy().into_owned();
            let Ok(kind) = entry.file_type() else {
                continue;
            };
            if kind.is_file() || name == LOCK_FILE || !self.writes(&name) {
                continue;
            }
            let what = if kind.is_dir() {
                "a folder"
            } else if kind.is_symlink() {
                "a symlink"
            } else {
                "not a regular file"
            };
            return Err(OutputError::Blocked {
                path: entry.path().display().to_string(),
                what,
                command: self.command(),
            });
        }
        Ok(())
    }

    /// The files of an earlier run in `dir`, sorted by name. Where its manifest lists its
    /// files, they are exactly those (the writer's own list, whatever their names), the
    /// manifest, and the temporary files of a killed run. Without a readable list (a run
    /// killed before its manifest), the names this product writes ([`Product::writes`]).
    fn earlier_run(self, dir: &Path) -> Result<Vec<PathBuf>, OutputError> {
        let Some(list) = listed_files(&dir.join(self.manifest())) else {
            return self.files_in(dir);
        };
        let mut found: Vec<PathBuf> = plain_files(dir)?
            .into_iter()
            .filter(|p| {
                file_name(p).is_some_and(|n| {
                    n == self.manifest()
                        || list.contains(&n)
                        || temp_target(&n).is_some_and(|t| list.contains(&t) || self.writes(&t))
                })
            })
            .collect();
        found.sort();
        Ok(found)
    }

    /// Refuse `inputs` (files the command reads) that lie in `dir` under a name this product
    /// writes: an input is never an output. Call it before [`Product::claim`].
    pub fn refuse_inputs(self, dir: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
        let Ok(out) = dir.canonicalize() else {
            return Ok(()); // a folder still to be made holds no input
        };
        for input in inputs {
            let Ok(p) = input.canonicalize() else {
                continue;
            };
            if p.parent() == Some(out.as_path()) && file_name(&p).is_some_and(|n| self.writes(&n)) {
                return Err(OutputError::InputIsOutput {
                    input: input.display().to_string(),
                    command: self.command(),
                    dir: dir.display().to_string(),
                });
            }
        }
        Ok(())
    }

    /// Another command's manifest in `dir`, if any.
    fn foreign_manifest(self, dir: &Path) -> Option<Product> {
        Product::ALL
            .into_iter()
            .filter(|p| p.command() != self.command())
            .find(|p| dir.join(p.manifest()).is_file())
    }
}

impl RunFiles for Product {
    fn writes(&self, name: &str) -> bool {
        Product::writes(*self, name)
    }
    fn manifest(&self) -> &'static str {
        Product::manifest(*self)
    }
}

/// The files of a record's analysis (`simulate` and `analyze`) besides the manifest.
const ANALYSIS_FILES: [&str; 16] = [
    "spectrum.csv",
    "spectrum.png",
    "scalogram.png",
    "zero_one.png",
    "phase_hist.png",
    "portrait.png",
    "phase_diff_rad.npy",
    "wavelet_power.npy",
    "wavelet_period_s.npy",
    "wavelet_scale_s.npy",
    "wavelet_time_s.npy",
    "wavelet_coi_s.npy",
    "wavelet_signif_level.npy",
    "wavelet_signif_ratio.npy",
    "wavelet_global_power.npy",
    "wavelet_global_signif.npy",
];

/// A map's files: its arrays (`K.npy`, `regime.npy`, `basin_fraction.npy`, `axis0.npy`,
/// `K_down.npy`, ...), its pictures (`K.png`, `K_slice003.png`, `hysteresis.png`, ...) and
/// `attractors.json`, `orbits.json`, `bifurcations.json`, by the stems the map's writer names them with
/// ([`super::map::stem`], [`super::map::map_fields`]).
fn is_map_file(name: &str) -> bool {
    use super::map::{MAP_JSONS, map_fields, stem};
    if MAP_JSONS.contains(&name) {
        return true;
    }
    let Some((stem_of, ext)) = name.rsplit_once('.') else {
        return false;
    };
    let base = match stem_of.split_once("_slice") {
        Some((m, n)) if ext == "png" && !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()) => m,
        _ => stem_of,
    };
    // The second direction of a continuation: `K_down.npy`, `regime_up.png`, ...
    let base = ["_up", "_down"]
        .iter()
        .find_map(|d| base.strip_suffix(d))
        .unwrap_or(base);
    let named = map_fields().any(|f| f.name == base)
        || stem::ALL.contains(&base)
        || pendulum_atlas_core::config::Metric::ALL
            .iter()
            .any(|m| m.name() == base);
    match ext {
        "npy" => named || ["axis0", "axis1", "axis2"].contains(&base),
        "png" => named,
        _ => false,
    }
}

/// The files a manifest lists under `files`, if it is readable and has that list.
pub(super) fn listed_files(manifest: &Path) -> Option<Vec<String>> {
    let text = std::fs::read_to_string(manifest).ok()?;
    let list: super::manifest::FileList = serde_json::from_str(&text).ok()?;
    Some(list.files)
}

/// The advisory lock of an output folder, held by a run from its check to its end (the lock
/// goes with the process, however it ends).
#[derive(Debug)]
pub struct FolderLock {
    _file: std::fs::File,
}

/// The lock file of an output folder.
pub const LOCK_FILE: &str = ".pendulum-atlas.lock";

impl FolderLock {
    /// Lock `dir` (which exists) for a run of `command`; refused while another run holds it.
    /// The lock file is opened without following a symlink and without blocking, and must be
    /// a regular file: a symlink or a FIFO planted in its place is refused, not followed or
    /// waited on.
    pub fn take(dir: &Path, command: &'static str) -> Result<FolderLock, OutputError> {
        let path = dir.join(LOCK_FILE);
        let mut options = std::fs::OpenOptions::new();
        options.create(true).truncate(false).write(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
        }
        let not_a_file = || {
            OutputError::io(
                &path,
                std::io::Error::other(
                    "the lock file is not a regular file (a symlink, a FIFO or a folder): remove it",
                ),
            )
        };
        let file = options.open(&path).map_err(|e| {
            // O_NOFOLLOW on a symlink fails with ELOOP.
            if path.symlink_metadata().is_ok_and(|m| !m.is_file()) {
                not_a_file()
            } else {
                OutputError::io(&path, e)
            }
        })?;
        if !file.metadata().is_ok_and(|m| m.is_file()) {
            return Err(not_a_file());
        }
        match file.try_lock() {
            Ok(()) => {
                hold(dir);
                Ok(FolderLock { _file: file })
            }
            Err(std::fs::TryLockError::WouldBlock) => Err(OutputError::Busy {
                dir: dir.display().to_string(),
                command,
            }),
            Err(std::fs::TryLockError::Error(e)) => Err(OutputError::io(&path, e)),
        }
    }
}

/// What `--force` does, for each command's `--help`.
pub const FORCE_HELP: &str = "Replace an earlier run in --out: its files are set aside and \
    deleted once the new run is complete, or put back if it fails (other files are left \
    alone). Without it, a folder that already holds such files is refused, so that no file of \
    an earlier run is left beside the new ones";

/// The target name of a temporary file (`.NAME.tmp-PID.EXT` → `NAME.EXT`).
fn temp_target(name: &str) -> Option<String> {
    let rest = name.strip_prefix('.')?;
    let (stem, tail) = rest.split_once(".tmp-")?;
    let ext = tail.split_once('.').map(|(_, e)| format!(".{e}"));
    Some(format!("{stem}{}", ext.unwrap_or_default()))
}

fn plain_files(dir: &Path) -> Result<Vec<PathBuf>, OutputError> {
    let entries = std::fs::read_dir(dir).map_err(|e| OutputError::io(dir, e))?;
    Ok(entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .collect())
}

fn file_name(p: &Path) -> Option<String> {
    p.file_name().map(|n| n.to_string_lossy().into_owned())
}

/// Up to four names, the manifest first, then "…".
fn examples(paths: &[PathBuf], manifest: &str) -> String {
    let mut names: Vec<String> = paths.iter().filter_map(|p| file_name(p)).collect();
    names.sort_by_key(|n| n != manifest);
    names.truncate(4);
    if paths.len() > 4 {
        names.push("…".into());
    }
    names.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_claimed_by_a_run_is_refused_to_a_second_until_the_first_ends() {
        let dir = std::env::temp_dir().join(format!("pa-lock-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (first, _) = Product::Map.claim(&dir, false).unwrap();
        let e = Product::Map.claim(&dir, true).unwrap_err().to_string();
        assert!(e.contains("in use by another run"), "{e}");
        drop(first);
        assert!(Product::Map.claim(&dir, false).is_ok());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temporary_files_count_as_their_target() {
        assert_eq!(temp_target(".K.tmp-123.npy").as_deref(), Some("K.npy"));
        assert_eq!(temp_target(".x.tmp-7").as_deref(), Some("x"));
        assert_eq!(temp_target("K.npy"), None);
        assert!(Product::Map.writes(".grid.tmp-99.csv"));
        assert!(!Product::Map.writes("data.csv"));
    }

    #[test]
    fn only_names_a_command_writes_are_its_files() {
        for ours in [
            "K.npy",
            "axis1.npy",
            "K.png",
            "lyapunov_slice007.png",
            "map.json",
        ] {
            assert!(Product::Map.writes(ours), "{ours}");
        }
        for theirs in [
            "rig_photo.png",
            "calib.npy",
            "K_slice.png",
            "Kx.npy",
            "notes.txt",
        ] {
            assert!(!Product::Map.writes(theirs), "{theirs}");
        }
        assert!(Product::Simulate.writes("wavelet_power.npy"));
        assert!(!Product::Simulate.writes("rig_photo.png"));
        assert!(!Product::Analyze.writes("calib.npy"));
        assert!(Product::Reproduce.writes("fig4a_f6.8_A9.png"));
    }
}
