//! The one error type of the analysis stage, so callers can tell bad input from bad arguments
//! and print a message that says how to mend it.

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
        "time step at index {index} is {step_s} s, but the mean step is {expected_s} s \
         (relative tolerance {rel_tol}); resample with resample_uniform first"
    )]
    NonUniformTime {
        /// Index of the later sample of the offending step.
        index: usize,
        /// The step found there, in seconds.
        step_s: f64,
        /// The mean step of the whole record, in seconds.
        expected_s: f64,
        /// The relative tolerance that was exceeded.
        rel_tol: f64,
    },
    /// Time stamps go backwards or repeat, so no interpolation is defined.
    #[error(
        "time stamps must increase strictly, but t[{index}] = {current_s} s follows {previous_s} s"
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
    /// An argument (a rate, a tolerance, a bin count…) is outside its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}
