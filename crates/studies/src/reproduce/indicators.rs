//! The paper's indicators for each case: K three ways, R in both conventions, spectra and
//! their lines, hops, a twin run's divergence, and the sweep's wavelet windows.

use super::error::ReproduceError;
use super::run::Simulation;
use pendulum_atlas_core::analysis::{
    AnalysisError, K01Method, PhaseConvention, PhaseHistogram, RatioReport, SpectralPeak, Spectrum,
    WaveletOptions, WaveletResult, ZeroOneOptions, ZeroOneResult, amplitude_spectrum,
    detect_period, dominant_peak, hops, lag1_autocorrelation, local_extrema, morlet_cwt,
    phase_histogram, phase_sync, ratio_to_forcing, significance_ar1, stroboscopic_uniform,
    zero_one_test,
};
use pendulum_atlas_core::config::ExcitationKind;
use pendulum_atlas_map::output::Row;
use serde::Serialize;

/// K at or above this is called chaotic, below it regular (the paper calls 0.67 and 0.70
/// chaotic and 0.13 periodic; 0.5 is the midpoint of the test's two limits).
pub const K_CHAOTIC_THRESHOLD: f64 = 0.5;
/// R in the paper's convention at or above this is called synchronised: uniform phases give
/// 2/π ≈ 0.64 there, and the paper calls 0.74 and 0.88 its best synchronisation.
pub const R_PAPER_SYNC_THRESHOLD: f64 = 0.70;
/// |Δα| (rad) above which twin runs count as having separated (about a sixth of the gap
/// between the wells at ±20°).
pub(crate) const TWIN_SEPARATED_RAD: f64 = 0.1;
/// |Δα| (rad) below which twin runs count as having converged onto one motion.
pub(crate) const TWIN_CONVERGED_RAD: f64 = 1e-3;
/// Start-angle change of the twin run (deg): 10⁻⁴ deg ≈ 1.7 µrad.
pub const TWIN_PERTURBATION_DEG: f64 = 1e-4;
/// Sample rate the sweep's wavelet transform works at (Hz): periods from 40 ms up.
pub(crate) const SWEEP_WAVELET_RATE_HZ: f64 = 50.0;
/// Longest period of the sweep's scalograms (s).
pub(crate) const SWEEP_MAX_PERIOD_S: f64 = 8.0;
/// The band of periods the paper names for the sweep's angle response (§3.2: "a number of
/// shorter periodics in the region 0.32–0.64 s").
pub(crate) const SWEEP_PAPER_BAND_S: (f64, f64) = (0.32, 0.64);

/// The regime a K value stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Regime {
    /// K ≥ [`K_CHAOTIC_THRESHOLD`].
    #[serde(rename = "chaotic")]
    Chaotic,
    /// K below it.
    #[serde(rename = "regular")]
    Regular,
    /// No K (the test refused the series).
    #[serde(rename = "n/a")]
    Unknown,
}

impl std::fmt::Display for Regime {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Regime::Chaotic => "chaotic",
            Regime::Regular => "regular",
            Regime::Unknown => "n/a",
        })
    }
}

/// The regime of a K value.
pub fn regime(k: f64) -> Regime {
    if k.is_nan() {
        Regime::Unknown
    } else if k >= K_CHAOTIC_THRESHOLD {
        Regime::Chaotic
    } else {
        Regime::Regular
    }
}

/// Whether an R in the paper's convention counts as synchronised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum SyncClass {
    /// R ≥ [`R_PAPER_SYNC_THRESHOLD`].
    #[serde(rename = "synchronised")]
    Synchronised,
    /// R below it.
    #[serde(rename = "not synchronised")]
    NotSynchronised,
    /// No R.
    #[serde(rename = "n/a")]
    Unknown,
}

impl std::fmt::Display for SyncClass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SyncClass::Synchronised => "synchronised",
            SyncClass::NotSynchronised => "not synchronised",
            SyncClass::Unknown => "n/a",
        })
    }
}

/// The sync class of an R in the paper's convention.
pub fn sync_class(r_paper: f64) -> SyncClass {
    if r_paper.is_nan() {
        SyncClass::Unknown
    } else if r_paper >= R_PAPER_SYNC_THRESHOLD {
        SyncClass::Synchronised
    } else {
        SyncClass::NotSynchronised
    }
}

