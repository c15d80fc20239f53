//! Classical RK4's arithmetic as WGSL: the stage states, the compensated finish, and adaptive
//! steps' candidate and error estimate, recorded on [`Sym`] from the functions of
//! `crate::engine::rk4` that the CPU engine's RK4 runs ([`stage`] with [`stage_step`],
//! [`finish_in`], [`candidate_in`], [`estimate_in`]), unrolled for the shape's N.
//!
//! They read the thread kernel's state (`th`, `om`, `volt`), its compensation (`th_c`, `om_c`,
//! `volt_c`) and the stage derivatives kept by `keep_stage` (`f_th[j]`, `f_om[j]`, `f_v[j]`,
//! `shaders/common.wgsl`), and write the stage state (`sth`, `som`, `svolt`) or the state.

use super::sym::{Sym, input, record};
use super::wgsl::{Function, emit};
use crate::engine::rk4::{candidate_in, estimate_in, finish_in, stage, stage_step};

/// A vector `[θ; θ̇; v]` of N segments held in the kernel as the arrays `th`, `om` and the
/// scalar `v` (names such as `("th", "om", "volt")`): component `j`'s expression.
fn component((th, om, v): (&str, &str, &str), n: usize, j: usize) -> String {
    match j {
        j if j < n => format!("{th}[{j}]"),
        j if j < 2 * n => format!("{om}[{}]", j - n),
        _ => v.to_string(),
    }
}

/// The vector `names` as kernel inputs (inside a recording).
fn inputs(names: (&str, &str, &str), n: usize) -> Vec<Sym> {
    (0..2 * n + 1)
        .map(|j| input(component(names, n, j)))
        .collect()
}

/// Stage `j`'s derivative as kept by `keep_stage`.
fn kept(n: usize, j: usize) -> Vec<Sym> {
    let (th, om, v) = (
        format!("f_th[{j}]"),
        format!("f_om[{j}]"),
        format!("f_v[{j}]"),
    );
    inputs((&th, &om, &v), n)
}

/// The four stage derivatives.
fn stages(n: usize) -> [Vec<Sym>; 4] {
    [0, 1, 2, 3].map(|j| kept(n, j))
}

/// `values` stored into the vector `names`.
fn stores(names: (&str, &str, &str), values: &[Sym]) -> Vec<(String, Sym)> {
    let n = (values.len() - 1) / 2;
    let at = |j| component(names, n, j);
    values
        .iter()
        .enumerate()
        .map(|(j, &s)| (at(j), s))
        .collect()
}

const STATE: (&str, &str, &str) = ("th", "om", "volt");
const COMP: (&str, &str, &str) = ("th_c", "om_c", "volt_c");
const STAGE_STATE: (&str, &str, &str) = ("sth", "som", "svolt");

/// Stage `j`'s state `y + h c_j k_{j−1}` into the stage state: `rk4_stage_state_j`.
fn stage_state(n: usize, j: usize) -> String {
    let (tape, out) = record(|| {
        let y = inputs(STATE, n);
        let mut out = y.clone();
        stage(&mut out, &y, &kept(n, j - 1), stage_step(input("h"), j));
        out
    });
    emit(
        &tape,
        &Function {
            doc: &[
                "stage and stage_step (src/engine/rk4.rs): stage j's state y + h c_j k_{j−1} into (sth, som, svolt).",
            ],
            signature: &format!("fn rk4_stage_state_{j}(h: f32)"),
            stores: stores(STAGE_STATE, &out),
            tail: "",
        },
    )
}

/// `y += h (k₁ + 2k₂ + 2k₃ + k₄)/6`, compensated: `rk4_finish`.
fn finish(n: usize) -> String {
    let (tape, (y, comp)) = record(|| {
        let (mut y, mut comp) = (inputs(STATE, n), inputs(COMP, n));
        finish_in(&mut y, &stages(n), &mut comp, input("h"));
        (y, comp)
    });
    let mut all = stores(STATE, &y);
    all.extend(stores(COMP, &comp));
    emit(
        &tape,
        &Function {
            doc: &[
                "finish_in (src/engine/rk4.rs): the state advanced by the stages kept, y += h (k₁ + 2k₂ + 2k₃ + k₄)/6 with compensation.",
            ],
            signature: "fn rk4_finish(h: f32)",
            stores: all,
            tail: "",
        },
    )
}

