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
    /// A path the scripts cannot hold safely.
    #[error(
        "{what} `{shown}`: a path written into the Slurm scripts may not hold control characters (newlines, tabs), double quotes or backslashes; choose another path",
        shown = path.escape_debug()
    )]
    UnsafePath {
        /// Which path (`--out`, the binary).
        what: &'static str,
        /// The path as given.
        path: String,
    },
    /// An argument the scripts cannot hold (a NUL byte).
    #[error("argument `{shown}` holds a NUL byte, which no shell script can hold", shown = arg.escape_debug())]
    UnsafeArgument {
        /// The argument.
        arg: String,
    },
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

/// `s` quoted for bash (every character literal, newlines included).
fn q(s: &str) -> Result<String, SlurmSpecError> {
    shlex::try_quote(s)
        .map(|c| c.into_owned())
        .map_err(|_| SlurmSpecError::UnsafeArgument { arg: s.into() })
}

fn qp(p: &Path) -> Result<String, SlurmSpecError> {
    q(&p.display().to_string())
}

/// A path as an `#SBATCH` value: in double quotes (which sbatch reads itself, there is no
/// shell), `%` doubled so that Slurm's file-name patterns keep it literal; `pattern` is
/// appended as it is (`%a`: the array index).
fn sbatch_path(dir: &Path, pattern: &str) -> String {
    format!(
        "\"{}{pattern}\"",
        dir.display().to_string().replace('%', "%%")
    )
}

/// Refuse a path that a script line cannot hold: control characters would end the line (a
/// newline in a comment starts a command), quotes and backslashes would end the `#SBATCH`
/// value.
fn check_script_path(what: &'static str, p: &Path) -> Result<(), SlurmSpecError> {
    let text = p.display().to_string();
    if text
        .chars()
        .any(|c| c.is_control() || c == '"' || c == '\\')
    {
        return Err(SlurmSpecError::UnsafePath { what, path: text });
    }
    Ok(())
}

impl SlurmJob {
    /// Refuse what the scripts cannot hold: the job folder and the binary are checked by
    /// `check_script_path`, the partition and time by their own rules, every argument
    /// for a NUL byte.
    pub fn check(&self) -> Result<(), SlurmSpecError> {
        check_script_path("--out", &self.dir)?;
        check_script_path("the pendulum-atlas binary", &self.binary)?;
        if let Some(p) = &self.partition {
            check_partition(p)?;
        }
        if let Some(t) = &self.time {
            check_time(t)?;
        }
        for a in &self.map_args {
            q(a)?;
        }
        Ok(())
    }

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

    /// The array job: task I runs shard I of N (refused as [`SlurmJob::check`] says).
    pub fn array_script(&self) -> Result<String, SlurmSpecError> {
        self.check()?;
        let mut s = format!(
            "#!/bin/bash\n# Shards of a pendulum-atlas map, one array task each (written by `pendulum-atlas slurm`).\n\
             # Rerun a failed shard alone with: sbatch --array=I {}\n\
             #SBATCH --job-name=pendulum-atlas-map\n#SBATCH --array=0-{}\n#SBATCH --ntasks=1\n#SBATCH --output={}\n",
            qp(&self.dir.join("array.sbatch"))?,
            self.shards - 1,
            sbatch_path(&self.dir.join("logs"), "/shard_%a.log")
        );
        s.push_str(&self.common_directives());
        if self.gpus_per_shard > 0 {
            s.push_str(&format!("#SBATCH --gres=gpu:{}\n", self.gpus_per_shard));
        }
        let args: Vec<String> = self
            .map_args
            .iter()
            .map(|a| q(a))
            .collect::<Result<_, _>>()?;
        s.push_str(&format!(
            "set -euo pipefail\n\
             i=\"${{SLURM_ARRAY_TASK_ID:?submit this script with sbatch: it is a Slurm array job}}\"\n\
             exec {} map {} {} --shard \"$i/{}\" --out {}/shards/shard_\"$i\" --force --quiet\n",
            qp(&self.binary)?,
            qp(&self.dir.join("scene.toml"))?,
            args.join(" "),
            self.shards,
            qp(&self.dir)?
        ));
        Ok(s)
    }

