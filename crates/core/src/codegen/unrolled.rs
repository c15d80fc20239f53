//! The CPU engine's chain solve unrolled for its common shapes: [`Chain::rates`] and
//! [`Chain::rates_on`] recorded on [`Sym`] for one [`ChainShape`] and written out as Rust,
//! generic over the lane type, into `crates/core/src/model/chain_unrolled.rs`.
//!
//! The generic solve loops over the segments and keeps its sweep in a workspace; lavapipe runs
//! the same operations as the straight-line code of the generated kernels, with every value in
//! a register. The unrolled functions give the CPU engine that too, for the shapes the shipped
//! scenes have ([`unrolled_shapes`]); other shapes keep the generic solve. They do the generic
//! solve's operations in its order, so every engine's numbers are unchanged bit for bit (a
//! test holds each against the generic solve in every lane type). The file is written by the
//! test that checks it is current (the sourcegen pattern, as for the top-level `shaders/`).

use super::rust::{Function, emit};
use super::sym::{Sym, input, record};
use crate::model::{Branches, Chain, ChainShape, ContactDamping, ContactLaw, Lane};

/// The shapes the CPU engine runs unrolled: the embedded default scene at N = 3 and 17, with
/// either bumper law, without and with its piezo patch.
pub fn unrolled_shapes() -> Vec<ChainShape> {
    let mut shapes = Vec::new();
    for n in [3, 17] {
        for law in ["loading", "kelvin_voigt"] {
            for piezo in [false, true] {
                let sets = [
                    format!("beam.segments={n}"),
                    format!("limiter.damping_law=\"{law}\""),
                    format!("piezo.enabled={piezo}"),
                ];
                let scene = crate::config::load_scene(None, &sets)
                    .expect("the embedded default scene loads");
                let params = scene
                    .model_params()
                    .expect("the embedded default scene builds");
                let shape = ChainShape::of(&params);
                if !shapes.contains(&shape) {
                    shapes.push(shape);
                }
            }
        }
    }
    shapes
}

/// The name of a shape's functions: `n3_l3_loading_p1` (segments, levers and law, piezo's
/// last segment).
fn tag(shape: ChainShape) -> String {
    let mut t = format!("n{}", shape.segments);
    if let Some((levers, law)) = shape.contact {
        let law = match law {
            ContactDamping::Loading => "loading",
            ContactDamping::KelvinVoigt => "kelvin_voigt",
        };
        t += &format!("_l{levers}_{law}");
    }
    if let Some(last) = shape.piezo_last {
        t += &format!("_p{last}");
    }
    t
}

/// The match pattern of a shape in `for_shape`.
fn pattern(shape: ChainShape) -> String {
    let contact = shape.contact.map_or("None".into(), |(levers, law)| {
        format!("Some(({levers}, ContactDamping::{law:?}))")
    });
    let piezo = shape
        .piezo_last
        .map_or("None".into(), |last| format!("Some({last})"));
    format!("({}, {contact}, {piezo})", shape.segments)
}

/// One function: the derivative by the exact law, or (`on`) with each bumper on the branches
/// `b`.
fn rates(shape: ChainShape, on: bool) -> String {
    let d = 2 * shape.segments + 1;
    let (tape, (dy, load)) = record(|| {
        let chain = Chain::from_coefficients(shape, |c| {
            input(format!("c.coefficient(Coefficient::{c:?})"))
        });
        let y: Vec<Sym> = (0..d).map(|i| input(format!("y[{i}]"))).collect();
        let mut ws = chain.workspace();
        let mut dy = vec![Sym::splat(0.0); d];
        let cart_a = input("cart_a");
        let load = if on {
            let b = Branches {
                right: (input("b.right.0"), input("b.right.1")),
                left: (input("b.left.0"), input("b.left.1")),
            };
            chain.rates_on(&mut ws, cart_a, &y, &mut dy, b)
        } else {
            chain.rates(&mut ws, cart_a, &y, &mut dy, ContactLaw::Exact)
        };
        (dy, load)
    });
    let mut stores: Vec<(String, Sym)> = dy
        .iter()
        .enumerate()
        .map(|(i, &s)| (format!("dy[{i}]"), s))
        .collect();
    let tail = match load {
        Some(l) => {
            let named = [
                ("force_x_n", l.force_x_n),
                ("right_m", l.right_m),
                ("left_m", l.left_m),
                ("right_on", l.branches.right.0),
                ("right_damped", l.branches.right.1),
                ("left_on", l.branches.left.0),
                ("left_damped", l.branches.left.1),
            ];
            stores.extend(named.map(|(name, s)| (format!("let {name}"), s)));
            "    Some(BumperLoad {\n        force_x_n,\n        right_m,\n        left_m,\n        \
             branches: Branches {\n            right: (right_on, right_damped),\n            \
             left: (left_on, left_damped),\n        },\n    })\n"
        }
        None => "    None\n",
    };
    let (name, extra, doc) = if on {
        ("rates_on", ", b: Branches<T>", "[`Chain::rates_on`]")
    } else {
        ("rates", "", "[`Chain::rates`] by the exact law")
    };
    let signature = format!(
        "pub(super) fn {name}_{}<T: Lane>(c: &Chain<T>, cart_a: T, y: &[T], dy: &mut [T]{extra}) -> Option<BumperLoad<T>>",
        tag(shape)
    );
    let doc = format!("{doc}, unrolled for `{}`.", pattern(shape));
    let preamble = format!("    let (y, dy) = (&y[..{d}], &mut dy[..{d}]);\n");
    emit(
        &tape,
        &Function {
            doc: &[&doc],
            signature: &signature,
            preamble: &preamble,
            stores,
            tail,
        },
    )
}