/// What became of a run and its twin.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum TwinVerdict {
    /// |Δα| grew beyond `TWIN_SEPARATED_RAD`.
    #[serde(rename = "separate")]
    Separate,
    /// |Δα| shrank below `TWIN_CONVERGED_RAD`.
    #[serde(rename = "converge")]
    Converge,
    /// In between.
    #[serde(rename = "stay close")]
    StayClose,
    /// No twin was run.
    #[serde(rename = "n/a")]
    Unknown,
}

impl std::fmt::Display for TwinVerdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TwinVerdict::Separate => "separate",
            TwinVerdict::Converge => "converge",
            TwinVerdict::StayClose => "stay close",
            TwinVerdict::Unknown => "n/a",
        })
    }
}

/// How far apart a run and its twin (start angle changed by [`TWIN_PERTURBATION_DEG`]) end up.
#[derive(Debug, Clone, Serialize)]
pub struct TwinDivergence {
    /// Start-angle change (deg).
    pub perturbation_deg: f64,
    /// Largest |α − α_twin| after the transient (rad).
    pub max_after_transient_rad: f64,
    /// First time |α − α_twin| exceeded `TWIN_SEPARATED_RAD` (s), if it did.
    pub separated_at_s: Option<f64>,
    /// Separate, converge or stay close.
    pub verdict: TwinVerdict,
}

/// Everything computed for a stationary (harmonically forced) case.
#[derive(Debug, Clone)]
pub struct StationaryAnalysis {
    /// Forcing frequency (Hz).
    pub forcing_hz: f64,
    /// Simulated time (s).
    pub duration_s: f64,
    /// Time discarded before R, spectra, hops and the stroboscopic K (s).
    pub transient_s: f64,
    /// Largest chord reduction after the transient (mm).
    pub chord_max_mm: f64,
    /// Largest distance of the tip from the holder's line (the beam's bending) after the
    /// transient (mm).
    pub tip_deflection_max_mm: f64,
    /// Local extrema of α over the whole record (rad): the paper's Fig. 6 series.
    pub extrema: Vec<f64>,
    /// 0–1 test on `extrema`, normalised (eq. 8), correlation method.
    pub k_extrema: ZeroOneResult,
    /// 0–1 test on `extrema`, normalised (eq. 8), regression of ln M_c on ln n (eq. 10).
    pub k_extrema_eq10: ZeroOneResult,
    /// 0–1 test on one α sample per forcing period after the transient (correlation).
    pub k_strobe: ZeroOneResult,
    /// R of cart position and α after the transient, paper convention (Δφ modulo π).
    pub r_paper: f64,
    /// R, standard convention (Δφ on the full circle).
    pub r_standard: f64,
    /// Histogram of Δφ in the paper's convention (Fig. 7).
    pub phase_hist_paper: PhaseHistogram,
    /// Amplitude spectrum of the cart position (mm) after the transient.
    pub spectrum_x0_mm: Spectrum,
    /// Amplitude spectrum of α (deg) after the transient.
    pub spectrum_alpha_deg: Spectrum,
    /// Amplitude spectrum of α̇ (deg/s) after the transient.
    pub spectrum_rate_deg_s: Spectrum,
    /// Amplitude spectrum of the chord reduction (mm) after the transient.
    pub spectrum_chord_mm: Spectrum,
    /// Strongest line of α's spectrum.
    pub alpha_peak: Option<SpectralPeak>,
    /// Its ratio to the forcing.
    pub alpha_ratio: Option<RatioReport>,
    /// Strongest line of the chord's spectrum.
    pub chord_peak: Option<SpectralPeak>,
    /// Its ratio to the forcing.
    pub chord_ratio: Option<RatioReport>,
    /// Prominence of α's spectrum at f/3 (see [`line_prominence`]).
    pub prominence_third: f64,
    /// Prominence of α's spectrum at f/2.
    pub prominence_half: f64,
    /// Prominence of α's strongest line (NaN without one).
    pub prominence_peak: f64,
    /// Period of the stroboscopic section (forcing periods; 0: none found).
    pub period: usize,
    /// Hops between the wells after the transient.
    pub hops: usize,
    /// Range of α after the transient (deg).
    pub alpha_range_deg: f64,
    /// Divergence from the twin run, when one was made.
    pub twin: Option<TwinDivergence>,
}

