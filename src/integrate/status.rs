//! The status of an integrated instance, and the guard that decides it.

use crate::model::ModelParams;
use serde::Serialize;

/// How an instance ended. Only `Ok` instances carry numbers that mean anything.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Status {
    /// Integrated to the end with a bounded, finite state.
    #[serde(rename = "ok")]
    Ok,
    /// The energy grew beyond any physical bound, or the chain folded (a joint bent past
    /// [`Guard::max_joint_bend_rad`]): the step is unstable for this instance.
    #[serde(rename = "diverged")]
    Diverged,
    /// A NaN or infinity appeared in the state.
    #[serde(rename = "non-finite")]
    NonFinite,
    /// The holder passed the horizontal (|α| > 90°) over a bumper: MODEL.md's point bumper
    /// pushes only horizontally and cannot hold a beam beyond it, so the run has left the
    /// model's domain (a soft bumper at a wide clearance). Not a numerical failure.
    #[serde(rename = "escaped")]
    Escaped,
}

impl Status {
    /// The name written to CSV and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Diverged => "diverged",
            Status::NonFinite => "non-finite",
            Status::Escaped => "escaped",
        }
    }
}

/// Bounds that flag a run as diverged.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Guard {
    /// Stored energy above which a run is diverged (J).
    pub max_energy_j: f64,
    /// Relative joint angle above which the chain has folded (rad).
    pub max_joint_bend_rad: f64,
    /// With bumpers: |α| beyond which the holder has escaped over a bumper (rad, π/2);
    /// infinite without bumpers (a hinged beam may then swing down).
    pub max_holder_angle_rad: f64,
}

impl Guard {
    /// A generous bound: 10⁴ times the energy scale of gravity, the cart's motion and a
    /// bumper compressed by a tenth of the beam. A physical run stays orders of magnitude below.
    pub fn for_params(p: &ModelParams) -> Guard {
        let mass = p.seg_mass_kg * p.segments as f64 + p.tip_mass_kg;
        let l = p.length_m();
        let f_max = match p.cart.kind {
            crate::config::ExcitationKind::Harmonic { frequency_hz } => frequency_hz,
            crate::config::ExcitationKind::Sweep {
                start_hz, end_hz, ..
            } => start_hz.max(end_hz),
        };
        let w = std::f64::consts::TAU * f_max;
        let cart = mass * (p.cart.amplitude_m * w).powi(2);
        let contact = p
            .contact
            .as_ref()
            .map_or(0.0, |c| 0.5 * c.stiffness_n_per_m * (0.1 * l).powi(2));
        let spring = 0.5 * p.joint_stiffness_nm.max(p.root_stiffness_nm) * 0.1;
        Guard {
            max_energy_j: 1e4 * (mass * p.g_m_s2 * l + cart + contact + spring + 1e-3),
            max_joint_bend_rad: 1.5,
            max_holder_angle_rad: if p.contact.is_some() {
                std::f64::consts::FRAC_PI_2
            } else {
                f64::INFINITY
            },
        }
    }
}
