//! The GPU side that needs no adapter: the structs shared with WGSL have the same layout in
//! both languages, the assembled shader validates, its generated header carries the Rust
//! definitions; and, with an adapter, one device compiles each kernel set once.

use pendulum_atlas_core::engine::gpu::kernels::{SHADER_STAGES, shader_header, shader_source};
use pendulum_atlas_core::engine::gpu::layout::{
    ACCUM_ENGINE_WORDS, GpuAccum, GpuControl, GpuInstanceParams,
};
use pendulum_atlas_core::model::{CHECK_EVERY, Status};
use pendulum_atlas_core::schema::{GPU_SLOTS, gpu_fields};

/// Member offsets of a Rust struct, by name.
macro_rules! offsets {
    ($t:ty; $($f:ident),* $(,)?) => {
        vec![$((stringify!($f), std::mem::offset_of!($t, $f))),*]
    };
}

fn module() -> naga::Module {
    module_for(3)
}

fn module_for(segments: usize) -> naga::Module {
    let src = shader_source(segments);
    naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)))
}

/// (member name, offset) of a WGSL struct, and its size.
fn wgsl_layout(module: &naga::Module, name: &str) -> (Vec<(String, usize)>, usize) {
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name)
            && let naga::TypeInner::Struct { members, span } = &ty.inner
        {
            let m = members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
                .collect();
            return (m, *span as usize);
        }
    }
    panic!("struct {name} not found in the shader");
}

fn assert_same_layout(
    module: &naga::Module,
    wgsl: &str,
    rust: Vec<(&str, usize)>,
    rust_size: usize,
) {
    let (members, span) = wgsl_layout(module, wgsl);
    let names: Vec<&str> = members.iter().map(|(n, _)| n.as_str()).collect();
    let rust_names: Vec<&str> = rust.iter().map(|(n, _)| *n).collect();
    assert_eq!(names, rust_names, "{wgsl}: member names and order");
    for ((n, wo), (_, ro)) in members.iter().zip(&rust) {
        assert_eq!(wo, ro, "{wgsl}.{n}: WGSL offset {wo}, Rust offset {ro}");
    }
    assert_eq!(span, rust_size, "{wgsl}: size");
}

#[test]
fn parameter_structs_have_the_same_layout_in_rust_and_wgsl() {
    let m = module();
    assert_same_layout(
        &m,
        "InstanceParams",
        offsets!(GpuInstanceParams; seg_len, seg_mass, seg_inertia, tip_mass, holder_inertia, g,
            k, k0, b, b0, gap, kc, cc, piezo_inv_c, piezo_inv_r, piezo_theta, pos_amp, vel_amp,
            acc_amp, dt, guard_energy, guard_bend, theta0, omega0, volt0, half_clearance,
            guard_holder, phase0, n_levers, piezo_last, spp, transient_periods, total_periods, strobe_offset,
            strobe_count, r_every, r_count, r_start, imex_offset, contact_law, twin_start,
            twin_align, twin_window, twin_d0, twin_rigid_w, twin_scale, period_s, rtol, atol),
        size_of::<GpuInstanceParams>(),
    );
    // Accum: the result schema's GPU words first, one word each, then the engine's own.
    let mut accum: Vec<(&str, usize)> = gpu_fields()
        .enumerate()
        .map(|(i, (_, g))| (g.member, 4 * i))
        .collect();
    accum.extend(
        offsets!(GpuAccum; touch, well, sub_pos, power_comp, sub_steps, lyap_sums,
        lyap_n, twin_flags, tw_start, tw_window, p_hops, p_impacts, p_power, p_amin, p_amax,
        e_phase, e_p, e_until, e_seen, e_last, stopped, level, sub_onsets),
    );
    assert_eq!(std::mem::offset_of!(GpuAccum, slots), 0);
    let engine: Vec<&str> = ACCUM_ENGINE_WORDS.iter().map(|w| w.0).collect();
    assert_eq!(
        engine,
        accum[GPU_SLOTS..].iter().map(|a| a.0).collect::<Vec<_>>()
    );
    assert_same_layout(&m, "Accum", accum, size_of::<GpuAccum>());
    assert_same_layout(
        &m,
        "Control",
        offsets!(GpuControl; n_inst, steps_per_dispatch, strobe_stride, rwork_stride,
            period_max, period_window, period_tol, c_index, slice_first, slice_end, n_active,
            e_p_max, e_window, e_tol, e_alpha_off, e_period_off, e_r_off, e_r_len, pass_budget, live_from),
        size_of::<GpuControl>(),
    );
}

#[test]
fn the_assembled_shader_validates_without_an_adapter() {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module())
    .unwrap_or_else(|e| panic!("{e:?}"));
    // At the smallest and the largest N too: the arrays are sized by N (MAX_SEG).
    for n in [1, 64] {
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module_for(n))
        .unwrap_or_else(|e| panic!("N = {n}: {e:?}"));
    }
    // Every stage file of shaders/ is part of the assembly, and nothing else is there.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/core/shaders");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .expect("shaders/")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    on_disk.sort();
    let mut assembled: Vec<String> = SHADER_STAGES.iter().map(|(n, _)| n.to_string()).collect();
    assembled.sort();
    assert_eq!(on_disk, assembled);
}

