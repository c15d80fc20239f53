//! The GPU side that needs no adapter: the structs shared with WGSL have the same layout in
//! both languages, the assembled shader validates, its generated header carries the Rust
//! definitions; and, with an adapter, one device compiles each kernel set once.

use pendulum_atlas_core::engine::gpu::codegen::{
    GENERATED, GENERATED_LINE, generated_wgsl, shared_rules,
};
use pendulum_atlas_core::engine::gpu::gpu_struct::{GpuStruct, Member};
use pendulum_atlas_core::engine::gpu::kernels::{
    SHADER_STAGES, shader_header, shader_source, written_kernels,
};
use pendulum_atlas_core::engine::gpu::layout::{GpuAccum, GpuControl, GpuInstanceParams};
use pendulum_atlas_core::model::{CHECK_EVERY, Status};
use pendulum_atlas_core::model::{ChainShape, ContactDamping};
use pendulum_atlas_core::schema::{GPU_SLOTS, gpu_fields};

fn module() -> naga::Module {
    module_for(3)
}

/// The default map's shape at N segments: bumpers on every lever, the loading-only law.
fn shape(segments: usize) -> ChainShape {
    ChainShape {
        segments,
        contact: Some((segments, ContactDamping::Loading)),
        piezo_last: None,
    }
}

fn module_for(segments: usize) -> naga::Module {
    module_of(shape(segments))
}

fn module_of(shape: ChainShape) -> naga::Module {
    let src = shader_source(shape);
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

/// The WGSL member names, offsets and size that naga gives each struct generated from Rust are
/// the Rust struct's (`gpu_struct!`): one definition, one check.
fn assert_generated_layout<T: GpuStruct>(module: &naga::Module, members: Vec<(String, usize)>) {
    let (wgsl, span) = wgsl_layout(module, T::WGSL_NAME);
    assert_eq!(wgsl, members, "{}: member names and offsets", T::WGSL_NAME);
    assert_eq!(span, size_of::<T>(), "{}: size", T::WGSL_NAME);
}

#[test]
fn parameter_structs_have_the_same_layout_in_rust_and_wgsl() {
    let m = module();
    let plain = |members: Vec<Member>| members.into_iter().map(|x| (x.name.to_string(), x.offset));
    assert_generated_layout::<GpuInstanceParams>(&m, plain(GpuInstanceParams::members()).collect());
    assert_generated_layout::<GpuControl>(&m, plain(GpuControl::members()).collect());
    // Accum: its `slots` are the result schema's GPU words, one named member each.
    let mut accum: Vec<(String, usize)> = gpu_fields()
        .enumerate()
        .map(|(i, (_, g))| (g.member.to_string(), 4 * i))
        .collect();
    assert_eq!(accum.len(), GPU_SLOTS);
    accum.extend(plain(GpuAccum::members()).filter(|(name, _)| name != "slots"));
    assert_generated_layout::<GpuAccum>(&m, accum);
}

#[test]
fn the_assembled_shader_validates_without_an_adapter() {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module())
    .unwrap_or_else(|e| panic!("{e:?}"));
    // Each kind of chain: without bumpers, with the Kelvin–Voigt law, with the piezo.
    for shape in [
        ChainShape {
            contact: None,
            ..shape(4)
        },
        ChainShape {
            contact: Some((4, ContactDamping::KelvinVoigt)),
            piezo_last: Some(2),
            ..shape(4)
        },
    ] {
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module_of(shape))
        .unwrap_or_else(|e| panic!("{shape:?}: {e:?}"));
    }
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
        ("REGIME_FLAT_PER_PERIOD", REGIME_FLAT_PER_PERIOD),
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
    assert_eq!(
        wgsl_const(&m, "LYAPUNOV_BLOCK_COUNT") as usize,
        LYAPUNOV_BLOCKS
    );
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

/// The top-level `shaders/` holds the kernels of the main shapes as the GPU compiles them
/// (the "sourcegen" pattern): a change of the Rust model or of a stage file that is not written
/// out fails here. `PENDULUM_ATLAS_UPDATE_SHADERS=1` writes them anew.
#[test]
fn the_kernels_in_the_top_level_shaders_folder_are_current() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let update = std::env::var_os("PENDULUM_ATLAS_UPDATE_SHADERS").is_some();
    let mut names = vec!["README.md".to_string()];
    for (file, text) in written_kernels() {
        let path = dir.join(&file);
        assert!(text.starts_with(GENERATED_LINE), "{file}");
        if update {
            std::fs::write(&path, &text).expect("write shaders/");
        }
        let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            on_disk == text,
            "shaders/{file} is stale: run `PENDULUM_ATLAS_UPDATE_SHADERS=1 cargo test --release \
             --test suite kernels_in_the_top_level` and commit it"
        );
        names.push(file);
    }
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .expect("shaders/")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    names.sort();
    assert_eq!(
        on_disk, names,
        "shaders/ holds the written kernels and its README only"
    );
}

/// What is generated from Rust is listed (`GENERATED`), each function is in the generated part
/// of every shape's kernels, and no hand-written stage file defines one of them.
#[test]
fn the_generated_functions_are_listed_and_written_nowhere_else() {
    for shape in [
        shape(3),
        ChainShape {
            contact: None,
            ..shape(2)
        },
    ] {
        let text = generated_wgsl(shape);
        assert!(text.starts_with(GENERATED_LINE));
        for (name, from) in GENERATED {
            assert!(
                text.contains(&format!("fn {name}(")),
                "{name} ({from}) in {shape:?}"
            );
        }
        // Unrolled: no loop and no array of its own.
        assert!(
            !text.contains("for (") && !text.contains("array<"),
            "{text}"
        );
    }
    for (file, text) in SHADER_STAGES {
        for (name, _) in GENERATED {
            assert!(
                !text.contains(&format!("fn {name}(")),
                "{file} defines {name}"
            );
        }
    }
}

/// The rules written once for Rust and WGSL (`pendulum_atlas_core::rules`) are in every
/// kernel's header, each once, under the module that defines it; no hand-written stage file
/// defines one, and the stage files call each of them.
#[test]
fn the_shared_rules_are_in_the_header_and_written_nowhere_else() {
    let header = shader_header(3);
    let stages: String = SHADER_STAGES.iter().map(|(_, t)| *t).collect();
    let rules: Vec<_> = shared_rules().collect();
    assert!(rules.len() >= 10, "{}", rules.len());
    for rule in &rules {
        let def = format!("fn {}(", rule.name);
        assert_eq!(
            header.matches(&def).count(),
            1,
            "{} in the header",
            rule.name
        );
        assert!(header.contains(&rule.wgsl()), "{}", rule.name);
        assert!(rule.module.starts_with("pendulum_atlas_core::"), "{rule:?}");
        for (file, text) in SHADER_STAGES {
            assert!(!text.contains(&def), "{file} defines {}", rule.name);
        }
        let called = format!("{}(", rule.name);
        assert!(
            stages.contains(&called) || header.matches(&called).count() > 1,
            "{} is called by no kernel",
            rule.name
        );
    }
}
