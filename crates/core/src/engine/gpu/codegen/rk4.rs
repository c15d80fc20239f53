//! Classical RK4's arithmetic as WGSL: the stage states, the compensated finish, and adaptive
//! steps' candidate and error estimate, recorded on [`Sym`] from the functions of
//! `crate::engine::rk4` that the CPU engine's RK4 runs ([`stage`] with [`stage_step`],
//! [`finish_in`], [`candidate_in`], [`estimate_in`]), unrolled for the shape's N.
//!
//! They read the thread kernel's state (`th`, `om`, `volt`), its compensation (`th_c`, `om_c`,
//! `volt_c`) and the stage derivatives kept by `keep_stage` (`f_th[j]`, `f_om[j]`, `f_v[j]`,
//! `shaders/common.wgsl`), and write the stage state (`sth`, `som`, `svolt`) or the state.

use super::sym::{Sym, input, record};
use super::wgsl::{Part, emit_parts};
use crate::engine::rk4::{candidate_in, estimate_in, finish_in, stage, stage_step};

/// Chains of up to this many segments get RK4's functions (and the IMEX method's element-wise
/// ones, `super::imex`) unrolled; longer ones a loop over
/// the segments, whose body is the same functions recorded on one segment's θ and θ̇ (they
/// are element-wise), with the voltage after it. Unrolled at N = 64, lavapipe's first compile
/// of the RK4 kernel took 85.4 s against 56.3 s for the hand-written loops it replaced
/// (`docs/bench/GENERATED_KERNELS.md`).
pub(crate) const UNROLLED_UP_TO: usize = 24;

/// A component of the state as one part of a function reads it: θ or θ̇ of the segment
/// `index` (a number, or the loop's `i`), or the voltage.
pub(super) enum Comp {
    Th(String),
    Om(String),
    Volt,
}

/// The kernel's names of a vector `[θ; θ̇; v]`: two arrays and a scalar.
pub(super) type Names = [String; 3];

pub(super) fn names(th: &str, om: &str, v: &str) -> Names {
    [th.to_string(), om.to_string(), v.to_string()]
}

impl Comp {
    /// The component's expression in the vector `n`.
    pub(super) fn expr(&self, n: &Names) -> String {
        match self {
            Comp::Th(i) => format!("{}[{i}]", n[0]),
            Comp::Om(i) => format!("{}[{i}]", n[1]),
            Comp::Volt => n[2].clone(),
        }
    }
}

/// The parts a function for chains of `n` segments is written in: all 2N + 1 components in
/// one straight-line part, or (above [`UNROLLED_UP_TO`]) a loop's part on (θ_i, θ̇_i) and
/// the voltage's part after it.
pub(super) fn layout(n: usize) -> Vec<(bool, Vec<Comp>)> {
    if n > UNROLLED_UP_TO {
        let each = vec![Comp::Th("i".into()), Comp::Om("i".into())];
        return vec![(true, each), (false, vec![Comp::Volt])];
    }
    let mut all: Vec<Comp> = (0..n).map(|i| Comp::Th(i.to_string())).collect();
    all.extend((0..n).map(|i| Comp::Om(i.to_string())));
    all.push(Comp::Volt);
    vec![(false, all)]
}

/// The components `comps` of the vector `n` as kernel inputs (inside a recording).
pub(super) fn vector(comps: &[Comp], n: &Names) -> Vec<Sym> {
    comps.iter().map(|c| input(c.expr(n))).collect()
}

/// `values` stored into the components `comps` of the vector `n`.
pub(super) fn stores(comps: &[Comp], n: &Names, values: &[Sym]) -> Vec<(String, Sym)> {
    comps
        .iter()
        .map(|c| c.expr(n))
        .zip(values.iter().copied())
        .collect()
}

pub(super) fn state() -> Names {
    names("th", "om", "volt")
}

pub(super) fn comp() -> Names {
    names("th_c", "om_c", "volt_c")
}

pub(super) fn stage_state_names() -> Names {
    names("sth", "som", "svolt")
}

/// Stage `j`'s derivative as kept by `keep_stage`.
pub(super) fn kept(j: usize) -> Names {
    names(
        &format!("f_th[{j}]"),
        &format!("f_om[{j}]"),
        &format!("f_v[{j}]"),
    )
}

/// The four stage derivatives' components `comps`.
pub(super) fn stages(comps: &[Comp]) -> [Vec<Sym>; 4] {
    [0, 1, 2, 3].map(|j| vector(comps, &kept(j)))
}

/// The function `signature` for chains of `n` segments: `f`, given the components of a part,
/// recorded on each part of [`layout`], returns that part's stores.
pub(super) fn written(
    n: usize,
    doc: &str,
    signature: &str,
    f: impl Fn(&[Comp]) -> Vec<(String, Sym)>,
) -> String {
    let parts: Vec<Part> = layout(n)
        .into_iter()
        .map(|(per_segment, comps)| {
            let (tape, stores) = record(|| f(&comps));
            Part {
                tape,
                stores,
                per_segment,
            }
        })
        .collect();
    emit_parts(&[doc], signature, &parts)
}

