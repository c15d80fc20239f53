//! The result schema: every number a map reports per cell, defined once.
//!
//! [`FIELDS`] is the table. Each row gives a result's name (the `.npy` stem, the `grid.csv`
//! and shard column, the Python variable), unit, storage type, description, the
//! [`Metric`] that brings it, the [`Stage`] that fills it, the values it may take ([`Range`])
//! and the GPU accumulator word it is read from ([`GpuSlot`]). Everything that lists results
//! is made from it:
//!
//! | made from the table | where |
//! |---|---|
//! | the result checks ([`InstanceResult::check`]) | `reduce/mod.rs` |
//! | the WGSL `Accum` struct's result words, and [`crate::engine::gpu::layout::GpuAccum`]'s | `engine/gpu/kernels.rs`, `layout.rs` |
//! | the GPU's read-back | `engine/gpu/mod.rs` |
//! | what the engines record for the metrics asked ([`Metric::source`]) | `engine/plan.rs` |
//! | the map's arrays, `grid.csv`, `map.json`'s units and descriptions | `pendulum-atlas-map`, `output/map.rs` |
//! | the shard columns, read back by name | `pendulum-atlas-map`, `shard/files.rs` |
//! | the explorer's metric list | `pendulum-atlas-explore` |
//! | the Python dataset's variables and their attributes | `python/` |
//!
//! A new metric is a [`Metric`] variant, an [`InstanceResult`] field and a row here, its
//! reduction (`reduce/`), and its shader code (`shaders/`): `docs/architecture.md` works one
//! through.

use crate::model::Status;
use serde::Serialize;

/// A per-instance quantity a map can be asked for (`map.metrics`); each brings one or more
/// [`FIELDS`].
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

/// What an engine records for a metric while it integrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Running accumulators after the transient (`reduce::Tally`).
    Tally,
    /// The stroboscopic samples of α.
    Strobe,
    /// The uniform α series of R, with the cart's reference.
    RSeries,
    /// λ1's twin trajectory.
    Twin,
    /// Nothing of its own: it is formed from other metrics ([`Metric::needs`]).
    Others,
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

    /// What an engine records to form it.
    pub fn source(self) -> Source {
        match self {
            Metric::K | Metric::Period => Source::Strobe,
            Metric::R | Metric::Line => Source::RSeries,
            Metric::Hops | Metric::ImpactsPerS | Metric::AlphaRange | Metric::Power => {
                Source::Tally
            }
            Metric::Lyapunov => Source::Twin,
            Metric::Regime => Source::Others,
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

    /// The label of its picture and of the explorer's list (with its unit).
    pub fn label(self) -> &'static str {
        match self {
            Metric::K => "0–1 test K (0 regular, 1 chaotic)",
            Metric::R => "phase synchronisation R",
            Metric::Period => "period (forcing periods)",
            Metric::Hops => "hops between wells",
            Metric::ImpactsPerS => "impacts per second (1/s)",
            Metric::AlphaRange => "holder angle range max−min (rad)",
            Metric::Power => "mean harvested power (W)",
            Metric::Line => "dominant line of α / forcing frequency",
            Metric::Lyapunov => "largest Lyapunov exponent λ1 (1/s)",
            Metric::Regime => "regime",
        }
    }

    /// The metric of a name (`None` for an unknown one).
    pub fn parse(s: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.name() == s)
    }

    /// Whether any of `metrics` is recorded from `source`.
    pub(crate) fn any_from(metrics: &[Metric], source: Source) -> bool {
        metrics.iter().any(|m| m.source() == source)
    }
}

/// One cell's verdict, with the fixed codes of `regime.npy` (the rule that forms it:
/// `reduce::regime`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Regime {
    /// The run failed (diverged, non-finite, escaped): code −1.
    Failed,
    /// The indicators disagree beyond their uncertainty, or λ1 is unresolved: code 0.
    Undecided,
    /// A stable orbit of a period ≤ `period_max` forcing periods: code 1.
    Periodic,
    /// Regular without a period up to the detector's limit (quasi-periodic, or a longer
    /// period): code 2.
    Regular,
    /// Chaotic: λ1 > 0 and K high: code 3.
    Chaotic,
}

