//! The one place where a validated [`Scene`] becomes the physics of [`crate::model`]: the built
//! pendulum ([`ChainDesign`], [`BumperDesign`], [`PiezoParams`], [`CartMotion`]), its
//! coefficients ([`ModelParams`], damping included), its initial state and its modes.

use super::scene::{BeamDamping, PivotMode, Scene};
use crate::model::linear::LinearError;
use crate::model::{
    BumperDesign, CartMotion, ChainDesign, ModelParams, Modes, PiezoParams, Tube, linear, modes,
};
use serde::Serialize;

/// The joint damping of a scene in all three of its forms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DampingReport {
    /// β = b/k (s).
    pub damping_time_s: f64,
    /// b per joint at the scene's N (N m s/rad).
    pub joint_damping_nms: f64,
    /// ζ1 of the first clamped bending mode.
    pub first_mode_damping_ratio: f64,
}

impl Scene {
    /// The beam, tip, root and gravity as the model describes them.
    pub(crate) fn chain_design(&self) -> ChainDesign {
        let b = &self.beam;
        ChainDesign {
            tube: Tube {
                length_m: b.length_m,
                mass_kg: b.mass_kg,
                outer_diameter_m: b.outer_diameter_m,
                inner_diameter_m: b.inner_diameter_m,
                youngs_modulus_pa: b.youngs_modulus_pa,
            },
            segments: b.segments,
            tip_mass_kg: self.tip.mass_kg,
            holder_inertia_kgm2: self.pivot.holder_inertia_kgm2,
            g_m_s2: self.gravity.g_m_s2,
            clamped: self.pivot.mode == PivotMode::Clamped,
            bearing_damping_nms: self.pivot.damping_nms,
        }
    }

    /// The bumpers, when enabled.
    pub(crate) fn bumper_design(&self) -> Option<BumperDesign> {
        let l = &self.limiter;
        l.enabled.then(|| BumperDesign {
            contact_arc_m: l.contact_arc_m,
            clearance_rad: l.clearance_deg.to_radians(),
            stiffness_n_per_m: l.stiffness_n_per_m,
            damping_ns_per_m: l.damping_ns_per_m,
            law: l.damping_law,
        })
    }

    /// The piezo patch and load, when enabled.
    pub fn piezo_params(&self) -> Option<PiezoParams> {
        let z = &self.piezo;
        z.enabled.then_some(PiezoParams {
            last_segment: z.segments,
            capacitance_f: z.capacitance_f,
            load_ohm: z.load_ohm,
            coupling_nm_per_v: z.coupling_nm_per_v,
        })
    }

    /// The cart motion.
    pub(crate) fn cart_motion(&self) -> CartMotion {
        CartMotion {
            amplitude_m: self.excitation.amplitude_m,
            kind: self.excitation.kind,
            phase_cycles: self.excitation.phase_deg / 360.0,
        }
    }

    /// Whether `other` has the same model coefficients as this scene but for the cart's
    /// motion: the same beam, tip, bumpers, gravity, pivot and piezo (what
    /// [`Scene::model_params`] reads besides the excitation).
    pub(crate) fn same_structure(&self, other: &Scene) -> bool {
        self.beam == other.beam
            && self.tip == other.tip
            && self.limiter == other.limiter
            && self.gravity == other.gravity
            && self.pivot == other.pivot
            && self.piezo == other.piezo
    }

    /// Every coefficient of the equations of motion, the joint dampers set from the scene's
    /// damping key (`beam.damping_ratio` solves one small eigenproblem for ω1).
    /// `Err` only when `beam.damping_ratio`'s eigenproblem cannot be solved.
    pub fn model_params(&self) -> Result<ModelParams, LinearError> {
        let bumpers = self.bumper_design();
        let p = ModelParams::undamped(
            &self.chain_design(),
            bumpers.as_ref(),
            self.piezo_params(),
            self.cart_motion(),
        );
        let beta_s = match self.beam.damping {
            BeamDamping::TimeS(beta) => beta,
            BeamDamping::Ratio(zeta) => linear::damping_time_for_ratio(&p, zeta)?,
            BeamDamping::JointNms(b) => b / p.joint_stiffness_nm,
        };
        Ok(p.with_damping_time(beta_s))
    }

    /// The joint damping a run uses: β, the per-joint b at this N, and ζ1 of the first clamped
    /// bending mode.
    pub fn damping_report(&self) -> Result<DampingReport, LinearError> {
        let p = self.model_params()?;
        Ok(DampingReport {
            damping_time_s: p.beta_s,
            joint_damping_nms: p.joint_damping_nms,
            first_mode_damping_ratio: linear::first_mode_damping_ratio(&p)?,
        })
    }

    /// The initial state `[θ; θ̇; v]` of the scene: a straight beam at `initial.angle_deg`.
    pub fn initial_state(&self, p: &ModelParams) -> Vec<f64> {
        p.straight_state(
            self.initial.angle_deg.to_radians(),
            self.initial.rate_deg_s.to_radians(),
            self.initial.voltage_v,
        )
    }

    /// Natural frequencies, unstable rates and the automatic RK4 step of the scene.
    pub fn modes(&self) -> Result<Modes, LinearError> {
        modes(&self.model_params()?, self.integration.dt_safety)
    }
}
