//! The validated scene: every physical input with its unit (the parameter table of
//! `docs/model.md`).

use super::error::ConfigError;
use super::reader::{Range, Reader, apply_override, leaf_keys, parse_toml};
use crate::analysis::{RecordOptions, Sampling};
use crate::model::Tube;
pub use crate::model::{ContactDamping, ExcitationKind};
use crate::text::num;
use serde::Serialize;
use toml::Table;

/// The paper's scene (Table 1, f = 8 Hz, A = 9 mm), embedded so the tool runs with no files.
pub const PAPER_SCENE_TOML: &str = include_str!("../../../../configs/paper.toml");

/// The beam: a hollow steel tube split into rigid segments.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Beam {
    /// Beam length L (m).
    pub length_m: f64,
    /// Beam mass (kg).
    pub mass_kg: f64,
    /// Outer diameter D (m).
    pub outer_diameter_m: f64,
    /// Inner diameter d (m); 0 for a solid rod.
    pub inner_diameter_m: f64,
    /// Young's modulus E (Pa).
    pub youngs_modulus_pa: f64,
    /// Number of rigid segments N (the fidelity knob).
    pub segments: usize,
    /// How the stiffness-proportional joint dampers are set.
    pub damping: BeamDamping,
}

/// The joint dampers' setting: exactly one of the three keys (`docs/model.md`, "Damping").
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub enum BeamDamping {
    /// `beam.damping_time_s`: β = b/k (s), kept for every N.
    #[serde(rename = "damping_time_s")]
    TimeS(f64),
    /// `beam.damping_ratio`: ζ1 of the first clamped bending mode (β = 2ζ1/ω1).
    #[serde(rename = "damping_ratio")]
    Ratio(f64),
    /// `beam.joint_damping_nms`: b per joint at the scene's N (N m s/rad).
    #[serde(rename = "joint_damping_nms")]
    JointNms(f64),
}

/// The damping ratio of the earlier reading of Table 1 ("0.35" read as 0.35 %).
pub const EARLIER_READING_DAMPING_RATIO: f64 = 0.0035;

/// The per-joint damping constant of the library reading of Table 1 (N m s/rad), at the
/// paper's N = 17: the default β is this over the joint stiffness EI/(L/17).
pub const LIBRARY_JOINT_DAMPING_NMS: f64 = 0.35;

/// The segment count the library reading's per-joint constant refers to.
pub const LIBRARY_SEGMENTS: usize = 17;

/// The tip mass.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Tip {
    /// Point mass at the free end (kg).
    pub mass_kg: f64,
}

/// The two amplitude limiters (bumpers) on the cart.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Limiter {
    /// Whether the bumpers exist.
    pub enabled: bool,
    /// Holder angle at which a straight beam touches a bumper (deg).
    pub clearance_deg: f64,
    /// Arc length from the pivot at which the bumpers touch the beam (m).
    pub contact_arc_m: f64,
    /// Contact stiffness k_c (N/m).
    pub stiffness_n_per_m: f64,
    /// Contact damping c_c (N s/m).
    pub damping_ns_per_m: f64,
    /// How the contact damper acts: on loading only, or Kelvin–Voigt.
    pub damping_law: ContactDamping,
}

/// Gravity.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Gravity {
    /// Gravitational acceleration (m/s²).
    pub g_m_s2: f64,
}

/// How the beam is held at its root.
#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum PivotMode {
    /// The paper's clearance joint: a free hinge.
    Hinged,
    /// A clamped cantilever: root spring 2EI/ℓ.
    Clamped,
}

/// The pivot (hinge) on the cart.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Pivot {
    /// Hinged or clamped.
    pub mode: PivotMode,
    /// Bearing damper b0 on the holder rate (N m s/rad).
    pub damping_nms: f64,
    /// Extra holder inertia about the pivot (kg m²).
    pub holder_inertia_kgm2: f64,
}

