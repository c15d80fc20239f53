//! The one error type of the analysis stage, so callers can tell bad input from bad arguments
//! and print a message that says how to mend it.

use crate::text::num;
use thiserror::Error;

/// What was wrong with the data or the arguments handed to an analysis function.
///
/// Every analysis entry point validates its input up front and returns one of these instead of
/// panicking or silently producing NaN.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AnalysisError {
    /// The series is shorter than the method needs to give a meaningful answer.
    #[error("{method} needs at least {needed} samples, got {got}")]
    TooFewSamples {
        /// The method that refused the series.
        method: &'static str,
        /// The smallest length it accepts.
        needed: usize,
        /// The length it was given.
        got: usize,
    },
    /// A sample is NaN or infinite (a diverged run, or a gap in measured data).
    #[error(
        "{what} has a non-finite value (NaN or infinity) at index {index}; drop or repair that sample"
    )]
    NonFinite {
        /// Which input held the value.
        what: String,
        /// Position of the first non-finite sample.
        index: usize,
    },
    /// Time stamps that should be uniform are not, within the tolerance.
    #[error(
        "time stamps are not uniform: the step before sample {index} is {} s, but the \
         median step is {} s (relative tolerance {}); resample the record onto a uniform grid \
         first",
        num(*step_s),
        num(*expected_s),
        num(*rel_tol)
    )]
    NonUniformTime {
        /// Index of the later sample of the offending step.
        index: usize,
        /// The step found there, in seconds.
        step_s: f64,
        /// The median step of the whole record, in seconds.
        expected_s: f64,
        /// The relative tolerance that was exceeded.
        rel_tol: f64,
    },
    /// Time stamps go backwards or repeat, so no interpolation is defined.
    #[error(
        "time stamps must increase strictly, but t[{index}] = {} s follows {} s",
        num(*current_s),
        num(*previous_s)
    )]
    NonIncreasingTime {
        /// Index of the sample that does not advance.
        index: usize,
        /// The previous time stamp, in seconds.
        previous_s: f64,
        /// The offending time stamp, in seconds.
        current_s: f64,
    },
    /// Two series that must pair sample by sample have different lengths.
    #[error("{what}: lengths differ ({left} vs {right})")]
    LengthMismatch {
        /// Which pair of inputs disagreed.
        what: &'static str,
        /// Length of the first input.
        left: usize,
        /// Length of the second input.
        right: usize,
    },
    /// The transient leaves too little of the record to analyse.
    #[error(
        "the transient of {} s leaves {remaining} of the samples of a {} s record, but at \
         least {needed} are needed: shorten the transient",
        num(*transient_s),
        num(*record_s)
    )]
    TransientTooLong {
        /// The transient asked for, in seconds.
        transient_s: f64,
        /// Length of the whole record (last minus first time stamp), in seconds.
        record_s: f64,
        /// Samples left after the transient.
        remaining: usize,
        /// Samples the analysis needs.
        needed: usize,
    },
    /// The forcing period is too short for the record's sampling to resolve.
    #[error(
        "a forcing frequency of {} Hz is not resolved by a record sampled at {} Hz: \
         stroboscopic samples need at least {} samples per forcing period, so the forcing must \
         lie in (0, {}] Hz",
        num(*forcing_hz),
        num(*sample_rate_hz),
        num(*min_samples_per_period),
        num(*max_forcing_hz)
    )]
    ForcingUnresolved {
        /// The forcing frequency asked for, in Hz.
        forcing_hz: f64,
        /// The record's (mean) sample rate, in Hz.
        sample_rate_hz: f64,
        /// The smallest number of samples per forcing period accepted.
        min_samples_per_period: f64,
        /// The largest forcing frequency accepted at this sample rate, in Hz.
        max_forcing_hz: f64,
    },
    /// The series does not vary, so indicators that measure variation are undefined.
    #[error(
        "{what} is constant (every sample equals {} to within {rel_range:e} of its \
         magnitude): there is no motion for K, R, a spectrum or a wavelet to describe",
        num(*value)
    )]
    ConstantSignal {
        /// Which input was constant.
        what: String,
        /// Its (first) value.
        value: f64,
        /// The relative range below which a series counts as constant.
        rel_range: f64,
    },
    /// The values are finite but so large that sums of their squares overflow.
    #[error(
        "{what} holds values up to {max_abs:e} in magnitude, too large to analyse (their \
         variance overflows a double); rescale the data"
    )]
    Overflow {
        /// Which input overflowed.
        what: String,
        /// Its largest magnitude.
        max_abs: f64,
    },
    /// An argument (a rate, a tolerance, a bin count…) is outside its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}
