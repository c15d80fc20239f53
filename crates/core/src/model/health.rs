//! The health rules of a run, defined once for every engine: what makes a state `ok`, and how
//! often the engines check (see `docs/model.md`, "Statuses").
//!
//! The WGSL kernels receive the status codes and [`CHECK_EVERY`] from these definitions (the
//! shader header is generated from them) and evaluate [`Guard`]'s bounds from the parameter
//! struct; the engine test suite holds the GPU's statuses against the CPU's.

use crate::model::chain::Chain;
use crate::model::lane::Real;
use crate::model::params::ModelParams;
use crate::rules::{Float, abs, is_finite, shared_rules};
use serde::Serialize;

/// Steps between health checks (energy bound, folded chain, non-finite state).
pub const CHECK_EVERY: u64 = 64;

/// Whether an engine checks the state after `step` of `total` steps: every [`CHECK_EVERY`]
/// steps, after the last step, and wherever the caller records the state (`recorded`).
#[inline]
pub fn health_due(step: u64, total: u64, recorded: bool) -> bool {
    recorded || step.is_multiple_of(CHECK_EVERY) || step == total
}

/// How an instance ended. Only `Ok` instances carry numbers that mean anything.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
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
    /// The holder passed the horizontal (|α| > 90°) over a bumper: the point bumper pushes only
    /// horizontally and cannot hold a beam beyond it, so the run has left the model's domain (a
    /// soft bumper at a wide clearance). Not a numerical failure.
    #[serde(rename = "escaped")]
    Escaped,
}

impl Status {
    /// Every status, in code order.
    pub const ALL: [Status; 4] = [
        Status::Ok,
        Status::Diverged,
        Status::NonFinite,
        Status::Escaped,
    ];

    /// The name written to CSV and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Diverged => "diverged",
            Status::NonFinite => "non-finite",
            Status::Escaped => "escaped",
        }
    }

    /// The numeric code of `status.npy` and of the GPU kernels.
    pub const fn code(self) -> u8 {
        match self {
            Status::Ok => 0,
            Status::Diverged => 1,
            Status::NonFinite => 2,
            Status::Escaped => 3,
        }
    }

    /// The status of a numeric code (`None` for an unknown code).
    pub fn from_code(code: u32) -> Option<Status> {
        Status::ALL
            .into_iter()
            .find(|s| u32::from(s.code()) == code)
    }

    /// The name of the WGSL constant that holds this status's code.
    pub fn wgsl_name(self) -> &'static str {
        match self {
            Status::Ok => "STATUS_OK",
            Status::Diverged => "STATUS_DIVERGED",
            Status::NonFinite => "STATUS_NONFINITE",
            Status::Escaped => "STATUS_ESCAPED",
        }
    }

    /// Whether the run ended normally.
    pub fn is_ok(self) -> bool {
        self == Status::Ok
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Bounds that flag a run as failed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
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
    pub(crate) fn for_params(p: &ModelParams) -> Guard {
        let mass = p.seg_mass_kg * p.segments as f64 + p.tip_mass_kg;
        let l = p.length_m();
        let w = std::f64::consts::TAU * p.cart.kind.max_frequency_hz();
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

    /// The status of state `y = [θ; θ̇; v]` with the cart at velocity `cart_v` (m/s), by the
    /// shared rule `guard_status`: non-finite values first, then a holder past the bumpers,
    /// then a folded chain or runaway energy.
    pub fn check<T: Real>(&self, chain: &Chain<T>, y: &[T], cart_v: f64) -> Status {
        let finite = y.iter().all(|v| v.is_finite());
        let n = chain.segments();
        let bend = (1..n).fold(0.0, |b: f64, i| b.max((y[i] - y[i - 1]).abs().wide()));
        let e = chain.energy(y, cart_v).total_j();
        let code = guard_status(
            finite,
            y[0].abs().wide(),
            bend,
            e,
            self.max_holder_angle_rad,
            self.max_joint_bend_rad,
            self.max_energy_j,
        );
        Status::from_code(code).expect("guard_status returns a status code")
    }
}

/// [`Status`]'s codes as the shared rules name them (the kernels' header defines the same
/// names from [`Status::wgsl_name`] and [`Status::code`]).
const STATUS_OK: u32 = Status::Ok.code() as u32;
const STATUS_DIVERGED: u32 = Status::Diverged.code() as u32;
const STATUS_NONFINITE: u32 = Status::NonFinite.code() as u32;
const STATUS_ESCAPED: u32 = Status::Escaped.code() as u32;

shared_rules! {
    /// The status code of a state from what Guard::check measures: whether every value is
    /// finite, |θ0|, the largest bend |θi − θi−1| and the stored energy, against the guard's
    /// bounds. Non-finite first, then a holder past the bumpers (escaped), then a folded chain
    /// or an energy not finite or past its bound (diverged).
    pub(crate) fn guard_status(
        finite: bool,
        holder: Float,
        bend: Float,
        energy: Float,
        max_holder: Float,
        max_bend: Float,
        max_energy: Float,
    ) -> u32 {
        if !finite {
            return STATUS_NONFINITE;
        }
        if holder > max_holder {
            return STATUS_ESCAPED;
        }
        if bend > max_bend || !is_finite(energy) || abs(energy) > max_energy {
            return STATUS_DIVERGED;
        }
        return STATUS_OK;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule's order: non-finite before escaped before diverged, and each bound strict.
    #[test]
    fn the_guard_rule_takes_its_statuses_in_order() {
        let status = |finite, holder, bend, energy| {
            Status::from_code(guard_status(finite, holder, bend, energy, 1.5, 1.5, 10.0))
        };
        let s = |x| Some(x);
        assert_eq!(status(false, 9.0, 9.0, f64::NAN), s(Status::NonFinite));
        assert_eq!(status(true, 1.6, 9.0, f64::NAN), s(Status::Escaped));
        assert_eq!(status(true, 1.5, 1.6, 0.0), s(Status::Diverged));
        assert_eq!(status(true, 1.5, 1.5, f64::INFINITY), s(Status::Diverged));
        assert_eq!(status(true, 1.5, 1.5, -10.5), s(Status::Diverged));
        assert_eq!(status(true, 1.5, 1.5, -10.0), s(Status::Ok));
    }
}
