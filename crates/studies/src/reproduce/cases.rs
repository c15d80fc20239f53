//! The paper's cases: their scenes (embedded from `configs/paper/`), the figure each stands for,
//! and the numbers the paper publishes for it, transcribed from `shared/seed/paper.txt`.

use super::error::ReproduceError;
use pendulum_atlas_core::config::Scene;
use serde::Serialize;

/// What a case is in the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CaseKind {
    /// One of the six simulated cases of Table 2 and Figs. 3–7.
    Table2,
    /// The 4 → 8 Hz frequency sweep of Fig. 9 (an experiment, simulated here).
    Sweep,
    /// One of the three stationary experiments of Figs. 10–12, simulated here.
    Experiment,
}

/// One case of the paper with everything needed to run it and compare it.
#[derive(Debug, Clone, Serialize)]
pub struct PaperCase {
    /// Identifier, also the scene's file stem: `table2_A09_f08`.
    pub id: &'static str,
    /// Role in the paper.
    pub kind: CaseKind,
    /// Scene file in the repository (its text is embedded in the binary).
    pub scene_path: &'static str,
    /// The scene text.
    #[serde(skip)]
    pub scene_toml: &'static str,
    /// Cart amplitude A as the paper states it (mm).
    pub amplitude_mm: f64,
    /// Forcing frequency f as the paper states it (Hz); `None` for the sweep.
    pub frequency_hz: Option<f64>,
    /// Stem of the time-series figure this case stands for: `fig4a` (Figs. 3–5), `fig10a`
    /// (Fig. 10, with `fig11a` and `fig12a`), or `fig9` for the sweep.
    pub figure: &'static str,
    /// Panel letter of Figs. 6 and 7 when the paper shows this case there.
    pub zero_one_panel: Option<char>,
    /// K published in Table 2.
    pub published_k: Option<f64>,
    /// R published in Table 2 (simulations) or in §3.2 (experiments, Fig. 12).
    pub published_r: Option<f64>,
}

/// Segments of the chain in `--quick` mode (a cheap model for CI and a first look).
pub const QUICK_SEGMENTS: usize = 3;
/// Simulated time in `--quick` mode (s); a sweep is compressed into it as well.
pub const QUICK_DURATION_S: f64 = 24.0;
/// Transient discarded in `--quick` mode for the stationary cases (s).
pub const QUICK_TRANSIENT_S: f64 = 4.0;

macro_rules! scene {
    ($stem:literal) => {
        (
            concat!("configs/paper/", $stem, ".toml"),
            include_str!(concat!("../../../../configs/paper/", $stem, ".toml")),
        )
    };
}

/// Builds a Table 2 case. Published K and R: Table 2 of the paper.
#[allow(clippy::too_many_arguments)]
const fn table2(
    id: &'static str,
    scene: (&'static str, &'static str),
    a_mm: f64,
    f_hz: f64,
    figure: &'static str,
    panel: Option<char>,
    k: f64,
    r: f64,
) -> PaperCase {
    PaperCase {
        id,
        kind: CaseKind::Table2,
        scene_path: scene.0,
        scene_toml: scene.1,
        amplitude_mm: a_mm,
        frequency_hz: Some(f_hz),
        figure,
        zero_one_panel: panel,
        published_k: Some(k),
        published_r: Some(r),
    }
}

/// Builds an experimental case. Published R: §3.2, "R = 0.64" (Fig. 12c), "R = 0.65 for the
/// case in Fig. 12b and R = 0.64 for the case in Fig. 12a".
const fn experiment(
    id: &'static str,
    scene: (&'static str, &'static str),
    a_mm: f64,
    f_hz: f64,
    figure: &'static str,
    r: f64,
) -> PaperCase {
    PaperCase {
        id,
        kind: CaseKind::Experiment,
        scene_path: scene.0,
        scene_toml: scene.1,
        amplitude_mm: a_mm,
        frequency_hz: Some(f_hz),
        figure,
        zero_one_panel: None,
        published_k: None,
        published_r: Some(r),
    }
}

/// Every case, in the order of the paper. Figs. 6 and 7 show four cases: (a) 5 Hz/9 mm,
/// (b) 5 Hz/12 mm, (c) 8 Hz/9 mm and (d) the case "from Fig. 3a", which is 10 Hz/9 mm (the
/// caption's "f = 5 Hz" for (d) contradicts Fig. 3a's own caption; we follow Fig. 3a).
pub fn paper_cases() -> Vec<PaperCase> {
    let mut cases = table2_cases();
    cases.push(sweep_case());
    cases.extend(experiment_cases());
    cases
}