impl Regime {
    /// Every regime, in code order.
    pub const ALL: [Regime; 5] = [
        Regime::Failed,
        Regime::Undecided,
        Regime::Periodic,
        Regime::Regular,
        Regime::Chaotic,
    ];

    /// The code of `regime.npy` (and of the GPU kernel).
    pub const fn code(self) -> i8 {
        match self {
            Regime::Failed => -1,
            Regime::Undecided => 0,
            Regime::Periodic => 1,
            Regime::Regular => 2,
            Regime::Chaotic => 3,
        }
    }

    /// The regime of a code (`None` for an unknown one).
    pub fn from_code(code: i64) -> Option<Regime> {
        Regime::ALL
            .into_iter()
            .find(|r| i64::from(r.code()) == code)
    }

    /// The name of CSV and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Regime::Failed => "failed",
            Regime::Undecided => "undecided",
            Regime::Periodic => "periodic",
            Regime::Regular => "regular",
            Regime::Chaotic => "chaotic",
        }
    }

    /// The name of the WGSL constant that holds its code.
    pub fn wgsl_name(self) -> &'static str {
        match self {
            Regime::Failed => "REGIME_FAILED",
            Regime::Undecided => "REGIME_UNDECIDED",
            Regime::Periodic => "REGIME_PERIODIC",
            Regime::Regular => "REGIME_REGULAR",
            Regime::Chaotic => "REGIME_CHAOTIC",
        }
    }
}

impl std::fmt::Display for Regime {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The numbers a map shows for one grid point, one field per row of [`FIELDS`]. Metrics not
/// requested, and every metric of an instance whose status is not `ok`, are NaN. Serialised
/// by the table: each row's name, codes by their names.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstanceResult {
    /// 0–1 test K.
    pub k: f64,
    /// Phase-synchronisation index R.
    pub r: f64,
    /// Period of the stroboscopic section in forcing periods (0 = none ≤ period_max).
    pub period: f64,
    /// Hops between the wells after the transient.
    pub hops: f64,
    /// Bumper contact onsets per second after the transient.
    pub impacts_per_s: f64,
    /// Smallest holder angle after the transient (rad).
    pub alpha_min_rad: f64,
    /// Largest holder angle after the transient (rad).
    pub alpha_max_rad: f64,
    /// Mean harvested power v²/R_L after the transient (W).
    pub power_w: f64,
    /// Dominant line of α (the R series) over the forcing frequency: 1/3 for a third.
    pub line: f64,
    /// Largest Lyapunov exponent λ1 (1/s).
    pub lyapunov_per_s: f64,
    /// Standard error of λ1 (1/s).
    pub lyapunov_se_per_s: f64,
    /// The cell's verdict ([`Regime::Undecided`] when not asked for).
    pub regime: Regime,
    /// Confidence of the verdict (NaN when undecided, failed or not asked for): the
    /// probability that λ1 lies on the verdict's side of its class boundary.
    pub regime_confidence: f64,
    /// The chance that the verdict is the one a converged run gives, from the verdict and its
    /// grid neighbours' (the map's confidence stage, `pendulum_atlas_map::map::confidence`,
    /// calibrated in `docs/bench/VERDICT.md`); NaN outside a map, in a shard before its merge,
    /// and where the verdict is undecided, failed or not asked for.
    pub verdict_confidence: f64,
    /// Whether the map's settling stage ran the cell on past the map's length
    /// (`map.settle_max_s`, `pendulum_atlas_map::map::settle`).
    pub ran_on: bool,
    /// How the integration ended.
    pub status: Status,
    /// Steps actually integrated (fewer than planned when the instance failed or stopped
    /// early on a confirmed periodic orbit).
    pub steps: u64,
}

