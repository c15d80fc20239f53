//! Signal analysis of pendulum responses: the indicators of the paper (0–1 test `K`, phase
//! synchronisation `R`, Fourier and wavelet spectra) and the per-instance statistics of the
//! parameter maps, for simulated and measured records alike.
//!
//! Stages, in the order a response flows through them:
//! 1. [`stroboscopic`], [`local_extrema`], [`resample_uniform`]: the series each indicator needs;
//! 2. [`zero_one_test`]: chaos indicator `K` on a (coarsely) sampled series;
//! 3. [`phase_sync`]: Hilbert phases, `R`, phase-difference histograms;
//! 4. [`amplitude_spectrum`] / [`dominant_peak`] / [`ratio_to_forcing`]: Fourier view;
//! 5. [`morlet_cwt`]: Torrence & Compo wavelet power with COI and AR(1) significance;
//! 6. [`detect_period`], [`hops`], [`rms`], [`range`]: per-instance numbers;
//! 7. [`analyze_record`]: all of them for one record, as `analyze` and `simulate` report it.
//!
//! Every fallible function returns [`AnalysisError`] instead of panicking on empty, short or
//! non-finite input. Library types carry no command-line concerns (no clap): the CLI has its
//! own spellings of the enums.

mod checks;
mod error;
pub(crate) mod periodicity;
mod phase;
mod report;
mod sampling;
mod spectrum;
mod wavelet;
mod zero_one;

pub use checks::FLAT_SIGNAL_REL_RANGE;
pub use error::AnalysisError;
pub(crate) use periodicity::RULES as HOP_RULES;
pub use periodicity::{Well, detect_period, hop_step, hops, range, rms, well_of};
pub use phase::{
    PHASE_MIN_SAMPLES, PhaseConvention, PhaseHistogram, PhaseSyncResult, analytic_signal,
    instantaneous_phase, phase_histogram, phase_sync,
};
pub use report::{
    Lag1Choice, PhaseSummary, RECORD_MIN_SAMPLES, RecordAnalysis, RecordOptions, Sampling,
    SpectrumSummary, Statistics, WaveletSettings, WaveletSignificance, WaveletSummary,
    ZeroOneSummary, analyze_record,
};
pub use sampling::{
    GAP_MEDIAN_STEPS, STROBE_MIN_SAMPLES_PER_PERIOD, TimeGap, check_uniform_time,
    ensure_forcing_resolved, local_extrema, median_step, resample_uniform, stroboscopic,
    stroboscopic_uniform, time_gaps,
};
pub use spectrum::{
    RATIO_MAX_DENOMINATOR, RATIO_REL_TOL, RatioReport, SPECTRUM_MIN_SAMPLES, SpectralPeak,
    Spectrum, amplitude_spectrum, dominant_peak, ratio_to_forcing, ratio_to_forcing_within,
};
pub use wavelet::{
    DEFAULT_CONFIDENCE, Lag1Estimator, MORLET_C_DELTA, MORLET_DOF_MIN, MORLET_GAMMA, MORLET_OMEGA0,
    MORLET_OMEGA0_MIN, MotherWavelet, WAVELET_MIN_SAMPLES, WaveletOptions, WaveletResult,
    chi2_2dof_quantile, chi2_quantile, cone_of_influence, estimate_lag1, global_significance_ar1,
    global_wavelet_spectrum, lag1_allen_smith, lag1_autocorrelation, morlet_cwt,
    morlet_fourier_factor, power_averaged_inside_coi, reconstruct_signal, reconstruct_variance,
    significance_ar1,
};
pub use zero_one::{
    K01Method, ZERO_ONE_COMFORTABLE_SAMPLES, ZERO_ONE_MIN_SAMPLES, ZeroOneOptions, ZeroOneResult,
    draw_c_values, pq_path, zero_one_test,
};
