//! Slurm job arrays for a sharded map: one array task per shard (`SLURM_ARRAY_TASK_ID` is the
//! shard index), and a merge job that runs once all of them succeeded (`afterok`).
//!
//! The scripts call the binary that wrote them by its absolute path, read the map scene copied
//! into the job folder, and write under it:
//!
//! ```text
//! DIR/array.sbatch  DIR/merge.sbatch  DIR/scene.toml  DIR/slurm.json
//! DIR/shards/shard_I/   one folder per shard (map --shard I/N)
//! DIR/logs/             shard_I.log, merge.log
//! DIR/map/              the merged map
//! ```

use std::path::{Path, PathBuf};

/// A Slurm submission of a sharded map.
#[derive(Debug, Clone)]
pub struct SlurmJob {
    /// The job folder (absolute).
    pub dir: PathBuf,
    /// The pendulum-atlas binary the jobs run (absolute).
    pub binary: PathBuf,
    /// Number of shards (array tasks).
    pub shards: u32,
    /// GPUs per array task (`--gres=gpu:G`; 0: none asked for).
    pub gpus_per_shard: u32,
    /// Partition, if any.
    pub partition: Option<String>,
    /// Time limit per task, in a Slurm time format, if any.
    pub time: Option<String>,
    /// Arguments every shard's `map` gets besides the scene, shard and folder (`--set`,
    /// `--backend`, `--precision`).
    pub map_args: Vec<String>,
}

/// A `--partition` or `--time` Slurm would refuse.
#[derive(Debug, thiserror::Error)]
pub enum SlurmSpecError {
    /// Not a partition name.
    #[error("--partition `{0}`: a partition name is letters, digits, '_', '-' and '.'")]
    Partition(String),
    /// Not a Slurm time.
    #[error(
        "--time `{0}`: give a Slurm time limit: minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS"
    )]
    Time(String),
}

/// Check a partition name.
pub fn check_partition(p: &str) -> Result<(), SlurmSpecError> {
    let ok = !p.is_empty()
        && p.chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
    if ok {
        Ok(())
    } else {
        Err(SlurmSpecError::Partition(p.into()))
    }
}

/// Check a time limit: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S` (all fields numbers).
pub fn check_time(t: &str) -> Result<(), SlurmSpecError> {
    let bad = || SlurmSpecError::Time(t.into());
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(d), r),
        None => (None, t),
    };
    let fields: Vec<&str> = rest.split(':').collect();
    let numeric = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_digit());
    let counts_ok = match days {
        Some(d) => numeric(d) && (1..=3).contains(&fields.len()),
        None => (1..=3).contains(&fields.len()),
    };
    if counts_ok && fields.iter().all(|f| numeric(f)) {
        Ok(())
    } else {
        Err(bad())
    }
}

fn q(s: &str) -> String {
    shlex::try_quote(s).map_or_else(|_| format!("'{s}'"), |c| c.into_owned())
}

fn qp(p: &Path) -> String {
    q(&p.display().to_string())
}

impl SlurmJob {
    /// `#SBATCH` lines shared by both scripts.
    fn common_directives(&self) -> String {
        let mut s = String::new();
        if let Some(p) = &self.partition {
            s.push_str(&format!("#SBATCH --partition={p}\n"));
        }
        if let Some(t) = &self.time {
            s.push_str(&format!("#SBATCH --time={t}\n"));
        }
        s
    }

    /// The array job: task I runs shard I of N.
    pub fn array_script(&self) -> String {
        let logs = self.dir.join("logs").join("shard_%a.log");
        let mut s = format!(
            "#!/bin/bash\n# Shards of a pendulum-atlas map, one array task each (written by `pendulum-atlas slurm`).\n\
             # Rerun a failed shard alone with: sbatch --array=I {}\n\
             #SBATCH --job-name=pendulum-atlas-map\n#SBATCH --array=0-{}\n#SBATCH --ntasks=1\n#SBATCH --output={}\n",
            self.dir.join("array.sbatch").display(),
            self.shards - 1,
            logs.display()
        );
        s.push_str(&self.common_directives());
        if self.gpus_per_shard > 0 {
            s.push_str(&format!("#SBATCH --gres=gpu:{}\n", self.gpus_per_shard));
        }
        let args: Vec<String> = self.map_args.iter().map(|a| q(a)).collect();
        s.push_str(&format!(
            "set -euo pipefail\n\
             i=\"${{SLURM_ARRAY_TASK_ID:?submit this script with sbatch: it is a Slurm array job}}\"\n\
             exec {} map {} {} --shard \"$i/{}\" --out {}/shards/shard_\"$i\" --force --quiet\n",
            qp(&self.binary),
            qp(&self.dir.join("scene.toml")),
            args.join(" "),
            self.shards,
            qp(&self.dir)
        ));
        s
    }

    /// The merge job: every shard folder into `DIR/map`.
    pub fn merge_script(&self) -> String {
        let mut s = format!(
            "#!/bin/bash\n# Merge of the shards of a pendulum-atlas map (written by `pendulum-atlas slurm`).\n\
             #SBATCH --job-name=pendulum-atlas-merge\n#SBATCH --ntasks=1\n#SBATCH --output={}\n",
            self.dir.join("logs").join("merge.log").display()
        );
        s.push_str(&self.common_directives());
        s.push_str(&format!(
            "set -euo pipefail\nexec {} merge {}/shards/shard_* --out {}/map --force\n",
            qp(&self.binary),
            qp(&self.dir),
            qp(&self.dir)
        ));
        s
    }

    /// The shell commands that submit both, the merge after the array succeeded.
    pub fn submit_commands(&self) -> String {
        format!(
            "jid=$(sbatch --parsable {}) && sbatch --dependency=afterok:\"${{jid%%;*}}\" {}",
            qp(&self.dir.join("array.sbatch")),
            qp(&self.dir.join("merge.sbatch"))
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_and_partitions_are_checked_as_slurm_reads_them() {
        for ok in ["30", "10:00", "1:00:00", "2-12", "2-12:30", "2-12:30:00"] {
            assert!(check_time(ok).is_ok(), "{ok}");
        }
        for bad in ["", "1h", "1:2:3:4", "-1", "2-", "a-1", "1:xx"] {
            assert!(check_time(bad).is_err(), "{bad}");
        }
        assert!(check_partition("gpu_a100.big-1").is_ok());
        assert!(check_partition("gpu;rm").is_err() && check_partition("").is_err());
    }

    #[test]
    fn the_array_maps_the_task_id_to_the_shard_and_quotes_every_argument() {
        let job = SlurmJob {
            dir: "/scratch/my map".into(),
            binary: "/opt/pa/pendulum-atlas".into(),
            shards: 4,
            gpus_per_shard: 1,
            partition: Some("gpu".into()),
            time: Some("1:00:00".into()),
            map_args: vec!["--set".into(), "map.axes=[{key=\"a\"}]".into()],
        };
        let a = job.array_script();
        assert!(a.contains("#SBATCH --array=0-3\n") && a.contains("#SBATCH --gres=gpu:1\n"));
        assert!(a.contains("--shard \"$i/4\""), "{a}");
        assert!(a.contains("'map.axes=[{key=\"a\"}]'"), "{a}");
        assert!(a.contains("'/scratch/my map/scene.toml'"), "{a}");
        let m = job.merge_script();
        assert!(m.contains("merge '/scratch/my map'/shards/shard_* --out '/scratch/my map'/map"));
        assert!(job.submit_commands().contains("--dependency=afterok:"));
    }
}