/// The cart excitation.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Excitation {
    /// Harmonic or sweep, with its frequencies.
    pub kind: ExcitationKind,
    /// Cart displacement amplitude A (m).
    pub amplitude_m: f64,
    /// Forcing phase at t = 0, φ0 (deg, [0, 360)): x0 = A sin(2π f t + φ0). 180° mirrors the
    /// forcing, which with the mirrored start gives the mirrored motion.
    pub phase_deg: f64,
}

impl Excitation {
    /// The frequency that defines one forcing period (harmonic f, or the sweep's end frequency).
    pub fn reference_frequency_hz(&self) -> f64 {
        self.kind.reference_frequency_hz()
    }
}

/// The optional piezoelectric patch and its load.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Piezo {
    /// Whether the circuit exists.
    pub enabled: bool,
    /// Number of joints p the patch spans: it covers segments 1 … p+1.
    pub segments: usize,
    /// Patch capacitance C_p (F).
    pub capacitance_f: f64,
    /// Load resistance R_L (Ω).
    pub load_ohm: f64,
    /// Electromechanical coupling Θ (N m/V).
    pub coupling_nm_per_v: f64,
}

/// The time step: automatic from the linearisation, or given.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
#[serde(rename_all = "lowercase")]
pub enum TimeStep {
    /// `safety · 2.78 / max|λ|` (`docs/model.md`, "Time step").
    Auto,
    /// A fixed step (s).
    Seconds(f64),
}

/// Which integration method a run asks for.
#[derive(Debug, Clone, Copy, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum MethodChoice {
    /// The cheaper of the two for the scene, at their automatic steps.
    Auto,
    /// Classical RK4: every term explicit, step bound by the stiffest joint mode.
    Rk4,
    /// ARK3(2)4L\[2\]SA: joint springs and dampers implicit, step set by accuracy.
    Imex,
}

/// How the step is controlled (`integration.step`).
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum StepControl {
    /// One step for the whole run (`integration.dt_s`).
    Fixed,
    /// Steps set by the embedded error estimate, on a ladder aligned to the sample grid
    /// (`crate::engine::adaptive`): a step is accepted when every component's error is within
    /// `atol + rtol·|y|`.
    Adaptive {
        /// Relative tolerance.
        rtol: f64,
        /// Absolute tolerance (rad, rad/s, V: the state's own units).
        atol: f64,
    },
}

/// The default relative tolerance of adaptive steps. Measured on the paper scene at 8 Hz /
/// 9 mm over 0.5 s through impacts against the DOP853 reference (`docs/model.md`, "Adaptive
/// steps"): the holder angle within 1.6e-4 rad at N = 3, 3.5e-6 at N = 9 and 5.0e-6 at N = 17,
/// with 1.6×, 6.6× and 5.7× fewer chain evaluations than fixed steps.
pub const DEFAULT_RTOL: f64 = 1e-3;

/// The default absolute tolerance of adaptive steps (the state's units: rad, rad/s, V).
pub const DEFAULT_ATOL: f64 = 1e-5;

/// Integration settings.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Integration {
    /// Integration method.
    pub method: MethodChoice,
    /// Simulated time (s).
    pub duration_s: f64,
    /// Time discarded before indicators are computed (s).
    pub transient_s: f64,
    /// Time step of fixed steps.
    pub dt_s: TimeStep,
    /// The base step of adaptive steps (`integration.base_step_s`; automatic by default): a
    /// map's cell rerun alone pins the base step its map took.
    pub base_step_s: TimeStep,
    /// Safety factor of the automatic step (on RK4's stability limit, or on the IMEX method's
    /// limits).
    pub dt_safety: f64,
    /// Fixed or error-controlled steps.
    pub step: StepControl,
}

impl Integration {
    /// Fixed steps of `dt` (a step in seconds, or the automatic one): what a study of fixed
    /// steps sets, whatever the scene had (adaptive steps are the default).
    pub fn set_fixed(&mut self, dt: TimeStep) {
        self.dt_s = dt;
        self.step = StepControl::Fixed;
    }
}