/// The candidate `y₄ = y + (Δ − c)` into the stage state: `rk4_candidate`.
fn candidate(n: usize) -> String {
    let (tape, end) = record(|| {
        let (y, comp) = (inputs(STATE, n), inputs(COMP, n));
        let mut end = y.clone();
        candidate_in(&y, &stages(n), &comp, input("h"), &mut end);
        end
    });
    emit(
        &tape,
        &Function {
            doc: &[
                "candidate_in (src/engine/rk4.rs): the state rk4_finish would leave, y + (Δ − c), into (sth, som, svolt).",
            ],
            signature: "fn rk4_candidate(h: f32)",
            stores: stores(STAGE_STATE, &end),
            tail: "",
        },
    )
}

/// The estimate `h (k₄ − k₅)/6`, k₅ the derivative just taken (`som`, `acc_out`,
/// `dvolt_out`), into the stage state: `rk4_estimate`.
fn estimate(n: usize) -> String {
    let (tape, out) = record(|| {
        let k5 = inputs(("som", "acc_out", "dvolt_out"), n);
        let mut out = k5.clone();
        estimate_in(&kept(n, 3), &k5, input("h"), &mut out);
        out
    });
    emit(
        &tape,
        &Function {
            doc: &[
                "estimate_in (src/engine/rk4.rs): h (k₄ − k₅)/6, k₅ the last derivative, into (sth, som, svolt).",
            ],
            signature: "fn rk4_estimate(h: f32)",
            stores: stores(STAGE_STATE, &out),
            tail: "",
        },
    )
}

