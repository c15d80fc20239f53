//! Typed scene fields: the swept keys a map sets on its validated base scene directly, instead
//! of writing each cell's value into a copy of the scene's table and reading the whole table
//! again (`docs/architecture.md`, "Planning a map").
//!
//! A key is a [`SceneField`] only if setting it changes nothing else in the scene:
//! - no other key's default follows it (as `initial.angle_deg` follows
//!   `limiter.clearance_deg`, or the library damping follows the tube), and
//! - no rule of the scene reader relates it to another field (its range may depend on keys
//!   that are not fields, as `tip.mass_kg`'s on `beam.mass_kg`).
//!
//! Then a cell's scene is valid exactly when each of its swept values is valid on the base
//! scene, so the map checks every value once by the reader ([`crate::config::MapSpec::run_scenes`]),
//! and the typed scene equals the one the reader makes from the cell's table (tested below,
//! field by field).

use super::scene::{ExcitationKind, Scene};

/// A numeric scene key set as a typed field of a validated scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneField {
    /// `excitation.frequency_hz` (harmonic forcing).
    FrequencyHz,
    /// `excitation.amplitude_m`.
    AmplitudeM,
    /// `excitation.phase_deg`.
    PhaseDeg,
    /// `initial.angle_deg`.
    AngleDeg,
    /// `initial.rate_deg_s`.
    RateDegS,
    /// `initial.voltage_v` (piezo enabled).
    VoltageV,
    /// `tip.mass_kg`.
    TipMassKg,
    /// `pivot.damping_nms`.
    PivotDampingNms,
    /// `pivot.holder_inertia_kgm2`.
    HolderInertiaKgm2,
    /// `gravity.g_m_s2`.
    GravityMS2,
    /// `limiter.stiffness_n_per_m` (limiter enabled).
    ContactStiffnessNPerM,
    /// `limiter.damping_ns_per_m` (limiter enabled).
    ContactDampingNsPerM,
    /// `piezo.capacitance_f` (piezo enabled).
    CapacitanceF,
    /// `piezo.load_ohm` (piezo enabled).
    LoadOhm,
    /// `piezo.coupling_nm_per_v` (piezo enabled).
    CouplingNmPerV,
}

impl SceneField {
    /// Every field.
    pub const ALL: [SceneField; 15] = [
        SceneField::FrequencyHz,
        SceneField::AmplitudeM,
        SceneField::PhaseDeg,
        SceneField::AngleDeg,
        SceneField::RateDegS,
        SceneField::VoltageV,
        SceneField::TipMassKg,
        SceneField::PivotDampingNms,
        SceneField::HolderInertiaKgm2,
        SceneField::GravityMS2,
        SceneField::ContactStiffnessNPerM,
        SceneField::ContactDampingNsPerM,
        SceneField::CapacitanceF,
        SceneField::LoadOhm,
        SceneField::CouplingNmPerV,
    ];

