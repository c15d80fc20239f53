//! Cart kinematics x0(t), ẋ0(t), ẍ0(t) for harmonic and sweep excitation.
//!
//! Time enters only through [`CartMotion::at_step`], which forms `t = (n + c)·dt` from the
//! integer step count `n` and the stage fraction `c` in `f64`, and reduces the forcing phase to
//! one cycle before any `f32` arithmetic sees it. No path accumulates `t += dt`.

use crate::config::{Excitation, ExcitationKind};
use serde::Serialize;
use std::f64::consts::TAU;

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

/// The prescribed cart motion of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CartMotion {
    /// Amplitude A (m).
    pub amplitude_m: f64,
    /// Harmonic or sweep.
    pub kind: ExcitationKind,
}

impl CartMotion {
    /// From the validated scene section.
    pub fn from_excitation(e: &Excitation) -> Self {
        CartMotion {
            amplitude_m: e.amplitude_m,
            kind: e.kind,
        }
    }

    /// Forcing phase φ(t) in cycles (not reduced), its rate (Hz) and its second derivative (Hz/s).
    fn phase_cycles(&self, t: f64) -> (f64, f64, f64) {
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
    pub fn at_step(&self, step: u64, stage: f64, dt_s: f64) -> CartState {
        self.at_time((step as f64 + stage) * dt_s)
    }

    /// Cart state at time `t` (s).
    pub fn at_time(&self, t: f64) -> CartState {
        let (cycles, f, fdot) = self.phase_cycles(t);
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

    /// Instantaneous forcing frequency at `t` (Hz).
    pub fn frequency_at(&self, t: f64) -> f64 {
        self.phase_cycles(t).1
    }
}