/// Output settings.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Output {
    /// Rows per second of a trajectory (Hz).
    pub sample_rate_hz: f64,
}

/// The initial state (straight beam).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Initial {
    /// Angle of every segment from the upward vertical (deg).
    pub angle_deg: f64,
    /// Angular rate of every segment (deg/s).
    pub rate_deg_s: f64,
    /// Initial piezo voltage (V).
    pub voltage_v: f64,
}

/// A complete, validated scene. Construct it with [`Scene::from_toml`] or [`load_scene`].
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Scene {
    /// The beam.
    pub beam: Beam,
    /// The tip mass.
    pub tip: Tip,
    /// The bumpers.
    pub limiter: Limiter,
    /// Gravity.
    pub gravity: Gravity,
    /// The pivot.
    pub pivot: Pivot,
    /// The cart motion.
    pub excitation: Excitation,
    /// The piezo harvester.
    pub piezo: Piezo,
    /// Integration settings.
    pub integration: Integration,
    /// Output settings.
    pub output: Output,
    /// Initial state.
    pub initial: Initial,
    /// Remarks from reading the scene (keys given but not used), for the commands to print.
    #[serde(skip)]
    pub notes: Vec<String>,
}

/// Upper bound on segments. The CPU engines' step cost grows with N and RK4's stable step falls
/// as 1/N² (4e-12 s at N = 256 with the library damping), the IMEX factorisation and `modes`
/// as N³ (1.7 s for `modes` at N = 256, over 20 s and 0.5 GB at 4096): 256 is 15× the paper's 17 and well past
/// where the beam's first modes converge. The GPU engine's own limit is lower (64).
pub const MAX_SEGMENTS: i64 = 256;

impl Scene {
    /// The paper's default scene (embedded `configs/paper.toml`).
    pub fn paper() -> Scene {
        Scene::from_toml(PAPER_SCENE_TOML, "<embedded paper.toml>", &[])
            .expect("embedded paper scene is valid")
    }

    /// Parse, apply overrides (`section.key=value`), and validate.
    pub fn from_toml(text: &str, origin: &str, sets: &[String]) -> Result<Scene, ConfigError> {
        let mut table = parse_toml(text, origin)?;
        for s in sets {
            apply_override(&mut table, s)?;
        }
        Scene::from_table(table)
    }

    /// Validate an already-parsed table. Every key is optional and defaults to Table 1.
    pub fn from_table(table: Table) -> Result<Scene, ConfigError> {
        Scene::from_reader(Reader::new(table))
    }

    /// The embedded paper scene with the user's overrides `sets`; its notes name only keys
    /// the user gave (a `--set limiter.enabled=false` is not told that the paper's limiter
    /// keys go unused).
    pub fn paper_with(sets: &[String]) -> Result<Scene, ConfigError> {
        let mut table = parse_toml(PAPER_SCENE_TOML, "<embedded paper.toml>")?;
        let mut defaults = leaf_keys(&table);
        for s in sets {
            apply_override(&mut table, s)?;
            if let Some((key, _)) = s.split_once('=') {
                defaults.remove(key.trim());
            }
        }
        Scene::from_reader(Reader::with_defaults(table, defaults))
    }

    fn from_reader(mut r: Reader) -> Result<Scene, ConfigError> {
        let mut scene = read_scene(&mut r)?;
        scene.notes = r.take_notes();
        r.finish()?;
        Ok(scene)
    }