/// Largest amplitude within ±4 % (at least one bin) of `target_hz`, over the median amplitude
/// of the bins between `target_hz/2` and `2·target_hz` outside that window: a clear spectral
/// line stands 10× or more above its neighbourhood, a broad band 1–3×. NaN when the
/// spectrum does not reach the band.
pub fn line_prominence(spec: &Spectrum, target_hz: f64) -> f64 {
    let f = &spec.frequency_hz;
    let a = &spec.amplitude;
    if f.len() < 3 || target_hz.is_nan() || target_hz <= 0.0 {
        return f64::NAN;
    }
    let bin = f[1] - f[0];
    let half_width = (0.04 * target_hz).max(1.01 * bin);
    let mut line = f64::NAN;
    let mut around = Vec::new();
    for (&fi, &ai) in f.iter().zip(a) {
        if (fi - target_hz).abs() <= half_width {
            line = if line.is_nan() { ai } else { line.max(ai) };
        } else if fi >= 0.5 * target_hz && fi <= 2.0 * target_hz {
            around.push(ai);
        }
    }
    if line.is_nan() || around.is_empty() {
        return f64::NAN;
    }
    around.sort_by(f64::total_cmp);
    let median = around[around.len() / 2];
    if median > 0.0 {
        line / median
    } else {
        f64::NAN
    }
}

/// Maps an analysis error of `case` to one that names the indicator `what`.
fn failed<'a>(case: &'a str, what: &'static str) -> impl Fn(AnalysisError) -> ReproduceError + 'a {
    move |e| ReproduceError::analysis(case, what, e)
}

/// The indicators of a harmonically forced case; `twin` is the same scene started
/// [`TWIN_PERTURBATION_DEG`] lower.
pub fn analyse_stationary(
    case: &str,
    sim: &Simulation,
    twin: Option<&Simulation>,
) -> Result<StationaryAnalysis, ReproduceError> {
    let forcing_hz = harmonic_forcing_hz(case, sim)?;
    let skip = sim.transient_rows();
    let alpha = sim.column(|r| r.alpha_rad);
    let x0 = sim.column(|r| r.x0_m);
    let (tail_alpha, tail_x0) = (&alpha[skip..], &x0[skip..]);
    let (extrema, k_extrema, k_extrema_eq10) = k_on_extrema(case, &alpha)?;
    let (strobe, k_strobe) = k_stroboscopic(case, sim, &alpha, forcing_hz)?;
    let (r_paper, r_standard, phase_hist_paper) = phase_locking(case, tail_x0, tail_alpha)?;
    let [
        spectrum_x0_mm,
        spectrum_alpha_deg,
        spectrum_rate_deg_s,
        spectrum_chord_mm,
    ] = spectra(case, sim, tail_x0, tail_alpha)?;
    let ratio = |p: Option<SpectralPeak>| -> Result<Option<RatioReport>, ReproduceError> {
        p.map(|p| ratio_to_forcing(p.frequency_hz, forcing_hz))
            .transpose()
            .map_err(failed(case, "frequency ratio"))
    };
    let alpha_peak = dominant_peak(&spectrum_alpha_deg);
    let chord_peak = dominant_peak(&spectrum_chord_mm);
    let prominence = |target_hz: f64| line_prominence(&spectrum_alpha_deg, target_hz);
    let clearance = sim.scene.limiter.clearance_deg.to_radians();
    Ok(StationaryAnalysis {
        forcing_hz,
        duration_s: sim.scene.integration.duration_s,
        transient_s: sim.scene.integration.transient_s,
        chord_max_mm: chord_max_mm(&sim.rows[skip..]),
        tip_deflection_max_mm: tip_deflection_max_mm(&sim.rows[skip..]),
        k_extrema,
        k_extrema_eq10,
        k_strobe,
        r_paper,
        r_standard,
        phase_hist_paper,
        prominence_third: prominence(forcing_hz / 3.0),
        prominence_half: prominence(forcing_hz / 2.0),
        prominence_peak: alpha_peak.map_or(f64::NAN, |p| prominence(p.frequency_hz)),
        alpha_ratio: ratio(alpha_peak)?,
        chord_ratio: ratio(chord_peak)?,
        alpha_peak,
        chord_peak,
        spectrum_x0_mm,
        spectrum_alpha_deg,
        spectrum_rate_deg_s,
        spectrum_chord_mm,
        period: detect_period(&strobe, 12, 12, 1e-3),
        hops: hops(tail_alpha, clearance),
        alpha_range_deg: range_deg(tail_alpha),
        twin: twin.map(|t| twin_divergence(sim, t)),
        extrema,
    })
}

