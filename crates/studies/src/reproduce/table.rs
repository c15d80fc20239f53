//! Table 2 side by side with ours (`table2.csv`, `table2.md`), and the experiments' rows.

use super::cases::PaperCase;
use super::error::ReproduceError;
use super::indicators::{Regime, StationaryAnalysis, SyncClass, TwinVerdict, regime, sync_class};
use super::run::RunStats;
use serde::Serialize;
use std::path::Path;

/// One row of our Table 2 (or of the experiments' table), every number with its unit in its name.
#[derive(Debug, Clone, Serialize)]
pub struct CaseRow {
    /// Case identifier (scene file stem).
    pub case: String,
    /// Figure this case stands for (`Fig. 4a`).
    pub figure: String,
    /// Cart amplitude A (mm).
    pub amplitude_mm: f64,
    /// Forcing frequency f (Hz).
    pub frequency_hz: f64,
    /// Segments of the chain.
    pub segments: usize,
    /// K published by the paper (Table 2), NaN when none.
    pub k_paper: f64,
    /// Our K on the local extrema of α over the whole run (correlation method, eq. 8 normalised).
    pub k_extrema: f64,
    /// Our K on the same extrema with the paper's regression estimator (eq. 10).
    pub k_extrema_eq10: f64,
    /// Whether the 0–1 test's oversampling check fired on the extrema (K unreliable).
    pub k_extrema_oversampled: bool,
    /// Number of local extrema (the paper: N ≈ 400).
    pub n_extrema: usize,
    /// Our K on one α sample per forcing period after the transient (correlation method).
    pub k_strobe: f64,
    /// Whether the oversampling check fired on the stroboscopic samples.
    pub k_strobe_oversampled: bool,
    /// Number of stroboscopic samples.
    pub n_strobe: usize,
    /// Regime the paper's K implies.
    pub regime_paper: Regime,
    /// Regime of our K on the extrema.
    pub regime_extrema: Regime,
    /// Regime of our K on the extrema with eq. 10.
    pub regime_extrema_eq10: Regime,
    /// Regime of our stroboscopic K.
    pub regime_strobe: Regime,
    /// R published by the paper (NaN when none).
    pub r_paper: f64,
    /// Our R, paper convention (Δφ modulo π; uniform phases give 2/π ≈ 0.64).
    pub r_paper_convention: f64,
    /// Our R, standard convention (uniform phases give 0).
    pub r_standard: f64,
    /// Synchronisation class of the paper's R.
    pub sync_paper: SyncClass,
    /// Synchronisation class of our R (paper convention).
    pub sync_ours: SyncClass,
    /// Strongest line of α's spectrum after the transient (Hz).
    pub alpha_peak_hz: f64,
    /// Its ratio to the forcing.
    pub alpha_peak_ratio: f64,
    /// The simple fraction naming that ratio, or "incommensurate".
    pub alpha_peak_label: String,
    /// Strongest line of the chord reduction's spectrum (Hz).
    pub chord_peak_hz: f64,
    /// The fraction naming its ratio to the forcing.
    pub chord_peak_label: String,
    /// Largest chord reduction after the transient (mm).
    pub chord_max_mm: f64,
    /// Largest tip distance from the holder's line after the transient (mm).
    pub tip_deflection_max_mm: f64,
    /// Period of the stroboscopic section (forcing periods; 0: none found).
    pub period: usize,
    /// Hops between the wells after the transient.
    pub hops: usize,
    /// Range of α after the transient (deg).
    pub alpha_range_deg: f64,
    /// Bumper contact onsets over the run.
    pub impacts: u64,
    /// Largest |Δα| after the transient between the run and its twin (rad); NaN without twin.
    pub twin_max_dalpha_rad: f64,
    /// Separate, converge or stay close.
    pub twin_verdict: TwinVerdict,
    /// RK4 step (s).
    pub dt_s: f64,
    /// Wall time of the integration (s).
    pub wall_s: f64,
}

impl CaseRow {
    /// Assemble the row of `case` from its analysis and run statistics.
    pub fn new(case: &PaperCase, segments: usize, a: &StationaryAnalysis, s: &RunStats) -> Self {
        let k_paper = case.published_k.unwrap_or(f64::NAN);
        let r_paper = case.published_r.unwrap_or(f64::NAN);
        CaseRow {
            case: case.id.to_string(),
            figure: case.figure_name(),
            amplitude_mm: case.amplitude_mm,
            frequency_hz: a.forcing_hz,
            segments,
            k_paper,
            k_extrema: a.k_extrema.k,
            k_extrema_eq10: a.k_extrema_eq10.k,
            k_extrema_oversampled: a.k_extrema.oversampled,
            n_extrema: a.extrema.len(),
            k_strobe: a.k_strobe.k,
            k_strobe_oversampled: a.k_strobe.oversampled,
            n_strobe: a.k_strobe.n_samples,
            regime_paper: regime(k_paper),
            regime_extrema: regime(a.k_extrema.k),
            regime_extrema_eq10: regime(a.k_extrema_eq10.k),
            regime_strobe: regime(a.k_strobe.k),
            r_paper,
            r_paper_convention: a.r_paper,
            r_standard: a.r_standard,
            sync_paper: sync_class(r_paper),
            sync_ours: sync_class(a.r_paper),
            alpha_peak_hz: a.alpha_peak.map_or(f64::NAN, |p| p.frequency_hz),
            alpha_peak_ratio: a.alpha_ratio.as_ref().map_or(f64::NAN, |r| r.ratio),
            alpha_peak_label: a
                .alpha_ratio
                .as_ref()
                .map_or("n/a".into(), |r| r.label.clone()),
            chord_peak_hz: a.chord_peak.map_or(f64::NAN, |p| p.frequency_hz),
            chord_peak_label: a
                .chord_ratio
                .as_ref()
                .map_or("n/a".into(), |r| r.label.clone()),
            chord_max_mm: a.chord_max_mm,
            tip_deflection_max_mm: a.tip_deflection_max_mm,
            period: a.period,
            hops: a.hops,
            alpha_range_deg: a.alpha_range_deg,
            impacts: s.impacts,
            twin_max_dalpha_rad: a
                .twin
                .as_ref()
                .map_or(f64::NAN, |t| t.max_after_transient_rad),
            twin_verdict: a.twin.as_ref().map_or(TwinVerdict::Unknown, |t| t.verdict),
            dt_s: s.dt_s,
            wall_s: s.wall_s,
        }
    }
}

