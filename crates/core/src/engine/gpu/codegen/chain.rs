//! The chain as WGSL: [`Chain::rates`], [`Chain::rates_on`], [`Chain::energy_in`] and
//! [`Chain::penetrations`] of `crate::model::chain`, and the twin's saltation
//! (`crate::engine::twin::saltation_lanes`), recorded on [`Sym`] for one [`ChainShape`] and
//! written out unrolled (no loop, no array of its own).
//!
//! The shape's levers are the kernel's `lev[i]` (zero past an instance's contact segment), so
//! one shape serves every contact height up to its lever count. The derivatives read and write
//! the thread kernel's stage state (`shaders/common.wgsl`): the angles `sth`, rates `som` and
//! voltage `svolt`, the instance's coefficients `P` and levers `lev`; θ̈ into `acc_out`, v̇ into
//! `dvolt_out`. The energy, the bumper flags and the saltation read the step's state `th`, `om`,
//! `volt` (and the twin's `tw_th`, `tw_om`).

use super::sym::{Sym, input, record};
use super::wgsl::{Function, emit};
use crate::model::{Branches, Chain, ChainShape, Coefficient, ContactLaw, Lane};
use crate::reduce::lyapunov::{NormCoefficient, distance2_in};

/// Where the kernel reads coefficient `c` (`GpuInstanceParams` and the `levers` buffer).
fn read(c: Coefficient) -> String {
    let field = match c {
        Coefficient::Lever(i) => return format!("lev[{i}]"),
        Coefficient::SegLength => "seg_len",
        Coefficient::SegMass => "seg_mass",
        Coefficient::SegInertia => "seg_inertia",
        Coefficient::TipMass => "tip_mass",
        Coefficient::HolderInertia => "holder_inertia",
        Coefficient::Gravity => "g",
        Coefficient::JointStiffness => "k",
        Coefficient::RootStiffness => "k0",
        Coefficient::JointDamping => "b",
        Coefficient::RootDamping => "b0",
        Coefficient::BumperGap => "gap",
        Coefficient::BumperStiffness => "kc",
        Coefficient::BumperDamping => "cc",
        Coefficient::PiezoInvCapacitance => "piezo_inv_c",
        Coefficient::PiezoInvLoad => "piezo_inv_r",
        Coefficient::PiezoCoupling => "piezo_theta",
    };
    format!("P.{field}")
}

/// The chain whose coefficients are kernel inputs (inside a recording).
fn coefficients(shape: ChainShape) -> Chain<Sym> {
    Chain::from_coefficients(shape, |c| input(read(c)))
}

/// The chain and the stage state `[θ; θ̇; v]` as kernel inputs (inside a recording).
fn symbolic(shape: ChainShape) -> (Chain<Sym>, Vec<Sym>) {
    let chain = coefficients(shape);
    let n = shape.segments;
    let mut y: Vec<Sym> = (0..n).map(|i| input(format!("sth[{i}]"))).collect();
    y.extend((0..n).map(|i| input(format!("som[{i}]"))));
    y.push(input("svolt"));
    (chain, y)
}

/// θ̈ into `acc_out`, v̇ into `dvolt_out`.
fn rate_stores(n: usize, dy: &[Sym]) -> Vec<(String, Sym)> {
    let mut stores: Vec<(String, Sym)> = (0..n)
        .map(|i| (format!("acc_out[{i}]"), dy[n + i]))
        .collect();
    stores.push(("dvolt_out".into(), dy[2 * n]));
    stores
}

/// The derivative by the scene's law, returning the bumpers' branches as 4 bits (+x on,
/// +x damped, −x on, −x damped): `chain_rates`.
fn rates(shape: ChainShape) -> String {
    let n = shape.segments;
    let (tape, (dy, load)) = record(|| {
        let (chain, y) = symbolic(shape);
        let mut ws = chain.workspace();
        let mut dy = vec![Sym::splat(0.0); y.len()];
        let load = chain.rates(&mut ws, input("cart_a"), &y, &mut dy, ContactLaw::Exact);
        (dy, load)
    });
    let mut stores = rate_stores(n, &dy);
    let tail = match load {
        Some(b) => {
            let bits = [b.branches.right.0, b.branches.right.1];
            let bits = bits
                .into_iter()
                .chain([b.branches.left.0, b.branches.left.1]);
            stores.extend(bits.enumerate().map(|(k, s)| (format!("let b{k}"), s)));
            "    return u32(b0) | (u32(b1) << 1u) | (u32(b2) << 2u) | (u32(b3) << 3u);\n"
        }
        None => "    return 0u;\n",
    };
    emit(
        &tape,
        &Function {
            doc: &[
                "Chain::rates (the scene's law) at the stage state: θ̈ into acc_out, v̇ into",
                "dvolt_out; returns the bumpers' branches (bits: +x on, +x damped, −x on, −x damped).",
            ],
            signature: "fn chain_rates(cart_a: f32) -> u32",
            stores,
            tail,
        },
    )
}

