//! "The paper's statements, checked": one table row per qualitative claim of the paper, with
//! our numbers and a verdict computed from them.

use super::{CaseResult, LINE_CLEAR, LINE_VISIBLE, R_RANDOM_BAND, ReportInput, range_of, short};
use crate::reproduce::indicators::{Regime, StationaryAnalysis, SyncClass, regime};
use crate::reproduce::table::num;
use std::f64::consts::FRAC_2_PI;
use std::fmt::Write;

/// The paper's qualitative statements, one per row, with our numbers and a verdict.
pub(super) fn statements(s: &mut String, inp: &ReportInput) {
    let find = |a: f64, f: f64| {
        inp.table2
            .iter()
            .find(|c| c.row.amplitude_mm == a && c.row.frequency_hz == f)
    };
    let _ = writeln!(
        s,
        "## The paper's statements, checked\n\n\
         A spectral line counts as *visible* when it stands at least {LINE_VISIBLE}× above the median of \
         the spectrum between half and twice its frequency (*prominence*), as a *clear peak* from \
         {LINE_CLEAR}×.\n\n| the paper says | where | ours | verdict |\n|---|---|---|---|"
    );
    if let Some(c) = find(9.0, 8.0) {
        third_subharmonic(s, c);
    }
    if let Some(c) = find(12.0, 8.0) {
        half_subharmonic(s, c);
    }
    chord_twice_per_period(s, &inp.table2);
    if let Some(c) = find(12.0, 5.0) {
        periodic_at_5hz(s, c);
    }
    if let Some(c) = find(12.0, 10.0) {
        regular_at_10hz(s, c);
    }
    random_phases(s, &inp.table2);
    if let Some(c) = inp.experiments.iter().find(|c| c.row.frequency_hz == 8.0) {
        experiment_third_subharmonic(s, c);
    }
    experiment_bands(s, &inp.experiments);
    let _ = writeln!(s);
}

/// Whether α's spectrum shows a line at `p/q` of the forcing: visible at that frequency
/// (`prominence` there), or the strongest line itself.
fn line_seen(a: &StationaryAnalysis, prominence: f64, p_q: (u32, u32)) -> bool {
    prominence >= LINE_VISIBLE
        || a.alpha_ratio
            .as_ref()
            .is_some_and(|r| r.fraction == Some(p_q))
}

/// The verdict on a claim our run either reproduces or not.
fn agrees_or_not(ok: bool) -> &'static str {
    if ok { "agrees" } else { "not reproduced" }
}

/// 8 Hz, 9 mm: a peak at one third of the forcing.
fn third_subharmonic(s: &mut String, c: &CaseResult) {
    let a = c.analysis;
    let ok = line_seen(a, a.prominence_third, (1, 3));
    let _ = writeln!(
        s,
        "| 8 Hz, 9 mm: a broad peak of the holder angle at one third of the forcing, 2.7 Hz | §2.1, Fig. 4a \
         | prominence at f/3 = {}; strongest line {} Hz ({}) | {} |",
        num(a.prominence_third, 1),
        num(c.row.alpha_peak_hz, 2),
        c.row.alpha_peak_label,
        agrees_or_not(ok)
    );
}

/// 8 Hz, 12 mm: the response at one half of the forcing.
fn half_subharmonic(s: &mut String, c: &CaseResult) {
    let a = c.analysis;
    let ok = line_seen(a, a.prominence_half, (1, 2));
    let _ = writeln!(
        s,
        "| 8 Hz, 12 mm: the response frequency \"switched to one half\" | §2.1, Fig. 4b | prominence at \
         f/2 = {}; strongest line {} Hz ({}) | {} |",
        num(a.prominence_half, 1),
        num(c.row.alpha_peak_hz, 2),
        c.row.alpha_peak_label,
        agrees_or_not(ok)
    );
}

/// The chord's spectrum peaking at twice the forcing, with how far the beam bends at all.
fn chord_twice_per_period(s: &mut String, t: &[CaseResult]) {
    let doubled: Vec<String> = t
        .iter()
        .filter(|c| {
            c.analysis
                .chord_ratio
                .as_ref()
                .is_some_and(|r| r.fraction == Some((2, 1)))
        })
        .map(short)
        .collect();
    let chord_labels: Vec<String> = t
        .iter()
        .map(|c| format!("{} {}", short(c), c.row.chord_peak_label))
        .collect();
    let n = t.len();
    let (chord_lo, chord_hi) = range_of(t.iter().map(|c| c.row.chord_max_mm));
    let (tip_lo, tip_hi) = range_of(t.iter().map(|c| c.row.tip_deflection_max_mm));
    let _ = writeln!(
        s,
        "| the chord reduction happens twice per forcing period (its spectrum peaks at 2f) | §2.1, Figs. 3–5 \
         | chord's strongest line at 2f in {} of {n} cases ({}); largest chord reduction {}–{} mm, largest tip deflection from the holder's line {}–{} mm | {} |",
        doubled.len(),
        chord_labels.join("; "),
        num(chord_lo, 4),
        num(chord_hi, 4),
        num(tip_lo, 2),
        num(tip_hi, 2),
        match doubled.len() {
            0 => "not reproduced",
            k if k == n => "agrees",
            _ => "partly",
        }
    );
}