impl InstanceResult {
    /// A result with every metric NaN (not yet reduced), of `status` after `steps` steps.
    pub fn unset(status: Status, steps: u64) -> InstanceResult {
        let nan = f64::NAN;
        InstanceResult {
            k: nan,
            r: nan,
            period: nan,
            hops: nan,
            impacts_per_s: nan,
            alpha_min_rad: nan,
            alpha_max_rad: nan,
            power_w: nan,
            line: nan,
            lyapunov_per_s: nan,
            lyapunov_se_per_s: nan,
            regime: if status.is_ok() {
                Regime::Undecided
            } else {
                Regime::Failed
            },
            regime_confidence: nan,
            verdict_confidence: nan,
            ran_on: false,
            status,
            steps,
        }
    }

    /// The value shown on the map of `m`: its first field's (α range: max − min; the
    /// regime: its code).
    pub fn metric(&self, m: Metric) -> f64 {
        match m {
            Metric::AlphaRange => self.alpha_max_rad - self.alpha_min_rad,
            Metric::Regime => f64::from(self.regime.code()),
            _ => FIELDS
                .iter()
                .find(|f| f.metric == Some(m))
                .map_or(f64::NAN, |f| (f.get)(self)),
        }
    }
}

impl Serialize for InstanceResult {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(FIELDS.len()))?;
        for f in &FIELDS {
            match f.dtype {
                Dtype::F64 => m.serialize_entry(f.name, &(f.get)(self))?,
                Dtype::U64 => m.serialize_entry(f.name, &self.steps)?,
                Dtype::I8 | Dtype::U8 => m.serialize_entry(f.name, &f.code_name(self))?,
            }
        }
        m.end()
    }
}

/// How a result is stored (the `.npy` dtype; shards hold every column as f64).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    /// A value (`float64`; NaN where not formed).
    F64,
    /// A signed code (`int8`), written by name in `grid.csv`.
    I8,
    /// An unsigned code (`uint8`), written by name in `grid.csv`.
    U8,
    /// A count (`uint64`).
    U64,
}

/// Which stage fills a result (`reduce/`'s stages, and the engine's own).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// The engine: how the integration ended and how far it went.
    Engine,
    /// The running accumulators after the transient (`reduce::Tally::result`).
    Tally,
    /// The recorded series (`reduce::reduce_series`; on the GPU, its reduction kernels).
    Series,
    /// λ1 from the twin's growths (`reduce::lyapunov`).
    Lyapunov,
    /// The verdict (`reduce::regime`).
    Verdict,
    /// The map's confidence stage, from the grid's neighbours (`pendulum-atlas-map`).
    Confidence,
    /// The map's settling stage, which runs the cells that are not firm on
    /// (`pendulum-atlas-map`).
    Settle,
}

impl Stage {
    /// Whether the GPU kernels leave this stage's value itself in the result's slot (the
    /// tally's slots hold accumulators that [`Stage::Tally`] turns into values on the host).
    pub(crate) fn gpu_final(self) -> bool {
        matches!(self, Stage::Series | Stage::Lyapunov)
    }
}

/// The values a result may take ([`InstanceResult::check`]); NaN is always allowed (not
/// formed), except where the result's metric was asked for and the instance ended `ok`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Range {
    /// [−1, 1].
    Signed1,
    /// [0, 1].
    Unit,
    /// A whole number ≥ 0.
    Whole,
    /// A finite number ≥ 0.
    NonNegative,
    /// |v| ≤ π.
    Angle,
    /// Any finite number.
    Finite,
    /// A code of a closed set, held by its type.
    Code,
}

impl Range {
    /// Whether `v` (not NaN) lies in this range.
    pub(crate) fn admits(self, v: f64) -> bool {
        let whole = v.fract() == 0.0;
        match self {
            Range::Signed1 => (-1.0..=1.0).contains(&v),
            Range::Unit => (0.0..=1.0).contains(&v),
            Range::Whole => v >= 0.0 && whole && v.is_finite(),
            Range::NonNegative => v >= 0.0 && v.is_finite(),
            Range::Angle => v.abs() <= std::f64::consts::PI,
            Range::Finite | Range::Code => v.is_finite(),
        }
    }
}

/// A WGSL scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WgslType {
    /// `f32`.
    F32,
    /// `u32`.
    U32,
    /// `i32`.
    I32,
}