/// The derivative with each bumper on the branches of `b` (bits as [`rates`] returns them):
/// `chain_rates_on`, the twin of λ1 on its main trajectory's branches.
fn rates_on(shape: ChainShape) -> String {
    let n = shape.segments;
    let (tape, dy) = record(|| {
        let (chain, y) = symbolic(shape);
        let mut ws = chain.workspace();
        let mut dy = vec![Sym::splat(0.0); y.len()];
        let bit = |k: u32| input(format!("f32((b >> {k}u) & 1u)"));
        let branches = Branches {
            right: (bit(0), bit(1)),
            left: (bit(2), bit(3)),
        };
        chain.rates_on(&mut ws, input("cart_a"), &y, &mut dy, branches);
        dy
    });
    emit(
        &tape,
        &Function {
            doc: &[
                "Chain::rates_on: the bumpers on the branches of `b` (bits as chain_rates returns).",
            ],
            signature: "fn chain_rates_on(cart_a: f32, b: u32)",
            stores: rate_stores(n, &dy),
            tail: "",
        },
    )
}

/// λ1's twin's saltation at a contact onset (`onsets`: bit 0 the +x bumper, bit 1 the −x
/// one) after a step of the main state (`th`, `om`, `volt`): the twin's rates `tw_om` take
/// the impulse of [`crate::engine::twin::saltation_lanes`] (nothing without bumpers, where
/// no contact begins).
fn twin_saltation(shape: ChainShape) -> String {
    let n = shape.segments;
    let (tape, rates) = record(|| {
        let chain = coefficients(shape);
        let mut ws = chain.workspace();
        let y: Vec<Sym> = (0..2 * n + 1).map(|j| step_state(n, j)).collect();
        let mut twin = twin_state(n);
        let bit = |k: u32| input(format!("f32((onsets >> {k}u) & 1u)"));
        crate::engine::twin::saltation_lanes(&chain, &mut ws, &y, &mut twin, (bit(0), bit(1)));
        shape.contact.map(|_| twin[n..2 * n].to_vec())
    });
    let stores = rates.map_or_else(Vec::new, |r| {
        r.iter()
            .enumerate()
            .map(|(i, &s)| (format!("tw_om[{i}]"), s))
            .collect()
    });
    emit(
        &tape,
        &Function {
            doc: &[
                "saltation_lanes (src/engine/twin.rs): the twin's rates at a contact onset of the main state (onsets: bit 0 +x, bit 1 −x).",
            ],
            signature: "fn twin_saltation(onsets: u32)",
            stores,
            tail: "",
        },
    )
}

/// The bumper flags at the step's state `th`: bit 0 the +x bumper penetrated, bit 1 the −x
/// one ([`Chain::penetrations`]; 0 without bumpers).
fn touch_flags(shape: ChainShape) -> String {
    let n = shape.segments;
    let (tape, pen) = record(|| {
        let chain = coefficients(shape);
        let y: Vec<Sym> = (0..2 * n + 1).map(|j| step_state(n, j)).collect();
        chain.penetrations(&y)
    });
    let (stores, tail) = match pen {
        Some((right, left)) => (
            vec![("let right".into(), right), ("let left".into(), left)],
            "    return select(0u, 1u, right > 0.0f) | select(0u, 2u, left > 0.0f);\n",
        ),
        None => (Vec::new(), "    return 0u;\n"),
    };
    emit(
        &tape,
        &Function {
            doc: &[
                "Chain::penetrations at the step's state th: bit 0 the +x bumper penetrated, bit 1 the −x one.",
            ],
            signature: "fn touch_flags() -> u32",
            stores,
            tail,
        },
    )
}

/// The state `[θ; θ̇; v]` at the start of the step, as the kernel reads it (`th`, `om`,
/// `volt`): component j of it.
fn step_state(n: usize, j: usize) -> Sym {
    match j {
        j if j < n => input(format!("th[{j}]")),
        j if j < 2 * n => input(format!("om[{}]", j - n)),
        _ => input("volt"),
    }
}

