//! The dense Lagrange form M(θ)θ̈ = Q (`docs/model.md`), term by term. O(N³): used only to
//! cross-check the O(N) recursion in tests and to build the linearisation.

use crate::model::params::ModelParams;
use nalgebra::{DMatrix, DVector};

/// The mass matrix M_ij = ℓ² μ_ij cos(θ_i − θ_j) + δ_ij J (+ J_h at (1,1)).
pub(crate) fn mass_matrix(p: &ModelParams, theta: &[f64]) -> DMatrix<f64> {
    let n = p.segments;
    let l2 = p.seg_length_m * p.seg_length_m;
    let mut m = DMatrix::zeros(n, n);
    for i in 0..n {
        for j in 0..n {
            m[(i, j)] = l2 * p.mu_kg(i, j) * (theta[i] - theta[j]).cos();
        }
        m[(i, i)] += p.seg_inertia_kgm2;
    }
    m[(0, 0)] += p.holder_inertia_kgm2;
    m
}

/// Q without the applied couples: velocity terms, gravity and cart acceleration.
pub(crate) fn inertial_forces(
    p: &ModelParams,
    theta: &[f64],
    omega: &[f64],
    cart_acc: f64,
) -> DVector<f64> {
    let n = p.segments;
    let l = p.seg_length_m;
    DVector::from_fn(n, |i, _| {
        let vel: f64 = (0..n)
            .map(|j| -l * l * p.mu_kg(i, j) * (theta[i] - theta[j]).sin() * omega[j] * omega[j])
            .sum();
        vel + p.carried_mass_kg(i) * l * (p.g_m_s2 * theta[i].sin() - cart_acc * theta[i].cos())
    })
}

/// θ̈ by a dense LU solve, given the applied generalised couples (springs, dampers, ...).
pub fn accelerations(
    p: &ModelParams,
    theta: &[f64],
    omega: &[f64],
    cart_acc: f64,
    applied: &[f64],
) -> DVector<f64> {
    let q = inertial_forces(p, theta, omega, cart_acc) + DVector::from_column_slice(applied);
    mass_matrix(p, theta)
        .lu()
        .solve(&q)
        .expect("the mass matrix is positive definite")
}