impl WgslType {
    /// The type's WGSL name.
    pub fn name(self) -> &'static str {
        match self {
            WgslType::F32 => "f32",
            WgslType::U32 => "u32",
            WgslType::I32 => "i32",
        }
    }

    /// The value of a word of this type, widened.
    pub fn read(self, bits: u32) -> f64 {
        match self {
            WgslType::F32 => f64::from(f32::from_bits(bits)),
            WgslType::U32 => f64::from(bits),
            WgslType::I32 => f64::from(bits as i32),
        }
    }
}

/// The word of the GPU's `Accum` struct a result is read from, and the value it starts at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpuSlot {
    /// The member's name in WGSL.
    pub member: &'static str,
    /// Its type.
    pub ty: WgslType,
    /// Its value before the first step (a running minimum starts at the largest f32).
    pub initial: f32,
}

/// One result of the table.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    /// File stem, `grid.csv` and shard column, Python variable.
    pub name: &'static str,
    /// Unit ("1": dimensionless; "" for codes).
    pub unit: &'static str,
    /// How it is stored.
    pub dtype: Dtype,
    /// What it is, for `map.json` and the Python variable's `long_name`.
    pub description: &'static str,
    /// The metric that brings it (`None`: every map has it).
    pub metric: Option<Metric>,
    /// The stage that fills it.
    pub stage: Stage,
    /// The values it may take.
    pub range: Range,
    /// A map folder stores it (`.npy`, `grid.csv`); the rest travel in shards only.
    pub in_map: bool,
    /// The GPU accumulator word it is read from (`None`: formed on the host).
    pub gpu: Option<GpuSlot>,
    /// Its value in a result (codes and counts as numbers).
    pub get: fn(&InstanceResult) -> f64,
    /// Set it from a value read back (a code or count must be one of its type's).
    pub set: fn(&mut InstanceResult, f64) -> Result<(), String>,
}

impl Field {
    /// The value's name where it is a code (`regime`, `status`), else its number as text.
    pub fn code_name(&self, r: &InstanceResult) -> String {
        match self.name {
            "regime" => r.regime.name().to_string(),
            "status" => r.status.as_str().to_string(),
            _ => crate::text::num((self.get)(r)),
        }
    }

    /// Whether a map with `metrics` forms this result.
    pub fn formed_for(&self, metrics: &[Metric]) -> bool {
        self.metric.is_none_or(|m| metrics.contains(&m))
    }
}

/// A whole number in `[lo, hi]` read back from an f64 column.
fn whole_in(v: f64, lo: f64, hi: f64) -> Result<f64, String> {
    if v.is_finite() && v.fract() == 0.0 && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "is {}, not a whole number from {} to {}",
            crate::text::num(v),
            crate::text::num(lo),
            crate::text::num(hi)
        ))
    }
}

/// The largest count an f64 holds exactly (2^53).
const EXACT_MAX: f64 = 9_007_199_254_740_992.0;

const NAN_START: f32 = f32::NAN;

/// A value field: (name, unit, description, metric, stage, range, GPU slot, field access).
macro_rules! value_field {
    ($name:literal, $unit:literal, $desc:literal, $metric:expr, $stage:expr, $range:expr,
     $gpu:expr, $f:ident) => {
        Field {
            name: $name,
            unit: $unit,
            dtype: Dtype::F64,
            description: $desc,
            metric: Some($metric),
            stage: $stage,
            range: $range,
            in_map: true,
            gpu: $gpu,
            get: |r| r.$f,
            set: |r, v| {
                r.$f = v;
                Ok(())
            },
        }
    };
}

const fn slot(member: &'static str, ty: WgslType, initial: f32) -> Option<GpuSlot> {
    Some(GpuSlot {
        member,
        ty,
        initial,
    })
}