/// The forcing frequency of a harmonically forced scene; an error for a sweep.
fn harmonic_forcing_hz(case: &str, sim: &Simulation) -> Result<f64, ReproduceError> {
    match sim.scene.excitation.kind {
        ExcitationKind::Harmonic { frequency_hz } => Ok(frequency_hz),
        ExcitationKind::Sweep { .. } => Err(ReproduceError::analysis(
            case,
            "stationary indicators",
            AnalysisError::InvalidArgument("a sweep has no single forcing frequency".into()),
        )),
    }
}

/// The paper's K: the local extrema of α over the whole run, and the normalised 0–1 test on
/// them by the correlation method and by the paper's regression (eq. 10).
fn k_on_extrema(
    case: &str,
    alpha: &[f64],
) -> Result<(Vec<f64>, ZeroOneResult, ZeroOneResult), ReproduceError> {
    let extrema = local_extrema(alpha).map_err(failed(case, "local extrema of α"))?;
    let normalised = |method| ZeroOneOptions {
        method,
        normalize: true,
        ..ZeroOneOptions::default()
    };
    let k_extrema = zero_one_test(&extrema, &normalised(K01Method::Correlation))
        .map_err(failed(case, "0-1 test on the extrema"))?;
    let k_extrema_eq10 = zero_one_test(&extrema, &normalised(K01Method::Regression))
        .map_err(failed(case, "0-1 test on the extrema, eq. 10"))?;
    Ok((extrema, k_extrema, k_extrema_eq10))
}

/// One α sample per forcing period after the transient, and the 0–1 test on them.
fn k_stroboscopic(
    case: &str,
    sim: &Simulation,
    alpha: &[f64],
    forcing_hz: f64,
) -> Result<(Vec<f64>, ZeroOneResult), ReproduceError> {
    let strobe = stroboscopic_uniform(
        alpha,
        sim.rate_hz(),
        0.0,
        forcing_hz,
        0.0,
        sim.scene.integration.transient_s,
    )
    .map_err(failed(case, "stroboscopic samples"))?;
    let k_strobe = zero_one_test(&strobe, &ZeroOneOptions::default())
        .map_err(failed(case, "0-1 test on the stroboscopic samples"))?;
    Ok((strobe, k_strobe))
}

/// R of cart position and α after the transient in the paper's convention and the standard
/// one, and the histogram of Δφ in the paper's (Fig. 7).
fn phase_locking(
    case: &str,
    tail_x0: &[f64],
    tail_alpha: &[f64],
) -> Result<(f64, f64, PhaseHistogram), ReproduceError> {
    let paper = phase_sync(tail_x0, tail_alpha, PhaseConvention::Paper)
        .map_err(failed(case, "phase synchronisation"))?;
    let standard = phase_sync(tail_x0, tail_alpha, PhaseConvention::Standard)
        .map_err(failed(case, "phase synchronisation"))?;
    let hist = phase_histogram(&paper.delta_phi_rad, 36, PhaseConvention::Paper)
        .map_err(failed(case, "phase histogram"))?;
    Ok((paper.r, standard.r, hist))
}

