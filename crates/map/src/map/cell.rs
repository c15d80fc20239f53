//! One cell of an ensemble as a plain scene that runs exactly what the ensemble ran: the
//! integration method and the step `dt = 1/(f·spp)` the plan took pinned, and rows at a whole
//! number of steps so that the record's sample rate is exact. The explorer's "run this cell"
//! and Python's `Scene.cell` both come here.

use pendulum_atlas_core::config::{ConfigError, Scene, set_key};
use pendulum_atlas_core::engine::{EngineError, EnsembleOptions, EnsemblePlan};
use toml::{Table, Value};

/// The scene table of one instance (`table`, with the ensemble's `integration.method` already
/// set where the ensemble fixed one), with the method, step and row rate its ensemble plan
/// (`opts`) takes set in it.
pub fn pinned_cell(mut table: Table, opts: &EnsembleOptions) -> Result<Table, EngineError> {
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
    set(&mut table, "integration.dt_s", Value::Float(p.dt_s))?;
    set(&mut table, "output.sample_rate_hz", Value::Float(rate))?;
    Ok(table)
}
