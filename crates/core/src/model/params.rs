//! [`ModelParams`]: every physical coefficient of the equations of motion (`docs/model.md`),
//! derived once from a physical description of the pendulum ([`ChainDesign`],
//! [`BumperDesign`], [`PiezoParams`], [`CartMotion`]).
//!
//! This is the one definition of the model's terms. The CPU chain solve reads it (converted to
//! its float type by [`crate::model::Chain`]); the GPU parameter struct is filled from it. The
//! scene (TOML) is turned into these descriptions in one place, `crate::config`.

use crate::model::excitation::CartMotion;
use serde::Serialize;
use std::f64::consts::PI;

/// A uniform hollow tube (a solid rod when the inner diameter is 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tube {
    /// Length L (m).
    pub length_m: f64,
    /// Mass (kg).
    pub mass_kg: f64,
    /// Outer diameter D (m).
    pub outer_diameter_m: f64,
    /// Inner diameter d (m).
    pub inner_diameter_m: f64,
    /// Young's modulus E (Pa).
    pub youngs_modulus_pa: f64,
}

impl Tube {
    /// Bending stiffness EI = E π (D⁴ − d⁴)/64 (N m²).
    pub(crate) fn bending_stiffness_nm2(&self) -> f64 {
        self.youngs_modulus_pa
            * PI
            * (self.outer_diameter_m.powi(4) - self.inner_diameter_m.powi(4))
            / 64.0
    }
}

/// The pendulum as built: the tube cut into N rigid segments, its tip mass and its root.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ChainDesign {
    /// The tube.
    pub tube: Tube,
    /// Rigid segments N.
    pub segments: usize,
    /// Tip mass M (kg).
    pub tip_mass_kg: f64,
    /// Extra holder inertia J_h about the pivot (kg m²).
    pub holder_inertia_kgm2: f64,
    /// Gravity g (m/s²).
    pub g_m_s2: f64,
    /// A clamped root (spring 2EI/ℓ to the cart) instead of the free hinge.
    pub clamped: bool,
    /// Bearing damper b0 on the holder rate (N m s/rad).
    pub bearing_damping_nms: f64,
}

/// How a bumper's contact damper acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactDamping {
    /// F = k_c δ + c_c max(δ̇, 0): damping only while the penetration grows (the contact
    /// library's linear law); the force falls to zero continuously on release.
    Loading,
    /// F = max(0, k_c δ + c_c δ̇): damping both ways, clipped so it never pulls.
    KelvinVoigt,
}

impl ContactDamping {
    /// Both laws, in code order.
    pub const ALL: [ContactDamping; 2] = [ContactDamping::Loading, ContactDamping::KelvinVoigt];

    /// The law's code in the GPU parameter struct.
    pub fn gpu_code(self) -> u32 {
        match self {
            ContactDamping::Loading => 0,
            ContactDamping::KelvinVoigt => 1,
        }
    }

    /// The name of the WGSL constant holding [`ContactDamping::gpu_code`].
    pub fn wgsl_name(self) -> &'static str {
        match self {
            ContactDamping::Loading => "CONTACT_LOADING",
            ContactDamping::KelvinVoigt => "CONTACT_KELVIN_VOIGT",
        }
    }
}

/// The two bumpers as built.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BumperDesign {
    /// Arc length s_b of the contact point above the pivot (m).
    pub contact_arc_m: f64,
    /// Holder angle θc at which a straight beam touches a bumper (rad).
    pub clearance_rad: f64,
    /// Contact stiffness k_c (N/m).
    pub stiffness_n_per_m: f64,
    /// Contact damping c_c (N s/m).
    pub damping_ns_per_m: f64,
    /// How the contact damper acts.
    pub law: ContactDamping,
}

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
    /// How the contact damper acts.
    pub law: ContactDamping,
}

impl ContactParams {
    /// The contact point at arc length s_b on a chain of `n` segments of length ℓ.
    fn on_chain(b: &BumperDesign, n: usize, l: f64) -> ContactParams {
        let s_b = b.contact_arc_m;
        let seg = (((s_b / l) - 1e-12).ceil() as usize).clamp(1, n) - 1;
        let mut levers_m = vec![l; seg + 1];
        levers_m[seg] = s_b - seg as f64 * l;
        ContactParams {
            segment: seg,
            levers_m,
            gap_m: s_b * b.clearance_rad.sin(),
            stiffness_n_per_m: b.stiffness_n_per_m,
            damping_ns_per_m: b.damping_ns_per_m,
            law: b.law,
        }
    }
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
    /// The bearing damper b0 alone (N m s/rad).
    pub bearing_damping_nms: f64,
    /// Stiffness-proportional damping coefficient β (s): every joint damper is β times its spring.
    pub beta_s: f64,
    /// The bumpers, if enabled.
    pub contact: Option<ContactParams>,
    /// The piezo circuit, if enabled.
    pub piezo: Option<PiezoParams>,
    /// The cart motion.
    pub cart: CartMotion,
}

