//! The IMEX method's element-wise arithmetic as WGSL: the compensated finish `y += h Σ b_j f_j`
//! and the embedded error `h Σ (b_j − b̂_j) f_j`, recorded on [`Sym`] from the functions of
//! `crate::engine::imex` that the CPU engine's IMEX runs ([`finish_in`], [`embedded_error_in`]),
//! unrolled or (above `UNROLLED_UP_TO` segments) as a loop over the segments, as RK4's are
//! (`super::rk4`). The stages' N × N products stay in `shaders/imex.wgsl`: they are not
//! element-wise, and unrolled at N = 64 lavapipe could not compile them in time
//! (`docs/bench/GENERATED_KERNELS.md`).

use super::rk4::{Comp, comp, names, stages, state, stores, vector, written};
use super::sym::{Sym, input};
use crate::engine::imex::{embedded_error_in, finish_in};

/// `y += h Σ b_j f_j`, compensated (components `c`).
fn finish_of(c: &[Comp]) -> Vec<(String, Sym)> {
    let (mut y, mut cy) = (vector(c, &state()), vector(c, &comp()));
    let f = stages(c);
    finish_in(&mut y, &f, &mut cy, input("h"));
    let mut all = stores(c, &state(), &y);
    all.extend(stores(c, &comp(), &cy));
    all
}

/// The embedded error's names: θ into `sth`, θ̇ into `rv` (the solve's right-hand side), the
/// voltage into `svolt`.
fn error_names() -> super::rk4::Names {
    names("sth", "rv", "svolt")
}

/// `h Σ (b_j − b̂_j) f_j` into (`sth`, `rv`, `svolt`) (components `c`).
fn error_of(c: &[Comp]) -> Vec<(String, Sym)> {
    let mut out = vector(c, &state());
    embedded_error_in(&stages(c), input("h"), &mut out);
    stores(c, &error_names(), &out)
}

/// The IMEX method's element-wise functions for chains of `n` segments.
pub(crate) fn imex_wgsl(n: usize) -> String {
    [
        written(
            n,
            "finish_in (src/engine/imex.rs): the state advanced by the stages kept, y += h Σ b_j f_j with compensation.",
            "fn imex_finish(h: f32)",
            finish_of,
        ),
        written(
            n,
            "embedded_error_in (src/engine/imex.rs): h Σ (b_j − b̂_j) f_j into (sth, rv, svolt).",
            "fn imex_embedded_error(h: f32)",
            error_of,
        ),
    ]
    .join("\n")
}

#[cfg(test)]
mod tests {
    use super::super::rk4::UNROLLED_UP_TO;
    use super::super::rk4::tests::{Memory, get, put, run};
    use super::super::rk4::{comp, kept, state};
    use super::*;

    /// The generated finish and embedded error are `finish_in` and `embedded_error_in` in f32
    /// bit for bit (the CPU's `Imex::finish` and `Imex::filtered_error` run those two),
    /// unrolled (N = 4) and as a loop over the segments (N = 27).
    #[test]
    fn the_recorded_finish_and_error_are_the_cpu_engines() {
        for n in [4, UNROLLED_UP_TO + 3] {
            let (h, dim) = (7e-4f32, 2 * n + 1);
            let v = |j: usize, s: f32| (j as f32 * 0.53 + s).sin();
            let y: Vec<f32> = (0..dim).map(|j| v(j, 0.3)).collect();
            let cy: Vec<f32> = (0..dim).map(|j| 1e-8 * v(j, 0.9)).collect();
            let f = [0, 1, 2, 3].map(|s| {
                (0..dim)
                    .map(|j| 40.0 * v(j, s as f32))
                    .collect::<Vec<f32>>()
            });
            let mut mem = Memory::from([("h".to_string(), h)]);
            put(&mut mem, n, &state(), &y);
            put(&mut mem, n, &comp(), &cy);
            for (j, fj) in f.iter().enumerate() {
                put(&mut mem, n, &kept(j), fj);
            }
            let (mut want_y, mut want_c, mut want_e) = (y.clone(), cy.clone(), vec![0f32; dim]);
            finish_in(&mut want_y, &f, &mut want_c, h);
            embedded_error_in(&f, h, &mut want_e);
            let done = run(n, finish_of, &mem);
            let (got_y, got_c) = (get(&done, n, &state()), get(&done, n, &comp()));
            let got_e = get(&run(n, error_of, &mem), n, &error_names());
            for j in 0..dim {
                assert_eq!(got_y[j].to_bits(), want_y[j].to_bits(), "N {n} y[{j}]");
                assert_eq!(got_c[j].to_bits(), want_c[j].to_bits(), "N {n} c[{j}]");
                assert_eq!(got_e[j].to_bits(), want_e[j].to_bits(), "N {n} e[{j}]");
            }
        }
    }
}
