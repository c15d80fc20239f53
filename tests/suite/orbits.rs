//! The orbit stage (`docs/analysis.md`, §15): shooting, Floquet multipliers, continuation and
//! bifurcation curves, held against the linearisation, the reference integrator, λ1 and the
//! map's own periods.

use pendulum_atlas_core::config::{MapSpec, Scene, map_from_toml};
use pendulum_atlas_core::engine::{Engine, EnsemblePlan, InstancePlan, Precision, no_progress};
use pendulum_atlas_core::model::linear::jacobian_eigenvalues;
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_core::reduce::orbits::{
    BifurcationKind, Multipliers, OrbitStatus, Strobe, distance, find_orbit, scales,
};
use pendulum_atlas_map::map::{MapRun, run_map};

/// A map of the default scene's cells at (f, A) pairs given as axes (N = 3, the default
/// map's lengths), with `extra` map keys.
fn cells_map(freqs: &[f64], amps: &[f64], extra: &str) -> MapSpec {
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    let text = format!(
        "[beam]\nsegments = 3\n[integration]\nduration_s = 34.0\ntransient_s = 10.0\n[map]\n{extra}\n\
         [[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [{}]\n\
         [[map.axes]]\nkey = \"excitation.amplitude_m\"\nvalues = [{}]\n",
        list(freqs),
        list(amps)
    );
    map_from_toml(&text, "<test>", &[]).expect("valid test map")
}

fn cpu_map(spec: &MapSpec) -> MapRun {
    let engine = Engine::cpu(Precision::F64);
    run_map(spec, &engine, &no_progress).expect("map")
}

/// The linear system: the clamped cantilever with the bumpers off, lightly damped and
/// forced by a tiny amplitude (its geometric nonlinearity then below rounding). Its orbit is
/// the forced response, and its multipliers are exp(λᵢ T) of the linearisation's eigenvalues.
#[test]
fn a_linear_systems_multipliers_are_the_exponentials_of_its_eigenvalues() {
    let text = "[beam]\nsegments = 3\njoint_damping_nms = 2e-4\n[pivot]\nmode = \"clamped\"\n\
                [limiter]\nenabled = false\n[excitation]\nfrequency_hz = 40.0\namplitude_m = 1e-9\n\
                [integration]\nduration_s = 4.0\ntransient_s = 1.0\nstep = \"fixed\"\ndt_s = 1.25e-5\n\
                [map]\nsettle = false\norbits = false\n\
                [[map.axes]]\nkey = \"excitation.amplitude_m\"\nvalues = [1e-9]\n";
    let spec = map_from_toml(text, "<test>", &[]).expect("valid linear map");
    let plan = EnsemblePlan::new(&spec).expect("plan");
    let inst = &plan.instances[0];
    let orbit = find_orbit::<f64>(inst, &vec![0.0; inst.y0.len()], 1).expect("the forced response");
    assert_eq!(orbit.period, 1);
    let t = 1.0 / inst.frequency_hz;
    let lambdas = jacobian_eigenvalues(&inst.params).expect("linearisation");
    assert_eq!(orbit.multipliers.values.len(), lambdas.len());
    let mut worst = 0.0f64;
    for l in &lambdas {
        let mu = (l * t).exp();
        let err = orbit
            .multipliers
            .values
            .iter()
            .map(|v| ((v[0] - mu.re).powi(2) + (v[1] - mu.im).powi(2)).sqrt())
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(err / mu.norm());
    }
    eprintln!("linear system: worst relative multiplier error {worst:e}");
    assert!(worst <= 1e-6, "worst relative multiplier error {worst:e}");
}

