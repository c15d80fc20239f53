//! Cart kinematics x0(t), ẋ0(t), ẍ0(t) for harmonic and sweep excitation: the one definition of
//! the cart motion (see `docs/model.md`, "Excitation").
//!
//! Time never accumulates as `t += dt`. Two evaluations exist, one per way a run counts time:
//! - [`CartMotion::at_step`] / [`CartMotion::at_time`] form `t = (n + c)·dt` in `f64` from the
//!   integer step count and reduce the forcing phase to one cycle before any `f32` sees it
//!   (single runs, sweeps);
//! - [`CartMotion::at_phase`] takes the phase in cycles directly, `(step mod spp + c)/spp`, exact
//!   in integers on an ensemble's step grid (every map instance, CPU and GPU alike; the WGSL
//!   kernels evaluate the same expressions from the amplitudes of [`CartMotion::amplitudes`]).

use serde::Serialize;
use std::f64::consts::TAU;

/// How the cart moves.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum ExcitationKind {
    /// x0 = A sin(2π f t + φ0).
    Harmonic {
        /// Forcing frequency f (Hz).
        frequency_hz: f64,
    },
    /// Linear chirp from `start_hz` to `end_hz` over `duration_s`, then held at `end_hz`.
    Sweep {
        /// Initial instantaneous frequency (Hz).
        start_hz: f64,
        /// Final instantaneous frequency (Hz).
        end_hz: f64,
        /// Sweep duration (s).
        duration_s: f64,
    },
}

impl ExcitationKind {
    /// The frequency that defines one forcing period (harmonic f, or the sweep's end frequency).
    pub fn reference_frequency_hz(&self) -> f64 {
        match *self {
            ExcitationKind::Harmonic { frequency_hz } => frequency_hz,
            ExcitationKind::Sweep { end_hz, .. } => end_hz,
        }
    }

    /// The highest instantaneous frequency the cart reaches (Hz).
    pub(crate) fn max_frequency_hz(&self) -> f64 {
        match *self {
            ExcitationKind::Harmonic { frequency_hz } => frequency_hz,
            ExcitationKind::Sweep {
                start_hz, end_hz, ..
            } => start_hz.max(end_hz),
        }
    }
}

/// Cart position, velocity and acceleration at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct CartState {
    /// x0 (m).
    pub x_m: f64,
    /// ẋ0 (m/s).
    pub v_m_s: f64,
    /// ẍ0 (m/s²).
    pub a_m_s2: f64,
}

/// Amplitudes of a harmonic cart motion: A, Aω and Aω².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HarmonicAmplitudes {
    /// A (m).
    pub position_m: f64,
    /// Aω (m/s).
    pub velocity_m_s: f64,
    /// Aω² (m/s²).
    pub acceleration_m_s2: f64,
}

/// The prescribed cart motion of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CartMotion {
    /// Amplitude A (m).
    pub amplitude_m: f64,
    /// Harmonic or sweep.
    pub kind: ExcitationKind,
    /// Forcing phase at t = 0, φ0/2π, in cycles ∈ [0, 1): `excitation.phase_deg` / 360.
    /// Half a cycle turns the cart's motion into its mirror image, x0 → −x0.
    pub phase_cycles: f64,
}

impl CartMotion {
    /// Forcing phase φ(t) in cycles (not reduced, φ0 included), its rate (Hz) and its second
    /// derivative (Hz/s).
    fn phase_at(&self, t: f64) -> (f64, f64, f64) {
        let (cycles, f, fdot) = self.phase_from_zero(t);
        (cycles + self.phase_cycles, f, fdot)
    }

    /// φ(t) − φ0 (cycles), its rate (Hz) and its second derivative (Hz/s).
    fn phase_from_zero(&self, t: f64) -> (f64, f64, f64) {
        match self.kind {
            ExcitationKind::Harmonic { frequency_hz } => (frequency_hz * t, frequency_hz, 0.0),
            ExcitationKind::Sweep {
                start_hz,
                end_hz,
                duration_s,
            } => {
                let rate = (end_hz - start_hz) / duration_s;
                if t <= duration_s {
                    (start_hz * t + 0.5 * rate * t * t, start_hz + rate * t, rate)
                } else {
                    let at_end = start_hz * duration_s + 0.5 * rate * duration_s * duration_s;
                    (at_end + end_hz * (t - duration_s), end_hz, 0.0)
                }
            }
        }
    }

    /// Cart state at `t = (step + stage)·dt`, phase reduced modulo one cycle.
    #[inline]
    pub(crate) fn at_step(&self, step: u64, stage: f64, dt_s: f64) -> CartState {
        self.at_time((step as f64 + stage) * dt_s)
    }

    /// Cart state at time `t` (s).
    pub(crate) fn at_time(&self, t: f64) -> CartState {
        let (cycles, f, fdot) = self.phase_at(t);
        let phase = TAU * cycles.fract();
        let (s, c) = phase.sin_cos();
        let a = self.amplitude_m;
        let w = TAU * f;
        let wdot = TAU * fdot;
        CartState {
            x_m: a * s,
            v_m_s: a * w * c,
            a_m_s2: -a * w * w * s + a * wdot * c,
        }
    }

    /// A, Aω and Aω² of the reference frequency (the harmonic motion's amplitudes).
    pub fn amplitudes(&self) -> HarmonicAmplitudes {
        let w = TAU * self.kind.reference_frequency_hz();
        HarmonicAmplitudes {
            position_m: self.amplitude_m,
            velocity_m_s: self.amplitude_m * TAU * self.kind.reference_frequency_hz(),
            acceleration_m_s2: self.amplitude_m * w.powi(2),
        }
    }

    /// Harmonic cart state `cycles` ∈ [0, 1) of a period after a whole number of periods
    /// (φ = cycles + φ0): x0 = A sin 2πφ, ẋ0 = Aω cos 2πφ, ẍ0 = −Aω² sin 2πφ.
    #[inline]
    pub(crate) fn at_phase(&self, cycles: f64) -> CartState {
        let amp = self.amplitudes();
        let (s, c) = (TAU * (cycles + self.phase_cycles)).sin_cos();
        CartState {
            x_m: amp.position_m * s,
            v_m_s: amp.velocity_m_s * c,
            a_m_s2: -amp.acceleration_m_s2 * s,
        }
    }
}
