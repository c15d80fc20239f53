//! Linearisation about the straight upright beam: natural frequencies, unstable growth rates,
//! the damping that gives a first-mode damping ratio, and the automatic RK4 time step from the
//! spectral radius of the first-order Jacobian (`docs/model.md`, "Linearisation").

use crate::model::dense::mass_matrix;
use crate::model::params::ModelParams;
use nalgebra::{Complex, DMatrix, Schur, SymmetricEigen};
use serde::Serialize;

/// Most QR iterations an eigen decomposition may take before it is given up: a chain of N
/// segments converges in a few times 2N (about 100 at the paper's N = 17), so this bound is
/// met only by a matrix the iteration cannot resolve (entries that overflowed, say).
pub const EIGEN_MAX_ITERATIONS: usize = 20_000;

/// Why the linearisation of a chain could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinearError {
    /// The mass matrix (or IMEX's iteration matrix) is not numerically positive definite.
    #[error(
        "the chain's {what} is not positive definite in floating point: its masses, lengths or stiffnesses are too far apart (check beam.mass_kg, tip.mass_kg, pivot.holder_inertia_kgm2 and beam.segments)"
    )]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
    },
    /// An eigen decomposition did not converge within [`EIGEN_MAX_ITERATIONS`].
    #[error(
        "the eigenvalues of the chain's {what} did not converge in {EIGEN_MAX_ITERATIONS} iterations: its coefficients are too far apart to linearise (check the masses, stiffnesses and beam.segments)"
    )]
    NoConvergence {
        /// Which matrix.
        what: &'static str,
    },
    /// An eigen decomposition that ended with values that are not numbers.
    #[error(
        "the eigenvalues of the chain's {what} are not finite: its coefficients overflowed (check the masses, stiffnesses and beam.segments)"
    )]
    NotFinite {
        /// Which matrix.
        what: &'static str,
    },
    /// The clamped chain has no bending mode to set a damping ratio against.
    #[error(
        "the clamped chain has no positive bending frequency, so beam.damping_ratio cannot set its damping: give beam.damping_time_s or beam.joint_damping_nms"
    )]
    NoBendingMode,
}

/// The stability boundary of classical RK4 on the negative real axis, |z| ≈ 2.785 (the automatic step uses 2.78).
pub(crate) const RK4_REAL_AXIS_LIMIT: f64 = 2.78;

/// Modal summary of a scene.
#[derive(Debug, Clone, Serialize)]
pub struct Modes {
    /// Undamped natural frequencies of the stable modes (Hz), ascending.
    pub frequencies_hz: Vec<f64>,
    /// Growth rates √(λ²) of the unstable (falling) modes (1/s), ascending.
    pub unstable_rates_per_s: Vec<f64>,
    /// The automatic RK4 step (s), before rounding to the output interval.
    pub dt_auto_s: f64,
    /// Spectral radius max|λ| of the damped first-order Jacobian with an active contact (1/s).
    pub spectral_radius_per_s: f64,
    /// Largest stable RK4 step for that Jacobian (s).
    pub dt_stable_s: f64,
}

/// Linear stiffness about θ = 0: springs minus the gravity "negative stiffness" w_i ℓ g.
pub(crate) fn stiffness_matrix(p: &ModelParams) -> DMatrix<f64> {
    let n = p.segments;
    let mut k = spring_pattern(n, p.joint_stiffness_nm, p.root_stiffness_nm);
    for i in 0..n {
        k[(i, i)] -= p.carried_mass_kg(i) * p.seg_length_m * p.g_m_s2;
    }
    k
}

/// The tridiagonal pattern of joint elements plus a root element at (1,1).
pub(crate) fn spring_pattern(n: usize, joint: f64, root: f64) -> DMatrix<f64> {
    let mut k = DMatrix::zeros(n, n);
    k[(0, 0)] += root;
    for i in 1..n {
        k[(i, i)] += joint;
        k[(i - 1, i - 1)] += joint;
        k[(i, i - 1)] -= joint;
        k[(i - 1, i)] -= joint;
    }
    k
}

