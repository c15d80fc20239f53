//! One cell of an ensemble as a plain scene that runs exactly what the ensemble ran: the
//! integration method, the step control and the step the plan took pinned (at fixed steps
//! `integration.dt_s = 1/(f·spp)`; at adaptive steps that base step,
//! `integration.base_step_s`, with the same tolerances), and rows at a whole number of steps
//! so that the record's sample rate is exact. The explorer's "run this cell" and Python's
//! `Scene.cell` both come here.

use pendulum_atlas_core::config::{ConfigError, MapSpec, Scene, StepControl, set_key};
use pendulum_atlas_core::engine::{EngineError, EnsembleOptions, EnsemblePlan};
use pendulum_atlas_core::text::num;
use toml::{Table, Value};

/// The keys [`pinned_cell`] sets: the method, the step control and its step, the row rate.
pub const PINNED_KEYS: [&str; 4] = [
    "integration.method",
    "integration.step",
    "integration.dt_s",
    "output.sample_rate_hz",
];

/// The keys [`pinned_cell`] sets at adaptive steps (the base step in place of `dt_s`).
pub const PINNED_ADAPTIVE_KEYS: [&str; 4] = [
    "integration.method",
    "integration.step",
    "integration.base_step_s",
    "output.sample_rate_hz",
];

/// The scene table of one instance (`table`, with the ensemble's `integration.method` already
/// set where the ensemble fixed one), with the method, step control, step and row rate its
/// ensemble plan (`opts`) takes set in it; and which keys were set ([`PINNED_KEYS`] or
/// [`PINNED_ADAPTIVE_KEYS`]).
pub fn pinned_cell(
    mut table: Table,
    opts: &EnsembleOptions,
) -> Result<(Table, &'static [&'static str]), EngineError> {
    let scene = Scene::from_table(table.clone())?;
    let plan = EnsemblePlan::from_scenes(std::slice::from_ref(&scene), opts)?;
    let p = &plan.instances[0];
    // Rows at a whole number of steps, so the record's sample rate is exact.
    let every = (f64::from(p.spp) * p.frequency_hz / scene.output.sample_rate_hz)
        .round()
        .max(1.0);
    let rate = p.frequency_hz * f64::from(p.spp) / every;
    let set =
        |t: &mut Table, key: &str, v: Value| -> Result<(), ConfigError> { set_key(t, key, v) };
    set(
        &mut table,
        "integration.method",
        Value::String(plan.method.name().into()),
    )?;
    let (step, keys) = match p.control {
        StepControl::Adaptive { .. } => (
            ("adaptive", "integration.base_step_s"),
            &PINNED_ADAPTIVE_KEYS,
        ),
        StepControl::Fixed => (("fixed", "integration.dt_s"), &PINNED_KEYS),
    };
    set(&mut table, "integration.step", Value::String(step.0.into()))?;
    set(&mut table, step.1, Value::Float(p.dt_s))?;
    set(&mut table, "output.sample_rate_hz", Value::Float(rate))?;
    Ok((table, keys))
}

/// The grid index of the cell of `spec` whose axis values are `coords` (key, value): every
/// axis named, each value one of its axis's values (to within 1e-9 of its magnitude, so that
/// a value read back from a dataset's coordinate matches). A missing axis or a value between
/// grid points is refused: the cell would not be one the map ran.
pub fn cell_index(spec: &MapSpec, coords: &[(String, f64)]) -> Result<usize, ConfigError> {
    let mut k = 0;
    for axis in &spec.axes {
        let refuse = |reason: String| ConfigError::Inconsistent {
            key: axis.key.clone(),
            reason,
        };
        let values = &axis.values;
        let (lo, hi) = (values[0], values[values.len() - 1]);
        let Some(&(_, v)) = coords.iter().find(|(key, _)| *key == axis.key) else {
            return Err(refuse(format!(
                "a cell of this map needs a value of each axis, and this one has none: give one of its {} values from {} to {}",
                values.len(),
                num(lo),
                num(hi)
            )));
        };
        let close = |x: f64| (x - v).abs() <= 1e-9 * x.abs().max(v.abs()).max(1e-300);
        let Some(i) = values.iter().position(|&x| close(x)) else {
            return Err(refuse(format!(
                "{} is not a value of this map's axis ({} values from {} to {}): a cell runs one of them",
                num(v),
                values.len(),
                num(lo),
                num(hi)
            )));
        };
        k = k * values.len() + i;
    }
    Ok(k)
}