    /// How one run of this scene is analysed (`simulate`, and `explore` for a clicked cell):
    /// holder angle against cart position after the transient, stroboscopic at the forcing
    /// frequency (at the extrema for a sweep), hops judged against the clearance.
    pub fn record_options(&self) -> RecordOptions {
        let forcing = match self.excitation.kind {
            ExcitationKind::Harmonic { frequency_hz } => Some(frequency_hz),
            ExcitationKind::Sweep { .. } => None,
        };
        RecordOptions {
            forcing_hz: forcing,
            sampling: if forcing.is_some() {
                Sampling::Stroboscopic
            } else {
                Sampling::Extrema
            },
            transient_s: self.integration.transient_s,
            clearance_rad: self
                .limiter
                .enabled
                .then(|| self.limiter.clearance_deg.to_radians()),
            ..Default::default()
        }
    }
}

/// Read a scene file (or the embedded paper scene when `path` is `None`) with overrides.
pub fn load_scene(path: Option<&std::path::Path>, sets: &[String]) -> Result<Scene, ConfigError> {
    match path {
        None => Scene::paper_with(sets),
        Some(p) => {
            let text = super::reader::read_scene_file(p)?;
            Scene::from_toml(&text, &p.display().to_string(), sets)
        }
    }
}

fn read_scene(r: &mut Reader) -> Result<Scene, ConfigError> {
    let beam = read_beam(r)?;
    // The chain's mass matrix stays well conditioned (and the model meaningful) while no mass
    // outweighs the beam by more than MAX_MASS_RATIO.
    let heaviest_tip = MAX_MASS_RATIO * beam.mass_kg;
    let tip = Tip {
        mass_kg: r.number(
            "tip.mass_kg",
            0.01195,
            Range::Closed(0.0, heaviest_tip),
            "kg (at most 1e6 times beam.mass_kg)",
        )?,
    };
    let heaviest_holder = MAX_MASS_RATIO * beam.mass_kg * beam.length_m * beam.length_m;
    let limiter = read_limiter(r, beam.length_m)?;
    let gravity = Gravity {
        g_m_s2: r.number("gravity.g_m_s2", 9.81, Range::NonNegative, "m/s^2")?,
    };
    let pivot = Pivot {
        mode: match r
            .choice("pivot.mode", "hinged", &["hinged", "clamped"])?
            .as_str()
        {
            "clamped" => PivotMode::Clamped,
            _ => PivotMode::Hinged,
        },
        damping_nms: r.number("pivot.damping_nms", 0.0, Range::NonNegative, "N m s")?,
        holder_inertia_kgm2: r.number(
            "pivot.holder_inertia_kgm2",
            0.0,
            Range::Closed(0.0, heaviest_holder),
            "kg m^2 (at most 1e6 times beam.mass_kg × beam.length_m²)",
        )?,
    };
    let integration = read_integration(r)?;
    let excitation = read_excitation(r, integration.duration_s)?;
    check_step_resolves_forcing(&integration, &excitation)?;
    let piezo = read_piezo(r, beam.segments)?;
    let output = Output {
        sample_rate_hz: r.number("output.sample_rate_hz", 1000.0, Range::Positive, "Hz")?,
    };
    let initial = Initial {
        angle_deg: read_start_angle(r, &limiter)?,
        rate_deg_s: r.number("initial.rate_deg_s", 0.0, Range::Any, "deg/s")?,
        voltage_v: r.number("initial.voltage_v", 0.0, Range::Any, "V")?,
    };
    Ok(Scene {
        beam,
        tip,
        limiter,
        gravity,
        pivot,
        excitation,
        piezo,
        integration,
        output,
        initial,
        notes: Vec::new(),
    })
}

/// The beam masses the model is meant for (kg): a milligram to ten tonnes.
pub(crate) const BEAM_MASS_RANGE_KG: (f64, f64) = (1e-6, 1e4);

/// How many times the beam's mass the tip mass (and the holder's inertia over the beam's
/// m L²) may be: beyond it the chain's mass matrix loses its precision in `f64`.
pub(crate) const MAX_MASS_RATIO: f64 = 1e6;