/// λ1's twin `[θ; θ̇; v]` as the kernel's inputs `tw_th`, `tw_om`, `tw_volt`.
fn twin_state(n: usize) -> Vec<Sym> {
    let mut twin: Vec<Sym> = (0..n).map(|i| input(format!("tw_th[{i}]"))).collect();
    twin.extend((0..n).map(|i| input(format!("tw_om[{i}]"))));
    twin.push(input("tw_volt"));
    twin
}

/// The stored energy at the step's state (`th`, `om`, `volt`) with the cart at velocity
/// `cart_v`: `Energy::total_j` of [`Chain::energy_in`], in f32, for the health check.
fn energy(shape: ChainShape) -> String {
    let n = shape.segments;
    let (tape, total) = record(|| {
        let chain = coefficients(shape);
        let [kinetic, gravity, springs, contact, electric] =
            chain.energy_in(|j| step_state(n, j), input("cart_v"), |x| x);
        kinetic + gravity + springs + contact + electric
    });
    emit(
        &tape,
        &Function {
            doc: &[
                "Chain::energy_in at the step's state (th, om, volt): the stored energy (J), Energy::total_j's sum.",
            ],
            signature: "fn energy(cart_v: f32) -> f32",
            stores: vec![("let e".into(), total)],
            tail: "    return e;\n",
        },
    )
}

/// Where the kernel reads the twin norm's coefficient `c` (the chain's own, and the norm's
/// weights and scale in `GpuInstanceParams`).
fn read_norm(c: NormCoefficient) -> &'static str {
    match c {
        NormCoefficient::SegLength => "P.seg_len",
        NormCoefficient::SegMass => "P.seg_mass",
        NormCoefficient::SegInertia => "P.seg_inertia",
        NormCoefficient::TipMass => "P.tip_mass",
        NormCoefficient::HolderInertia => "P.holder_inertia",
        NormCoefficient::JointStiffness => "P.k",
        NormCoefficient::RootStiffness => "P.k0",
        NormCoefficient::RigidWeight => "P.twin_rigid_w",
        NormCoefficient::VoltWeight => "P.twin_volt_w",
        NormCoefficient::Scale => "P.twin_scale",
    }
}

/// The squared norm of λ1's separation ([`distance2_in`]) of the twin from the main state:
/// `twin_norm2`. (Its initial direction, `TwinNorm::direction`, is formed on the host in f64
/// as the CPU forms it, and reaches the kernel as `P.twin_start_*`.)
fn twin_norm2(shape: ChainShape) -> String {
    let n = shape.segments;
    let (tape, d2) = record(|| {
        let diff = |k: usize| match k {
            k if k < n => input(format!("tw_th[{k}]")) - input(format!("th[{k}]")),
            k if k < 2 * n => input(format!("tw_om[{}]", k - n)) - input(format!("om[{}]", k - n)),
            _ => input("tw_volt") - input("volt"),
        };
        distance2_in(n, true, |c| input(read_norm(c)), diff)
    });
    emit(
        &tape,
        &Function {
            doc: &[
                "distance2_in of λ1's separation: the twin (tw_th, tw_om, tw_volt) less the main state (th, om, volt).",
            ],
            signature: "fn twin_norm2() -> f32",
            stores: vec![("let d2".into(), d2)],
            tail: "    return d2;\n",
        },
    )
}

