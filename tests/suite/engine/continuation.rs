//! Continuation on every engine (cases of the engine suite, see `mod.rs`): a cell continues
//! from exactly the state its neighbour ended in, and a pinned stretch of the forcing axis
//! keeps a period-2 orbit sweeping down that sweeping up never reaches (hysteresis).

use super::Under;
use super::cases::tiny_map;
use pendulum_atlas_core::engine::no_progress;
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_map::map::{MapRun, run_map};

fn map_on(under: Under, spec: &pendulum_atlas_core::config::MapSpec) -> Option<MapRun> {
    let engine = under.engine()?;
    Some(run_map(spec, engine, &no_progress).expect("map"))
}

/// An undamped clamped cantilever released bent, under weak forcing, no bumpers: its motion
/// never settles, so the stroboscopic samples of a run tell how long it has run since its
/// start. (The first line continues the `[beam]` table of [`tiny_map`].)
const UNSETTLED: &str = "damping_ratio = 0.0\n[pivot]\nmode = \"clamped\"\n\
    [limiter]\nenabled = false\n[excitation]\namplitude_m = 0.001\n[initial]\nangle_deg = 2.0\n";

fn unsettled(
    under: Under,
    duration: f64,
    transient: f64,
    map: &str,
) -> pendulum_atlas_core::config::MapSpec {
    let extra = format!(
        "{UNSETTLED}[integration]\nduration_s = {duration:.1}\ntransient_s = {transient:.1}\n"
    );
    let map =
        format!("metrics = [\"alpha_range\"]\nbifurcation = true\nbifurcation_samples = 16\n{map}");
    tiny_map(under, &extra, &map)
}

/// Two cells 1e-9 Hz apart, continued upwards for 10 s each, against one run of 20 s: the
/// second cell's last 16 stroboscopic samples are the long run's, because it started where
/// the first cell ended, at a whole number of forcing periods.
pub fn a_continued_cell_starts_exactly_where_its_neighbour_ended(under: Under) {
    let pair = unsettled(
        under,
        10.0,
        5.0,
        "continuation = \"up\"\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [8.0, 8.000000001]\n",
    );
    let long = unsettled(
        under,
        20.0,
        15.0,
        "[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [8.0]\n",
    );
    let (Some(p), Some(l)) = (map_on(under, &pair), map_on(under, &long)) else {
        return;
    };
    let gap = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    let (first, second, whole) = (&p.strobe_tail[0], &p.strobe_tail[1], &l.strobe_tail[0]);
    let continued = gap(second, whole);
    let restarted = gap(first, whole);
    eprintln!("{under:?}: continued {continued:e} rad, restarted {restarted:e} rad");
    assert!(
        restarted > 1e-3,
        "the test's motion must not settle ({restarted})"
    );
    assert!(
        continued < 1e-3 * restarted,
        "the continued cell is {continued} rad from the long run (a fresh start is {restarted})"
    );
    let c = p.continuation.as_ref().expect("a continued map");
    assert_eq!(c.legs.len(), 1);
    assert_eq!(c.legs[0].restarted, 0);
}

/// The pinned hysteresis: at 1 mm, sweeping down from 12 Hz (started from the scene's state)
/// in steps of at most 1 Hz holds a period-2 orbit down to 10 Hz (about 9.5 Hz in steps of
/// 0.25 Hz), while sweeping up stays on the period-1 orbit of the α > 0 well all the way (`docs/analysis.md`, "Continuation and hysteresis").
pub fn sweeping_down_keeps_a_period_two_orbit_that_sweeping_up_never_reaches(under: Under) {
    let spec = tiny_map(
        under,
        "[integration]\nduration_s = 36.0\ntransient_s = 12.0\n[excitation]\namplitude_m = 0.001\n",
        "metrics = [\"period\", \"alpha_range\", \"regime\"]\nlyapunov_window_s = 6.0\n\
         continuation = \"both\"\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\n\
         values = [9.0, 10.0, 10.5, 11.0, 11.5, 12.0]\n",
    );
    let Some(run) = map_on(under, &spec) else {
        return;
    };
    let c = run.continuation.as_ref().expect("a continued map");
    let (up, down) = (&c.legs[0].results, &c.legs[1].results);
    let periods = |rs: &[pendulum_atlas_core::reduce::InstanceResult]| -> Vec<f64> {
        rs.iter().map(|r| r.period).collect()
    };
    assert!(
        up.iter().chain(down).all(|r| r.regime == Regime::Periodic),
        "{up:?} {down:?}"
    );
    assert_eq!(periods(up), vec![1.0; 6], "up");
    assert_eq!(periods(down), vec![1.0, 2.0, 2.0, 2.0, 2.0, 2.0], "down");
    let h = c.hysteresis.as_ref().expect("both directions");
    assert_eq!(h.differs, vec![false, true, true, true, true, true]);
    assert_eq!(h.bands.len(), 1);
    assert_eq!(
        (h.bands[0].from, h.bands[0].to, h.bands[0].cells),
        (10.0, 12.0, 5)
    );
}
