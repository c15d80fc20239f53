//! What a cell's nudged copies say (`docs/analysis.md`, §16): the eventual verdict of each
//! copy, the cell's verdict after them, the share of copies that disagree with it (the
//! final-state sensitivity of Grebogi, McDonald, Ott and Yorke, 1983) and the chaotic
//! transient's mean lifetime from the copies' escape times.
//!
//! ```text
//! eventual:     a copy's verdict at its end: (class, period) for a periodic one, the class
//!               otherwise
//! escape:       a copy that ends periodic; its escape time t_e = t_end − span/f, at least 0,
//!               where span = window + p forcing periods (the early stop's confirmation),
//!               + 8·max(p, 2) when the map measures λ1 (the stop waits for λ1): an upper
//!               bound, the confirmation's slack above the span included
//! lifetime:     escapes taken as exponential with rate κ, the copies that did not escape
//!               censored at their length L:  κ̂ = n_e / (Σ_escapes t_e + Σ_others L),
//!               τ = 1/κ̂ with standard error τ/√n_e; none where n_e = 0
//! verdict:      a cell that is not periodic takes the orbit its escapes land on when they
//!               all land on one (the chaos was a transient: the copies still chaotic have
//!               not escaped yet); any cell takes a verdict more than half of the M copies
//!               share (an orbit, or for an undecided cell any decided verdict); otherwise
//!               the cell keeps its own
//! sensitivity:  s = (copies whose decided eventual verdict differs from the cell's verdict)
//!               / M; an undecided copy says nothing of the end state and does not count; a
//!               cell that stays undecided is compared with its copies' most common decided
//!               verdict
//! ```

use crate::schema::Regime;

/// A verdict at the end of a run: the class, and the period of a periodic one (0 otherwise).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Eventual {
    /// The class.
    pub regime: Regime,
    /// The period in forcing periods (periodic only; 0 otherwise).
    pub period: u32,
}

impl Eventual {
    /// The eventual verdict of a result with `regime` and `period` (forcing periods; NaN or
    /// 0 for none): a periodic verdict without a usable period counts as its class alone.
    pub fn of(regime: Regime, period: f64) -> Eventual {
        let p = if regime == Regime::Periodic && period.is_finite() && period >= 1.0 {
            period as u32
        } else {
            0
        };
        Eventual { regime, period: p }
    }

    /// Whether it is a verdict (not undecided): a failed run counts, it left the model.
    pub fn decided(&self) -> bool {
        self.regime != Regime::Undecided
    }

    /// Whether it is a periodic orbit of a known period (an escape from chaos).
    pub fn periodic(&self) -> bool {
        self.regime == Regime::Periodic && self.period >= 1
    }
}

/// One copy's outcome: its eventual verdict and how long it ran (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CopyOutcome {
    /// Its verdict at its end.
    pub eventual: Eventual,
    /// Seconds it ran (its early stop included).
    pub ran_s: f64,
    /// Seconds its early stop needs to confirm its orbit (the span above), 0 if not periodic.
    pub confirm_s: f64,
}

impl CopyOutcome {
    /// The escape time (s): `None` for a copy that did not escape.
    pub fn escape_s(&self) -> Option<f64> {
        self.eventual
            .periodic()
            .then(|| (self.ran_s - self.confirm_s).max(0.0))
    }
}

/// The early stop's least confirmation span of an orbit of period `p` (forcing periods):
/// `window + p`, plus λ1's `8·max(p, 2)` where the map measures it.
pub fn confirm_periods(window: u32, p: u32, lyapunov: bool) -> u32 {
    let twin = if lyapunov {
        crate::engine::early::early_twin_window(p)
    } else {
        0
    };
    window + p + twin
}

/// The mean lifetime of the chaotic transient and its standard error (s), from the copies'
/// escapes (`None` without an escape).
pub fn lifetime(copies: &[CopyOutcome]) -> Option<(f64, f64)> {
    let escapes: Vec<f64> = copies.iter().filter_map(CopyOutcome::escape_s).collect();
    if escapes.is_empty() {
        return None;
    }
    let exposure: f64 = copies.iter().map(|c| c.escape_s().unwrap_or(c.ran_s)).sum();
    let n = escapes.len() as f64;
    let tau = exposure / n;
    Some((tau, tau / n.sqrt()))
}

/// What a cell's copies decide.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// The copy whose result the cell takes (its orbit, shared by more than half of the
    /// copies), or `None`: the cell keeps its own.
    pub take: Option<usize>,
    /// The cell's verdict after the copies.
    pub verdict: Eventual,
    /// The share of copies whose eventual verdict differs from it.
    pub sensitivity: f64,
}

/// The decision of a cell with eventual verdict `own` and its `copies` (at least one).
pub fn decide(own: Eventual, copies: &[CopyOutcome]) -> Decision {
    let m = copies.len();
    let count = |v: Eventual| copies.iter().filter(|c| c.eventual == v).count();
    // A majority: an orbit for a decided cell, any decided verdict for an undecided one.
    let takes = |v: &Eventual| match own.regime {
        Regime::Undecided => v.decided(),
        _ => v.periodic(),
    };
    let majority = copies
        .iter()
        .map(|c| c.eventual)
        .find(|v| takes(v) && *v != own && 2 * count(*v) > m);
    let taken = majority.or_else(|| one_escape_orbit(own, copies));
    let take = taken.and_then(|v| copies.iter().position(|c| c.eventual == v));
    let verdict = taken.unwrap_or(own);
    let against = match verdict.regime {
        Regime::Undecided => most_common_decided(copies),
        _ => Some(verdict),
    };
    let differ = against.map_or(0, |v| {
        let other = |c: &&CopyOutcome| c.eventual.decided() && c.eventual != v;
        copies.iter().filter(other).count()
    });
    Decision {
        take,
        verdict,
        sensitivity: differ as f64 / m as f64,
    }
}