/// A given step must sample the forcing above its Nyquist rate, two steps per period of the
/// highest forcing frequency: slower, the cart's motion aliases (at one step per half period
/// the cart is at rest at every step, and the run is "ok").
fn check_step_resolves_forcing(i: &Integration, e: &Excitation) -> Result<(), ConfigError> {
    let TimeStep::Seconds(dt) = i.dt_s else {
        return Ok(());
    };
    let f_max = match e.kind {
        ExcitationKind::Harmonic { frequency_hz } => frequency_hz,
        ExcitationKind::Sweep {
            start_hz, end_hz, ..
        } => start_hz.max(end_hz),
    };
    if dt * f_max < 0.5 {
        return Ok(());
    }
    Err(ConfigError::Inconsistent {
        key: "integration.dt_s".into(),
        reason: format!(
            "dt = {dt:e} s takes {:.3} steps per forcing period at {} Hz, below the 2 that resolve the cart's motion at all (dt < {:e} s) and far below what an accurate run takes: shorten integration.dt_s or set it to \"auto\"",
            1.0 / (dt * f_max),
            num(f_max),
            0.5 / f_max
        ),
    })
}

fn read_beam(r: &mut Reader) -> Result<Beam, ConfigError> {
    let outer = r.number("beam.outer_diameter_m", 0.006, Range::Positive, "m")?;
    let inner = r.number("beam.inner_diameter_m", 0.0035, Range::NonNegative, "m")?;
    if inner >= outer {
        return Err(ConfigError::OutOfRange {
            key: "beam.inner_diameter_m".into(),
            value: inner,
            range: format!("[0, {}) m (below beam.outer_diameter_m)", num(outer)),
        });
    }
    let tube = Tube {
        length_m: r.number("beam.length_m", 0.375, Range::Positive, "m")?,
        mass_kg: r.number(
            "beam.mass_kg",
            0.05525,
            Range::Closed(BEAM_MASS_RANGE_KG.0, BEAM_MASS_RANGE_KG.1),
            "kg",
        )?,
        outer_diameter_m: outer,
        inner_diameter_m: inner,
        youngs_modulus_pa: r.number("beam.youngs_modulus_pa", 2e11, Range::Positive, "Pa")?,
    };
    Ok(Beam {
        segments: r.integer("beam.segments", 17, 1, MAX_SEGMENTS)? as usize,
        damping: read_beam_damping(r, library_damping_time_s(&tube))?,
        length_m: tube.length_m,
        mass_kg: tube.mass_kg,
        outer_diameter_m: tube.outer_diameter_m,
        inner_diameter_m: tube.inner_diameter_m,
        youngs_modulus_pa: tube.youngs_modulus_pa,
    })
}

/// The library reading's β for a tube: `b / k` with `b` = [`LIBRARY_JOINT_DAMPING_NMS`] and
/// `k = EI / (L / 17)` (s), the same for every N of the scene.
pub(crate) fn library_damping_time_s(tube: &Tube) -> f64 {
    LIBRARY_JOINT_DAMPING_NMS
        / (tube.bending_stiffness_nm2() / (tube.length_m / LIBRARY_SEGMENTS as f64))
}

/// At most one of `beam.damping_time_s`, `beam.damping_ratio`, `beam.joint_damping_nms`;
/// without any, the library reading's β (`library_beta_s`).
fn read_beam_damping(r: &mut Reader, library_beta_s: f64) -> Result<BeamDamping, ConfigError> {
    let time = r.number_opt("beam.damping_time_s", Range::NonNegative, "s")?;
    let ratio = r.number_opt("beam.damping_ratio", Range::ClosedOpen(0.0, 1.0), "")?;
    let joint = r.number_opt("beam.joint_damping_nms", Range::NonNegative, "N m s/rad")?;
    let given: Vec<&str> = [
        (time.is_some(), "beam.damping_time_s"),
        (ratio.is_some(), "beam.damping_ratio"),
        (joint.is_some(), "beam.joint_damping_nms"),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, k)| *k)
    .collect();
    if given.len() > 1 {
        return Err(ConfigError::Inconsistent {
            key: given[1].into(),
            reason: format!(
                "the joint damping is set twice ({}): give at most one of beam.damping_time_s, beam.damping_ratio, beam.joint_damping_nms",
                given.join(" and ")
            ),
        });
    }
    Ok(match (time, ratio, joint) {
        (Some(t), _, _) => BeamDamping::TimeS(t),
        (_, _, Some(b)) => BeamDamping::JointNms(b),
        (_, Some(z), _) => BeamDamping::Ratio(z),
        (None, None, None) => BeamDamping::TimeS(library_beta_s),
    })
}