/// 5 Hz, 12 mm: periodic and the best synchronised.
fn periodic_at_5hz(s: &mut String, c: &CaseResult) {
    let r = c.row;
    let regular = regime(r.k_extrema) == Regime::Regular && r.period > 0;
    let _ = writeln!(
        s,
        "| 5 Hz, 12 mm: periodic, a single frequency; K = 0.13, R = 0.88, the best synchronisation | \
         §2.1–2.3, Fig. 5b, Table 2 | K = {} (extrema), {} (strobe); period {}; R = {} (paper conv.); {} \
         hops | {} |",
        num(r.k_extrema, 2),
        num(r.k_strobe, 2),
        if r.period > 0 {
            format!("{} T", r.period)
        } else {
            "none found".into()
        },
        num(r.r_paper_convention, 2),
        r.hops,
        if regular && r.sync_ours == SyncClass::Synchronised {
            "agrees"
        } else if regular {
            "regular, but not synchronised"
        } else {
            "not reproduced: chaotic here"
        }
    );
}

/// 10 Hz, 12 mm: K = 0, regular.
fn regular_at_10hz(s: &mut String, c: &CaseResult) {
    let r = c.row;
    let _ = writeln!(
        s,
        "| 10 Hz, 12 mm: K = 0.00, regular | Table 2, Fig. 3b | K = {} (extrema), {} (strobe); {} hops | {} |",
        num(r.k_extrema, 2),
        num(r.k_strobe, 2),
        r.hops,
        if regime(r.k_extrema) == Regime::Regular {
            "agrees"
        } else {
            "not reproduced: chaotic here"
        }
    );
}

/// The cases the paper does not call synchronised: R near the random value 2/π.
fn random_phases(s: &mut String, t: &[CaseResult]) {
    let random_paper: Vec<&CaseResult> = t
        .iter()
        .filter(|c| c.row.sync_paper != SyncClass::Synchronised)
        .collect();
    let near = random_paper
        .iter()
        .filter(|c| (c.row.r_paper_convention - FRAC_2_PI).abs() <= R_RANDOM_BAND)
        .count();
    let _ = writeln!(
        s,
        "| the other solutions have R close to the random value 0.64 | §2.3, Table 2 | R = {} | {} |",
        random_paper
            .iter()
            .map(|c| format!("{} ({})", num(c.row.r_paper_convention, 3), short(c)))
            .collect::<Vec<_>>()
            .join(", "),
        if near == random_paper.len() {
            "agrees".to_string()
        } else {
            format!(
                "{near} of {} within ±{R_RANDOM_BAND} of 2/π",
                random_paper.len()
            )
        }
    );
}

/// Experiment 8 Hz, 9 mm: frequency division by three.
fn experiment_third_subharmonic(s: &mut String, c: &CaseResult) {
    let a = c.analysis;
    let ok = line_seen(a, a.prominence_third, (1, 3));
    let _ = writeln!(
        s,
        "| experiment 8 Hz, 9 mm: frequency division from 8 Hz to about 2.6 Hz (one third) | §3.2, \
         Figs. 10a, 11a | prominence at f/3 = {}; strongest line {} Hz ({}) | {} |",
        num(a.prominence_third, 1),
        num(c.row.alpha_peak_hz, 2),
        c.row.alpha_peak_label,
        agrees_or_not(ok)
    );
}

/// The other experiments: a broad band in place of clear spectral lines.
fn experiment_bands(s: &mut String, experiments: &[CaseResult]) {
    let band: Vec<&CaseResult> = experiments
        .iter()
        .filter(|c| c.row.frequency_hz != 8.0)
        .collect();
    if band.is_empty() {
        return;
    }
    let broad = band
        .iter()
        .filter(|c| c.analysis.prominence_peak.is_nan() || c.analysis.prominence_peak < LINE_CLEAR)
        .count();
    let _ = writeln!(
        s,
        "| experiments 10 Hz/12 mm and 5 Hz/25 mm: a band response in place of frequency peaks | §3.2, \
         Figs. 11b, c | prominence of the strongest line: {} | {} |",
        band.iter()
            .map(|c| format!("{} ({})", num(c.analysis.prominence_peak, 1), short(c)))
            .collect::<Vec<_>>()
            .join(", "),
        if broad == band.len() {
            "agrees"
        } else if broad == 0 {
            "not reproduced: clear lines here"
        } else {
            "partly"
        }
    );
}