/// Eigenvalues λ² of K x = λ² M x (ω² for stable modes, negative for unstable ones), ascending:
/// `M = L Lᵀ` (Cholesky), then the symmetric `L⁻¹ K L⁻ᵀ`.
pub fn generalized_eigenvalues(p: &ModelParams) -> Result<Vec<f64>, LinearError> {
    let n = p.segments;
    let m = mass_matrix(p, &vec![0.0; n]);
    let k = stiffness_matrix(p);
    let not_pd = LinearError::NotPositiveDefinite {
        what: "mass matrix",
    };
    let chol = m.cholesky().ok_or(not_pd.clone())?;
    let l_inv = chol.l().try_inverse().ok_or(not_pd)?;
    let a = &l_inv * k * l_inv.transpose();
    let a = (&a + a.transpose()) * 0.5;
    let eigen = SymmetricEigen::try_new(a, f64::EPSILON, EIGEN_MAX_ITERATIONS).ok_or(
        LinearError::NoConvergence {
            what: "stiffness over mass",
        },
    )?;
    let mut ev: Vec<f64> = eigen.eigenvalues.iter().copied().collect();
    if !ev.iter().all(|x| x.is_finite()) {
        return Err(LinearError::NotFinite {
            what: "stiffness over mass",
        });
    }
    ev.sort_by(f64::total_cmp);
    Ok(ev)
}

/// ω1 (rad/s): the first natural frequency of the chain clamped to a still cart without gravity
/// (`ModelParams::clamped_cantilever`), the reference of the damping ratio ζ1.
pub fn clamped_first_omega(p: &ModelParams) -> Result<f64, LinearError> {
    let ev = generalized_eigenvalues(&p.clamped_cantilever())?;
    ev.iter()
        .copied()
        .find(|&x| x > 0.0)
        .map(f64::sqrt)
        .ok_or(LinearError::NoBendingMode)
}

/// The stiffness-proportional damping time β = 2ζ1/ω1 (s) that gives the first clamped bending
/// mode the damping ratio `zeta1`.
pub(crate) fn damping_time_for_ratio(p: &ModelParams, zeta1: f64) -> Result<f64, LinearError> {
    if zeta1 == 0.0 {
        return Ok(0.0);
    }
    Ok(2.0 * zeta1 / clamped_first_omega(p)?)
}

/// The damping ratio ζ1 = β ω1 / 2 of the first clamped bending mode for the chain's β.
pub fn first_mode_damping_ratio(p: &ModelParams) -> Result<f64, LinearError> {
    Ok(0.5 * p.beta_s * clamped_first_omega(p)?)
}

/// The first-order Jacobian about θ = 0 with dampers, an engaged bumper, and the piezo.
pub(crate) fn jacobian(p: &ModelParams) -> Result<DMatrix<f64>, LinearError> {
    let n = p.segments;
    let mut k = stiffness_matrix(p);
    let mut c = spring_pattern(n, p.joint_damping_nms, 0.0);
    c[(0, 0)] += p.root_damping_nms;
    if let Some(ct) = &p.contact {
        for (i, &li) in ct.levers_m.iter().enumerate() {
            for (j, &lj) in ct.levers_m.iter().enumerate() {
                k[(i, j)] += ct.stiffness_n_per_m * li * lj;
                c[(i, j)] += ct.damping_ns_per_m * li * lj;
            }
        }
    }
    let m_inv =
        mass_matrix(p, &vec![0.0; n])
            .try_inverse()
            .ok_or(LinearError::NotPositiveDefinite {
                what: "mass matrix",
            })?;
    let dim = 2 * n + usize::from(p.piezo.is_some());
    let mut jac = DMatrix::zeros(dim, dim);
    for i in 0..n {
        jac[(i, n + i)] = 1.0;
    }
    let mk = -&m_inv * k;
    let mc = -&m_inv * c;
    jac.view_mut((n, 0), (n, n)).copy_from(&mk);
    jac.view_mut((n, n), (n, n)).copy_from(&mc);
    if let Some(z) = &p.piezo {
        let e = z.last_segment;
        // Couple Θv on θ_1 and −Θv on θ_{p+1}; v̇ = (Θ ψ̇ − v/R)/C.
        for i in 0..n {
            jac[(n + i, 2 * n)] = z.coupling_nm_per_v * (m_inv[(i, 0)] - m_inv[(i, e)]);
        }
        jac[(2 * n, n + e)] = z.coupling_nm_per_v / z.capacitance_f;
        jac[(2 * n, n)] = -z.coupling_nm_per_v / z.capacitance_f;
        jac[(2 * n, 2 * n)] = -1.0 / (z.load_ohm * z.capacitance_f);
    }
    Ok(jac)
}

