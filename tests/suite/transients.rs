//! The transient stage (`docs/analysis.md`, §16): nudged copies of the cells settling leaves
//! not firm see through a chaotic transient, name the cells where the start decides, and hold
//! their confidence below firm; held against a long run from the cell's start.

use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, FIRM, MapSpec, map_from_toml};
use pendulum_atlas_core::engine::{Engine, Precision, no_progress};
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_map::map::confidence::summary;
use pendulum_atlas_map::map::{MapRun, run_map};

/// The default map's cells at the given axis values (its scene, lengths and metrics), with
/// `extra` overrides.
fn default_cells(freqs: &[&str], amps: &[&str], extra: &[&str]) -> MapSpec {
    let axes = format!(
        "map.axes=[{{key=\"excitation.frequency_hz\",values=[{}]}},{{key=\"excitation.amplitude_m\",values=[{}]}}]",
        freqs.join(","),
        amps.join(",")
    );
    let mut sets = vec![axes];
    sets.extend(extra.iter().map(|s| s.to_string()));
    map_from_toml(DEFAULT_MAP_TOML, "<default>", &sets).expect("valid test map")
}

fn cpu_map(spec: &MapSpec) -> MapRun {
    run_map(spec, &Engine::cpu(Precision::F64), &no_progress).expect("map")
}

/// The 3 × 3 cells of the default map around (10.095 Hz, 21.87 mm), its cell (48, 40) (the
/// values exactly as the default map computes them): a period-3 orbit after a chaotic
/// transient, by the converged reference of `docs/bench/VERDICT.md`.
const FREQS: [&str; 3] = [
    "9.968253968253968",
    "10.095238095238095",
    "10.222222222222221",
];
const AMPS: [&str; 3] = [
    "0.021425531914893617",
    "0.021872340425531916",
    "0.022319148936170215",
];
const CENTRE: usize = 4;

#[test]
fn a_chaotic_transient_is_seen_through_to_the_orbit_a_long_run_reaches() {
    let raw = cpu_map(&default_cells(&FREQS, &AMPS, &["map.transient_copies=0"]));
    let r = &raw.results[CENTRE];
    assert_eq!(
        r.regime,
        Regime::Chaotic,
        "settled, without copies: still chaotic"
    );
    assert!(r.verdict_confidence < FIRM);
    let run = cpu_map(&default_cells(&FREQS, &AMPS, &[]));
    let t = run.transients.as_ref().expect("the stage ran");
    assert_eq!(t.copies, 4);
    let r = &run.results[CENTRE];
    let tau = t.lifetime_s[CENTRE];
    eprintln!(
        "centre: {:?} period {} after a transient of {tau:.1} ± {:.1} s, start sensitivity {}, confidence {}",
        r.regime, r.period, t.lifetime_se_s[CENTRE], t.sensitivity[CENTRE], r.verdict_confidence
    );
    assert_eq!((r.regime, r.period), (Regime::Periodic, 3.0));
    assert!(t.after_transient[CENTRE]);
    assert!(tau.is_finite() && tau > 0.0 && t.lifetime_se_s[CENTRE] > 0.0);
    // Independent: one run of 1000 s from the cell's start, without settling or copies,
    // lands on the same orbit.
    let long = default_cells(
        &FREQS[1..2],
        &AMPS[1..2],
        &[
            "integration.duration_s=1000.0",
            "integration.transient_s=976.0",
            "map.settle=false",
            "map.orbits=false",
        ],
    );
    let l = cpu_map(&long).results[0];
    assert_eq!((l.regime, l.period), (Regime::Periodic, 3.0), "{l:?}");
    // The cells that ran no copies have neither a sensitivity nor a lifetime.
    for k in 0..run.results.len() {
        if t.sensitivity[k].is_nan() {
            assert!(t.lifetime_s[k].is_nan());
        }
    }
}

/// Where the copies disagree with the cell, its confidence is at most FIRM·(1 − s): never
/// firm; `map.json`'s summary counts those cells.
#[test]
fn a_cell_where_the_start_decides_is_never_firm() {
    let freqs = [
        "6.920634920634921",
        "7.0476190476190474",
        "7.174603174603174",
    ];
    let amps = [
        "0.01070212765957447",
        "0.011148936170212766",
        "0.011595744680851065",
    ];
    let run = cpu_map(&default_cells(&freqs, &amps, &[]));
    let t = run.transients.as_ref().expect("the stage ran");
    let sensitive: Vec<usize> = (0..run.results.len())
        .filter(|&k| t.start_decides_at(k))
        .collect();
    eprintln!(
        "sensitivities {:?}, confidences {:?}",
        t.sensitivity,
        run.results
            .iter()
            .map(|r| r.verdict_confidence)
            .collect::<Vec<_>>()
    );
    assert!(
        !sensitive.is_empty(),
        "this block holds a cell where the start decides"
    );
    for &k in &sensitive {
        let (c, s) = (run.results[k].verdict_confidence, t.sensitivity[k]);
        assert!(
            c <= FIRM * (1.0 - s) && c < FIRM,
            "cell {k}: {c} with s = {s}"
        );
    }
    let s = summary(&run).expect("decided cells");
    assert_eq!(s.start_decides, Some(t.start_decides));
    assert_eq!(t.start_decides, sensitive.len());
}

#[test]
fn copies_are_refused_by_name_where_the_map_does_not_settle_and_out_of_range() {
    let err = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        map_from_toml(DEFAULT_MAP_TOML, "<default>", &sets)
            .expect_err("refused")
            .to_string()
    };
    let e = err(&["map.settle=false", "map.transient_copies=4"]);
    assert!(
        e.contains("map.transient_copies") && e.contains("does not settle"),
        "{e}"
    );
    let e = err(&["map.transient_copies=65"]);
    assert!(
        e.contains("map.transient_copies") && e.contains("64"),
        "{e}"
    );
    let e = err(&["map.transient_nudge_deg_s=2.0"]);
    assert!(e.contains("map.transient_nudge_deg_s"), "{e}");
    // Off: no stage, and the nudge is noted as unused.
    let spec = map_from_toml(
        DEFAULT_MAP_TOML,
        "<default>",
        &[
            "map.transient_copies=0".to_string(),
            "map.transient_nudge_deg_s=0.01".to_string(),
        ],
    )
    .expect("valid");
    assert!(spec.transients.is_none());
    assert!(
        spec.notes
            .iter()
            .any(|n| n.contains("map.transient_nudge_deg_s")),
        "{:?}",
        spec.notes
    );
}