/// Stage `j`'s state `y + h c_j k_{j−1}` into the stage state (components `c`).
fn stage_state_of(c: &[Comp], j: usize) -> Vec<(String, Sym)> {
    let y = vector(c, &state());
    let mut out = y.clone();
    stage(
        &mut out,
        &y,
        &vector(c, &kept(j - 1)),
        stage_step(input("h"), j),
    );
    stores(c, &stage_state_names(), &out)
}

/// `y += h (k₁ + 2k₂ + 2k₃ + k₄)/6`, compensated (components `c`).
fn finish_of(c: &[Comp]) -> Vec<(String, Sym)> {
    let (mut y, mut cy) = (vector(c, &state()), vector(c, &comp()));
    finish_in(&mut y, &stages(c), &mut cy, input("h"));
    let mut all = stores(c, &state(), &y);
    all.extend(stores(c, &comp(), &cy));
    all
}

/// The candidate `y₄ = y + (Δ − c)` into the stage state (components `c`).
fn candidate_of(c: &[Comp]) -> Vec<(String, Sym)> {
    let y = vector(c, &state());
    let mut end = y.clone();
    candidate_in(&y, &stages(c), &vector(c, &comp()), input("h"), &mut end);
    stores(c, &stage_state_names(), &end)
}

/// The estimate `h (k₄ − k₅)/6`, k₅ the derivative just taken (`som`, `acc_out`,
/// `dvolt_out`), into the stage state (components `c`).
fn estimate_of(c: &[Comp]) -> Vec<(String, Sym)> {
    let k5 = vector(c, &names("som", "acc_out", "dvolt_out"));
    let mut out = k5.clone();
    estimate_in(&vector(c, &kept(3)), &k5, input("h"), &mut out);
    stores(c, &stage_state_names(), &out)
}