/// The chain's functions for `shape`.
pub(crate) fn chain_wgsl(shape: ChainShape) -> String {
    [
        rates(shape),
        rates_on(shape),
        energy(shape),
        touch_flags(shape),
        twin_saltation(shape),
        twin_norm2(shape),
    ]
    .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::load_scene;
    use crate::model::{ContactDamping, ModelParams, Workspace};

    /// The default scene at N segments, with the piezo on and the given bumper law.
    fn params(n: usize, law: &str) -> ModelParams {
        let sets = [
            format!("beam.segments={n}"),
            "piezo.enabled=true".to_string(),
            format!("limiter.damping_law=\"{law}\""),
        ];
        load_scene(None, &sets).unwrap().model_params().unwrap()
    }

    /// A state with both bumpers' branches visited over the seeds: a lean of up to ±0.45 rad
    /// (the default clearance is 20°) bent a little, rates of a few rad/s, a voltage.
    fn state(n: usize, seed: u32) -> Vec<f32> {
        let r = |k: u32| ((seed * 7919 + k * 104_729) % 2000) as f32 / 1000.0 - 1.0;
        let lean = 0.45 * r(1000);
        let mut y: Vec<f32> = (0..n as u32).map(|i| lean + 0.05 * r(i)).collect();
        let swing = 3.0 * r(2000);
        y.extend((0..n as u32).map(|i| swing + 0.5 * r(100 + i)));
        y.push(3.0 * r(999));
        y
    }

    /// The value of the kernel input `expr` for instance `p`: a named scalar of `extra`, the
    /// main state `y` (read as the stage state `sth`/`som`/`svolt` or the step's
    /// `th`/`om`/`volt`), the twin's `twin`, a lever, or a coefficient of `P`.
    fn bind(
        expr: &str,
        p: &ModelParams,
        (y, twin): (&[f32], &[f32]),
        extra: &[(&str, f32)],
    ) -> f32 {
        if let Some(&(_, v)) = extra.iter().find(|(k, _)| *k == expr) {
            return v;
        }
        let n = p.segments;
        let (base, rest) = expr.split_once('[').unwrap_or((expr, ""));
        let at = || rest.trim_end_matches(']').parse::<usize>().unwrap();
        match base {
            "sth" | "th" => y[at()],
            "som" | "om" => y[n + at()],
            "svolt" | "volt" => y[2 * n],
            "tw_th" => twin[at()],
            "tw_om" => twin[n + at()],
            "tw_volt" => twin[2 * n],
            "lev" => Coefficient::Lever(at()).of(p) as f32,
            _ => {
                let c = ALL_COEFFICIENTS.iter().find(|&&c| read(c) == expr);
                c.unwrap_or_else(|| panic!("no input {expr}")).of(p) as f32
            }
        }
    }

    /// The recorded program, run on numbers, gives the CPU engine's f32 derivative bit for
    /// bit: the kernel computes what `Chain::rates` computes, in its order (the GPU's own
    /// `sin`, `cos` and rounding aside, which the parity suite bounds).
    #[test]
    fn the_recording_computes_what_the_chain_computes_bit_for_bit() {
        for (n, law) in [(3, "loading"), (17, "loading"), (5, "kelvin_voigt")] {
            let p = params(n, law);
            let shape = ChainShape::of(&p).every_lever();
            let (tape, (dy, load)) = record(|| {
                let (chain, y) = symbolic(shape);
                let mut ws = chain.workspace();
                let mut dy = vec![Sym::splat(0.0); y.len()];
                let load = chain.rates(&mut ws, input("cart_a"), &y, &mut dy, ContactLaw::Exact);
                (dy, load.map(|b| b.branches))
            });
            let chain = Chain::<f32>::new(&p);
            let mut ws: Workspace<f32> = chain.workspace();
            let (mut switched, mut pushing) = (0, 0);
            for seed in 0..64 {
                let y = state(n, seed);
                let cart_a = 5.0 * (seed as f32 - 20.0);
                let value = |e: &str| bind(e, &p, (&y, &[]), &[("cart_a", cart_a)]);
                let v = tape.eval(value);
                let mut want = vec![0f32; y.len()];
                let rep = chain.rates(&mut ws, cart_a, &y, &mut want, ContactLaw::Exact);
                for i in n..y.len() {
                    assert_eq!(
                        v[dy[i].index()].to_bits(),
                        want[i].to_bits(),
                        "N {n} seed {seed} [{i}]"
                    );
                }
                let (br, want_br) = (load.unwrap().right, rep.unwrap().branches.right);
                assert_eq!((v[br.0.index()], v[br.1.index()]), want_br);
                pushing += usize::from(want_br.0 > 0.0);
                switched += usize::from(want_br.0 > 0.0 && want_br.1 == 0.0);
            }
            assert!(pushing > 0, "N {n}: no state pressed the +x bumper");
            if p.contact.as_ref().unwrap().law == ContactDamping::Loading {
                assert!(switched > 0, "N {n}: no state on the undamped branch");
            }
        }
    }

    /// The recorded energy, run on numbers, is `Chain::energy_in` in f32 bit for bit, and that
    /// is `Chain::energy` (in f64) to f32's precision.
    #[test]
    fn the_recorded_energy_is_the_chains() {
        for (n, law) in [(3, "loading"), (17, "kelvin_voigt")] {
            let p = params(n, law);
            let shape = ChainShape::of(&p).every_lever();
            let (tape, total) = record(|| {
                let chain = coefficients(shape);
                let e = chain.energy_in(|j| step_state(n, j), input("cart_v"), |x| x);
                e[0] + e[1] + e[2] + e[3] + e[4]
            });
            let chain = Chain::<f32>::new(&p);
            for seed in 0..16 {
                let y = state(n, seed);
                let cart_v = 0.1 * (seed as f32 - 8.0);
                let value = |e: &str| bind(e, &p, (&y, &[]), &[("cart_v", cart_v)]);
                let got = tape.eval(value)[total.index()];
                let e = chain.energy_in(|j| y[j], cart_v, |x| x);
                let want = e[0] + e[1] + e[2] + e[3] + e[4];
                assert_eq!(got.to_bits(), want.to_bits(), "N {n} seed {seed}");
                let wide = chain.energy(&y, f64::from(cart_v)).total_j();
                assert!(
                    (f64::from(got) - wide).abs() <= 1e-5 * wide.abs().max(1.0),
                    "{got} {wide}"
                );
            }
        }
    }

    /// The recorded saltation, run on numbers, is `saltation_lanes` in f32 bit for bit.
    #[test]
    fn the_recorded_saltation_is_the_twins() {
        let (n, p) = (5, params(5, "loading"));
        let shape = ChainShape::of(&p).every_lever();
        let (tape, rates) = record(|| {
            let chain = coefficients(shape);
            let mut ws = chain.workspace();
            let y: Vec<Sym> = (0..2 * n + 1).map(|j| step_state(n, j)).collect();
            let mut twin = twin_state(n);
            let flags = (input("right"), input("left"));
            crate::engine::twin::saltation_lanes(&chain, &mut ws, &y, &mut twin, flags);
            twin
        });
        let chain = Chain::<f32>::new(&p);
        let mut ws = chain.workspace();
        for seed in 0..8 {
            let (y, mut twin) = (state(n, seed), state(n, seed + 100));
            let flags = ((seed % 2) as f32, (seed / 2 % 2) as f32);
            let extra = [("right", flags.0), ("left", flags.1)];
            let value = |e: &str| bind(e, &p, (&y, &twin), &extra);
            let v = tape.eval(value);
            crate::engine::twin::saltation_lanes(&chain, &mut ws, &y, &mut twin, flags);
            for i in n..2 * n {
                assert_eq!(
                    v[rates[i].index()].to_bits(),
                    twin[i].to_bits(),
                    "seed {seed} [{i}]"
                );
            }
        }
    }

    /// The recorded norm of λ1's separation, run on numbers, is `distance2_in` in f32 bit for
    /// bit, and its root is `TwinNorm::distance` (in f64) to f32's precision.
    #[test]
    fn the_recorded_twin_norm_is_the_lyapunov_stages() {
        use crate::reduce::lyapunov::TwinNorm;
        let (n, p) = (4, params(4, "loading"));
        let norm = TwinNorm::of(&p, 60.0);
        let (tape, d2) = record(|| {
            let diff = |k: usize| match k {
                k if k < n => input(format!("tw_th[{k}]")) - input(format!("th[{k}]")),
                k if k < 2 * n => {
                    input(format!("tw_om[{}]", k - n)) - input(format!("om[{}]", k - n))
                }
                _ => input("tw_volt") - input("volt"),
            };
            distance2_in(n, true, |c| input(read_norm(c)), diff)
        });
        for seed in 0..8 {
            let (y, twin) = (state(n, seed), state(n, seed + 50));
            // The norm's own words of `P`; the chain's coefficients are the instance's.
            let extra = [
                NormCoefficient::RigidWeight,
                NormCoefficient::VoltWeight,
                NormCoefficient::Scale,
            ]
            .map(|c| (read_norm(c), norm.coefficient(c) as f32));
            let value = |e: &str| bind(e, &p, (&y, &twin), &extra);
            let got = tape.eval(value)[d2.index()];
            let want = distance2_in(n, true, |c| norm.coefficient(c) as f32, |k| twin[k] - y[k]);
            assert_eq!(got.to_bits(), want.to_bits(), "seed {seed}");
            let wide = norm.distance(n, 2 * n + 1, |k| f64::from(twin[k]) - f64::from(y[k]));
            assert!(
                (f64::from(got).sqrt() - wide).abs() <= 1e-5 * wide,
                "{got} {wide}"
            );
        }
    }

    const ALL_COEFFICIENTS: [Coefficient; 16] = [
        Coefficient::SegLength,
        Coefficient::SegMass,
        Coefficient::SegInertia,
        Coefficient::TipMass,
        Coefficient::HolderInertia,
        Coefficient::Gravity,
        Coefficient::JointStiffness,
        Coefficient::RootStiffness,
        Coefficient::JointDamping,
        Coefficient::RootDamping,
        Coefficient::BumperGap,
        Coefficient::BumperStiffness,
        Coefficient::BumperDamping,
        Coefficient::PiezoInvCapacitance,
        Coefficient::PiezoInvLoad,
        Coefficient::PiezoCoupling,
    ];
}