/// A default-map cell's own orbit: converged where the map calls the cell periodic, with
/// the map's period; the stroboscopic map keeps it within 1e-6 rad for 100 periods; its
/// largest multiplier agrees with the reference integrator's monodromy to 1e-3 and with λ1's
/// Floquet exponent within λ1's standard error.
#[test]
fn a_periodic_cells_orbit_is_exact_stable_and_agrees_with_the_reference() {
    // Period 1 and period 3 cells of the default map.
    let spec = cells_map(&[4.254, 6.0], &[0.004], "");
    let run = cpu_map(&spec);
    let orbits = run
        .orbits
        .as_ref()
        .expect("the orbit stage is on by default");
    for k in 0..2 {
        let r = &run.results[k];
        assert_eq!(r.regime, Regime::Periodic, "cell {k}");
        assert_eq!(orbits.status[k], OrbitStatus::Converged, "cell {k}");
        let own = orbits.own_orbit(k).expect("own orbit");
        let o = &own.orbit;
        assert_eq!(f64::from(o.period), r.period, "cell {k}");
        assert!(o.stable(), "cell {k}: {:?}", o.multipliers.values);
        let inst = &run.plan.instances[k];
        let strobe = Strobe::<f64>::new(inst);
        let s = scales(&strobe);
        let mut x = o.x().to_vec();
        for _ in 0..100 {
            x = strobe.advance(&x, o.period).expect("ok");
            let d = distance(&x, o.x(), &s);
            assert!(d <= 1e-6, "cell {k}: drifted {d:e} from its orbit");
        }
        let scene = spec.instance_scene(k).expect("scene");
        let reference = reference_multipliers(&scene, inst, o.x(), o.period);
        let (mu, mu_ref) = (o.multipliers.max_abs, reference.max_abs);
        assert!(
            (mu - mu_ref).abs() <= 1e-3 * mu_ref,
            "cell {k}: max |mu| {mu} against the reference's {mu_ref}"
        );
        let exponent = mu.ln() * inst.frequency_hz / f64::from(o.period);
        eprintln!(
            "cell {k}: period {}, max |mu| {mu} (reference {mu_ref}), exponent {exponent} /s, lambda1 {} ± {} /s",
            o.period, r.lyapunov_per_s, r.lyapunov_se_per_s
        );
        assert!(
            (exponent - r.lyapunov_per_s).abs() <= r.lyapunov_se_per_s,
            "cell {k}: Floquet exponent {exponent} against lambda1 {} ± {}",
            r.lyapunov_per_s,
            r.lyapunov_se_per_s
        );
    }
}

/// The reference integrator's monodromy of `P^p` at `x` (forward differences, DOP853 with
/// located events, `engine::verdict::reference_after`), and its multipliers.
fn reference_multipliers(scene: &Scene, inst: &InstancePlan, x: &[f64], p: u32) -> Multipliers {
    let end = |y0: Vec<f64>| super::engine::verdict::reference_after(scene, &y0, p);
    let s = scales(&Strobe::<f64>::new(inst));
    let base = end(x.to_vec());
    let d = s.len();
    let cols: Vec<Vec<f64>> = (0..d)
        .map(|j| {
            let h = 1e-7 * s[j];
            let mut xp = x.to_vec();
            xp[j] += h;
            end(xp)
                .iter()
                .zip(&base)
                .map(|(a, b)| (a - b) / h)
                .collect()
        })
        .collect();
    Multipliers::of(nalgebra::DMatrix::from_fn(d, d, |r, c| cols[c][r])).expect("eigenvalues")
}

/// Along A = 4 mm the default map's period-1 orbit doubles between 4.64 and 4.76 Hz: the
/// period-doubling point lies within a cell of where the map's period turns from 1 to 2,
/// and its multiplier nearest −1 crosses −1 there.
#[test]
fn a_period_doubling_point_lies_within_a_cell_of_the_maps_period_change() {
    let freqs: Vec<f64> = (0..6).map(|i| 4.381 + 0.127 * f64::from(i)).collect();
    let spec = cells_map(&freqs, &[0.004], "orbits_reach = 1");
    let run = cpu_map(&spec);
    let orbits = run.orbits.as_ref().expect("orbits");
    let pd: Vec<f64> = orbits
        .curves
        .iter()
        .filter(|c| c.kind == BifurcationKind::PeriodDoubling && c.period == 1)
        .flat_map(|c| c.points.iter().map(|p| p[0]))
        .collect();
    assert_eq!(
        pd.len(),
        1,
        "one period doubling of the period-1 orbit: {:?}",
        orbits.curves
    );
    let periods: Vec<f64> = run.results.iter().map(|r| r.period).collect();
    let change = (1..freqs.len())
        .find(|&i| periods[i - 1] == 1.0 && periods[i] == 2.0)
        .unwrap_or_else(|| panic!("the map's period turns from 1 to 2: {periods:?}"));
    let step = freqs[1] - freqs[0];
    eprintln!(
        "period doubling at {} Hz; the map's periods {periods:?}",
        pd[0]
    );
    let boundary = 0.5 * (freqs[change - 1] + freqs[change]);
    assert!(
        (pd[0] - boundary).abs() <= step,
        "period doubling at {} Hz, the map's period changes at {boundary} Hz",
        pd[0]
    );
}