/// Write rows as CSV with a header of the field names.
pub fn write_csv(path: &Path, rows: &[CaseRow]) -> Result<(), ReproduceError> {
    let io = |e: csv::Error| {
        let text = e.to_string();
        let source = match e.into_kind() {
            csv::ErrorKind::Io(e) => e,
            _ => std::io::Error::other(text),
        };
        ReproduceError::io(path, source)
    };
    let mut w = csv::Writer::from_path(path).map_err(io)?;
    for r in rows {
        w.serialize(r).map_err(io)?;
    }
    w.flush().map_err(|e| ReproduceError::io(path, e))
}

/// A number with `digits` decimals, or "–" when it is not finite.
pub fn num(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

/// A K value, marked † when the 0–1 test's oversampling check fired.
pub(crate) fn k_cell(k: f64, oversampled: bool) -> String {
    format!("{}{}", num(k, 2), if oversampled { " †" } else { "" })
}

/// The Markdown table of Table 2 side by side with ours.
pub fn table2_markdown(rows: &[CaseRow]) -> String {
    let mut s = String::new();
    s.push_str(
        "| A (mm) | f (Hz) | K paper | K extrema | K extrema, eq. 10 | K strobe | regime: paper / extrema / eq. 10 / strobe | R paper | R ours (paper conv.) | R ours (standard) | sync: paper / ours | α peak (Hz, × f) | hops | twin |\n",
    );
    s.push_str("|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---|---|---:|---|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} / {} / {} / {} | {} | {} | {} | {} / {} | {} ({}, {}) | {} | {} |\n",
            r.amplitude_mm,
            r.frequency_hz,
            num(r.k_paper, 2),
            k_cell(r.k_extrema, r.k_extrema_oversampled),
            k_cell(r.k_extrema_eq10, r.k_extrema_oversampled),
            k_cell(r.k_strobe, r.k_strobe_oversampled),
            r.regime_paper,
            r.regime_extrema,
            r.regime_extrema_eq10,
            r.regime_strobe,
            num(r.r_paper, 2),
            num(r.r_paper_convention, 2),
            num(r.r_standard, 2),
            r.sync_paper,
            r.sync_ours,
            num(r.alpha_peak_hz, 2),
            num(r.alpha_peak_ratio, 3),
            r.alpha_peak_label,
            r.hops,
            r.twin_verdict,
        ));
    }
    s
}

/// `table2.md`: the table with the legend that says how each column was computed.
pub fn table2_document(rows: &[CaseRow], settings: &str) -> String {
    let n_ext: Vec<String> = rows.iter().map(|r| r.n_extrema.to_string()).collect();
    format!(
        "# Table 2 of Łygas et al. (2019) side by side with pendulum-atlas\n\n\
         {settings}\n\n{}\n\
         - **K paper**, **R paper**: transcribed from the paper's Table 2.\n\
         - **K extrema**: 0–1 test (correlation method, median over 100 seeded c ∈ (π/5, 4π/5)) on the \
         local maxima and minima of the holder angle α over the whole run, normalised as the paper's eq. 8 \
         ({} extrema per case; the paper has N ≈ 400).\n\
         - **K extrema, eq. 10**: the same extrema with the paper's estimator, the slope of ln M_c(n) \
         against ln n, n ≤ N/10.\n\
         - **K strobe**: 0–1 test (correlation) on one α sample per forcing period after the transient.\n\
         - **†**: the 0–1 test's oversampling check fired (Matthews' criteria: the series' range over its \
         mean step exceeds 10, or K_c of low c exceeds that of high c by 0.5): that K is unreliable.\n\
         - **regime**: chaotic when K ≥ {}, regular otherwise.\n\
         - **R**: phase synchronisation of the cart position and α (Hilbert phases) after the transient; \
         *paper convention* reduces Δφ modulo π (independent phases give 2/π ≈ 0.64, the paper's \
         \"random\" value), *standard* keeps the full circle (independent phases give 0). \
         **sync**: synchronised when R (paper convention) ≥ {}.\n\
         - **α peak**: strongest line of α's amplitude spectrum after the transient, its ratio to f and the \
         simple fraction within 2 % (or \"incommensurate\").\n\
         - **hops**: passages between the wells after the transient.\n\
         - **twin**: the same run started {}° lower: *separate* when α differs by more than {} rad after \
         the transient (sensitive dependence), *converge* when by less than {} rad.\n",
        table2_markdown(rows),
        n_ext.join(", "),
        super::indicators::K_CHAOTIC_THRESHOLD,
        super::indicators::R_PAPER_SYNC_THRESHOLD,
        super::indicators::TWIN_PERTURBATION_DEG,
        super::indicators::TWIN_SEPARATED_RAD,
        super::indicators::TWIN_CONVERGED_RAD,
    )
}
