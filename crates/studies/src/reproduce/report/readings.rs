//! "Both readings of Table 1's damping": every stationary case with the library reading (the
//! run above) next to the earlier reading, and how often each agrees with the paper.

use super::ReportInput;
use crate::reproduce::indicators::{Regime, SyncClass};
use crate::reproduce::table::{CaseRow, k_cell, num};
use std::fmt::Write;

/// The side-by-side table and the agreement counts of both readings.
pub(super) fn both_readings(s: &mut String, inp: &ReportInput) {
    if inp.earlier_reading.is_empty() {
        return;
    }
    let library: Vec<&CaseRow> = inp
        .table2
        .iter()
        .chain(&inp.experiments)
        .map(|c| c.row)
        .collect();
    let pairs: Vec<(&CaseRow, &CaseRow)> = library
        .iter()
        .filter_map(|l| {
            inp.earlier_reading
                .iter()
                .find(|e| e.case == l.case)
                .map(|e| (*l, e))
        })
        .collect();
    let _ = writeln!(
        s,
        "## Both readings of Table 1's damping\n\n\
         The run above uses the library reading (joint dampers b = 0.35 N m s/rad per joint at \
         N = 17, ζ1 ≈ 0.054; contact damping on loading only). Every stationary case was run again \
         with the earlier reading (ζ1 = 0.0035; Kelvin–Voigt contact), the same N, step rule and \
         analysis (`earlier_reading.csv`). In each cell: library / earlier.\n\n\
         | case | A (mm) | f (Hz) | K paper | K extrema | K strobe | regime paper | regime (extrema) | R paper | R ours (paper conv.) | sync paper | sync ours | α peak (× f) |\n\
         |---|---:|---:|---:|---|---|---|---|---:|---|---|---|---|"
    );
    for (l, e) in &pairs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} / {} | {} / {} | {} | {} / {} | {} | {} / {} | {} | {} / {} | {} / {} |",
            l.figure,
            num(l.amplitude_mm, 0),
            num(l.frequency_hz, 0),
            num(l.k_paper, 2),
            k_cell(l.k_extrema, l.k_extrema_oversampled),
            k_cell(e.k_extrema, e.k_extrema_oversampled),
            k_cell(l.k_strobe, l.k_strobe_oversampled),
            k_cell(e.k_strobe, e.k_strobe_oversampled),
            if l.k_paper.is_finite() {
                l.regime_paper.to_string()
            } else {
                "–".into()
            },
            l.regime_extrema,
            e.regime_extrema,
            num(l.r_paper, 2),
            num(l.r_paper_convention, 2),
            num(e.r_paper_convention, 2),
            l.sync_paper,
            l.sync_ours,
            e.sync_ours,
            num(l.alpha_peak_ratio, 3),
            num(e.alpha_peak_ratio, 3),
        );
    }
    agreement(s, &pairs);
}

/// Which reading of a pair: 0 the library reading, 1 the earlier one.
fn side<'a>(p: &(&'a CaseRow, &'a CaseRow), which: usize) -> &'a CaseRow {
    if which == 0 { p.0 } else { p.1 }
}

/// Cases of `pairs` whose row on `which` side satisfies `keep`.
fn count(
    pairs: &[(&CaseRow, &CaseRow)],
    which: usize,
    keep: impl Fn(&CaseRow, &CaseRow) -> bool,
) -> usize {
    pairs.iter().filter(|p| keep(side(p, which), p.0)).count()
}

/// How many cases each reading classifies as the paper does.
fn agreement(s: &mut String, pairs: &[(&CaseRow, &CaseRow)]) {
    let with_k: Vec<(&CaseRow, &CaseRow)> = pairs
        .iter()
        .copied()
        .filter(|(l, _)| l.k_paper.is_finite())
        .collect();
    let with_r: Vec<(&CaseRow, &CaseRow)> = pairs
        .iter()
        .copied()
        .filter(|(l, _)| l.r_paper.is_finite())
        .collect();
    let regime = |w| count(&with_k, w, |r, l| r.regime_extrema == l.regime_paper);
    let sync = |w| count(&with_r, w, |r, l| r.sync_ours == l.sync_paper);
    let locked = |w| count(pairs, w, |r, _| r.sync_ours == SyncClass::Synchronised);
    let regular = |w| count(pairs, w, |r, _| r.regime_extrema == Regime::Regular);
    let _ = writeln!(
        s,
        "\nRegime on the extrema as the paper's: **{} of {}** with the library reading, **{} of {}** \
         with the earlier one. Synchronisation class as the paper's: {} of {} and {} of {}. Cases \
         locked to the cart (R ≥ 0.7, paper convention): {} and {} of {}; regular on the extrema: {} \
         and {} of {}.\n",
        regime(0),
        with_k.len(),
        regime(1),
        with_k.len(),
        sync(0),
        with_r.len(),
        sync(1),
        with_r.len(),
        locked(0),
        locked(1),
        pairs.len(),
        regular(0),
        regular(1),
        pairs.len()
    );
}
