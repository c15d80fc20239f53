//! Several starts per cell on every engine (cases of the engine suite, see `mod.rs`): a cell
//! pinned as bistable shows both of its attractors, and a basin picture over the start agrees
//! with the starts' estimate of the basin fractions.

use super::Under;
use super::cases::tiny_map;
use pendulum_atlas_core::config::MapSpec;
use pendulum_atlas_core::engine::no_progress;
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_core::reduce::attractors::Wells;
use pendulum_atlas_map::map::{MapRun, run_map};

/// The pinned bistable cell: 8 Hz at 1 mm (N = 3), where the pendulum rattles on one bumper
/// in a period-1 orbit, the one of the α > 0 well or its mirror image in the α < 0 well,
/// whichever well the start leads to (`docs/analysis.md`, "Attractors").
const BISTABLE: &str = "[integration]\nduration_s = 30.0\ntransient_s = 15.0";

fn bistable_axes(extra_axes: &str) -> String {
    format!(
        "[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [8.0]\n\
         [[map.axes]]\nkey = \"excitation.amplitude_m\"\nvalues = [0.001]\n{extra_axes}"
    )
}

fn map_on(under: Under, spec: &MapSpec) -> Option<MapRun> {
    let engine = under.engine()?;
    Some(run_map(spec, engine, &no_progress).expect("map"))
}

pub fn a_bistable_cell_shows_the_attractor_of_each_well(under: Under) {
    let spec = tiny_map(
        under,
        BISTABLE,
        &format!("initial_states = 8\n{}", bistable_axes("")),
    );
    let Some(run) = map_on(under, &spec) else {
        return;
    };
    let a = run
        .attractors
        .as_ref()
        .expect("a map with starts labels attractors");
    assert_eq!(a.starts, 8);
    assert_eq!(a.count, vec![2], "{:?}", a.families);
    let mut wells: Vec<Wells> = a.families.iter().map(|f| f.fingerprint.wells).collect();
    wells.sort_by_key(|w| *w as u8);
    assert_eq!(wells, vec![Wells::Positive, Wells::Negative]);
    for f in &a.families {
        assert_eq!(f.fingerprint.regime, Regime::Periodic, "{f:?}");
        assert_eq!(f.fingerprint.period, 1, "{f:?}");
    }
    // Every start reached one of the two; the fractions and the failed share sum to 1.
    assert_eq!(a.failed, vec![0.0]);
    let total: f64 = a.fractions.iter().map(|f| f[0]).sum();
    assert!((total - 1.0).abs() < 1e-12, "{total}");
    assert!(a.run_label.iter().all(|&l| l == 0 || l == 1));
    // The cell's metric arrays hold a run of its most likely attractor.
    assert_eq!(run.results.len(), 1);
    assert_eq!(run.results[0].regime, Regime::Periodic);
    let most = a.most_likely[0] as usize;
    assert!(a.fractions[most][0] >= 0.5);
}

pub fn a_basin_picture_agrees_with_the_starts_estimate(under: Under) {
    let range = "initial_angle_min_deg = -15.0\ninitial_angle_max_deg = 15.0\n\
                 initial_rate_min_deg_s = -150.0\ninitial_rate_max_deg_s = 150.0\n";
    // The basin picture: an 8 × 8 grid over the start of the one cell.
    let cell = format!("{BISTABLE}\n[excitation]\nfrequency_hz = 8.0\namplitude_m = 0.001");
    let picture = tiny_map(
        under,
        &cell,
        "[[map.axes]]\nkey = \"initial.angle_deg\"\nstart = -15.0\nend = 15.0\ncount = 8\n\
         [[map.axes]]\nkey = \"initial.rate_deg_s\"\nstart = -150.0\nend = 150.0\ncount = 8\n",
    );
    let starts = tiny_map(
        under,
        BISTABLE,
        &format!("initial_states = 64\n{range}{}", bistable_axes("")),
    );
    let (Some(p), Some(s)) = (map_on(under, &picture), map_on(under, &starts)) else {
        return;
    };
    let (pa, sa) = (p.attractors.unwrap(), s.attractors.unwrap());
    // The picture's share of each well's attractor against the starts' basin fraction.
    let share_of = |wells: Wells, a: &pendulum_atlas_core::reduce::AttractorMap| -> f64 {
        a.families
            .iter()
            .filter(|f| f.fingerprint.wells == wells)
            .map(|f| f.runs as f64)
            .sum::<f64>()
            / a.run_label.len() as f64
    };
    for wells in [Wells::Positive, Wells::Negative] {
        let (x, y) = (share_of(wells, &pa), share_of(wells, &sa));
        // Two estimates of one fraction from 64 points each: within three standard errors
        // of their difference.
        let q = 0.5 * (x + y);
        let se = (q * (1.0 - q) * (2.0 / 64.0)).sqrt().max(1.0 / 64.0);
        assert!(
            (x - y).abs() <= 3.0 * se,
            "{wells:?}: picture {x}, starts {y} (3 SE = {})",
            3.0 * se
        );
        assert!(
            x > 0.1,
            "{wells:?}: both wells have a basin in the picture ({x})"
        );
    }
    // Each cell of the picture is one start: its label is its run's.
    assert_eq!(pa.starts, 1);
    assert_eq!(pa.run_label, pa.most_likely);
}

/// Three starts that are not mirror images of one another, given as (angle, rate) in
/// (deg, deg/s); `sign` −1 mirrors them.
fn starts_list(sign: f64) -> String {
    let starts = [(6.0, 90.0), (-12.0, 40.0), (15.0, -150.0)];
    let items: Vec<String> = starts
        .iter()
        .map(|(a, r)| {
            format!(
                "{{angle_deg = {:.1}, rate_deg_s = {:.1}}}",
                sign * a,
                sign * r
            )
        })
        .collect();
    format!("initial_states = [{}]\n", items.join(", "))
}

/// The model is unchanged by (α, α̇, t) → (−α, −α̇, t + T/2) with x0 = A sin 2πft: the
/// mirrored start under the forcing shifted by half a period (`excitation.phase_deg = 180`)
/// lands on the mirror image of the attractor the start reached, run by run.
pub fn a_mirrored_start_with_half_a_period_of_phase_lands_on_the_mirrored_attractor(under: Under) {
    let plain = tiny_map(
        under,
        BISTABLE,
        &format!("{}{}", starts_list(1.0), bistable_axes("")),
    );
    let mirror = tiny_map(
        under,
        &format!("{BISTABLE}\n[excitation]\nphase_deg = 180.0"),
        &format!("{}{}", starts_list(-1.0), bistable_axes("")),
    );
    let (Some(p), Some(m)) = (map_on(under, &plain), map_on(under, &mirror)) else {
        return;
    };
    let (pa, ma) = (p.attractors.unwrap(), m.attractors.unwrap());
    let fingerprint = |a: &pendulum_atlas_core::reduce::AttractorMap, run: usize| {
        let label = a.run_label[run];
        assert!(label >= 0, "run {run} failed");
        a.families[label as usize].fingerprint.clone()
    };
    let mut wells = Vec::new();
    for run in 0..3 {
        let (f, g) = (fingerprint(&pa, run), fingerprint(&ma, run));
        let rule = pa.rule;
        assert!(
            g.same_as(&f.mirrored(), rule.cycle_tol_rad, rule.range_overlap),
            "run {run}: {g:?} is not the mirror image of {f:?}"
        );
        wells.push(f.wells);
    }
    // The starts reach both wells, so the mirror exchanges two different attractors.
    assert!(
        wells.contains(&Wells::Positive) && wells.contains(&Wells::Negative),
        "{wells:?}"
    );
}
