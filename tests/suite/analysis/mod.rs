//! Integration tests of the analysis stage, one module per area, each held against an
//! independent reference (known dynamics, scipy, pycwt, hand-computed values).

mod common;
mod errors;
mod periodicity;
mod phase;
mod record;
mod sampling;
mod significance;
mod spectrum;
mod wavelet;
mod zero_one;