    /// The dotted scene key.
    pub fn key(self) -> &'static str {
        match self {
            SceneField::FrequencyHz => "excitation.frequency_hz",
            SceneField::AmplitudeM => "excitation.amplitude_m",
            SceneField::PhaseDeg => "excitation.phase_deg",
            SceneField::AngleDeg => "initial.angle_deg",
            SceneField::RateDegS => "initial.rate_deg_s",
            SceneField::VoltageV => "initial.voltage_v",
            SceneField::TipMassKg => "tip.mass_kg",
            SceneField::PivotDampingNms => "pivot.damping_nms",
            SceneField::HolderInertiaKgm2 => "pivot.holder_inertia_kgm2",
            SceneField::GravityMS2 => "gravity.g_m_s2",
            SceneField::ContactStiffnessNPerM => "limiter.stiffness_n_per_m",
            SceneField::ContactDampingNsPerM => "limiter.damping_ns_per_m",
            SceneField::CapacitanceF => "piezo.capacitance_f",
            SceneField::LoadOhm => "piezo.load_ohm",
            SceneField::CouplingNmPerV => "piezo.coupling_nm_per_v",
        }
    }

    /// The field of a dotted key, if it is one.
    pub(crate) fn of_key(key: &str) -> Option<SceneField> {
        SceneField::ALL.into_iter().find(|f| f.key() == key)
    }

    /// Whether `scene` uses the field. Where it does not (the limiter's or the piezo's keys
    /// with the part off, a frequency under a sweep), the reader notes the key as unused, so
    /// a map reads such cells from their tables instead.
    pub fn applies(self, scene: &Scene) -> bool {
        match self {
            SceneField::FrequencyHz => {
                matches!(scene.excitation.kind, ExcitationKind::Harmonic { .. })
            }
            SceneField::ContactStiffnessNPerM | SceneField::ContactDampingNsPerM => {
                scene.limiter.enabled
            }
            SceneField::VoltageV
            | SceneField::CapacitanceF
            | SceneField::LoadOhm
            | SceneField::CouplingNmPerV => scene.piezo.enabled,
            _ => true,
        }
    }

    /// Set the field to `v` on a scene it [applies](SceneField::applies) to. The value must
    /// have been validated on that scene by the reader.
    pub fn set(self, scene: &mut Scene, v: f64) {
        match self {
            SceneField::FrequencyHz => {
                scene.excitation.kind = ExcitationKind::Harmonic { frequency_hz: v }
            }
            SceneField::AmplitudeM => scene.excitation.amplitude_m = v,
            SceneField::PhaseDeg => scene.excitation.phase_deg = v,
            SceneField::AngleDeg => scene.initial.angle_deg = v,
            SceneField::RateDegS => scene.initial.rate_deg_s = v,
            SceneField::VoltageV => scene.initial.voltage_v = v,
            SceneField::TipMassKg => scene.tip.mass_kg = v,
            SceneField::PivotDampingNms => scene.pivot.damping_nms = v,
            SceneField::HolderInertiaKgm2 => scene.pivot.holder_inertia_kgm2 = v,
            SceneField::GravityMS2 => scene.gravity.g_m_s2 = v,
            SceneField::ContactStiffnessNPerM => scene.limiter.stiffness_n_per_m = v,
            SceneField::ContactDampingNsPerM => scene.limiter.damping_ns_per_m = v,
            SceneField::CapacitanceF => scene.piezo.capacitance_f = v,
            SceneField::LoadOhm => scene.piezo.load_ohm = v,
            SceneField::CouplingNmPerV => scene.piezo.coupling_nm_per_v = v,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{PAPER_SCENE_TOML, parse_toml, set_key};
    use toml::Value;

    /// A valid value of each field on the paper scene with the piezo on, away from its
    /// default.
    fn probe_value(f: SceneField) -> f64 {
        match f {
            SceneField::FrequencyHz => 9.25,
            SceneField::AmplitudeM => 0.0125,
            SceneField::PhaseDeg => 90.0,
            SceneField::AngleDeg => -7.5,
            SceneField::RateDegS => 30.0,
            SceneField::VoltageV => 0.5,
            SceneField::TipMassKg => 0.02,
            SceneField::PivotDampingNms => 1e-3,
            SceneField::HolderInertiaKgm2 => 1e-5,
            SceneField::GravityMS2 => 9.5,
            SceneField::ContactStiffnessNPerM => 2e4,
            SceneField::ContactDampingNsPerM => 50.0,
            SceneField::CapacitanceF => 2e-8,
            SceneField::LoadOhm => 5e5,
            SceneField::CouplingNmPerV => 2e-4,
        }
    }

    fn base_table(without: Option<&str>) -> toml::Table {
        let mut t = parse_toml(PAPER_SCENE_TOML, "paper").unwrap();
        set_key(&mut t, "piezo.enabled", Value::Boolean(true)).unwrap();
        if let Some(key) = without {
            let (section, leaf) = key.split_once('.').unwrap();
            if let Some(Value::Table(s)) = t.get_mut(section) {
                s.remove(leaf);
                if s.is_empty() {
                    t.remove(section);
                }
            }
        }
        t
    }

    /// Setting a field on the validated base gives the scene the reader makes from the table
    /// with the key set, whether or not the base table wrote the key.
    #[test]
    fn a_typed_field_gives_the_scene_the_reader_gives() {
        for f in SceneField::ALL {
            for without in [None, Some(f.key())] {
                let table = base_table(without);
                let mut typed = Scene::from_table(table.clone()).unwrap();
                assert!(f.applies(&typed), "{}", f.key());
                f.set(&mut typed, probe_value(f));
                let mut cell = table;
                set_key(&mut cell, f.key(), Value::Float(probe_value(f))).unwrap();
                let read = Scene::from_table(cell).unwrap();
                assert_eq!(
                    typed,
                    read,
                    "{} (base without it: {})",
                    f.key(),
                    without.is_some()
                );
            }
        }
    }

    /// All fields set at once: no field's value changes another's.
    #[test]
    fn every_field_at_once_gives_the_scene_the_reader_gives() {
        let table = base_table(None);
        let mut typed = Scene::from_table(table.clone()).unwrap();
        let mut cell = table;
        for f in SceneField::ALL {
            f.set(&mut typed, probe_value(f));
            set_key(&mut cell, f.key(), Value::Float(probe_value(f))).unwrap();
        }
        assert_eq!(typed, Scene::from_table(cell).unwrap());
    }

    /// The fields of a part that is off do not apply (the reader would note them as unused).
    #[test]
    fn fields_of_a_part_that_is_off_do_not_apply() {
        let mut t = base_table(None);
        set_key(&mut t, "piezo.enabled", Value::Boolean(false)).unwrap();
        set_key(&mut t, "limiter.enabled", Value::Boolean(false)).unwrap();
        let scene = Scene::from_table(t).unwrap();
        let off: Vec<&str> = SceneField::ALL
            .into_iter()
            .filter(|f| !f.applies(&scene))
            .map(SceneField::key)
            .collect();
        assert_eq!(off.len(), 6, "{off:?}");
        assert!(off.iter().all(|k| k.starts_with("limiter.")
            || k.starts_with("piezo.")
            || *k == "initial.voltage_v"));
        assert!(SceneField::of_key("limiter.clearance_deg").is_none());
        assert_eq!(
            SceneField::of_key("excitation.amplitude_m"),
            Some(SceneField::AmplitudeM)
        );
    }
}