impl ModelParams {
    /// The coefficients of a built pendulum, with the stiffness-proportional joint dampers off
    /// (β = 0; the bearing damper kept). Set β with `ModelParams::with_damping_time`.
    pub fn undamped(
        chain: &ChainDesign,
        bumpers: Option<&BumperDesign>,
        piezo: Option<PiezoParams>,
        cart: CartMotion,
    ) -> ModelParams {
        let n = chain.segments;
        let l = chain.tube.length_m / n as f64;
        let m = chain.tube.mass_kg / n as f64;
        let ei = chain.tube.bending_stiffness_nm2();
        let k = ei / l;
        let k0 = if chain.clamped { 2.0 * ei / l } else { 0.0 };
        ModelParams {
            segments: n,
            seg_length_m: l,
            seg_mass_kg: m,
            seg_inertia_kgm2: m * l * l / 12.0,
            tip_mass_kg: chain.tip_mass_kg,
            holder_inertia_kgm2: chain.holder_inertia_kgm2,
            g_m_s2: chain.g_m_s2,
            ei_nm2: ei,
            joint_stiffness_nm: k,
            root_stiffness_nm: k0,
            joint_damping_nms: 0.0,
            root_damping_nms: chain.bearing_damping_nms,
            bearing_damping_nms: chain.bearing_damping_nms,
            beta_s: 0.0,
            contact: bumpers.map(|b| ContactParams::on_chain(b, n, l)),
            piezo,
            cart,
        }
    }

    /// The same pendulum with stiffness-proportional damping β (s): joint dampers b = βk and a
    /// root damper βk0 (clamped) plus the bearing damper.
    pub(crate) fn with_damping_time(mut self, beta_s: f64) -> ModelParams {
        self.beta_s = beta_s;
        self.joint_damping_nms = beta_s * self.joint_stiffness_nm;
        self.root_damping_nms = beta_s * self.root_stiffness_nm + self.bearing_damping_nms;
        self
    }

    /// The same pendulum driven by another cart motion.
    pub(crate) fn with_cart(&self, cart: CartMotion) -> ModelParams {
        ModelParams {
            cart,
            ..self.clone()
        }
    }

    /// Length of the first-order state vector: N angles, N rates, one voltage slot.
    pub(crate) fn state_len(&self) -> usize {
        2 * self.segments + 1
    }

    /// w_i = m/2 + m(N − i) + M (1-based i): the mass "carried" by segment i's centre lever.
    pub(crate) fn carried_mass_kg(&self, i0: usize) -> f64 {
        let n = self.segments;
        let i = i0 + 1;
        self.seg_mass_kg * 0.5 + self.seg_mass_kg * (n - i) as f64 + self.tip_mass_kg
    }

    /// μ_ij of the mass matrix (0-based indices).
    pub(crate) fn mu_kg(&self, i0: usize, j0: usize) -> f64 {
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

    /// A straight beam at holder angle `angle_rad`, every segment at rate `rate_rad_s`, the
    /// patch at `voltage_v`: the state `[θ; θ̇; v]`.
    pub(crate) fn straight_state(
        &self,
        angle_rad: f64,
        rate_rad_s: f64,
        voltage_v: f64,
    ) -> Vec<f64> {
        let n = self.segments;
        let mut y = vec![0.0; self.state_len()];
        y[..n].fill(angle_rad);
        y[n..2 * n].fill(rate_rad_s);
        if self.piezo.is_some() {
            y[2 * n] = voltage_v;
        }
        y
    }

    /// Every coefficient but the cart's, as bit patterns: two chains with equal bits have the
    /// same linearisation (the key under which ensembles share one eigenproblem).
    pub(crate) fn structure_bits(&self) -> Vec<u64> {
        let mut bits = vec![self.segments as u64];
        bits.extend(
            [
                self.seg_length_m,
                self.seg_mass_kg,
                self.seg_inertia_kgm2,
                self.tip_mass_kg,
                self.holder_inertia_kgm2,
                self.g_m_s2,
                self.ei_nm2,
                self.joint_stiffness_nm,
                self.root_stiffness_nm,
                self.joint_damping_nms,
                self.root_damping_nms,
                self.bearing_damping_nms,
                self.beta_s,
            ]
            .map(f64::to_bits),
        );
        if let Some(c) = &self.contact {
            bits.extend([u64::MAX - 1, c.segment as u64, c.levers_m.len() as u64]);
            bits.extend(c.levers_m.iter().map(|x| x.to_bits()));
            bits.extend([c.gap_m, c.stiffness_n_per_m, c.damping_ns_per_m].map(f64::to_bits));
            bits.push(c.law as u64);
        }
        if let Some(z) = &self.piezo {
            bits.extend([u64::MAX - 2, z.last_segment as u64]);
            bits.extend([z.capacitance_f, z.load_ohm, z.coupling_nm_per_v].map(f64::to_bits));
        }
        bits
    }

    /// The same chain clamped to a still cart with no gravity, bumpers or piezo: the cantilever
    /// whose first bending mode defines the damping ratio ζ1.
    pub(crate) fn clamped_cantilever(&self) -> ModelParams {
        let mut c = self.clone();
        c.root_stiffness_nm = 2.0 * self.ei_nm2 / self.seg_length_m;
        c.g_m_s2 = 0.0;
        c.contact = None;
        c.piezo = None;
        c.with_damping_time(0.0)
    }
}