/// Amplitude spectra after the transient of the cart position (mm), α (deg), α̇ (deg/s) and
/// the chord reduction (mm), in that order.
fn spectra(
    case: &str,
    sim: &Simulation,
    tail_x0: &[f64],
    tail_alpha: &[f64],
) -> Result<[Spectrum; 4], ReproduceError> {
    let skip = sim.transient_rows();
    let rate = sim.rate_hz();
    let deg = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x.to_degrees()).collect() };
    let mm = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x * 1e3).collect() };
    let spectrum = |x: Vec<f64>, what| amplitude_spectrum(&x, rate).map_err(failed(case, what));
    Ok([
        spectrum(mm(tail_x0), "spectrum of x0")?,
        spectrum(deg(tail_alpha), "spectrum of α")?,
        spectrum(
            deg(&sim.column(|r| r.alpha_dot_rad_s)[skip..]),
            "spectrum of α̇",
        )?,
        spectrum(
            mm(&sim.column(|r| r.chord_m)[skip..]),
            "spectrum of the chord",
        )?,
    ])
}

/// Largest chord reduction over `rows` (mm).
fn chord_max_mm(rows: &[Row]) -> f64 {
    rows.iter()
        .map(|r| r.chord_m * 1e3)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Largest distance of the tip from the holder's line over `rows`: how far the beam bends
/// (mm).
fn tip_deflection_max_mm(rows: &[Row]) -> f64 {
    rows.iter()
        .map(|r| {
            let (sin, cos) = r.alpha_rad.sin_cos();
            ((r.tip_x_m - r.x0_m) * cos - r.tip_y_m * sin).abs() * 1e3
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Range of an angle series (rad), in degrees.
fn range_deg(x: &[f64]) -> f64 {
    let (lo, hi) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| {
        (a.0.min(v), a.1.max(v))
    });
    (hi - lo).to_degrees()
}

/// Compare a run with its twin row by row.
fn twin_divergence(sim: &Simulation, twin: &Simulation) -> TwinDivergence {
    let skip = sim.transient_rows();
    let mut max_after = 0.0f64;
    let mut separated_at_s = None;
    for (i, (a, b)) in sim.rows.iter().zip(&twin.rows).enumerate() {
        let d = (a.alpha_rad - b.alpha_rad).abs();
        if separated_at_s.is_none() && d > TWIN_SEPARATED_RAD {
            separated_at_s = Some(a.t_s);
        }
        if i >= skip {
            max_after = max_after.max(d);
        }
    }
    let verdict = if max_after > TWIN_SEPARATED_RAD {
        TwinVerdict::Separate
    } else if max_after < TWIN_CONVERGED_RAD {
        TwinVerdict::Converge
    } else {
        TwinVerdict::StayClose
    };
    TwinDivergence {
        perturbation_deg: TWIN_PERTURBATION_DEG,
        max_after_transient_rad: max_after,
        separated_at_s,
        verdict,
    }
}

/// One frequency window of the sweep (1 Hz of forcing frequency each).
#[derive(Debug, Clone, Serialize)]
pub struct SweepWindow {
    /// Forcing frequency at the window's start (Hz).
    pub f_start_hz: f64,
    /// Forcing frequency at its end (Hz).
    pub f_end_hz: f64,
    /// Start time (s).
    pub t_start_s: f64,
    /// End time (s).
    pub t_end_s: f64,
    /// RMS of α in the window (deg).
    pub alpha_rms_deg: f64,
    /// Range of α in the window (deg).
    pub alpha_range_deg: f64,
    /// Hops between the wells in the window.
    pub hops: usize,
    /// Period of the largest time-averaged wavelet power of the cart inside the COI (s).
    pub base_peak_period_s: Option<f64>,
    /// The same for the holder angle (s).
    pub angle_peak_period_s: Option<f64>,
    /// Share of the angle's time-averaged wavelet power (inside the COI) at periods
    /// 0.32–0.64 s, the band the paper names.
    pub angle_share_paper_band: Option<f64>,
    /// Share of the angle's wavelet cells (inside the COI) at 0.32–0.64 s whose power exceeds
    /// the 95 % red-noise level: the paper's black contours in that band.
    pub angle_significant_paper_band: Option<f64>,
}

/// The sweep's wavelet transforms and windows.
#[derive(Debug, Clone)]
pub struct SweepAnalysis {
    /// Times of the wavelet columns (s).
    pub times_s: Vec<f64>,
    /// Wavelet transform of the cart position.
    pub base: WaveletResult,
    /// Its power over the 95 % red-noise level.
    pub base_significance: Vec<Vec<f64>>,
    /// Wavelet transform of the holder angle.
    pub angle: WaveletResult,
    /// Its power over the 95 % red-noise level.
    pub angle_significance: Vec<Vec<f64>>,
    /// One window per hertz of forcing.
    pub windows: Vec<SweepWindow>,
    /// Hops over the whole sweep.
    pub hops: usize,
}

/// Wavelet transform of `x` block-averaged to [`SWEEP_WAVELET_RATE_HZ`], with its significance.
fn sweep_wavelet(
    case: &str,
    x: &[f64],
    rate_hz: f64,
) -> Result<(WaveletResult, Vec<Vec<f64>>), ReproduceError> {
    let factor = ((rate_hz / SWEEP_WAVELET_RATE_HZ).floor() as usize).max(1);
    let reduced: Vec<f64> = x
        .chunks_exact(factor)
        .map(|c| c.iter().sum::<f64>() / factor as f64)
        .collect();
    let dt = factor as f64 / rate_hz;
    let lambda = pendulum_atlas_core::analysis::morlet_fourier_factor();
    let s0 = 2.0 * dt / lambda;
    let dj = 1.0 / 12.0;
    let j = ((SWEEP_MAX_PERIOD_S / (2.0 * dt)).log2() / dj)
        .round()
        .max(1.0) as usize;
    let opts = WaveletOptions {
        s0: Some(s0),
        j: Some(j),
        ..WaveletOptions::default()
    };
    let wt = morlet_cwt(&reduced, dt, &opts).map_err(failed(case, "wavelet transform"))?;
    let lag1 = lag1_autocorrelation(&reduced)
        .map_err(failed(case, "lag-1 autocorrelation"))?
        .clamp(-0.999_999, 0.999_999);
    let level = significance_ar1(1.0, dt, &wt.period_s, lag1, 0.95)
        .map_err(failed(case, "wavelet significance"))?;
    let ratio = wt
        .power
        .iter()
        .zip(&level)
        .map(|(row, l)| row.iter().map(|p| p / l).collect())
        .collect();
    Ok((wt, ratio))
}

/// Time-averaged power per period over columns `c0..c1`, counting only cells inside the COI;
/// `None` for a period with no such cell.
fn averaged_inside_coi(wt: &WaveletResult, c0: usize, c1: usize) -> Vec<Option<f64>> {
    wt.power
        .iter()
        .zip(&wt.period_s)
        .map(|(row, &p)| {
            let inside: Vec<f64> = (c0..c1.min(row.len()))
                .filter(|&c| p <= wt.coi_s[c])
                .map(|c| row[c])
                .collect();
            (!inside.is_empty()).then(|| inside.iter().sum::<f64>() / inside.len() as f64)
        })
        .collect()
}

/// Period with the largest averaged power.
fn peak_period(wt: &WaveletResult, avg: &[Option<f64>]) -> Option<f64> {
    avg.iter()
        .zip(&wt.period_s)
        .filter_map(|(a, &p)| a.map(|a| (a, p)))
        .max_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, p)| p)
}

/// The sweep's indicators: wavelets of cart and angle, and one window per hertz.
pub fn analyse_sweep(case: &str, sim: &Simulation) -> Result<SweepAnalysis, ReproduceError> {
    let (start_hz, end_hz, duration_s) = sweep_excitation(case, sim)?;
    let rate = sim.rate_hz();
    let alpha = sim.column(|r| r.alpha_rad);
    let x0 = sim.column(|r| r.x0_m);
    let (base, base_significance) = sweep_wavelet(case, &x0, rate)?;
    let (angle, angle_significance) = sweep_wavelet(case, &alpha, rate)?;
    let cols = angle.power.first().map_or(0, Vec::len);
    let times_s: Vec<f64> = (0..cols)
        .map(|i| (i as f64 + 0.5) * angle.dt_s - 0.5 / rate)
        .collect();
    let clearance = sim.scene.limiter.clearance_deg.to_radians();
    let t_of = |f: f64| (f - start_hz) / (end_hz - start_hz) * duration_s;
    let steps = (end_hz - start_hz).abs().round().max(1.0) as usize;
    let df = (end_hz - start_hz) / steps as f64;
    let mut windows = Vec::with_capacity(steps);
    for w in 0..steps {
        let (fa, fb) = (start_hz + w as f64 * df, start_hz + (w + 1) as f64 * df);
        let (ta, tb) = (t_of(fa), t_of(fb).min(sim.scene.integration.duration_s));
        let ra = ((ta * rate).round() as usize).min(alpha.len());
        let rb = ((tb * rate).round() as usize).min(alpha.len());
        let seg = &alpha[ra..rb.max(ra)];
        let c1 = ((tb / angle.dt_s).ceil() as usize).min(cols);
        let c0 = ((ta / angle.dt_s).floor() as usize).min(c1);
        let avg_angle = averaged_inside_coi(&angle, c0, c1);
        let avg_base = averaged_inside_coi(&base, c0, c1);
        windows.push(SweepWindow {
            f_start_hz: fa,
            f_end_hz: fb,
            t_start_s: ta,
            t_end_s: tb,
            alpha_rms_deg: rms_deg(seg),
            alpha_range_deg: range_deg(seg),
            hops: hops(seg, clearance),
            base_peak_period_s: peak_period(&base, &avg_base),
            angle_peak_period_s: peak_period(&angle, &avg_angle),
            angle_share_paper_band: paper_band_share(&angle, &avg_angle),
            angle_significant_paper_band: paper_band_significant(
                &angle,
                &angle_significance,
                c0,
                c1,
            ),
        });
    }
    Ok(SweepAnalysis {
        times_s,
        base,
        base_significance,
        angle,
        angle_significance,
        windows,
        hops: hops(&alpha, clearance),
    })
}

/// Start and end frequency (Hz) and duration (s) of the sweep; an error for a harmonic scene.
fn sweep_excitation(case: &str, sim: &Simulation) -> Result<(f64, f64, f64), ReproduceError> {
    let ExcitationKind::Sweep {
        start_hz,
        end_hz,
        duration_s,
    } = sim.scene.excitation.kind
    else {
        return Err(ReproduceError::analysis(
            case,
            "sweep indicators",
            AnalysisError::InvalidArgument(
                "the sweep case needs excitation.kind = \"sweep\"".into(),
            ),
        ));
    };
    Ok((start_hz, end_hz, duration_s))
}

/// RMS of an angle series (rad), in degrees; NaN when empty.
fn rms_deg(x: &[f64]) -> f64 {
    if x.is_empty() {
        f64::NAN
    } else {
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64)
            .sqrt()
            .to_degrees()
    }
}