/// Keys of a part that is switched off, and the setting that switches it off.
type SwitchedOff = (&'static [&'static str], &'static str);

/// The limiter's keys, unused with `limiter.enabled = false`.
const LIMITER_OFF: SwitchedOff = (
    &[
        "limiter.clearance_deg",
        "limiter.contact_arc_m",
        "limiter.stiffness_n_per_m",
        "limiter.damping_ns_per_m",
        "limiter.damping_law",
    ],
    "limiter.enabled = false",
);

/// The patch's keys, unused with `piezo.enabled = false`.
const PIEZO_OFF: SwitchedOff = (
    &[
        "piezo.segments",
        "piezo.capacitance_f",
        "piezo.load_ohm",
        "piezo.coupling_nm_per_v",
        "initial.voltage_v",
    ],
    "piezo.enabled = false",
);

/// A sweep's keys, unused under harmonic forcing.
const SWEEP_OFF: SwitchedOff = (
    &[
        "excitation.sweep_start_hz",
        "excitation.sweep_end_hz",
        "excitation.sweep_duration_s",
    ],
    "only used with excitation.kind = \"sweep\"",
);

/// The frequency of harmonic forcing, unused by a sweep.
const HARMONIC_OFF: SwitchedOff = (
    &["excitation.frequency_hz"],
    "a sweep runs from excitation.sweep_start_hz to excitation.sweep_end_hz",
);

/// The keys of adaptive steps, unused at fixed steps.
const TOLERANCES_OFF: SwitchedOff = (
    &[
        "integration.rtol",
        "integration.atol",
        "integration.base_step_s",
    ],
    "integration.step is \"fixed\"",
);

/// A given step, unused at adaptive steps.
const STEP_OFF: SwitchedOff = (
    &["integration.dt_s"],
    "integration.step is \"adaptive\" (the tolerances set the steps)",
);

impl Scene {
    /// The keys this scene does not use, each with the setting that switches it off: a
    /// value given for one changes nothing of a run (a note says so), and a sweep over one
    /// (a map axis, a design variable, an unknown) would give identical cells.
    pub(crate) fn unused_keys(&self) -> Vec<(&'static str, &'static str)> {
        let mut off: Vec<SwitchedOff> = Vec::new();
        if !self.limiter.enabled {
            off.push(LIMITER_OFF);
        }
        if !self.piezo.enabled {
            off.push(PIEZO_OFF);
        }
        off.push(match self.excitation.kind {
            ExcitationKind::Harmonic { .. } => SWEEP_OFF,
            ExcitationKind::Sweep { .. } => HARMONIC_OFF,
        });
        off.push(match self.integration.step {
            StepControl::Fixed => TOLERANCES_OFF,
            StepControl::Adaptive { .. } => STEP_OFF,
        });
        off.into_iter()
            .flat_map(|(keys, why)| keys.iter().map(move |k| (*k, why)))
            .collect()
    }
}

/// The one rule for keys of a part that is switched off (the limiter, the piezo, a sweep under
/// a harmonic forcing): they are accepted, and each one the scene sets is named in a note
/// (printed as a warning) saying it is not used.
pub(super) fn note_unused(r: &mut Reader, (keys, why): SwitchedOff) -> Result<(), ConfigError> {
    for k in keys {
        if r.given(k)? {
            r.note(format!("{k} is set but not used: {why}"));
        }
    }
    Ok(())
}

