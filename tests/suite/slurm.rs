//! A sharded map on a real Slurm: a one-node cluster on this machine (munged, slurmctld and
//! slurmd started here with a slurm.conf written here), `pendulum-atlas slurm --submit` of a
//! 4-shard array and its merge job, and the merged map against an unsharded run.
//!
//! Needs Debian's slurm-wlm and munge (`.ci/run` installs them). Without them the test prints
//! a skip message, unless PENDULUM_ATLAS_REQUIRE_SLURM=1 (as `.ci/run` sets), which fails it.

use super::shard::{SETS, assert_same_map, bin, map, ok, out_dir};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

const REQUIRE: &str = "PENDULUM_ATLAS_REQUIRE_SLURM";

/// A running one-node cluster; its daemons are stopped on drop.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for pid in ["slurmd.pid", "slurmctld.pid"] {
            if let Ok(p) = std::fs::read_to_string(self.dir.join(pid)) {
                let _ = Command::new("kill").arg(p.trim()).status();
            }
        }
    }
}

fn sh(cmd: &str) -> Option<String> {
    let o = Command::new("sh").args(["-c", cmd]).output().ok()?;
    o.status
        .success()
        .then(|| String::from_utf8_lossy(&o.stdout).trim().to_string())
}

/// Skip (or fail, when required) with `why`.
fn unavailable(why: &str) -> Option<Cluster> {
    if std::env::var(REQUIRE).is_ok_and(|v| v == "1") {
        panic!("{REQUIRE}=1 but Slurm cannot run here: {why}");
    }
    eprintln!("SKIPPED: {why} (install slurm-wlm and munge; set {REQUIRE}=1 to fail instead)");
    None
}

/// A free TCP port on localhost.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn write_conf(dir: &Path) -> PathBuf {
    let host = sh("hostname -s").unwrap_or_else(|| "localhost".into());
    let user = sh("id -un").unwrap_or_else(|| "root".into());
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let d = dir.display();
    let conf = format!(
        "ClusterName=pendulumatlas\nSlurmctldHost={host}(127.0.0.1)\nSlurmctldPort={}\nSlurmdPort={}\n\
         SlurmUser={user}\nSlurmdUser={user}\nAuthType=auth/munge\n\
         StateSaveLocation={d}/state\nSlurmdSpoolDir={d}/spool\n\
         SlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
         SlurmctldLogFile={d}/slurmctld.log\nSlurmdLogFile={d}/slurmd.log\n\
         ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nJobAcctGatherType=jobacct_gather/none\n\
         AccountingStorageType=accounting_storage/none\nJobCompType=jobcomp/none\n\
         SchedulerType=sched/backfill\nSelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\n\
         ReturnToService=2\nMpiDefault=none\n\
         NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
         PartitionName=atlas Nodes={host} Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES\n",
        free_port(),
        free_port()
    );
    let path = dir.join("slurm.conf");
    std::fs::write(&path, conf).unwrap();
    path
}