/// Every per-cell result, in output order (`grid.csv`'s columns after the axes, the map's
/// arrays, the shard's columns after the grid index).
pub const FIELDS: [Field; 17] = [
    value_field!(
        "K",
        "1",
        "0-1 test for chaos K on the stroboscopic samples (0 regular, 1 chaotic)",
        Metric::K,
        Stage::Series,
        Range::Signed1,
        slot("k", WgslType::F32, NAN_START),
        k
    ),
    value_field!(
        "R",
        "1",
        "phase-synchronisation index R of the holder angle against the cart",
        Metric::R,
        Stage::Series,
        Range::Unit,
        slot("r", WgslType::F32, NAN_START),
        r
    ),
    value_field!(
        "period",
        "forcing periods",
        "period of the stroboscopic section (0: none up to map.period_max)",
        Metric::Period,
        Stage::Series,
        Range::Whole,
        slot("period", WgslType::U32, 0.0),
        period
    ),
    value_field!(
        "hops",
        "1",
        "hops between the wells after the transient",
        Metric::Hops,
        Stage::Tally,
        Range::Whole,
        slot("hops", WgslType::U32, 0.0),
        hops
    ),
    value_field!(
        "impacts_per_s",
        "1/s",
        "bumper contact onsets per second after the transient",
        Metric::ImpactsPerS,
        Stage::Tally,
        Range::NonNegative,
        slot("impacts", WgslType::U32, 0.0),
        impacts_per_s
    ),
    value_field!(
        "alpha_min_rad",
        "rad",
        "smallest holder angle after the transient",
        Metric::AlphaRange,
        Stage::Tally,
        Range::Angle,
        slot("alpha_min", WgslType::F32, f32::MAX),
        alpha_min_rad
    ),
    value_field!(
        "alpha_max_rad",
        "rad",
        "largest holder angle after the transient",
        Metric::AlphaRange,
        Stage::Tally,
        Range::Angle,
        slot("alpha_max", WgslType::F32, -f32::MAX),
        alpha_max_rad
    ),
    value_field!(
        "power_w",
        "W",
        "mean harvested power v^2/R_L after the transient",
        Metric::Power,
        Stage::Tally,
        Range::NonNegative,
        slot("power_sum", WgslType::F32, 0.0),
        power_w
    ),
    value_field!(
        "line_ratio",
        "1",
        "dominant line of the holder angle's spectrum over the forcing frequency (1/3: a third)",
        Metric::Line,
        Stage::Series,
        Range::NonNegative,
        slot("line", WgslType::F32, NAN_START),
        line
    ),
    value_field!(
        "lyapunov",
        "1/s",
        "largest Lyapunov exponent lambda1 from a twin trajectory",
        Metric::Lyapunov,
        Stage::Lyapunov,
        Range::Finite,
        slot("lyap", WgslType::F32, NAN_START),
        lyapunov_per_s
    ),
    value_field!(
        "lyapunov_se",
        "1/s",
        "standard error of lambda1",
        Metric::Lyapunov,
        Stage::Lyapunov,
        Range::NonNegative,
        slot("lyap_se", WgslType::F32, NAN_START),
        lyapunov_se_per_s
    ),
    value_field!(
        "regime_confidence",
        "1",
        "probability that lambda1 lies on the verdict's side of its class boundary",
        Metric::Regime,
        Stage::Verdict,
        Range::Unit,
        None,
        regime_confidence
    ),
    value_field!(
        "verdict_confidence",
        "1",
        "chance that the verdict is the one a converged run gives (the map's confidence stage)",
        Metric::Regime,
        Stage::Confidence,
        Range::Unit,
        None,
        verdict_confidence
    ),
    Field {
        name: "regime",
        unit: "",
        dtype: Dtype::I8,
        description: "the cell's verdict: -1 failed, 0 undecided, 1 periodic, 2 regular, 3 chaotic",
        metric: Some(Metric::Regime),
        stage: Stage::Verdict,
        range: Range::Code,
        in_map: true,
        gpu: slot("regime", WgslType::I32, 0.0),
        get: |r| f64::from(r.regime.code()),
        set: |r, v| {
            let c = whole_in(v, -128.0, 127.0)?;
            r.regime = Regime::from_code(c as i64)
                .ok_or_else(|| format!("is {}, an unknown regime code", crate::text::num(v)))?;
            Ok(())
        },
    },
    Field {
        name: "ran_on",
        unit: "",
        dtype: Dtype::U8,
        description: "1 where the settling stage ran the cell on past the map's length (map.settle_max_s), else 0",
        metric: Some(Metric::Regime),
        stage: Stage::Settle,
        range: Range::Code,
        in_map: true,
        gpu: None,
        get: |r| f64::from(u8::from(r.ran_on)),
        set: |r, v| {
            r.ran_on = whole_in(v, 0.0, 1.0)? == 1.0;
            Ok(())
        },
    },
    Field {
        name: "status",
        unit: "",
        dtype: Dtype::U8,
        description: "how the integration ended: 0 ok, 1 diverged, 2 non-finite, 3 escaped",
        metric: None,
        stage: Stage::Engine,
        range: Range::Code,
        in_map: true,
        gpu: slot("status", WgslType::U32, 0.0),
        get: |r| f64::from(r.status.code()),
        set: |r, v| {
            let c = whole_in(v, 0.0, 255.0)?;
            r.status = Status::from_code(c as u32)
                .ok_or_else(|| format!("is {}, an unknown status code", crate::text::num(v)))?;
            Ok(())
        },
    },
    Field {
        name: "steps",
        unit: "base steps",
        dtype: Dtype::U64,
        description: "base steps integrated (fewer than planned where the run failed or stopped early)",
        metric: None,
        stage: Stage::Engine,
        range: Range::Whole,
        in_map: false,
        gpu: slot("step", WgslType::U32, 0.0),
        get: |r| r.steps as f64,
        set: |r, v| {
            r.steps = whole_in(v, 0.0, EXACT_MAX)? as u64;
            Ok(())
        },
    },
];

