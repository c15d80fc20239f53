//! Recording a trajectory at the output rows and writing it as CSV.

use crate::output::OutputError;
use crate::output::files::{commit_csv, create_csv, csv_error};
use pendulum_atlas_core::engine::Observer;
use pendulum_atlas_core::model::{CartState, Chain, Real, Workspace};
use std::ops::ControlFlow;
use std::path::Path;

/// Columns of `trajectory.csv` (the piezo columns are appended when the piezo is on).
pub const BASE_COLUMNS: [&str; 9] = [
    "t_s",
    "x0_m",
    "alpha_rad",
    "alpha_dot_rad_s",
    "tip_x_m",
    "tip_y_m",
    "chord_m",
    "contact_force_n",
    "energy_j",
];

/// Extra columns when `piezo.enabled`.
pub const PIEZO_COLUMNS: [&str; 2] = ["piezo_v", "power_w"];

/// Every column of a trajectory in `trajectory.csv` order: (name, unit, value); the last
/// two ([`PIEZO_COLUMNS`]) only with the piezo on. The CSV and the Python package read rows
/// through it.
pub const ROW_COLUMNS: [RowColumn; 11] = [
    ("t_s", "s", |r| r.t_s),
    ("x0_m", "m", |r| r.x0_m),
    ("alpha_rad", "rad", |r| r.alpha_rad),
    ("alpha_dot_rad_s", "rad/s", |r| r.alpha_dot_rad_s),
    ("tip_x_m", "m", |r| r.tip_x_m),
    ("tip_y_m", "m", |r| r.tip_y_m),
    ("chord_m", "m", |r| r.chord_m),
    ("contact_force_n", "N", |r| r.contact_force_n),
    ("energy_j", "J", |r| r.energy_j),
    ("piezo_v", "V", |r| r.piezo_v),
    ("power_w", "W", |r| r.power_w),
];

/// A trajectory column: its name, unit and value in a row.
pub type RowColumn = (&'static str, &'static str, fn(&Row) -> f64);

/// The columns of a run's trajectory: [`ROW_COLUMNS`], without the piezo's when it is off.
pub fn row_columns(piezo: bool) -> &'static [RowColumn] {
    let n = BASE_COLUMNS.len() + if piezo { PIEZO_COLUMNS.len() } else { 0 };
    &ROW_COLUMNS[..n]
}

/// One output row of a single run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Row {
    /// Time (s).
    pub t_s: f64,
    /// Cart position x0 (m).
    pub x0_m: f64,
    /// Holder angle α = θ_1 (rad).
    pub alpha_rad: f64,
    /// Holder rate (rad/s).
    pub alpha_dot_rad_s: f64,
    /// Tip position, inertial frame (m).
    pub tip_x_m: f64,
    /// Tip height above the pivot (m).
    pub tip_y_m: f64,
    /// Chord reduction L − |r_N − r_0| (m).
    pub chord_m: f64,
    /// Horizontal bumper force on the beam (N).
    pub contact_force_n: f64,
    /// Stored energy: kinetic + gravity + springs + bumper + capacitor (J).
    pub energy_j: f64,
    /// Piezo voltage (V).
    pub piezo_v: f64,
    /// Power into the load v²/R (W).
    pub power_w: f64,
    /// Energy dissipated so far is not tracked here; this is the instantaneous damper + load power (W).
    pub dissipation_w: f64,
}

/// Records every output row of one run.
#[derive(Default)]
pub struct TrajectoryRecorder {
    /// The rows recorded so far.
    pub rows: Vec<Row>,
    /// Load resistance (Ω) when the piezo is on.
    pub load_ohm: Option<f64>,
    /// Called with the step after each row and every [`POLL_STEPS`](pendulum_atlas_core::engine::POLL_STEPS) steps between rows (to
    /// move a progress bar, to check a cancel or a time limit); `Break` stops the run there,
    /// and [`TrajectoryRecorder::stopped`] says so afterwards.
    pub on_row: Option<Box<dyn FnMut(u64) -> ControlFlow<()> + Send>>,
    /// Whether `on_row` asked the run to stop.
    pub stopped: bool,
}

impl<T: Real> Observer<T> for TrajectoryRecorder {
    fn sample(
        &mut self,
        step: u64,
        t_s: f64,
        cart: &CartState,
        y: &[T],
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
    ) {
        let n = chain.segments();
        let ((tx, ty), chord) = chain.tip_and_chord(y);
        let contact = chain.contact_report(ws, y);
        let v = y[2 * n].wide();
        self.rows.push(Row {
            t_s,
            x0_m: cart.x_m,
            alpha_rad: y[0].wide(),
            alpha_dot_rad_s: y[n].wide(),
            tip_x_m: cart.x_m + tx,
            tip_y_m: ty,
            chord_m: chord,
            contact_force_n: contact.force_x_n.wide(),
            energy_j: chain.energy(y, cart.v_m_s).total_j(),
            piezo_v: v,
            power_w: self.load_ohm.map_or(0.0, |r| v * v / r),
            dissipation_w: chain.dissipated_power_w(y),
        });
        if let Some(f) = self.on_row.as_mut() {
            self.stopped |= f(step).is_break();
        }
    }

    fn stopped(&self) -> bool {
        self.stopped
    }

    fn poll(&mut self, step: u64) -> bool {
        if let Some(f) = self.on_row.as_mut() {
            self.stopped |= f(step).is_break();
        }
        self.stopped
    }
}

/// Write rows as `trajectory.csv` with a header line.
pub fn write_trajectory_csv(path: &Path, rows: &[Row], piezo: bool) -> Result<(), OutputError> {
    let err = csv_error(path);
    let mut w = create_csv(path)?;
    let columns = row_columns(piezo);
    let header: Vec<&str> = columns.iter().map(|c| c.0).collect();
    w.write_record(&header).map_err(&err)?;
    let mut rec: Vec<String> = Vec::with_capacity(header.len());
    for r in rows {
        rec.clear();
        rec.extend(columns.iter().map(|c| (c.2)(r).to_string()));
        w.write_record(&rec).map_err(&err)?;
    }
    commit_csv(w, path)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_columns_are_the_csv_header_in_order() {
        let names: Vec<&str> = ROW_COLUMNS.iter().map(|c| c.0).collect();
        assert_eq!(names, [&BASE_COLUMNS[..], &PIEZO_COLUMNS[..]].concat());
        assert_eq!(row_columns(false).len(), BASE_COLUMNS.len());
    }
}