/// Start munged (if no munge credential can be made yet), slurmctld and slurmd; wait until
/// the node is idle.
fn start_cluster() -> Option<Cluster> {
    for b in ["slurmctld", "slurmd", "sbatch", "sinfo", "munged", "munge"] {
        if sh(&format!("command -v {b}")).is_none() {
            return unavailable(&format!("`{b}` is not on the PATH"));
        }
    }
    if sh("munge -n >/dev/null").is_none() {
        let _ =
            sh("mkdir -p /run/munge && chown munge:munge /run/munge 2>/dev/null; munged --force");
        if sh("munge -n >/dev/null").is_none() {
            return unavailable("munged is not running and could not be started");
        }
    }
    let dir = out_dir("slurm-cluster");
    for d in ["state", "spool"] {
        std::fs::create_dir_all(dir.join(d)).unwrap();
    }
    let conf = write_conf(&dir);
    let cluster = Cluster { dir, conf };
    for daemon in ["slurmctld", "slurmd"] {
        let st = Command::new(daemon)
            .env("SLURM_CONF", &cluster.conf)
            .status();
        if !st.is_ok_and(|s| s.success()) {
            return unavailable(&format!(
                "{daemon} did not start (see {})",
                cluster.dir.display()
            ));
        }
    }
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(60) {
        let state = Command::new("sinfo")
            .args(["-h", "-o", "%t"])
            .env("SLURM_CONF", &cluster.conf)
            .output();
        if state.is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle") {
            return Some(cluster);
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    unavailable(&format!(
        "the node never became idle (logs in {})",
        cluster.dir.display()
    ))
}

#[test]
fn a_four_shard_array_and_its_merge_job_on_slurm_equal_the_unsharded_map() {
    let Some(cluster) = start_cluster() else {
        return;
    };
    let root = out_dir("slurm-job");
    let job = root.join("job");
    let o = bin()
        .args([
            "slurm",
            "configs/maps/bifurcation_f.toml",
            "--backend",
            "cpu",
        ])
        .args(SETS)
        .args(["--shards", "4", "--time", "10:00", "--submit", "--out"])
        .arg(&job)
        .env("SLURM_CONF", &cluster.conf)
        .output()
        .unwrap();
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("submitted: array job"), "{stdout}");
    let array = std::fs::read_to_string(job.join("array.sbatch")).unwrap();
    assert!(array.contains("#SBATCH --array=0-3") && array.contains("#SBATCH --time=10:00"));
    let merged = job.join("map");
    let t0 = Instant::now();
    while !merged.join("map.json").exists() {
        assert!(
            t0.elapsed() < Duration::from_secs(600),
            "no merged map after 10 min; logs: {}",
            sh(&format!("tail -n 5 {}/logs/*", job.display())).unwrap_or_default()
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    for i in 0..4 {
        assert!(job.join(format!("shards/shard_{i}/shard.json")).exists());
    }
    let whole = root.join("whole");
    ok(&map(&["--out", whole.to_str().unwrap()]));
    assert_same_map(&whole, &merged);
}

/// `slurm` refuses, before writing any job, every map whose cells cannot run apart (one rule,
/// `MapMode::unshardable`), without needing a cluster.
#[test]
fn slurm_refuses_a_map_that_cannot_be_sharded_before_writing_jobs() {
    let f = "map.axes=[{key=\"excitation.frequency_hz\",values=[7.0,8.0,9.0]}]";
    let basin = "map.axes=[{key=\"initial.angle_deg\",values=[-10.0,10.0]},{key=\"initial.rate_deg_s\",values=[0.0,20.0]}]";
    for (sets, key) in [
        (vec![f, "map.initial_states=2"], "map.initial_states"),
        (vec![basin], "map.axes"),
        (vec![f, "map.continuation=up"], "map.continuation"),
    ] {
        let job = out_dir(&format!("slurm-refused-{}", key.replace('.', "_")));
        let mut cmd = bin();
        cmd.args(["slurm", "--backend", "cpu", "--shards", "2", "--out"])
            .arg(&job);
        for s in &sets {
            cmd.args(["--set", s]);
        }
        let o = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{sets:?}: {err}");
        assert!(
            err.contains("cannot be sharded") && err.contains(key),
            "{sets:?}: {err}"
        );
        assert!(
            !job.join("array.sbatch").exists(),
            "{sets:?}: a job was written"
        );
    }
}

/// `slurm` refuses shards that would each be huge before writing jobs, with their figures;
/// with `--yes` it writes them and every shard carries the acceptance, so that no array task
/// is refused on the cluster.
#[test]
fn slurm_asks_before_huge_shards_and_passes_the_acceptance_to_every_shard() {
    let grid = "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=2001},\
                {key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=1000}]";
    let slurm = |name: &str, yes: bool| {
        let job = out_dir(name);
        let mut cmd = bin();
        cmd.args(["slurm", "--backend", "cpu", "--shards", "2", "--out"])
            .arg(&job)
            .args(["--set", grid]);
        if yes {
            cmd.arg("--yes");
        }
        (job, cmd.output().unwrap())
    };
    let (job, o) = slurm("slurm-huge", false);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("each of the 2 shards")
            && err.contains("1000500 runs")
            && err.contains("--yes"),
        "{err}"
    );
    assert!(!job.join("array.sbatch").exists(), "a job was written");
    let (job, o) = slurm("slurm-huge-yes", true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let array = std::fs::read_to_string(job.join("array.sbatch")).unwrap();
    assert!(array.contains("map.accept_huge=true"), "{array}");
}

/// Every shard's command pins the engine and its precision, so that a shard computes the
/// same numbers wherever Slurm places it and the merged map equals the map run whole (issue
/// 71: shards of `auto` ran in f32 lanes while the whole map ran in f64).
#[test]
fn every_shard_pins_its_engine_and_precision() {
    for (backend, gpus, pinned) in [
        ("auto", "0", "--backend cpu --precision f64"),
        ("auto", "1", "--backend gpu --precision f32"),
        ("cpu", "0", "--backend cpu --precision f64"),
        ("gpu", "1", "--backend gpu --precision f32"),
    ] {
        let job = out_dir(&format!("slurm-pin-{backend}-{gpus}"));
        let o = bin()
            .args(["slurm", "--backend", backend, "--gpus-per-shard", gpus])
            .args(["--shards", "2", "--out"])
            .arg(&job)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let array = std::fs::read_to_string(job.join("array.sbatch")).unwrap();
        let words: Vec<&str> = array.split_whitespace().collect();
        let want: Vec<&str> = pinned.split(' ').collect();
        assert!(
            words.windows(4).any(|w| w == want.as_slice()),
            "{backend}, {gpus} GPUs: no `{pinned}` in {array}"
        );
        let _ = std::fs::remove_dir_all(&job);
    }
}