/// RK4's functions for chains of `n` segments.
pub(crate) fn rk4_wgsl(n: usize) -> String {
    let mut parts: Vec<String> = (1..4).map(|j| stage_state(n, j)).collect();
    parts.extend([finish(n), candidate(n), estimate(n)]);
    parts.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::rk4::Rk4;
    use crate::engine::stepper::{CartClock, Stepper};
    use crate::model::{Chain, ModelParams, Workspace};

    fn params(n: usize) -> ModelParams {
        let sets = [format!("beam.segments={n}"), "piezo.enabled=true".into()];
        crate::config::load_scene(None, &sets)
            .unwrap()
            .model_params()
            .unwrap()
    }

    /// A cart of constant acceleration `a`, for steps of a known cart.
    struct Steady(f64);
    impl CartClock for Steady {
        fn acceleration(&self, _: u64, _: f64) -> f64 {
            self.0
        }
        fn velocity(&self, _: u64) -> f64 {
            0.0
        }
    }

    /// The generated stage states and finish, run on numbers with the chain's own f32
    /// derivative between them, take the CPU engine's f32 RK4 step bit for bit.
    #[test]
    fn the_recorded_rk4_step_is_the_cpu_engines() {
        let n = 5;
        let p = params(n);
        let chain = Chain::<f32>::new(&p);
        let mut ws: Workspace<f32> = chain.workspace();
        let dt = 2.5e-4f32;
        let tapes: Vec<_> = (1..4)
            .map(|j| {
                record(|| {
                    let y = inputs(STATE, n);
                    let mut out = y.clone();
                    stage(&mut out, &y, &kept(n, j - 1), stage_step(input("h"), j));
                    out
                })
            })
            .collect();
        let (fin, (fy, _)) = record(|| {
            let (mut y, mut comp) = (inputs(STATE, n), inputs(COMP, n));
            finish_in(&mut y, &stages(n), &mut comp, input("h"));
            (y, comp)
        });
        for seed in 0..6u32 {
            let r = |k: u32| ((seed * 7919 + k * 104_729) % 2000) as f32 / 1000.0 - 1.0;
            let mut y: Vec<f32> = (0..n as u32).map(|i| 0.4 * r(1) + 0.05 * r(i)).collect();
            y.extend((0..n as u32).map(|i| 2.0 * r(50 + i)));
            y.push(r(99));
            let mut cpu = Rk4::<f32>::new(f64::from(dt), y.len());
            let mut want = y.clone();
            cpu.step(&chain, &mut ws, &mut want, 0, &Steady(3.0));
            // The kernel's sequence: k₀ at y, then each stage's state and its derivative.
            let mut k: Vec<Vec<f32>> = Vec::new();
            let mut at = y.clone();
            for j in 0..4 {
                if j > 0 {
                    let value = |e: &str| bind(e, n, &y, &k, &[], dt);
                    let v = tapes[j - 1].0.eval(value);
                    at = tapes[j - 1].1.iter().map(|s| v[s.index()]).collect();
                }
                let mut dy = vec![0f32; y.len()];
                chain.rates(&mut ws, 3.0, &at, &mut dy, crate::model::ContactLaw::Exact);
                k.push(dy);
            }
            let comp = vec![0f32; y.len()];
            let v = fin.eval(|e| bind(e, n, &y, &k, &comp, dt));
            for j in 0..y.len() {
                assert_eq!(
                    v[fy[j].index()].to_bits(),
                    want[j].to_bits(),
                    "seed {seed} [{j}]"
                );
            }
        }
    }

    /// The generated candidate and estimate, run on numbers, are `candidate_in` and
    /// `estimate_in` in f32 bit for bit (the CPU's `Rk4Pair::error` runs those two).
    #[test]
    fn the_recorded_candidate_and_estimate_are_the_pairs() {
        let n = 4;
        let (h, dim) = (1e-3f32, 2 * n + 1);
        let (tc, end) = record(|| {
            let (y, comp) = (inputs(STATE, n), inputs(COMP, n));
            let mut end = y.clone();
            candidate_in(&y, &stages(n), &comp, input("h"), &mut end);
            end
        });
        let (te, out) = record(|| {
            let k5 = inputs(("som", "acc_out", "dvolt_out"), n);
            let mut out = k5.clone();
            estimate_in(&kept(n, 3), &k5, input("h"), &mut out);
            out
        });
        let v = |j: usize, s: f32| (j as f32 * 0.37 + s).sin();
        let y: Vec<f32> = (0..dim).map(|j| v(j, 0.1)).collect();
        let comp: Vec<f32> = (0..dim).map(|j| 1e-8 * v(j, 0.2)).collect();
        let k: Vec<Vec<f32>> = (0..4)
            .map(|s| (0..dim).map(|j| v(j, s as f32)).collect())
            .collect();
        let k5: Vec<f32> = (0..dim).map(|j| v(j, 0.7)).collect();
        let karr = [k[0].clone(), k[1].clone(), k[2].clone(), k[3].clone()];
        let (mut want_end, mut want_out) = (vec![0f32; dim], vec![0f32; dim]);
        candidate_in(&y, &karr, &comp, h, &mut want_end);
        estimate_in(&k[3], &k5, h, &mut want_out);
        let got = tc.eval(|e| bind(e, n, &y, &k, &comp, h));
        let k5_at =
            |e: &str| (0..dim).find(|&j| component(("som", "acc_out", "dvolt_out"), n, j) == e);
        let got_out = te.eval(|e| k5_at(e).map_or_else(|| bind(e, n, &y, &k, &comp, h), |j| k5[j]));
        for j in 0..dim {
            assert_eq!(
                got[end[j].index()].to_bits(),
                want_end[j].to_bits(),
                "[{j}]"
            );
            assert_eq!(
                got_out[out[j].index()].to_bits(),
                want_out[j].to_bits(),
                "[{j}]"
            );
        }
    }

    /// The value of a kernel input: the state `y`, the kept stages `k`, the compensation.
    fn bind(e: &str, n: usize, y: &[f32], k: &[Vec<f32>], comp: &[f32], h: f32) -> f32 {
        if e == "h" {
            return h;
        }
        let find = |names: (&str, &str, &str), v: &[f32]| {
            (0..2 * n + 1)
                .find(|&j| component(names, n, j) == e)
                .map(|j| v[j])
        };
        if let Some(x) = find(STATE, y).or_else(|| find(COMP, comp)) {
            return x;
        }
        for (j, kj) in k.iter().enumerate() {
            let names = (
                format!("f_th[{j}]"),
                format!("f_om[{j}]"),
                format!("f_v[{j}]"),
            );
            if let Some(x) = find((&names.0, &names.1, &names.2), kj) {
                return x;
            }
        }
        panic!("no input {e}")
    }
}