/// The row of `name` (`None` for an unknown one).
pub fn field(name: &str) -> Option<&'static Field> {
    FIELDS.iter().find(|f| f.name == name)
}

/// The rows with a GPU accumulator word, in table order: the first words of `Accum`.
pub fn gpu_fields() -> impl Iterator<Item = (&'static Field, GpuSlot)> {
    FIELDS.iter().filter_map(|f| f.gpu.map(|g| (f, g)))
}

/// The number of rows with a GPU accumulator word.
pub const GPU_SLOTS: usize = {
    let mut n = 0;
    let mut i = 0;
    while i < FIELDS.len() {
        if FIELDS[i].gpu.is_some() {
            n += 1;
        }
        i += 1;
    }
    n
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_reads_back_what_it_wrote() {
        let mut r = InstanceResult::unset(Status::Ok, 12);
        r.regime = Regime::Chaotic;
        for (i, f) in FIELDS.iter().enumerate() {
            let mut w = InstanceResult::unset(Status::Diverged, 0);
            let v = match f.dtype {
                Dtype::F64 => 0.25 + i as f64,
                _ => (f.get)(&r),
            };
            (f.set)(&mut w, v).unwrap();
            assert_eq!((f.get)(&w), v, "{}", f.name);
        }
    }

    #[test]
    fn names_are_distinct_and_codes_refuse_what_their_type_lacks() {
        for (i, f) in FIELDS.iter().enumerate() {
            assert!(FIELDS[..i].iter().all(|g| g.name != f.name), "{}", f.name);
        }
        let mut r = InstanceResult::unset(Status::Ok, 0);
        let regime = field("regime").unwrap();
        assert!(
            (regime.set)(&mut r, 9.0)
                .unwrap_err()
                .contains("unknown regime code")
        );
        assert!(
            (regime.set)(&mut r, 0.5)
                .unwrap_err()
                .contains("not a whole number")
        );
        let steps = field("steps").unwrap();
        assert!((steps.set)(&mut r, -3.0).unwrap_err().contains("is -3"));
        assert_eq!(GPU_SLOTS, gpu_fields().count());
    }

    #[test]
    fn every_metric_brings_a_field_or_is_formed_from_others() {
        for m in Metric::ALL {
            let fields = FIELDS.iter().filter(|f| f.metric == Some(m)).count();
            assert!(fields > 0, "{}", m.name());
            assert_eq!(Metric::parse(m.name()), Some(m));
        }
    }
}