/// RK4's functions for chains of `n` segments.
pub(crate) fn rk4_wgsl(n: usize) -> String {
    let mut parts: Vec<String> = (1..4)
        .map(|j| {
            written(
                n,
                "stage and stage_step (src/engine/rk4.rs): stage j's state y + h c_j k_{j−1} into (sth, som, svolt).",
                &format!("fn rk4_stage_state_{j}(h: f32)"),
                |c| stage_state_of(c, j),
            )
        })
        .collect();
    parts.push(written(
        n,
        "finish_in (src/engine/rk4.rs): the state advanced by the stages kept, y += h (k₁ + 2k₂ + 2k₃ + k₄)/6 with compensation.",
        "fn rk4_finish(h: f32)",
        finish_of,
    ));
    parts.push(written(
        n,
        "candidate_in (src/engine/rk4.rs): the state rk4_finish would leave, y + (Δ − c), into (sth, som, svolt).",
        "fn rk4_candidate(h: f32)",
        candidate_of,
    ));
    parts.push(written(
        n,
        "estimate_in (src/engine/rk4.rs): h (k₄ − k₅)/6, k₅ the last derivative, into (sth, som, svolt).",
        "fn rk4_estimate(h: f32)",
        estimate_of,
    ));
    parts.join("\n")
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::engine::rk4::Rk4;
    use crate::engine::stepper::{CartClock, Stepper};
    use crate::model::{Chain, ContactLaw, ModelParams, Workspace};
    use std::collections::HashMap;

    /// The kernel's values, each array element and scalar by its expression (`th[3]`, `h`).
    pub(crate) type Memory = HashMap<String, f32>;

    /// Put the vector `v` (`[θ; θ̇; v]` of `n` segments) under the names `names`.
    pub(crate) fn put(mem: &mut Memory, n: usize, names: &Names, v: &[f32]) {
        for (j, &x) in v.iter().enumerate() {
            mem.insert(at(n, names, j), x);
        }
    }

    /// The vector under `names`.
    pub(crate) fn get(mem: &Memory, n: usize, names: &Names) -> Vec<f32> {
        (0..2 * n + 1).map(|j| mem[&at(n, names, j)]).collect()
    }

    fn at(n: usize, names: &Names, j: usize) -> String {
        let c = match j {
            j if j < n => Comp::Th(j.to_string()),
            j if j < 2 * n => Comp::Om((j - n).to_string()),
            _ => Comp::Volt,
        };
        c.expr(names)
    }

    /// What the function `f` writes, run as the kernel runs it for chains of `n` segments
    /// (each part of [`layout`], a loop's part once per segment) on the values `mem`.
    pub(crate) fn run(n: usize, f: impl Fn(&[Comp]) -> Vec<(String, Sym)>, mem: &Memory) -> Memory {
        let mut out = Memory::new();
        for (per_segment, comps) in layout(n) {
            let (tape, stores) = record(|| f(&comps));
            let segments: Vec<Option<usize>> = match per_segment {
                true => (0..n).map(Some).collect(),
                false => vec![None],
            };
            for seg in segments {
                let sub =
                    |e: &str| seg.map_or(e.to_string(), |i| e.replace("[i]", &format!("[{i}]")));
                // (`ctl.one` is the run-time 1 of `Lane::opaque`.)
                let v = tape.eval(|e| match e {
                    "ctl.one" => 1.0,
                    _ => *mem.get(&sub(e)).unwrap_or_else(|| panic!("no input {e}")),
                });
                for (target, value) in &stores {
                    out.insert(sub(target), v[value.index()]);
                }
            }
        }
        out
    }

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

    /// A state of `n` segments: a lean of up to ±0.4 rad bent a little, rates, a voltage.
    fn state_of(n: usize, seed: u32) -> Vec<f32> {
        let r = |k: u32| ((seed * 7919 + k * 104_729) % 2000) as f32 / 1000.0 - 1.0;
        let mut y: Vec<f32> = (0..n as u32).map(|i| 0.4 * r(1) + 0.05 * r(i)).collect();
        y.extend((0..n as u32).map(|i| 2.0 * r(50 + i)));
        y.push(r(99));
        y
    }

    /// The generated stage states and finish, run as the kernel runs them with the chain's own
    /// f32 derivative between them, take the CPU engine's f32 RK4 step bit for bit: unrolled
    /// (N = 5) and as a loop over the segments (N = 30).
    #[test]
    fn the_recorded_rk4_step_is_the_cpu_engines() {
        for n in [5, UNROLLED_UP_TO + 6] {
            let p = params(n);
            let chain = Chain::<f32>::new(&p);
            let mut ws: Workspace<f32> = chain.workspace();
            let dt = 2.5e-4f32;
            for seed in 0..4u32 {
                let y = state_of(n, seed);
                let mut cpu = Rk4::<f32>::new(f64::from(dt), y.len());
                let mut want = y.clone();
                cpu.step(&chain, &mut ws, &mut want, 0, &Steady(3.0));
                let mut mem = Memory::from([("h".to_string(), dt)]);
                put(&mut mem, n, &state(), &y);
                put(&mut mem, n, &comp(), &vec![0.0; y.len()]);
                let mut at_stage = y.clone();
                for j in 0..4 {
                    if j > 0 {
                        let out = run(n, |c| stage_state_of(c, j), &mem);
                        at_stage = get(&out, n, &stage_state_names());
                    }
                    let mut k = vec![0f32; y.len()];
                    chain.rates(&mut ws, 3.0, &at_stage, &mut k, ContactLaw::Exact);
                    put(&mut mem, n, &kept(j), &k);
                }
                let got = get(&run(n, finish_of, &mem), n, &state());
                for (j, (g, w)) in got.iter().zip(&want).enumerate() {
                    assert_eq!(g.to_bits(), w.to_bits(), "N {n} seed {seed} [{j}]");
                }
            }
        }
    }

    /// The generated candidate and estimate are `candidate_in` and `estimate_in` in f32 bit
    /// for bit (the CPU's `Rk4Pair::error` runs those two), unrolled and as a loop.
    #[test]
    fn the_recorded_candidate_and_estimate_are_the_pairs() {
        for n in [4, UNROLLED_UP_TO + 3] {
            let (h, dim) = (1e-3f32, 2 * n + 1);
            let v = |j: usize, s: f32| (j as f32 * 0.37 + s).sin();
            let y: Vec<f32> = (0..dim).map(|j| v(j, 0.1)).collect();
            let cy: Vec<f32> = (0..dim).map(|j| 1e-8 * v(j, 0.2)).collect();
            let k = [0, 1, 2, 3].map(|s| (0..dim).map(|j| v(j, s as f32)).collect::<Vec<f32>>());
            let k5: Vec<f32> = (0..dim).map(|j| v(j, 0.7)).collect();
            let mut mem = Memory::from([("h".to_string(), h)]);
            put(&mut mem, n, &state(), &y);
            put(&mut mem, n, &comp(), &cy);
            for (j, kj) in k.iter().enumerate() {
                put(&mut mem, n, &kept(j), kj);
            }
            put(&mut mem, n, &names("som", "acc_out", "dvolt_out"), &k5);
            let (mut want_end, mut want_out) = (vec![0f32; dim], vec![0f32; dim]);
            candidate_in(&y, &k, &cy, h, &mut want_end);
            estimate_in(&k[3], &k5, h, &mut want_out);
            let end = get(&run(n, candidate_of, &mem), n, &stage_state_names());
            let out = get(&run(n, estimate_of, &mem), n, &stage_state_names());
            for j in 0..dim {
                assert_eq!(end[j].to_bits(), want_end[j].to_bits(), "N {n} [{j}]");
                assert_eq!(out[j].to_bits(), want_out[j].to_bits(), "N {n} [{j}]");
            }
        }
    }

    /// Up to [`UNROLLED_UP_TO`] segments the functions have no loop; above it each has one.
    #[test]
    fn long_chains_get_a_loop_over_the_segments() {
        let short = rk4_wgsl(UNROLLED_UP_TO);
        assert!(!short.contains("for ("), "{short}");
        let long = rk4_wgsl(UNROLLED_UP_TO + 1);
        assert_eq!(long.matches("for (var i = 0u; i < N_SEG; i++)").count(), 6);
        assert!(long.contains("th[i] = "), "{long}");
    }
}