/// Eigenvalues of the first-order Jacobian (real Schur form, at most
/// [`EIGEN_MAX_ITERATIONS`]).
pub fn jacobian_eigenvalues(p: &ModelParams) -> Result<Vec<Complex<f64>>, LinearError> {
    let schur = Schur::try_new(jacobian(p)?, f64::EPSILON, EIGEN_MAX_ITERATIONS)
        .ok_or(LinearError::NoConvergence { what: "Jacobian" })?;
    let ev: Vec<Complex<f64>> = schur.complex_eigenvalues().iter().copied().collect();
    if !ev.iter().all(|z| z.re.is_finite() && z.im.is_finite()) {
        return Err(LinearError::NotFinite { what: "Jacobian" });
    }
    Ok(ev)
}

/// Spectral radius (1/s) of the first-order Jacobian without the joint and root springs and
/// dampers: what is left when those linear terms are treated implicitly (gravity, an engaged
/// bumper, the piezo circuit, all through the straight beam's mass matrix).
pub(crate) fn explicit_part_radius(p: &ModelParams) -> Result<f64, LinearError> {
    let mut q = p.clone();
    q.joint_stiffness_nm = 0.0;
    q.root_stiffness_nm = 0.0;
    q.joint_damping_nms = 0.0;
    q.root_damping_nms = 0.0;
    Ok(jacobian_eigenvalues(&q)?
        .iter()
        .fold(0.0f64, |a, z| a.max(z.norm())))
}

/// |R(z)| for classical RK4, R(z) = 1 + z + z²/2 + z³/6 + z⁴/24.
pub(crate) fn rk4_amplification(z: Complex<f64>) -> f64 {
    let one = Complex::new(1.0, 0.0);
    (one + z * (one + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)))).norm()
}

/// Largest dt with |R(λ dt)| ≤ 1 for every eigenvalue with Re λ ≤ 0 (unstable physical modes
/// grow whatever the step and are not a stability limit of the integrator).
pub(crate) fn rk4_stable_dt(eigs: &[Complex<f64>]) -> f64 {
    let mut dt_max = f64::INFINITY;
    for &lam in eigs {
        let r = lam.norm();
        if lam.re > 1e-9 * r.max(1.0) || r == 0.0 {
            continue;
        }
        // Scan |z| from 0 to 3 along the ray of λ; the stable set along the ray is an interval.
        let steps = 3000;
        let mut last_ok = 0.0;
        for s in 1..=steps {
            let mag = 3.0 * s as f64 / steps as f64;
            if rk4_amplification(lam / r * mag) > 1.0 + 1e-12 {
                break;
            }
            last_ok = mag;
        }
        dt_max = dt_max.min(last_ok / r);
    }
    dt_max
}

/// Natural frequencies, unstable rates and the automatic RK4 step (`dt_safety` times the
/// real-axis limit over the spectral radius) of a chain.
pub fn modes(p: &ModelParams, dt_safety: f64) -> Result<Modes, LinearError> {
    let ev = generalized_eigenvalues(p)?;
    let scale = ev.iter().fold(0.0f64, |a, &x| a.max(x.abs())).max(1e-300);
    let frequencies_hz = ev
        .iter()
        .filter(|&&x| x > 1e-12 * scale)
        .map(|&x| x.sqrt() / std::f64::consts::TAU)
        .collect();
    let mut unstable_rates_per_s: Vec<f64> = ev
        .iter()
        .filter(|&&x| x < -1e-12 * scale)
        .map(|&x| (-x).sqrt())
        .collect();
    unstable_rates_per_s.sort_by(f64::total_cmp);
    let eigs = jacobian_eigenvalues(p)?;
    let radius = eigs.iter().fold(0.0f64, |a, z| a.max(z.norm()));
    Ok(Modes {
        frequencies_hz,
        unstable_rates_per_s,
        dt_auto_s: dt_safety * RK4_REAL_AXIS_LIMIT / radius,
        spectral_radius_per_s: radius,
        dt_stable_s: rk4_stable_dt(&eigs),
    })
}
