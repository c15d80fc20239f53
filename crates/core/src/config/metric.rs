//! The per-instance quantities a map can show ([`Metric`]): their names in scenes and file
//! names, and what each is formed from.

use serde::Serialize;

/// A per-instance quantity a map can show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub enum Metric {
    /// 0–1 test K on the stroboscopic samples.
    #[serde(rename = "K")]
    K,
    /// Phase-synchronisation index R of holder angle vs cart position.
    #[serde(rename = "R")]
    R,
    /// Period of the stroboscopic section (0 = none found).
    #[serde(rename = "period")]
    Period,
    /// Hops between the wells after the transient.
    #[serde(rename = "hops")]
    Hops,
    /// Bumper contact onsets per second after the transient.
    #[serde(rename = "impacts_per_s")]
    ImpactsPerS,
    /// Smallest and largest holder angle after the transient.
    #[serde(rename = "alpha_range")]
    AlphaRange,
    /// Mean harvested power v²/R_L after the transient (needs `piezo.enabled`).
    #[serde(rename = "power")]
    Power,
    /// Dominant line of α's spectrum as a multiple of the forcing frequency (1/3: a third).
    #[serde(rename = "line")]
    Line,
    /// Largest Lyapunov exponent λ1 (1/s) with its standard error, from a twin trajectory.
    #[serde(rename = "lyapunov")]
    Lyapunov,
    /// One verdict per cell (periodic, regular, chaotic, undecided, failed) from λ1, the
    /// period and K, which it brings in.
    #[serde(rename = "regime")]
    Regime,
}

impl Metric {
    /// Every metric, in output order.
    pub const ALL: [Metric; 10] = [
        Metric::K,
        Metric::R,
        Metric::Period,
        Metric::Hops,
        Metric::ImpactsPerS,
        Metric::AlphaRange,
        Metric::Power,
        Metric::Line,
        Metric::Lyapunov,
        Metric::Regime,
    ];

    /// The metrics this one is formed from (the verdict needs K, the period and λ1).
    pub fn needs(self) -> &'static [Metric] {
        match self {
            Metric::Regime => &[Metric::K, Metric::Period, Metric::Lyapunov],
            _ => &[],
        }
    }

    /// The name used in scenes and file names.
    pub fn name(self) -> &'static str {
        match self {
            Metric::K => "K",
            Metric::R => "R",
            Metric::Period => "period",
            Metric::Hops => "hops",
            Metric::ImpactsPerS => "impacts_per_s",
            Metric::AlphaRange => "alpha_range",
            Metric::Power => "power",
            Metric::Line => "line",
            Metric::Lyapunov => "lyapunov",
            Metric::Regime => "regime",
        }
    }

    /// The metric of a name (`None` for an unknown one).
    pub(super) fn parse(s: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.name() == s)
    }
}