/// Whether a period lies in the band the paper names ([`SWEEP_PAPER_BAND_S`]).
fn in_paper_band(period_s: &f64) -> bool {
    (SWEEP_PAPER_BAND_S.0..=SWEEP_PAPER_BAND_S.1).contains(period_s)
}

/// Share of the time-averaged power `avg` (inside the COI) at periods in the paper's band;
/// `None` without power.
fn paper_band_share(wt: &WaveletResult, avg: &[Option<f64>]) -> Option<f64> {
    let total: f64 = avg.iter().flatten().sum();
    let band: f64 = avg
        .iter()
        .zip(&wt.period_s)
        .filter(|(_, p)| in_paper_band(p))
        .filter_map(|(a, _)| *a)
        .sum();
    (total > 0.0).then(|| band / total)
}

/// Share of the cells in columns `c0..c1` inside the COI at periods in the paper's band whose
/// power reaches the 95 % red-noise level (`significance` ≥ 1); `None` without such cells.
fn paper_band_significant(
    wt: &WaveletResult,
    significance: &[Vec<f64>],
    c0: usize,
    c1: usize,
) -> Option<f64> {
    let (mut cells, mut significant) = (0usize, 0usize);
    for (row, p) in significance.iter().zip(&wt.period_s) {
        if !in_paper_band(p) {
            continue;
        }
        for (ratio, coi) in row[c0..c1].iter().zip(&wt.coi_s[c0..c1]) {
            if p <= coi {
                cells += 1;
                significant += usize::from(*ratio >= 1.0);
            }
        }
    }
    (cells > 0).then(|| significant as f64 / cells as f64)
}