/// Asked for on a map that cannot serve it, the orbit stage is refused by name, with the
/// reason; left to its default there, the map runs without it.
#[test]
fn the_orbit_stage_is_refused_by_name_where_it_cannot_serve() {
    let text = |extra: &str| {
        format!(
            "[beam]\nsegments = 3\n[map]\n{extra}\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [7.8, 8.0]\n"
        )
    };
    for (extra, what) in [
        ("initial_states = 4\norbits = true", "several starts"),
        ("continuation = \"up\"\norbits = true", "continuation"),
        ("metrics = [\"K\", \"period\"]\norbits = true", "regime"),
    ] {
        let e = map_from_toml(&text(extra), "<test>", &[]).expect_err("refused");
        let msg = e.to_string();
        assert!(msg.contains("map.orbits") && msg.contains(what), "{msg}");
    }
    let spec = map_from_toml(&text("initial_states = 4"), "<test>", &[]).expect("valid");
    assert!(spec.orbits.is_none());
    let e = map_from_toml(&text("orbits_reach = 65"), "<test>", &[]).expect_err("refused");
    assert!(e.to_string().contains("map.orbits_reach"), "{e}");
}

/// Every engine gives the same orbits: the stage shoots in f64 from whatever end state the
/// map's engine left, so a map run in f32 (the CPU's, and the GPU's where an adapter answers)
/// finds the f64 map's orbits to Newton's tolerance. The stroboscopic map itself in f32 holds
/// an f64 orbit to f32's precision (stated here).
#[test]
fn every_engine_gives_the_same_orbits_within_its_precision() {
    let spec = cells_map(&[4.254, 6.0], &[0.004], "");
    let f64_run = cpu_map(&spec);
    let cpu32 = Engine::cpu(Precision::F32);
    let mut engines = vec![("cpu f32", &cpu32)];
    engines.extend(super::engine::gpu().map(|g| ("gpu f32", g)));
    for (name, engine) in engines {
        let run = run_map(&spec, engine, &no_progress).expect("map");
        same_orbits(&f64_run, &run, name);
    }
}

/// The own orbits of `run`'s two cells are those of `f64_run`.
fn same_orbits(f64_run: &MapRun, run: &MapRun, name: &str) {
    let (a, b) = (
        f64_run.orbits.as_ref().unwrap(),
        run.orbits.as_ref().unwrap(),
    );
    for k in 0..2 {
        let (oa, ob) = (
            &a.own_orbit(k).expect("f64").orbit,
            &b.own_orbit(k).expect(name).orbit,
        );
        let inst = &f64_run.plan.instances[k];
        let s = scales(&Strobe::<f64>::new(inst));
        let d = oa.nearest_point(ob.x(), &s).1;
        let dmu = (oa.multipliers.max_abs - ob.multipliers.max_abs).abs();
        eprintln!(
            "{name}, cell {k}: the map's orbit {d:e} from the f64 map's, max |mu| {dmu:e} apart"
        );
        assert!(
            oa.period == ob.period && d <= 1e-7 && dmu <= 1e-6,
            "{name}, cell {k}: {d:e}, {dmu:e}"
        );
        let strobe32 = Strobe::<f32>::new(inst);
        let back = strobe32.advance(oa.x(), oa.period).expect("ok");
        let drift = distance(&back, oa.x(), &s);
        eprintln!("cell {k}: one period of the f32 stroboscopic map moves the orbit by {drift:e}");
        assert!(drift <= 1e-6, "cell {k}: {drift:e}");
    }
}
