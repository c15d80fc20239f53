//! Shared generators and fixture loading for the analysis tests.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Logistic map `x ← r x (1 − x)` from `x0 = 0.1`, `n` points after a 1000-step transient.
pub fn logistic(r: f64, n: usize) -> Vec<f64> {
    let mut x = 0.1;
    for _ in 0..1000 {
        x = r * x * (1.0 - x);
    }
    (0..n)
        .map(|_| {
            x = r * x * (1.0 - x);
            x
        })
        .collect()
}

/// Lorenz (σ=10, ρ=28, β=8/3) `x`, RK4 with step 0.001, sampled every `every` steps, `n`
/// samples after a transient of 50 time units.
pub fn lorenz_x(every: usize, n: usize) -> Vec<f64> {
    let mut s = [1.0, 1.0, 1.0];
    let h = 0.001;
    for _ in 0..50_000 {
        s = rk4(s, h);
    }
    (0..n)
        .map(|_| {
            for _ in 0..every {
                s = rk4(s, h);
            }
            s[0]
        })
        .collect()
}

fn lorenz(s: [f64; 3]) -> [f64; 3] {
    let (sigma, rho, beta) = (10.0, 28.0, 8.0 / 3.0);
    [
        sigma * (s[1] - s[0]),
        s[0] * (rho - s[2]) - s[1],
        s[0] * s[1] - beta * s[2],
    ]
}

fn rk4(s: [f64; 3], h: f64) -> [f64; 3] {
    let add =
        |a: [f64; 3], b: [f64; 3], k: f64| [a[0] + k * b[0], a[1] + k * b[1], a[2] + k * b[2]];
    let k1 = lorenz(s);
    let k2 = lorenz(add(s, k1, h / 2.0));
    let k3 = lorenz(add(s, k2, h / 2.0));
    let k4 = lorenz(add(s, k3, h));
    std::array::from_fn(|i| s[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

/// Seeded uniform white noise on `[-1, 1)`.
pub fn white_noise(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| 2.0 * rng.random::<f64>() - 1.0).collect()
}

/// Parses a fixture file of `tests/fixtures/`.
pub fn fixture(name: &str) -> serde_json::Value {
    let path = format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// A fixture array of numbers.
pub fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Fails with the index and both values when `got` and `want` differ by more than `tol`
/// (NaN counts as a failure).
pub fn assert_all_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: lengths differ");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= tol,
            "{what}[{i}]: got {g}, want {w} (tol {tol})"
        );
    }
}