fn read_limiter(r: &mut Reader, length_m: f64) -> Result<Limiter, ConfigError> {
    let limiter = read_limiter_keys(r, length_m)?;
    if !limiter.enabled {
        note_unused(r, LIMITER_OFF)?;
    }
    Ok(limiter)
}

fn read_limiter_keys(r: &mut Reader, length_m: f64) -> Result<Limiter, ConfigError> {
    Ok(Limiter {
        enabled: r.boolean("limiter.enabled", true)?,
        clearance_deg: r.number("limiter.clearance_deg", 20.0, Range::Open(0.0, 90.0), "deg")?,
        contact_arc_m: r.number(
            "limiter.contact_arc_m",
            0.03,
            Range::OpenClosed(0.0, length_m),
            "m (along the beam, up to beam.length_m)",
        )?,
        stiffness_n_per_m: r.number("limiter.stiffness_n_per_m", 1e4, Range::NonNegative, "N/m")?,
        damping_ns_per_m: r.number("limiter.damping_ns_per_m", 1e2, Range::NonNegative, "N s/m")?,
        damping_law: match r
            .choice(
                "limiter.damping_law",
                "loading",
                &["loading", "kelvin_voigt"],
            )?
            .as_str()
        {
            "loading" => ContactDamping::Loading,
            _ => ContactDamping::KelvinVoigt,
        },
    })
}

fn read_integration(r: &mut Reader) -> Result<Integration, ConfigError> {
    let duration_s = r.number("integration.duration_s", 30.0, Range::Positive, "s")?;
    let transient_s = r.number(
        "integration.transient_s",
        (duration_s / 3.0).min(10.0),
        Range::NonNegative,
        "s",
    )?;
    let dt_s = read_time_step(r, "integration.dt_s")?;
    let base_step_s = read_time_step(r, "integration.base_step_s")?;
    let method = match r
        .choice("integration.method", "auto", &["auto", "rk4", "imex"])?
        .as_str()
    {
        "rk4" => MethodChoice::Rk4,
        "imex" => MethodChoice::Imex,
        _ => MethodChoice::Auto,
    };
    let dt_safety = r.number(
        "integration.dt_safety",
        0.8,
        Range::OpenClosed(0.0, 0.8),
        "",
    )?;
    let step = read_step_control(r, dt_s)?;
    Ok(Integration {
        method,
        duration_s,
        transient_s,
        dt_s,
        base_step_s,
        dt_safety,
        step,
    })
}

/// A step key: `"auto"` (the default) or a positive number of seconds.
fn read_time_step(r: &mut Reader, key: &str) -> Result<TimeStep, ConfigError> {
    Ok(match r.raw(key)? {
        None => TimeStep::Auto,
        Some(toml::Value::String(s)) if s == "auto" => TimeStep::Auto,
        Some(toml::Value::String(s)) => {
            return Err(ConfigError::BadChoice {
                key: key.into(),
                value: s.clone(),
                choices: "\"auto\" or a positive number of seconds".into(),
            });
        }
        Some(_) => TimeStep::Seconds(r.number(key, 0.0, Range::Positive, "s")?),
    })
}

/// `initial.angle_deg`: by default leaning on the +x bumper (`limiter.clearance_deg`, 0
/// without bumpers); with the bumpers on, within their reach, ±`limiter.clearance_deg`: a
/// start beyond a bumper would begin inside it, its penetration a spring force no run
/// could have built up.
fn read_start_angle(r: &mut Reader, limiter: &Limiter) -> Result<f64, ConfigError> {
    if !limiter.enabled {
        return r.number("initial.angle_deg", 0.0, Range::Open(-90.0, 90.0), "deg");
    }
    let c = limiter.clearance_deg;
    r.number(
        "initial.angle_deg",
        c,
        Range::Closed(-c, c),
        "deg (within the bumpers' reach, ±limiter.clearance_deg)",
    )
}

