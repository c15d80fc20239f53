//! The result schema (`pendulum_atlas_core::schema::FIELDS`) against every output that lists
//! results: a map's arrays, `grid.csv`, `map.json`'s units and descriptions, a shard's
//! columns, and the explorer's metric list. (The Python dataset's variables: `python/tests`.)

use super::map_cli;
use pendulum_atlas_core::config::Metric;
use pendulum_atlas_core::schema::{Dtype, FIELDS, field};
use pendulum_atlas_map::output::map::stem;
use std::collections::BTreeMap;
use std::path::Path;

/// A 2 × 2 map at N = 2 over short runs, with the given metrics.
fn small_map(out: &Path, metrics: &str, extra: &[&str]) {
    let mut args = vec![
        "--set",
        "map.axes=[{key=\"excitation.frequency_hz\",values=[7.0,9.0]},{key=\"excitation.amplitude_m\",values=[0.01,0.02]}]",
        "--set",
        "beam.segments=2",
        "--set",
        "integration.duration_s=24",
        "--set",
        "integration.transient_s=8",
        "--set",
    ];
    let m = format!("map.metrics={metrics}");
    args.push(&m);
    args.extend_from_slice(extra);
    map_cli(out, &args);
}

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("pa-schema-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn manifest(dir: &Path, name: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join(name)).unwrap()).unwrap()
}

/// The schema's rows a map asked for `metrics` stores: (name, dtype), in table order.
fn stored(metrics: &[Metric]) -> Vec<(&'static str, Dtype)> {
    FIELDS
        .iter()
        .filter(|f| f.in_map && f.formed_for(metrics))
        .map(|f| (f.name, f.dtype))
        .collect()
}

#[test]
fn every_output_of_a_map_lists_the_results_of_the_schema() {
    for metrics in [
        "[\"K\",\"hops\"]",
        "[\"period\",\"alpha_range\",\"regime\"]",
    ] {
        let out = scratch("map");
        small_map(&out, metrics, &[]);
        // The metrics the map formed: those asked and those they are formed from.
        let m = manifest(&out, "map.json");
        let asked: Vec<Metric> = m["metrics"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| Metric::parse(n.as_str().unwrap()).unwrap())
            .collect();
        assert!(asked.len() >= 2, "{metrics}");
        let want = stored(&asked);
        // The arrays: one .npy per stored result the map formed, in its schema type.
        let files: Vec<String> = m["files"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f.as_str().unwrap().to_string())
            .filter(|f| f.ends_with(".npy") && !f.starts_with("axis"))
            // The stages' own arrays (the orbit stage's, ...) are not results of the schema.
            .filter(|f| !stem::ALL.contains(&f.trim_end_matches(".npy")))
            .collect();
        let names: Vec<String> = want.iter().map(|(n, _)| format!("{n}.npy")).collect();
        assert_eq!(files, names, "{metrics}");
        for (name, dtype) in &want {
            let bytes = std::fs::read(out.join(format!("{name}.npy"))).unwrap();
            let header = String::from_utf8_lossy(&bytes[..128.min(bytes.len())]).into_owned();
            let descr = match dtype {
                Dtype::F64 => "'<f8'",
                Dtype::I8 => "'|i1'",
                Dtype::U8 => "'|u1'",
                Dtype::U64 => "'<u8'",
            };
            assert!(header.contains(descr), "{name}: {header}");
        }
        // grid.csv: the axes, every stored result of the schema (formed or not), `inferred`.
        let csv = std::fs::read_to_string(out.join("grid.csv")).unwrap();
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let mut expected = vec!["excitation.frequency_hz", "excitation.amplitude_m"];
        expected.extend(FIELDS.iter().filter(|f| f.in_map).map(|f| f.name));
        expected.push("inferred");
        assert_eq!(header, expected);
        // map.json: a unit per value, a description per stored result, as the schema has them.
        let units: BTreeMap<String, String> = serde_json::from_value(m["units"].clone()).unwrap();
        let descriptions: BTreeMap<String, String> =
            serde_json::from_value(m["descriptions"].clone()).unwrap();
        for f in FIELDS.iter().filter(|f| f.in_map) {
            assert_eq!(descriptions[f.name], f.description);
            let unit = units.get(f.name).map(String::as_str);
            assert_eq!(
                unit,
                (f.dtype == Dtype::F64).then_some(f.unit),
                "{}",
                f.name
            );
        }
        // The explorer: a column per metric asked (and the verdict's confidence), each a
        // metric's or a schema row's name, or an array of a stage after the reductions.
        let folder = pendulum_atlas_explore::RunFolder::open(&out).unwrap();
        let columns: Vec<&str> = folder.columns.iter().map(|c| c.name.as_str()).collect();
        let stage = pendulum_atlas_map::output::map::stem::ALL;
        for c in &columns {
            assert!(
                Metric::parse(c).is_some() || field(c).is_some() || stage.contains(c),
                "{c} is neither a metric nor a result nor a stage's array"
            );
        }
        for m in &asked {
            assert!(columns.contains(&m.name()), "{}: {columns:?}", m.name());
        }
        let _ = std::fs::remove_dir_all(&out);
    }
}

