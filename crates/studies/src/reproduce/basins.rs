//! The Table 2 cases as basins: each case's (f, A) run from [`BASIN_STARTS`] starts through the
//! map's attractor stage (`map.initial_states`, `docs/analysis.md` §13), so that the report can
//! say which motions coexist there, how many starts each one holds, and whether one of them has
//! the paper's class. A single start on a chaotic border says little: a start 1e-4° away
//! changes the motion in most of these cases (the twin runs).

use super::cases::{CaseKind, PaperCase};
use super::error::ReproduceError;
use super::indicators::K_CHAOTIC_THRESHOLD;
use pendulum_atlas_core::config::map_from_toml;
use pendulum_atlas_core::engine::{Engine, Precision, no_progress};
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_map::map::run_map;
use pendulum_atlas_map::output::map::family_words;
use serde::Serialize;
use std::time::Instant;

/// Starts per case: a seeded Latin hypercube over the holder's angle and rate within the
/// bumpers' reach (the map's `initial_states = 16`).
pub const BASIN_STARTS: usize = 16;

/// The metrics the attractor stage fingerprints a run with (the regime brings λ1).
const METRICS: &str = r#"["K", "period", "alpha_range", "hops", "regime"]"#;

/// One attractor found at a case's (f, A).
#[derive(Debug, Clone, Serialize)]
pub struct BasinAttractor {
    /// Its label in the case's map (0: the one most starts reached).
    pub label: usize,
    /// Its verdict.
    pub regime: Regime,
    /// Its period in forcing periods (0 unless periodic).
    pub period: u32,
    /// The attractor in a few characters (`P2 +`: period 2 in the α > 0 well).
    pub words: String,
    /// Share of the starts that reached it.
    pub fraction: f64,
    /// Whether it has the paper's class (chaotic for K ≥ 0.5 in Table 2, else regular:
    /// periodic or regular).
    pub paper_class: bool,
}

/// The attractors of one Table 2 case.
#[derive(Debug, Clone, Serialize)]
pub struct CaseBasins {
    /// The case.
    pub id: &'static str,
    /// Forcing frequency (Hz).
    pub frequency_hz: f64,
    /// Cart amplitude (mm).
    pub amplitude_mm: f64,
    /// The paper's class: K ≥ 0.5 in Table 2.
    pub paper_chaotic: bool,
    /// Starts run.
    pub starts: usize,
    /// The attractors reached, most starts first.
    pub attractors: Vec<BasinAttractor>,
    /// Share of the starts whose run failed.
    pub failed_fraction: f64,
    /// Wall time of the case's map (s).
    pub wall_s: f64,
}

impl CaseBasins {
    /// The paper's class in words.
    pub fn paper_class(&self) -> &'static str {
        if self.paper_chaotic {
            "chaotic"
        } else {
            "regular"
        }
    }

    /// Share of the starts on attractors of the paper's class.
    pub(crate) fn paper_class_fraction(&self) -> f64 {
        self.attractors
            .iter()
            .filter(|a| a.paper_class)
            .map(|a| a.fraction)
            .sum()
    }

    /// One sentence: the case, its attractors with their shares, and whether the paper's
    /// motion is among them.
    pub fn sentence(&self) -> String {
        let pct = |x: f64| format!("{:.0} %", 100.0 * x);
        let found: Vec<String> = self
            .attractors
            .iter()
            .map(|a| format!("{} ({})", a.words, pct(a.fraction)))
            .collect();
        let head = format!(
            "{} Hz/{} mm: {} attractor{} from {} starts: {}",
            self.frequency_hz,
            self.amplitude_mm,
            self.attractors.len(),
            if self.attractors.len() == 1 { "" } else { "s" },
            self.starts,
            found.join(", ")
        );
        let failed = if self.failed_fraction > 0.0 {
            format!("; {} of the starts failed", pct(self.failed_fraction))
        } else {
            String::new()
        };
        let matching: Vec<&BasinAttractor> =
            self.attractors.iter().filter(|a| a.paper_class).collect();
        let verdict = match matching.as_slice() {
            [] => format!(
                "none has the paper's class ({}): the paper's motion was not reached",
                self.paper_class()
            ),
            [a] => format!(
                "the paper's {} motion is the {} attractor, holding {} of the starts",
                self.paper_class(),
                a.words,
                pct(a.fraction)
            ),
            many => format!(
                "the paper's {} motion is one of {} attractors of its class, holding {} of the starts together",
                self.paper_class(),
                many.len(),
                pct(self.paper_class_fraction())
            ),
        };
        format!("{head}{failed}. {}.", capitalise(&verdict))
    }
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().collect::<String>() + c.as_str())
        .unwrap_or_default()
}

