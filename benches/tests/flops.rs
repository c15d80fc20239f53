//! The flop table the product ships (`bench::cost`) against the count of the engine's own step,
//! and the peers' cases against the ones the peers read (`docs/bench/cpu`).

use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_lab::flops::{step_count, table_report, throughput_params};
use pendulum_atlas_lab::peer_case::write_peer_cases;
use pendulum_atlas_studies::bench::cost::step_flops;
use pendulum_atlas_studies::bench::gpu_throughput::ThroughputScene;
use serde_json::Value;

#[test]
fn the_shipped_flop_table_is_the_count_of_the_engines_own_step() {
    let (text, same) = table_report().expect("count");
    assert!(same, "{text}");
    for method in [Method::Rk4, Method::Imex] {
        for n in [3, 9, 17] {
            let (p, dt) = throughput_params(ThroughputScene::Default, method, n).unwrap();
            let counted = step_count(method, &p, dt);
            assert_eq!(step_flops(method, &p), counted, "{method:?} N = {n}");
            // Four stages (RK4) or four explicit stages (IMEX), each one sin/cos per segment
            // and two divisions per segment (the backward sweep's 1/d and the forward sweep's
            // division by d).
            let per = (counted.sin_cos, counted.divisions);
            assert_eq!(per, (4 * n as u64, 8 * n as u64), "{method:?} N = {n}");
        }
    }
}

/// Numbers equal to 1e-12 (relative), everything else exactly.
fn same(a: &Value, b: &Value, at: &str) {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
                "{at}: {x} against {y}"
            );
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}");
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                same(u, v, &format!("{at}[{i}]"));
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            let keys = |o: &serde_json::Map<String, Value>| o.keys().cloned().collect::<Vec<_>>();
            assert_eq!(keys(x), keys(y), "{at}");
            for (k, u) in x {
                same(u, &y[k], &format!("{at}.{k}"));
            }
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

#[test]
fn the_peer_cases_are_those_the_peers_read() {
    let dir = std::env::temp_dir().join(format!("lab-peer-cases-{}", std::process::id()));
    let written = write_peer_cases(&dir).expect("write");
    assert_eq!(written.len(), 3);
    let docs = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/bench/cpu");
    for path in &written {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let read = |p: &std::path::Path| -> Value {
            serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
        };
        same(
            &read(path),
            &read(&std::path::Path::new(docs).join(&name)),
            &name,
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