/// `integration.step` and its tolerances: `"adaptive"` by default, `"fixed"` where
/// `integration.dt_s` is given (a step in seconds keeps its meaning). Adaptive steps run the
/// embedded estimate of the method's pair (RK4's third-order one, or the IMEX pair's); a
/// given `dt_s` with adaptive steps, and the tolerances of fixed steps, are noted as unused.
fn read_step_control(r: &mut Reader, dt_s: TimeStep) -> Result<StepControl, ConfigError> {
    let default = match dt_s {
        TimeStep::Seconds(_) => "fixed",
        TimeStep::Auto => "adaptive",
    };
    let adaptive = r.choice("integration.step", default, &["fixed", "adaptive"])? == "adaptive";
    let rtol = r.number(
        "integration.rtol",
        DEFAULT_RTOL,
        Range::Closed(1e-10, 0.1),
        "",
    )?;
    let atol = r.number(
        "integration.atol",
        DEFAULT_ATOL,
        Range::Closed(1e-14, 0.1),
        "",
    )?;
    if !adaptive {
        note_unused(r, TOLERANCES_OFF)?;
        return Ok(StepControl::Fixed);
    }
    if matches!(dt_s, TimeStep::Seconds(_)) {
        note_unused(r, STEP_OFF)?;
    }
    Ok(StepControl::Adaptive { rtol, atol })
}

fn read_excitation(r: &mut Reader, duration_s: f64) -> Result<Excitation, ConfigError> {
    let kind = r.choice("excitation.kind", "harmonic", &["harmonic", "sweep"])?;
    let frequency_hz = r.number("excitation.frequency_hz", 8.0, Range::Positive, "Hz")?;
    let kind = if kind == "sweep" {
        if r.given("excitation.frequency_hz")? {
            r.note(format!(
                "excitation.frequency_hz = {} is not used: a sweep runs from \
                 excitation.sweep_start_hz to excitation.sweep_end_hz",
                num(frequency_hz)
            ));
        }
        ExcitationKind::Sweep {
            start_hz: r.number("excitation.sweep_start_hz", 4.0, Range::Positive, "Hz")?,
            end_hz: r.number("excitation.sweep_end_hz", 8.0, Range::Positive, "Hz")?,
            duration_s: r.number(
                "excitation.sweep_duration_s",
                duration_s,
                Range::Positive,
                "s",
            )?,
        }
    } else {
        note_unused(r, SWEEP_OFF)?;
        ExcitationKind::Harmonic { frequency_hz }
    };
    Ok(Excitation {
        kind,
        amplitude_m: r.number("excitation.amplitude_m", 0.009, Range::NonNegative, "m")?,
        phase_deg: r.number(
            "excitation.phase_deg",
            0.0,
            Range::ClosedOpen(0.0, 360.0),
            "deg",
        )?,
    })
}

fn read_piezo(r: &mut Reader, segments: usize) -> Result<Piezo, ConfigError> {
    let enabled = r.boolean("piezo.enabled", false)?;
    let p = r.integer("piezo.segments", 2, 1, MAX_SEGMENTS)? as usize;
    if enabled && p + 1 > segments {
        return Err(ConfigError::Inconsistent {
            key: "piezo.segments".into(),
            reason: format!(
                "the patch spans segments 1..=p+1, so p must be in [1, {}] for beam.segments = {segments} (a piezo needs at least 2 segments)",
                segments.saturating_sub(1)
            ),
        });
    }
    if !enabled {
        note_unused(r, PIEZO_OFF)?;
    }
    Ok(Piezo {
        enabled,
        segments: p,
        capacitance_f: r.number("piezo.capacitance_f", 10e-9, Range::Positive, "F")?,
        load_ohm: r.number("piezo.load_ohm", 1e6, Range::Positive, "ohm")?,
        coupling_nm_per_v: r.number(
            "piezo.coupling_nm_per_v",
            1e-4,
            Range::NonNegative,
            "N m/V",
        )?,
    })
}