/// Whether a verdict has the paper's class.
fn has_class(regime: Regime, paper_chaotic: bool) -> bool {
    match regime {
        Regime::Chaotic => paper_chaotic,
        Regime::Periodic | Regime::Regular => !paper_chaotic,
        _ => false,
    }
}

/// Each Table 2 case (its `--quick` variant when `quick`) from [`BASIN_STARTS`] starts on the
/// CPU engine in f64, through the attractor stage; `progress` gets a line per case.
pub fn case_basins(
    cases: &[PaperCase],
    quick: bool,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<CaseBasins>, ReproduceError> {
    let engine = Engine::cpu(Precision::F64);
    cases
        .iter()
        .filter(|c| c.kind == CaseKind::Table2)
        .map(|c| {
            let b = one_case(c, quick, &engine)?;
            progress(&format!(
                "{} from {} starts: {} attractor(s) in {:.1} s",
                c.id,
                b.starts,
                b.attractors.len(),
                b.wall_s
            ));
            Ok(b)
        })
        .collect()
}

/// One case's map of one cell and [`BASIN_STARTS`] starts.
fn one_case(c: &PaperCase, quick: bool, engine: &Engine) -> Result<CaseBasins, ReproduceError> {
    let f = c.frequency_hz.unwrap_or(f64::NAN);
    let text = format!(
        "{}\n[map]\nmetrics = {METRICS}\ninitial_states = {BASIN_STARTS}\n\
         [[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [{f:?}]\n",
        c.scene_toml
    );
    let sets = if quick {
        c.quick_overrides()
    } else {
        Vec::new()
    };
    let invalid = |source| ReproduceError::Scene {
        case: c.id.to_string(),
        source,
    };
    let spec = map_from_toml(&text, c.scene_path, &sets).map_err(invalid)?;
    let started = Instant::now();
    let run = run_map(&spec, engine, &no_progress).map_err(|e| ReproduceError::Basins {
        case: c.id.to_string(),
        reason: e.to_string(),
    })?;
    let wall_s = started.elapsed().as_secs_f64();
    let a = run.attractors.ok_or_else(|| ReproduceError::Basins {
        case: c.id.to_string(),
        reason: "the map labelled no attractors".into(),
    })?;
    let paper_chaotic = c.published_k.unwrap_or(f64::NAN) >= K_CHAOTIC_THRESHOLD;
    let mut attractors: Vec<BasinAttractor> = a
        .families
        .iter()
        .filter(|fam| a.fractions[fam.label][0] > 0.0)
        .map(|fam| BasinAttractor {
            label: fam.label,
            regime: fam.fingerprint.regime,
            period: fam.fingerprint.period,
            words: family_words(&fam.fingerprint),
            fraction: a.fractions[fam.label][0],
            paper_class: has_class(fam.fingerprint.regime, paper_chaotic),
        })
        .collect();
    attractors.sort_by(|x, y| y.fraction.total_cmp(&x.fraction));
    Ok(CaseBasins {
        id: c.id,
        frequency_hz: f,
        amplitude_mm: c.amplitude_mm,
        paper_chaotic,
        starts: a.starts,
        attractors,
        failed_fraction: a.failed[0],
        wall_s,
    })
}