/// The text of `crates/core/src/model/chain_unrolled.rs`.
pub fn unrolled_source() -> String {
    let shapes = unrolled_shapes();
    let mut out = format!(
        "{}\n\
         //! The chain's derivative unrolled for the shapes of the shipped scenes: [`Chain::rates`] \
         and\n\
         //! [`Chain::rates_on`] recorded and written out by `crate::codegen::unrolled`, the same\n\
         //! operations in the same order, with every value a local. `Chain::from_lanes` picks\n\
         //! them by shape ([`for_shape`]); other shapes run the generic solve.\n\
         #![allow(clippy::all, clippy::pedantic)]\n\n\
         use super::chain::{{BumperLoad, Chain, Coefficient, Unrolled}};\n\
         use super::{{Branches, ChainShape, ContactDamping, Lane}};\n\n",
        super::GENERATED_LINE
    );
    out += "/// The unrolled functions of `shape`, where it is one of the shapes generated.\n";
    out += "pub(super) fn for_shape<T: Lane>(shape: ChainShape) -> Option<Unrolled<T>> {\n";
    out += "    Some(match (shape.segments, shape.contact, shape.piezo_last) {\n";
    for &s in &shapes {
        let t = tag(s);
        out += &format!(
            "        {} => Unrolled {{\n            rates: rates_{t},\n            rates_on: rates_on_{t},\n        }},\n",
            pattern(s)
        );
    }
    out += "        _ => return None,\n    })\n}\n";
    for &s in &shapes {
        out += "\n";
        out += &rates(s, false);
        out += "\n";
        out += &rates(s, true);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Coefficient, F32x8, F64x4, ModelParams, Real};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The parameters of each unrolled shape, from the scene it was taken from.
    fn params_of_shapes() -> Vec<ModelParams> {
        let mut out: Vec<ModelParams> = Vec::new();
        for n in [3, 17] {
            for law in ["loading", "kelvin_voigt"] {
                for piezo in [false, true] {
                    let sets = [
                        format!("beam.segments={n}"),
                        format!("limiter.damping_law=\"{law}\""),
                        format!("piezo.enabled={piezo}"),
                    ];
                    let scene = crate::config::load_scene(None, &sets).expect("scene");
                    out.push(scene.model_params().expect("params"));
                }
            }
        }
        out
    }

    /// Every lane of `a` and `b` the same bits.
    fn same<T: Lane>(a: T, b: T, what: &str) {
        for i in 0..T::LANES {
            let (x, y) = (a.lane(i).wide(), b.lane(i).wide());
            assert_eq!(x.to_bits(), y.to_bits(), "{what}, lane {i}: {x:e} vs {y:e}");
        }
    }

    /// The unrolled derivative against the generic solve, both laws of evaluation, at random
    /// states of chains of `p` (bumpers penetrated, pulled apart and free among them).
    fn unrolled_is_generic<T: Lane>(p: &ModelParams, rng: &mut ChaCha8Rng) {
        let fast = Chain::<T>::new(p);
        assert!(fast.is_unrolled(), "{:?}", ChainShape::of(p));
        let slow = fast.clone().generic();
        let d = 2 * p.segments + 1;
        let mut ws = slow.workspace();
        for _ in 0..200 {
            let y: Vec<T> = (0..d)
                .map(|i| {
                    T::gather(|_| match i {
                        i if i < p.segments => rng.random_range(-0.6..0.6),
                        i if i < 2 * p.segments => rng.random_range(-20.0..20.0),
                        _ => rng.random_range(-5.0..5.0),
                    })
                })
                .collect();
            let cart = T::gather(|_| rng.random_range(-50.0..50.0));
            let mut bit = || T::gather(|_| f64::from(rng.random_range(0..2u8)));
            let branches = Branches {
                right: (bit(), bit()),
                left: (bit(), bit()),
            };
            let (mut a, mut b) = (vec![T::splat(0.0); d], vec![T::splat(0.0); d]);
            for on in [false, true] {
                let (la, lb) = if on {
                    let la = fast.rates_on(&mut ws, cart, &y, &mut a, branches);
                    (la, slow.rates_on(&mut ws, cart, &y, &mut b, branches))
                } else {
                    let la = fast.rates(&mut ws, cart, &y, &mut a, ContactLaw::Exact);
                    (la, slow.rates(&mut ws, cart, &y, &mut b, ContactLaw::Exact))
                };
                for i in 0..d {
                    same(a[i], b[i], &format!("dy[{i}], on = {on}"));
                }
                let (la, lb) = (la.expect("bumpers"), lb.expect("bumpers"));
                same(la.force_x_n, lb.force_x_n, "force");
                same(la.right_m, lb.right_m, "right");
                same(la.left_m, lb.left_m, "left");
                for (x, y) in [
                    (la.branches.right, lb.branches.right),
                    (la.branches.left, lb.branches.left),
                ] {
                    same(x.0, y.0, "on");
                    same(x.1, y.1, "damped");
                }
            }
        }
    }

    #[test]
    fn the_unrolled_derivative_is_the_generic_one_bit_for_bit_in_every_lane_type() {
        let mut rng = ChaCha8Rng::seed_from_u64(73);
        let params = params_of_shapes();
        assert_eq!(
            params.iter().map(ChainShape::of).collect::<Vec<_>>(),
            unrolled_shapes()
        );
        for p in &params {
            unrolled_is_generic::<f64>(p, &mut rng);
            unrolled_is_generic::<f32>(p, &mut rng);
            unrolled_is_generic::<F64x4>(p, &mut rng);
            unrolled_is_generic::<F32x8>(p, &mut rng);
        }
    }

    #[test]
    fn a_chain_of_another_shape_runs_the_generic_solve() {
        let scene = crate::config::load_scene(None, &["beam.segments=5".into()]).expect("scene");
        let chain = Chain::<f64>::new(&scene.model_params().expect("params"));
        assert!(!chain.is_unrolled());
    }

    #[test]
    fn every_coefficient_reads_back_as_the_chain_was_built() {
        let shape = unrolled_shapes()[1];
        let index = |c: Coefficient| match c {
            Coefficient::Lever(i) => 100.0 + i as f64,
            other => format!("{other:?}").len() as f64,
        };
        let chain = Chain::<f64>::from_coefficients(shape, index);
        let levers = shape.contact.map_or(0, |(l, _)| l);
        for i in 0..levers {
            assert_eq!(
                chain.coefficient(Coefficient::Lever(i)),
                index(Coefficient::Lever(i))
            );
        }
        assert_eq!(chain.coefficient(Coefficient::Lever(levers)), 0.0);
        for c in Coefficient::NAMED {
            assert_eq!(chain.coefficient(c), index(c), "{c:?}");
        }
    }

    /// `crates/core/src/model/chain_unrolled.rs` is what the generator writes now (the
    /// sourcegen pattern): a change of the chain's Rust that is not written out fails here.
    /// `PENDULUM_ATLAS_UPDATE_SHADERS=1` writes it anew.
    #[test]
    fn the_unrolled_chain_file_is_current() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/model/chain_unrolled.rs");
        let text = unrolled_source();
        if std::env::var_os("PENDULUM_ATLAS_UPDATE_SHADERS").is_some() {
            std::fs::write(&path, &text).expect("write chain_unrolled.rs");
        }
        let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            on_disk == text,
            "crates/core/src/model/chain_unrolled.rs is stale: run `PENDULUM_ATLAS_UPDATE_SHADERS=1 \
             cargo test --release -p pendulum-atlas-core unrolled_chain_file` and commit it"
        );
    }
}