    /// The merge job: every shard folder into `DIR/map`.
    pub fn merge_script(&self) -> Result<String, SlurmSpecError> {
        self.check()?;
        let mut s = format!(
            "#!/bin/bash\n# Merge of the shards of a pendulum-atlas map (written by `pendulum-atlas slurm`).\n\
             #SBATCH --job-name=pendulum-atlas-merge\n#SBATCH --ntasks=1\n#SBATCH --output={}\n",
            sbatch_path(&self.dir.join("logs"), "/merge.log")
        );
        s.push_str(&self.common_directives());
        s.push_str(&format!(
            "set -euo pipefail\nexec {} merge {}/shards/shard_* --out {}/map --force\n",
            qp(&self.binary)?,
            qp(&self.dir)?,
            qp(&self.dir)?
        ));
        Ok(s)
    }

    /// The shell commands that submit both, the merge after the array succeeded.
    pub fn submit_commands(&self) -> Result<String, SlurmSpecError> {
        Ok(format!(
            "jid=$(sbatch --parsable {}) && sbatch --dependency=afterok:\"${{jid%%;*}}\" {}",
            qp(&self.dir.join("array.sbatch"))?,
            qp(&self.dir.join("merge.sbatch"))?
        ))
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
        let a = job.array_script().unwrap();
        assert!(a.contains("#SBATCH --array=0-3\n") && a.contains("#SBATCH --gres=gpu:1\n"));
        assert!(a.contains("--shard \"$i/4\""), "{a}");
        assert!(a.contains("'map.axes=[{key=\"a\"}]'"), "{a}");
        assert!(a.contains("'/scratch/my map/scene.toml'"), "{a}");
        let m = job.merge_script().unwrap();
        assert!(m.contains("merge '/scratch/my map'/shards/shard_* --out '/scratch/my map'/map"));
        assert!(
            job.submit_commands()
                .unwrap()
                .contains("--dependency=afterok:")
        );
        assert!(
            a.contains("#SBATCH --output=\"/scratch/my map/logs/shard_%a.log\"\n"),
            "{a}"
        );
    }

    fn job_in(dir: &str, args: &[&str]) -> SlurmJob {
        SlurmJob {
            dir: dir.into(),
            binary: "/opt/pa/pendulum-atlas".into(),
            shards: 2,
            gpus_per_shard: 0,
            partition: None,
            time: None,
            map_args: args.iter().map(|a| a.to_string()).collect(),
        }
    }

    #[test]
    fn a_path_that_would_end_a_script_line_is_refused_before_any_script() {
        for bad in [
            "/tmp/x\n#SBATCH --wrap=touch /tmp/pwned\ny",
            "/tmp/a\rb",
            "/tmp/q\"x",
            "/tmp/b\\s",
            "/tmp/t\tab",
        ] {
            let job = job_in(bad, &[]);
            let e = job.array_script().expect_err(bad).to_string();
            assert!(
                e.starts_with("--out `") && e.contains("control characters"),
                "{e}"
            );
            assert!(job.merge_script().is_err() && job.check().is_err());
        }
    }

    #[test]
    fn arguments_with_newlines_and_quotes_stay_one_literal_word() {
        let evil = "integration.method=\"rk4\"\n$(touch /tmp/pwned)'; rm -rf ~ #";
        let a = job_in("/scratch/100%/map", &["--set", evil])
            .array_script()
            .unwrap();
        let exec = a.lines().find(|l| l.starts_with("exec ")).unwrap();
        let words = shlex::split(&a[a.find(exec).unwrap()..]).expect("bash-quoted");
        assert!(words.iter().any(|w| w == evil), "{a}");
        assert!(
            a.contains("#SBATCH --output=\"/scratch/100%%/map/logs/shard_%a.log\""),
            "{a}"
        );
        assert_eq!(
            a.lines().filter(|l| l.starts_with("#SBATCH")).count(),
            4,
            "{a}"
        );
    }
}