#[test]
fn a_shard_names_its_columns_by_the_schema_and_merges_back_by_name() {
    let root = scratch("shard");
    let metrics = "[\"K\",\"period\",\"regime\"]";
    for i in 0..2 {
        let shard = format!("{i}/2");
        small_map(&root.join(format!("s{i}")), metrics, &["--shard", &shard]);
    }
    let m = manifest(&root.join("s0"), "shard.json");
    let columns: Vec<&str> = m["columns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_str().unwrap())
        .collect();
    let mut expected = vec!["index"];
    expected.extend(FIELDS.iter().map(|f| f.name));
    assert_eq!(columns, expected);
    // The columns are read by name: the same shard with its columns in another order (the
    // manifest's list and the rows permuted alike, the hash recomputed) merges to the same map.
    let whole = root.join("whole");
    small_map(&whole, metrics, &[]);
    permute_columns(&root.join("s1"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
        .args(["merge", "--out"])
        .arg(root.join("merged"))
        .arg(root.join("s0"))
        .arg(root.join("s1"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for name in ["K", "period", "regime", "status"] {
        let a = std::fs::read(whole.join(format!("{name}.npy"))).unwrap();
        let b = std::fs::read(root.join("merged").join(format!("{name}.npy"))).unwrap();
        assert_eq!(a, b, "{name}.npy");
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// Reverse the columns of a shard's `shard_results.npy` and of its manifest's list alike,
/// with the values' hash recomputed as its run would have written it.
fn permute_columns(dir: &Path) {
    use pendulum_atlas_map::output::npy::{read_npy, write_npy_f64};
    use pendulum_atlas_map::shard::files::values_sha256;
    let path = dir.join("shard_results.npy");
    let (shape, rows): (Vec<usize>, Vec<f64>) = read_npy(&path).unwrap();
    let permuted: Vec<f64> = rows
        .chunks_exact(shape[1])
        .flat_map(|r| r.iter().rev().copied())
        .collect();
    write_npy_f64(&path, &shape, &permuted).unwrap();
    let mut m = manifest(dir, "shard.json");
    let reversed: Vec<serde_json::Value> = m["columns"]
        .as_array()
        .unwrap()
        .iter()
        .rev()
        .cloned()
        .collect();
    m["columns"] = serde_json::Value::Array(reversed);
    let state = dir.join("shard_state.npy");
    let states: Vec<f64> = if state.exists() {
        read_npy(&state).unwrap().1
    } else {
        Vec::new()
    };
    m["values_sha256"] = values_sha256(&[&permuted, &[], &states]).into();
    std::fs::write(dir.join("shard.json"), m.to_string()).unwrap();
}
