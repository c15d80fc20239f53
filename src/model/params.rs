//! [`ModelParams`]: every physical coefficient of MODEL.md, derived once from a [`Scene`].
//!
//! This is the one definition of the model's terms. The CPU chain solve reads it (converted to
//! its float type by [`crate::model::Chain`]); the GPU parameter struct is filled from it.

use crate::config::{PivotMode, Scene};
use crate::model::excitation::CartMotion;
use serde::Serialize;
use std::f64::consts::PI;

/// The bumper contact, resolved onto the chain.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactParams {
    /// Index (0-based) of the segment that holds the contact point.
    pub segment: usize,
    /// Levers λ_i (m) of segments 0..=segment: ℓ below the contact, the remainder on `segment`.
    pub levers_m: Vec<f64>,
    /// Bumper offset g_c = s_b sin θ_c from the cart axis (m).
    pub gap_m: f64,
    /// Contact stiffness k_c (N/m).
    pub stiffness_n_per_m: f64,
    /// Contact damping c_c (N s/m).
    pub damping_ns_per_m: f64,
}

/// The piezo patch and circuit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PiezoParams {
    /// Index (0-based) of the last segment the patch spans (p): ψ = θ_p − θ_0.
    pub last_segment: usize,
    /// C_p (F).
    pub capacitance_f: f64,
    /// R_L (Ω).
    pub load_ohm: f64,
    /// Θ (N m/V).
    pub coupling_nm_per_v: f64,
}

/// Every coefficient of the equations of motion, in SI units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelParams {
    /// Number of segments N.
    pub segments: usize,
    /// Segment length ℓ = L/N (m).
    pub seg_length_m: f64,
    /// Segment mass m (kg).
    pub seg_mass_kg: f64,
    /// Segment centroidal inertia J = mℓ²/12 (kg m²).
    pub seg_inertia_kgm2: f64,
    /// Tip mass M (kg).
    pub tip_mass_kg: f64,
    /// Extra holder inertia J_h about the pivot (kg m²).
    pub holder_inertia_kgm2: f64,
    /// Gravity g (m/s²).
    pub g_m_s2: f64,
    /// Bending stiffness EI (N m²).
    pub ei_nm2: f64,
    /// Joint spring k = EI/ℓ (N m/rad).
    pub joint_stiffness_nm: f64,
    /// Root spring k0 (2EI/ℓ when clamped, 0 when hinged) (N m/rad).
    pub root_stiffness_nm: f64,
    /// Joint damper b = βk (N m s/rad).
    pub joint_damping_nms: f64,
    /// Root damper: βk0 (clamped) plus the bearing damper b0 (N m s/rad).
    pub root_damping_nms: f64,
    /// Stiffness-proportional damping coefficient β = 2ζ1/ω1 (s).
    pub beta_s: f64,
    /// The bumpers, if enabled.
    pub contact: Option<ContactParams>,
    /// The piezo circuit, if enabled.
    pub piezo: Option<PiezoParams>,
    /// The cart motion.
    pub cart: CartMotion,
}

impl ModelParams {
    /// Derive the coefficients from a scene. Damping needs ω1 of the clamped, g = 0 chain with
    /// the same segments, so this solves one small eigenproblem.
    pub fn from_scene(scene: &Scene) -> ModelParams {
        let mut p = ModelParams::undamped(scene);
        let zeta = scene.beam.damping_ratio;
        if zeta > 0.0 {
            let omega1 = crate::model::linear::clamped_first_omega(scene);
            p.beta_s = 2.0 * zeta / omega1;
        }
        p.joint_damping_nms = p.beta_s * p.joint_stiffness_nm;
        p.root_damping_nms = p.beta_s * p.root_stiffness_nm + scene.pivot.damping_nms;
        p
    }

    /// The coefficients with the stiffness-proportional dampers switched off (bearing damper kept).
    pub fn undamped(scene: &Scene) -> ModelParams {
        let b = &scene.beam;
        let n = b.segments;
        let l = b.length_m / n as f64;
        let m = b.mass_kg / n as f64;
        let ei =
            b.youngs_modulus_pa * PI * (b.outer_diameter_m.powi(4) - b.inner_diameter_m.powi(4))
                / 64.0;
        let k = ei / l;
        let k0 = match scene.pivot.mode {
            PivotMode::Clamped => 2.0 * ei / l,
            PivotMode::Hinged => 0.0,
        };
        let contact = scene.limiter.enabled.then(|| {
            let s_b = scene.limiter.contact_arc_m;
            let seg = (((s_b / l) - 1e-12).ceil() as usize).clamp(1, n) - 1;
            let mut levers_m = vec![l; seg + 1];
            levers_m[seg] = s_b - seg as f64 * l;
            ContactParams {
                segment: seg,
                levers_m,
                gap_m: s_b * scene.limiter.clearance_deg.to_radians().sin(),
                stiffness_n_per_m: scene.limiter.stiffness_n_per_m,
                damping_ns_per_m: scene.limiter.damping_ns_per_m,
            }
        });
        let piezo = scene.piezo.enabled.then_some(PiezoParams {
            last_segment: scene.piezo.segments,
            capacitance_f: scene.piezo.capacitance_f,
            load_ohm: scene.piezo.load_ohm,
            coupling_nm_per_v: scene.piezo.coupling_nm_per_v,
        });
        ModelParams {
            segments: n,
            seg_length_m: l,
            seg_mass_kg: m,
            seg_inertia_kgm2: m * l * l / 12.0,
            tip_mass_kg: scene.tip.mass_kg,
            holder_inertia_kgm2: scene.pivot.holder_inertia_kgm2,
            g_m_s2: scene.gravity.g_m_s2,
            ei_nm2: ei,
            joint_stiffness_nm: k,
            root_stiffness_nm: k0,
            joint_damping_nms: 0.0,
            root_damping_nms: scene.pivot.damping_nms,
            beta_s: 0.0,
            contact,
            piezo,
            cart: CartMotion::from_excitation(&scene.excitation),
        }
    }

    /// Length of the first-order state vector: N angles, N rates, one voltage slot.
    pub fn state_len(&self) -> usize {
        2 * self.segments + 1
    }

    /// w_i = m/2 + m(N − i) + M (1-based i): the mass "carried" by segment i's centre lever.
    pub fn carried_mass_kg(&self, i0: usize) -> f64 {
        let n = self.segments;
        let i = i0 + 1;
        self.seg_mass_kg * 0.5 + self.seg_mass_kg * (n - i) as f64 + self.tip_mass_kg
    }

    /// μ_ij of MODEL.md (0-based indices).
    pub fn mu_kg(&self, i0: usize, j0: usize) -> f64 {
        if i0 == j0 {
            self.carried_mass_kg(i0) - self.seg_mass_kg * 0.25
        } else {
            self.carried_mass_kg(i0.max(j0))
        }
    }

    /// Total beam length (m).
    pub fn length_m(&self) -> f64 {
        self.seg_length_m * self.segments as f64
    }

    /// The initial state of a scene: straight beam at `initial.angle_deg`, uniform rate.
    pub fn initial_state(&self, scene: &Scene) -> Vec<f64> {
        let n = self.segments;
        let mut y = vec![0.0; self.state_len()];
        y[..n].fill(scene.initial.angle_deg.to_radians());
        y[n..2 * n].fill(scene.initial.rate_deg_s.to_radians());
        if self.piezo.is_some() {
            y[2 * n] = scene.initial.voltage_v;
        }
        y
    }
}