/// The value of a `const NAME: u32 = …u;` of the assembled shader, as naga evaluates it.
fn wgsl_const(module: &naga::Module, name: &str) -> u32 {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no const {name} in the shader"));
    match module.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::U32(v)) => v,
        ref other => panic!("{name} = {other:?}"),
    }
}

#[test]
fn the_shader_takes_status_codes_and_the_check_interval_from_rust() {
    let m = module();
    for s in Status::ALL {
        assert_eq!(wgsl_const(&m, s.wgsl_name()), u32::from(s.code()), "{s}");
        assert_eq!(Status::from_code(u32::from(s.code())), Some(s));
    }
    assert_eq!(u64::from(wgsl_const(&m, "CHECK_EVERY")), CHECK_EVERY);
    for law in pendulum_atlas_core::model::ContactDamping::ALL {
        assert_eq!(wgsl_const(&m, law.wgsl_name()), law.gpu_code(), "{law:?}");
    }
    // The stage files carry no copy of their own.
    for (name, text) in SHADER_STAGES {
        for s in Status::ALL {
            assert!(
                !text.contains(&format!("const {}", s.wgsl_name())),
                "{name} defines {s}"
            );
        }
        assert!(
            !text.contains("const CHECK_EVERY"),
            "{name} defines CHECK_EVERY"
        );
    }
    assert!(shader_header(17).contains("const MAX_SEG: u32 = 17u;"));
}

/// The literal of a `const NAME` of the assembled shader, as naga evaluates it.
fn wgsl_literal(module: &naga::Module, name: &str) -> naga::Literal {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no const {name} in the shader"));
    match module.global_expressions[c.init] {
        naga::Expression::Literal(l) => l,
        ref other => panic!("{name} = {other:?}"),
    }
}

#[test]
fn the_shader_takes_regime_codes_thresholds_and_twin_flags_from_rust() {
    use pendulum_atlas_core::engine::gpu::layout::{TWIN_BROKEN, TWIN_RUNNING};
    use pendulum_atlas_core::reduce::Regime;
    use pendulum_atlas_core::reduce::lyapunov::LYAPUNOV_BLOCKS;
    use pendulum_atlas_core::reduce::regime::{REGIME_FLAT_PER_PERIOD, REGIME_K_CHAOS, REGIME_Z};
    let m = module();
    for r in Regime::ALL {
        assert_eq!(
            wgsl_literal(&m, r.wgsl_name()),
            naga::Literal::I32(i32::from(r.code())),
            "{r}"
        );
    }
    for (name, v) in [
        ("REGIME_Z", REGIME_Z),
        ("REGIME_FLAT", REGIME_FLAT_PER_PERIOD),
        ("REGIME_K_CHAOS", REGIME_K_CHAOS),
    ] {
        assert_eq!(
            wgsl_literal(&m, name),
            naga::Literal::F32(v as f32),
            "{name}"
        );
    }
    assert_eq!(
        wgsl_const(&m, "K_FIRM_SAMPLES") as usize,
        pendulum_atlas_core::analysis::ZERO_ONE_COMFORTABLE_SAMPLES
    );
    assert_eq!(wgsl_const(&m, "LYAPUNOV_BLOCKS") as usize, LYAPUNOV_BLOCKS);
    assert_eq!(wgsl_const(&m, "TWIN_RUNNING"), TWIN_RUNNING);
    assert_eq!(wgsl_const(&m, "TWIN_BROKEN"), TWIN_BROKEN);
    for (name, text) in SHADER_STAGES {
        for r in Regime::ALL {
            assert!(
                !text.contains(&format!("const {}", r.wgsl_name())),
                "{name} defines {r}"
            );
        }
        assert!(!text.contains("const REGIME_Z"), "{name} defines REGIME_Z");
    }
}

#[test]
fn one_gpu_device_compiles_each_kernel_set_once() {
    use pendulum_atlas_core::engine::gpu::{AdapterChoice, GpuContext};
    use pendulum_atlas_core::engine::{Engine, no_progress};
    if super::gpu().is_none() {
        return;
    }
    // A fresh device, so that the suite's other tests do not count.
    let engine = Engine::gpu(
        GpuContext::new(AdapterChoice::Any).expect("adapter"),
        String::new(),
        0.0,
    );
    let ctx = engine.gpu_context().expect("gpu");
    let k_only = super::cases::tiny_map(
        super::Under {
            eng: super::Eng::Gpu,
            method: pendulum_atlas_core::engine::method::Method::Rk4,
            adaptive: false,
        },
        "",
        "metrics = [\"K\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [5.0, 8.0]",
    );
    let hops = super::cases::tiny_map(
        super::Under {
            eng: super::Eng::Gpu,
            method: pendulum_atlas_core::engine::method::Method::Rk4,
            adaptive: false,
        },
        "",
        "metrics = [\"hops\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [5.0, 8.0]",
    );
    for spec in [&k_only, &k_only, &hops, &k_only, &hops] {
        pendulum_atlas_map::map::run_map(spec, &engine, &no_progress).expect("map");
    }
    assert_eq!(ctx.compiled_kernel_sets(), 2);
}