/// The orbit every escape of a cell that is not periodic lands on, if they all land on one
/// (the other copies have not escaped yet).
fn one_escape_orbit(own: Eventual, copies: &[CopyOutcome]) -> Option<Eventual> {
    if own.regime == Regime::Periodic {
        return None;
    }
    let mut escapes = copies.iter().map(|c| c.eventual).filter(Eventual::periodic);
    let first = escapes.next()?;
    escapes.all(|v| v == first).then_some(first)
}

/// The decided eventual verdict most copies share (the first of equals), if any.
fn most_common_decided(copies: &[CopyOutcome]) -> Option<Eventual> {
    let count = |v: Eventual| copies.iter().filter(|c| c.eventual == v).count();
    let mut best: Option<(Eventual, usize)> = None;
    for v in copies.iter().map(|c| c.eventual).filter(Eventual::decided) {
        if best.is_none_or(|(_, n)| count(v) > n) {
            best = Some((v, count(v)));
        }
    }
    best.map(|(v, _)| v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn copy(regime: Regime, period: f64, ran_s: f64) -> CopyOutcome {
        CopyOutcome {
            eventual: Eventual::of(regime, period),
            ran_s,
            confirm_s: 2.0,
        }
    }

    #[test]
    fn the_lifetime_is_the_exposure_per_escape() {
        use Regime::{Chaotic as C, Periodic as P};
        // Escapes at 8 − 2 = 6 s and 4 − 2 = 2 s, two censored at 30 s: τ = 68/2.
        let cs = [
            copy(P, 3.0, 8.0),
            copy(P, 3.0, 4.0),
            copy(C, 0.0, 30.0),
            copy(C, 0.0, 30.0),
        ];
        let (tau, se) = lifetime(&cs).unwrap();
        assert_eq!(tau, 34.0);
        assert!((se - 34.0 / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(copy(P, 1.0, 1.0).escape_s(), Some(0.0));
        assert!(lifetime(&cs[2..]).is_none());
    }

    #[test]
    fn a_majority_on_one_orbit_decides_and_the_rest_is_the_sensitivity() {
        use Regime::{Chaotic as C, Periodic as P};
        let chaos = Eventual::of(C, 0.0);
        // 3 of 4 on period 3: the cell takes the first of them; one copy disagrees.
        let cs = [
            copy(C, 0.0, 30.0),
            copy(P, 3.0, 9.0),
            copy(P, 3.0, 5.0),
            copy(P, 3.0, 7.0),
        ];
        let d = decide(chaos, &cs);
        assert_eq!(d.take, Some(1));
        assert_eq!(d.verdict, Eventual::of(P, 3.0));
        assert_eq!(d.sensitivity, 0.25);
        // One escape, the other copy still chaotic: the escape's orbit, half disagree.
        let d = decide(chaos, &cs[..2]);
        assert_eq!(
            (d.take, d.verdict, d.sensitivity),
            (Some(1), Eventual::of(P, 3.0), 0.5)
        );
        // Escapes to two orbits, neither a majority: the cell keeps its own.
        let split = [copy(P, 3.0, 9.0), copy(P, 5.0, 9.0), copy(C, 0.0, 30.0)];
        let d = decide(chaos, &split);
        assert_eq!((d.take, d.verdict, d.sensitivity), (None, chaos, 2.0 / 3.0));
        // A periodic cell leaves its orbit only for a majority.
        let p1 = Eventual::of(P, 1.0);
        let d = decide(
            p1,
            &[copy(P, 2.0, 9.0), copy(P, 1.0, 3.0), copy(P, 1.0, 3.0)],
        );
        assert_eq!((d.take, d.verdict, d.sensitivity), (None, p1, 1.0 / 3.0));
        // Copies that agree with a periodic cell: nothing to take, nothing sensitive.
        let own = Eventual::of(P, 2.0);
        let d = decide(own, &[copy(P, 2.0, 3.0), copy(P, 2.0, 3.0)]);
        assert_eq!((d.take, d.verdict, d.sensitivity), (None, own, 0.0));
        // A periodic verdict without a period is not an escape.
        assert!(!Eventual::of(P, f64::NAN).periodic());
        // An undecided copy does not disagree; an undecided cell takes a decided majority.
        let u = Regime::Undecided;
        let d = decide(chaos, &[copy(u, 0.0, 30.0), copy(C, 0.0, 30.0)]);
        assert_eq!((d.take, d.sensitivity), (None, 0.0));
        let undecided = Eventual::of(u, 0.0);
        let d = decide(
            undecided,
            &[copy(C, 0.0, 30.0), copy(C, 0.0, 30.0), copy(P, 3.0, 9.0)],
        );
        assert_eq!(
            (d.take, d.verdict, d.sensitivity),
            (Some(0), chaos, 1.0 / 3.0)
        );
        // One that stays undecided: its copies against their most common decided verdict.
        let cs = [
            copy(u, 0.0, 30.0),
            copy(P, 3.0, 9.0),
            copy(P, 5.0, 9.0),
            copy(C, 0.0, 30.0),
        ];
        let d = decide(undecided, &cs);
        assert_eq!((d.take, d.verdict, d.sensitivity), (None, undecided, 0.5));
    }

    #[test]
    fn the_confirmation_span_adds_lambda1s_window_when_it_is_measured() {
        assert_eq!(confirm_periods(16, 3, false), 19);
        assert_eq!(confirm_periods(16, 3, true), 19 + 24);
        assert_eq!(confirm_periods(16, 1, true), 17 + 16);
    }
}