/// The six simulated cases of Table 2, by amplitude then frequency.
fn table2_cases() -> Vec<PaperCase> {
    vec![
        table2(
            "table2_A09_f05",
            scene!("table2_A09_f05"),
            9.0,
            5.0,
            "fig5a",
            Some('a'),
            0.67,
            0.74,
        ),
        table2(
            "table2_A09_f08",
            scene!("table2_A09_f08"),
            9.0,
            8.0,
            "fig4a",
            Some('c'),
            0.70,
            0.64,
        ),
        table2(
            "table2_A09_f10",
            scene!("table2_A09_f10"),
            9.0,
            10.0,
            "fig3a",
            Some('d'),
            0.60,
            0.64,
        ),
        table2(
            "table2_A12_f05",
            scene!("table2_A12_f05"),
            12.0,
            5.0,
            "fig5b",
            Some('b'),
            0.13,
            0.88,
        ),
        table2(
            "table2_A12_f08",
            scene!("table2_A12_f08"),
            12.0,
            8.0,
            "fig4b",
            None,
            0.59,
            0.66,
        ),
        table2(
            "table2_A12_f10",
            scene!("table2_A12_f10"),
            12.0,
            10.0,
            "fig3b",
            None,
            0.00,
            0.66,
        ),
    ]
}

/// The 4 → 8 Hz sweep of Fig. 9 (no published K or R).
fn sweep_case() -> PaperCase {
    PaperCase {
        id: "fig09_sweep_4_8hz",
        kind: CaseKind::Sweep,
        scene_path: scene!("fig09_sweep_4_8hz").0,
        scene_toml: scene!("fig09_sweep_4_8hz").1,
        amplitude_mm: 9.0,
        frequency_hz: None,
        figure: "fig9",
        zero_one_panel: None,
        published_k: None,
        published_r: None,
    }
}

/// The three stationary experiments of Figs. 10–12.
fn experiment_cases() -> Vec<PaperCase> {
    vec![
        experiment(
            "fig10a_f08_A09",
            scene!("fig10a_f08_A09"),
            9.0,
            8.0,
            "fig10a",
            0.64,
        ),
        experiment(
            "fig10b_f10_A12",
            scene!("fig10b_f10_A12"),
            12.0,
            10.0,
            "fig10b",
            0.65,
        ),
        experiment(
            "fig10c_f05_A25",
            scene!("fig10c_f05_A25"),
            25.0,
            5.0,
            "fig10c",
            0.64,
        ),
    ]
}

impl PaperCase {
    /// The validated scene of this case, with `extra` overrides (`section.key=value`) applied
    /// after the `--quick` ones.
    pub fn scene(&self, quick: bool, extra: &[String]) -> Result<Scene, ReproduceError> {
        let mut sets = if quick {
            self.quick_overrides()
        } else {
            Vec::new()
        };
        sets.extend(extra.iter().cloned());
        Scene::from_toml(self.scene_toml, self.scene_path, &sets).map_err(|source| {
            ReproduceError::Scene {
                case: self.id.to_string(),
                source,
            }
        })
    }

    /// The `--quick` overrides: a 3-segment chain and 24 s runs (the sweep compressed into them).
    pub(crate) fn quick_overrides(&self) -> Vec<String> {
        let mut sets = vec![
            format!("beam.segments={QUICK_SEGMENTS}"),
            format!("integration.duration_s={QUICK_DURATION_S:?}"),
        ];
        match self.kind {
            CaseKind::Sweep => {
                sets.push(format!("excitation.sweep_duration_s={QUICK_DURATION_S:?}"));
            }
            CaseKind::Table2 | CaseKind::Experiment => {
                sets.push(format!("integration.transient_s={QUICK_TRANSIENT_S:?}"));
            }
        }
        sets
    }

    /// A short label: `f = 8 Hz, A = 9 mm` (or the sweep's range).
    pub fn label(&self) -> String {
        match self.frequency_hz {
            Some(f) => format!("f = {} Hz, A = {} mm", f, self.amplitude_mm),
            None => format!("sweep 4 → 8 Hz, A = {} mm", self.amplitude_mm),
        }
    }

    /// A compact label for titles: `8 Hz/9 mm`.
    pub(crate) fn short_label(&self) -> String {
        match self.frequency_hz {
            Some(f) => format!("{} Hz/{} mm", f, self.amplitude_mm),
            None => format!("4 → 8 Hz/{} mm", self.amplitude_mm),
        }
    }

    /// The paper's name of the time-series figure: `Fig. 4a`.
    pub(crate) fn figure_name(&self) -> String {
        let stem = self.figure.trim_start_matches("fig");
        let num: String = stem.chars().take_while(|c| c.is_ascii_digit()).collect();
        let letter: String = stem.chars().skip(num.len()).collect();
        format!("Fig. {num}{letter}")
    }

    /// File-name suffix with the forcing: `f8_A9` (`sweep_4_8Hz_A9` for the sweep).
    pub(crate) fn file_tag(&self) -> String {
        match self.frequency_hz {
            Some(f) => format!("f{}_A{}", f, self.amplitude_mm),
            None => format!("sweep_4_8Hz_A{}", self.amplitude_mm),
        }
    }
}
