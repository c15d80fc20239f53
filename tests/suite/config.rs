//! Scene validation: each class of bad input gets a message naming the key and the range.

use super::{scene, scene_error};
use pendulum_atlas_core::config::{PivotMode, Scene, TimeStep, parse_override_value};

#[test]
fn paper_scene_is_table_1() {
    let s = Scene::paper();
    assert_eq!(s.beam.segments, 17);
    assert_eq!(s.beam.length_m, 0.375);
    assert_eq!(s.tip.mass_kg, 0.01195);
    assert_eq!(s.limiter.clearance_deg, 20.0);
    assert_eq!(s.excitation.amplitude_m, 0.009);
    assert_eq!(s.excitation.reference_frequency_hz(), 8.0);
    assert_eq!(s.integration.dt_s, TimeStep::Auto);
    assert_eq!(s.integration.transient_s, 10.0);
    // The initial angle follows the clearance unless set.
    assert_eq!(s.initial.angle_deg, 20.0);
    assert_eq!(scene(&["limiter.clearance_deg=12"]).initial.angle_deg, 12.0);
}

#[test]
fn overrides_take_toml_values_and_bare_words() {
    let s = scene(&[
        "beam.segments=3",
        "excitation.frequency_hz=5",
        "pivot.mode=clamped",
        "integration.dt_s=1e-4",
    ]);
    assert_eq!(s.beam.segments, 3);
    assert_eq!(s.excitation.reference_frequency_hz(), 5.0);
    assert_eq!(s.pivot.mode, PivotMode::Clamped);
    assert_eq!(s.integration.dt_s, TimeStep::Seconds(1e-4));
    assert_eq!(parse_override_value("clamped").as_str(), Some("clamped"));
    assert_eq!(parse_override_value("\"auto\"").as_str(), Some("auto"));
    assert_eq!(parse_override_value("3").as_integer(), Some(3));
}

#[test]
fn unknown_key_is_named_with_a_suggestion() {
    let e = scene_error(&["beam.mas_kg=1"]);
    assert!(e.contains("unknown key `beam.mas_kg`"), "{e}");
    assert!(e.contains("did you mean `beam.mass_kg`"), "{e}");
    let e = scene_error(&["nonsense.key=1"]);
    assert!(e.contains("unknown key `nonsense.key`"), "{e}");
}

#[test]
fn wrong_type_is_named() {
    let e = scene_error(&["beam.segments=3.5"]);
    assert!(e.contains("`beam.segments` must be an integer"), "{e}");
    let e = scene_error(&["beam.mass_kg=heavy"]);
    assert!(e.contains("`beam.mass_kg` must be a number (kg)"), "{e}");
    let e = scene_error(&["limiter.enabled=1"]);
    assert!(e.contains("`limiter.enabled` must be true or false"), "{e}");
}

#[test]
fn nan_and_inf_are_refused() {
    let e = scene_error(&["excitation.amplitude_m=nan"]);
    assert!(
        e.contains("`excitation.amplitude_m` must be a finite number"),
        "{e}"
    );
    let e = scene_error(&["beam.length_m=inf"]);
    assert!(e.contains("`beam.length_m` must be a finite number"), "{e}");
}

#[test]
fn negative_mass_and_length_are_refused_with_the_range() {
    let e = scene_error(&["beam.mass_kg=-0.1"]);
    assert!(
        e.contains("`beam.mass_kg` = -0.1 is out of range: accepted [1e-6, 10000] kg"),
        "{e}"
    );
    let e = scene_error(&["tip.mass_kg=-1"]);
    assert!(
        e.contains("`tip.mass_kg` = -1 is out of range: accepted [0, 55250] kg"),
        "{e}"
    );
    let e = scene_error(&["beam.length_m=-0.3"]);
    assert!(e.contains("`beam.length_m`"), "{e}");
}

#[test]
fn segments_outside_one_to_256_are_refused_with_the_range() {
    for n in [0, 257, 4096] {
        let e = scene_error(&[&format!("beam.segments={n}")]);
        assert!(
            e.contains(&format!(
                "`beam.segments` = {n} is out of range: accepted integers in [1, 256]"
            )),
            "{e}"
        );
    }
    assert_eq!(scene(&["beam.segments=256"]).beam.segments, 256);
}

#[test]
fn clearance_must_lie_in_the_open_quarter_circle() {
    for bad in ["0", "90", "-5", "120"] {
        let e = scene_error(&[&format!("limiter.clearance_deg={bad}")]);
        assert!(e.contains("`limiter.clearance_deg`"), "{e}");
        assert!(e.contains("accepted (0, 90) deg"), "{e}");
    }
    assert_eq!(
        scene(&["limiter.clearance_deg=0.5"]).limiter.clearance_deg,
        0.5
    );
}

#[test]
fn choices_and_combinations_are_checked() {
    let e = scene_error(&["pivot.mode=glued"]);
    assert!(
        e.contains("`pivot.mode` = \"glued\" is not one of \"hinged\", \"clamped\""),
        "{e}"
    );
    let e = scene_error(&["integration.dt_s=fast"]);
    assert!(e.contains("`integration.dt_s`"), "{e}");
    let e = scene_error(&["piezo.enabled=true", "beam.segments=2", "piezo.segments=2"]);
    assert!(e.contains("`piezo.segments`"), "{e}");
    let e = scene_error(&["beam.inner_diameter_m=0.007"]);
    assert!(e.contains("`beam.inner_diameter_m`"), "{e}");
}

#[test]
fn keys_of_a_switched_off_part_are_accepted_and_named_as_unused() {
    for (switch, key) in [
        ("excitation.kind=\"harmonic\"", "excitation.sweep_end_hz=9"),
        ("limiter.enabled=false", "limiter.stiffness_n_per_m=5e3"),
        (
            "limiter.enabled=false",
            "limiter.damping_law=\"kelvin_voigt\"",
        ),
        ("piezo.enabled=false", "piezo.load_ohm=5e5"),
        ("piezo.enabled=false", "initial.voltage_v=1.0"),
    ] {
        let s = scene(&[switch, key]);
        let name = key.split('=').next().unwrap();
        assert!(
            s.notes
                .iter()
                .any(|n| n.starts_with(name) && n.contains("not used")),
            "{switch} {key}: {:?}",
            s.notes
        );
    }
    // Switched on, the same keys are used and nothing is noted.
    let s = scene(&[
        "piezo.enabled=true",
        "piezo.load_ohm=5e5",
        "initial.voltage_v=1.0",
    ]);
    assert!(s.notes.is_empty(), "{:?}", s.notes);
}

#[test]
fn the_default_scene_names_as_unused_only_the_keys_the_user_set() {
    let sets = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    // The embedded paper scene sets the limiter's keys and the frequency; switching the
    // limiter off or sweeping must not blame the user for them.
    let s = Scene::paper_with(&sets(&["limiter.enabled=false"])).unwrap();
    assert!(s.notes.is_empty(), "{:?}", s.notes);
    let s = Scene::paper_with(&sets(&["excitation.kind=\"sweep\""])).unwrap();
    assert!(s.notes.is_empty(), "{:?}", s.notes);
    // A key the user set is named, once, and nothing else is.
    let s = Scene::paper_with(&sets(&[
        "limiter.enabled=false",
        "limiter.clearance_deg=10",
    ]))
    .unwrap();
    assert_eq!(s.notes.len(), 1, "{:?}", s.notes);
    assert!(s.notes[0].starts_with("limiter.clearance_deg is set but not used"));
    let s = Scene::paper_with(&sets(&[
        "excitation.kind=\"sweep\"",
        "excitation.frequency_hz=9",
    ]))
    .unwrap();
    assert_eq!(s.notes.len(), 1, "{:?}", s.notes);
    assert!(s.notes[0].starts_with("excitation.frequency_hz = 9 is not used"));
    // A scene file of the user's own: every key in it is the user's.
    let s = scene(&["limiter.enabled=false"]);
    assert_eq!(s.notes.len(), 5, "{:?}", s.notes);
}

#[test]
fn malformed_overrides_and_toml_are_reported() {
    let e = scene_error(&["beam.segments"]);
    assert!(e.contains("bad override `beam.segments`"), "{e}");
    let e = scene_error(&["beam.segments.x=3"]);
    assert!(e.contains("is a value, not a section"), "{e}");
    let e = Scene::from_toml("[beam\nlength_m = 1", "bad.toml", &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.toml") && e.contains("not valid TOML"),
        "{e}"
    );
}

#[test]
fn every_shipped_scene_is_valid() {
    use pendulum_atlas_core::config::{load_map, load_scene};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    let mut checked = 0;
    for dir in ["", "paper", "maps", "stress"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "toml") {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            if text.contains("[map]") {
                let spec = load_map(Some(&path), &[])
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                // Planning checks what validation cannot: enough samples for every metric.
                pendulum_atlas_core::engine::EnsemblePlan::new(&spec)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            } else {
                load_scene(Some(&path), &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            }
            checked += 1;
        }
    }
    assert!(checked >= 15, "only {checked} scenes found");
}

#[test]
fn two_joint_damping_keys_are_an_error_naming_both() {
    // paper.toml sets none of them: any two given together are refused.
    let e = scene_error(&["beam.damping_ratio=0.01", "beam.joint_damping_nms=0.35"]);
    assert!(e.contains("beam.damping_ratio"), "{e}");
    assert!(e.contains("beam.joint_damping_nms"), "{e}");
    let e = scene_error(&["beam.damping_time_s=1e-4", "beam.damping_ratio=0.01"]);
    assert!(
        e.contains("beam.damping_time_s") && e.contains("beam.damping_ratio"),
        "{e}"
    );
    let e = scene_error(&["beam.damping_ratio=1.5"]);
    assert!(e.contains("beam.damping_ratio"), "{e}");
    let e = scene_error(&["beam.joint_damping_nms=-1"]);
    assert!(e.contains("beam.joint_damping_nms"), "{e}");
}

#[test]
fn the_contact_damping_law_is_one_of_two_names() {
    use pendulum_atlas_core::config::ContactDamping;
    assert_eq!(scene(&[]).limiter.damping_law, ContactDamping::Loading);
    let kv = scene(&["limiter.damping_law=\"kelvin_voigt\""]);
    assert_eq!(kv.limiter.damping_law, ContactDamping::KelvinVoigt);
    let e = scene_error(&["limiter.damping_law=\"viscous\""]);
    assert!(
        e.contains("limiter.damping_law") && e.contains("loading") && e.contains("kelvin_voigt"),
        "{e}"
    );
}

#[test]
fn a_sweep_says_that_its_frequency_key_is_not_used() {
    let sweep = pendulum_atlas_core::config::load_scene(
        None,
        &[
            "excitation.kind=\"sweep\"".into(),
            "excitation.frequency_hz=9".into(),
        ],
    )
    .expect("scene");
    assert_eq!(sweep.notes.len(), 1, "{:?}", sweep.notes);
    assert!(
        sweep.notes[0].contains("excitation.frequency_hz"),
        "{:?}",
        sweep.notes
    );
    // The harmonic scene uses every key it is given.
    assert!(Scene::paper().notes.is_empty());
}

#[test]
fn setting_a_swept_key_is_an_error_that_names_the_axis() {
    for value in ["5.0", "5"] {
        let arg = format!("excitation.amplitude_m={value}");
        let err = pendulum_atlas_core::config::load_map(None, std::slice::from_ref(&arg))
            .expect_err("an axis cannot be set");
        let text = err.to_string();
        assert!(text.contains("is an axis of this map"), "{text}");
        assert!(!text.contains("integer"), "{text}");
    }
    // A key no axis sweeps is still overridden.
    let spec = pendulum_atlas_core::config::load_map(None, &["limiter.clearance_deg=15".into()])
        .expect("map");
    assert_eq!(spec.scene.limiter.clearance_deg, 15.0);
    let err =
        pendulum_atlas_design::harvest::load_search(None, &["limiter.clearance_deg=15".into()])
            .expect_err("a design variable cannot be set");
    assert!(err.to_string().contains("design variable"), "{err}");
}

#[test]
fn masses_beyond_what_the_model_holds_are_refused_with_their_range() {
    for (sets, key) in [
        (vec!["beam.mass_kg=1e-20"], "beam.mass_kg"),
        (vec!["beam.mass_kg=1e9"], "beam.mass_kg"),
        (vec!["tip.mass_kg=1e20"], "tip.mass_kg"),
        (vec!["beam.mass_kg=1e-3", "tip.mass_kg=2e3"], "tip.mass_kg"),
        (
            vec!["pivot.holder_inertia_kgm2=1e20"],
            "pivot.holder_inertia_kgm2",
        ),
    ] {
        let e = crate::scene_error(&sets);
        assert!(
            e.contains(key) && e.contains("out of range"),
            "{sets:?}: {e}"
        );
    }
    // Inside the ranges, the linearisation is computed (no panic) on every kept extreme.
    for sets in [
        vec!["beam.mass_kg=1e-6", "tip.mass_kg=1.0"],
        vec!["beam.mass_kg=1e4", "tip.mass_kg=0.0"],
        vec!["beam.mass_kg=1e-3", "tip.mass_kg=1e3", "beam.segments=64"],
    ] {
        let m = crate::scene(&sets).modes().unwrap();
        assert!(
            m.spectral_radius_per_s.is_finite() && m.dt_auto_s > 0.0,
            "{sets:?}: {m:?}"
        );
    }
}

#[test]
fn map_axes_are_read_by_the_one_swept_key_reader() {
    let err = |axes: &str| {
        let arg = format!("map.axes={axes}");
        pendulum_atlas_core::config::load_map(None, std::slice::from_ref(&arg))
            .expect_err("refused")
            .to_string()
    };
    let f = "{key=\"excitation.frequency_hz\",values=[4.0,5.0]}";
    let e = err(&format!("[{f},{f}]"));
    assert!(
        e.contains("`excitation.frequency_hz` is a map axis twice"),
        "{e}"
    );
    let e = err("[{key=\"beam.segments\",values=[3.0,5.0]}]");
    assert!(
        e.contains("`beam.segments` cannot be a map axis: every instance"),
        "{e}"
    );
    let a = "{key=\"excitation.amplitude_m\",values=[0.001]}";
    let e = err(&format!("[{f},{a},{a},{a}]"));
    assert!(e.contains("a map needs 1 to 3 axes, found 4"), "{e}");
    let e = err(
        "[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=3000},{key=\"excitation.amplitude_m\",start=0.001,end=0.02,count=3000}]",
    );
    assert!(
        e.contains("grids of at most 4000000 instances in all"),
        "{e}"
    );
}

/// A map planned from typed fields gives every run the scene its own table gives, whether the
/// swept keys are fields (frequency, tip mass, several starts) or not (the clearance, which
/// the default start follows).
#[test]
fn a_map_planned_once_gives_every_run_the_scene_of_its_table() {
    let maps: [&[&str]; 3] = [
        &[
            "map.axes=[{key=\"excitation.frequency_hz\",values=[6.0,8.5]},{key=\"tip.mass_kg\",values=[0.005,0.02]}]",
            "map.initial_states=3",
        ],
        &[
            "map.axes=[{key=\"excitation.amplitude_m\",values=[0.002,0.03]},{key=\"initial.rate_deg_s\",values=[-40.0,0.0,40.0]}]",
        ],
        &[
            "map.axes=[{key=\"limiter.clearance_deg\",values=[10.0,25.0]},{key=\"excitation.phase_deg\",values=[0.0,180.0]}]",
        ],
    ];
    for sets in maps {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let spec = pendulum_atlas_core::config::load_map(None, &sets).unwrap();
        let scenes = spec.run_scenes().unwrap();
        assert_eq!(scenes.len(), spec.instances() * spec.starts_per_cell());
        for (i, s) in scenes.iter().enumerate() {
            assert_eq!(s, &spec.run_scene(i).unwrap(), "{sets:?}, run {i}");
        }
    }
}

/// An axis value that makes the scene invalid is refused with its key and value, whichever
/// way the map is planned.
#[test]
fn an_invalid_axis_value_is_named_with_its_key() {
    for (axes, named) in [
        (
            "[{key=\"excitation.frequency_hz\",values=[6.0,8.0]},{key=\"excitation.phase_deg\",values=[0.0,400.0]}]",
            "excitation.phase_deg",
        ),
        (
            "[{key=\"limiter.clearance_deg\",values=[10.0,95.0]}]",
            "limiter.clearance_deg",
        ),
    ] {
        let spec =
            pendulum_atlas_core::config::load_map(None, &[format!("map.axes={axes}")]).unwrap();
        let e = spec.run_scenes().expect_err("refused").to_string();
        assert!(e.contains(named) && e.contains("invalid scene"), "{e}");
    }
}

/// Every map has one mode, read from its keys: plain, attractors, basin, continuation or
/// refined; only the plain map can be split.
#[test]
fn a_map_has_one_mode_read_from_its_keys() {
    let f = "{key=\"excitation.frequency_hz\",start=6.0,end=12.0,count=9}";
    let a = "{key=\"excitation.amplitude_m\",start=0.004,end=0.02,count=9}";
    let angle = "{key=\"initial.angle_deg\",values=[-10.0,10.0]}";
    let rate = "{key=\"initial.rate_deg_s\",values=[-20.0,20.0]}";
    for (sets, mode, shardable) in [
        (vec![format!("map.axes=[{f},{a}]")], "plain", true),
        (
            vec![format!("map.axes=[{f},{a}]"), "map.initial_states=3".into()],
            "attractors",
            false,
        ),
        (vec![format!("map.axes=[{f},{angle}]")], "attractors", false),
        (vec![format!("map.axes=[{angle},{rate}]")], "basin", false),
        (
            vec![format!("map.axes=[{f}]"), "map.continuation=both".into()],
            "continuation",
            false,
        ),
        (
            vec![format!("map.axes=[{f},{a}]"), "map.refine=true".into()],
            "refined",
            false,
        ),
    ] {
        let spec = pendulum_atlas_core::config::load_map(None, &sets).unwrap();
        assert_eq!(spec.mode.name(), mode, "{sets:?}");
        assert_eq!(spec.mode.unshardable().is_none(), shardable, "{sets:?}");
    }
}

/// Starts lie within the bumpers of every cell: where an axis sweeps the clearance, they are
/// held to its smallest value, not to the base scene's.
#[test]
fn starts_lie_within_the_bumpers_of_every_swept_cell() {
    let axes = "map.axes=[{key=\"excitation.frequency_hz\",values=[7.0,8.0]},{key=\"limiter.clearance_deg\",values=[2.0,20.0]}]";
    let err = |starts: &str| {
        pendulum_atlas_core::config::load_map(None, &[axes.to_string(), starts.to_string()])
            .expect_err("refused")
            .to_string()
    };
    let e = err("map.initial_states=[{angle_deg=16.0,rate_deg_s=0.0}]");
    assert!(
        e.contains("map.initial_states[0].angle_deg") && e.contains("[-2, 2]"),
        "{e}"
    );
    let e = err("map.initial_angle_max_deg=10");
    assert!(e.contains("map.initial_angle_max_deg"), "{e}");
    let spec = pendulum_atlas_core::config::load_map(
        None,
        &[axes.to_string(), "map.initial_states=6".to_string()],
    )
    .unwrap();
    let starts = spec.starts().expect("starts");
    assert!(
        starts.states.iter().all(|s| s.angle_deg.abs() <= 2.0),
        "{:?}",
        starts.states
    );
}

#[test]
fn a_start_beyond_its_bumper_is_refused_on_a_scene_and_on_a_map_over_the_clearance() {
    let e = scene_error(&["initial.angle_deg=30"]);
    assert!(
        e.contains("initial.angle_deg") && e.contains("[-20, 20]") && e.contains("bumpers' reach"),
        "{e}"
    );
    // On the bumper is a start (the default), past it is not; without bumpers any angle.
    assert_eq!(scene(&["initial.angle_deg=-20"]).initial.angle_deg, -20.0);
    let free = scene(&["limiter.enabled=false", "initial.angle_deg=30"]);
    assert_eq!(free.initial.angle_deg, 30.0);
    // A map over the clearance: the cells whose bumpers stand closer than the start refuse.
    let e = pendulum_atlas_core::config::map_from_toml(
        "[initial]\nangle_deg = 15.0\n[map]\n[[map.axes]]\nkey = \"limiter.clearance_deg\"\nvalues = [10.0, 20.0]\n",
        "<test>",
        &[],
    )
    .expect_err("a start beyond the 10° bumpers")
    .to_string();
    assert!(
        e.contains("limiter.clearance_deg = 10") && e.contains("initial.angle_deg"),
        "{e}"
    );
}

#[test]
fn a_sweep_over_a_key_the_scene_does_not_use_is_refused_before_any_work() {
    use pendulum_atlas_core::config::map_from_toml;
    let map = |extra: &str, axis: &str| {
        map_from_toml(
            &format!("{extra}[map]\n[[map.axes]]\nkey = \"{axis}\"\nvalues = [1e-4, 2e-4]\n"),
            "<test>",
            &[],
        )
    };
    let e = map("[integration]\nstep = \"fixed\"\n", "integration.rtol")
        .expect_err("tolerances at fixed steps")
        .to_string();
    assert!(
        e.contains("map.axes[1].key") && e.contains("integration.step is \"fixed\""),
        "{e}"
    );
    let e = map("[integration]\nstep = \"adaptive\"\n", "integration.dt_s")
        .expect_err("a step at adaptive steps")
        .to_string();
    assert!(e.contains("integration.step is \"adaptive\""), "{e}");
    let e = map("[limiter]\nenabled = false\n", "limiter.stiffness_n_per_m")
        .expect_err("the bumpers' stiffness without bumpers")
        .to_string();
    assert!(e.contains("limiter.enabled = false"), "{e}");
    // Used keys sweep: the tolerances at adaptive steps, a step that makes the steps fixed.
    assert!(map("", "integration.rtol").is_ok());
    assert!(map("", "integration.dt_s").is_ok());
    // A design variable and an unknown follow the same rule.
    let e = pendulum_atlas_design::harvest::search_from_toml(
        pendulum_atlas_design::harvest::DEFAULT_SEARCH_TOML,
        "<default search>",
        &[
            "integration.step=\"fixed\"".into(),
            "search.variables=[{key=\"integration.atol\",values=[1e-6,1e-5]}]".into(),
        ],
    )
    .expect_err("a design variable over an unused tolerance")
    .to_string();
    assert!(
        e.contains("search.variables[1].key") && e.contains("\"fixed\""),
        "{e}"
    );
    let e = pendulum_atlas_design::calibrate::calibration_from_toml(
        "[integration]\nstep = \"fixed\"\n[calibrate]\n\
         [[calibrate.unknowns]]\nkey = \"integration.rtol\"\nvalues = [1e-4, 1e-3]\n\
         [[calibrate.cases]]\nname = \"8 Hz\"\nset = { \"excitation.frequency_hz\" = 8.0 }\nk_class = \"chaotic\"\n",
        "<test>",
        &[],
    )
    .expect_err("an unknown over an unused tolerance")
    .to_string();
    assert!(
        e.contains("calibrate.unknowns[1].key") && e.contains("\"fixed\""),
        "{e}"
    );
}

#[test]
fn settling_defaults_to_twice_the_run_and_a_run_too_long_for_that_maps_raw() {
    use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, map_from_toml};
    let map = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        map_from_toml(DEFAULT_MAP_TOML, "the default map", &sets)
    };
    assert_eq!(map(&[]).unwrap().settle_max_s, Some(68.0));
    let long = "integration.duration_s=50001.0";
    assert_eq!(map(&[long]).unwrap().settle_max_s, None);
    let err = map(&[long, "map.settle=true"]).unwrap_err().to_string();
    assert!(err.contains("beyond its limit of 100000 s"), "{err}");
    let given = map(&[long, "map.settle_max_s=100000.0"]).unwrap();
    assert_eq!(given.settle_max_s, Some(100000.0));
}

/// The removed `gpu.layout` (the working arrays in a storage buffer, slower on every adapter
/// measured) is refused by name with the reason, in a scene or from `--set`; any other key of
/// `[gpu]` is an unknown key.
#[test]
fn the_removed_gpu_layout_is_refused_with_its_reason() {
    use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, map_from_toml};
    let in_scene = format!("{DEFAULT_MAP_TOML}\n[gpu]\nlayout = \"global\"\n");
    let from_set = ["gpu.layout=\"private\"".to_string()];
    for e in [
        map_from_toml(&in_scene, "<test>", &[]).unwrap_err(),
        map_from_toml(DEFAULT_MAP_TOML, "<test>", &from_set).unwrap_err(),
    ] {
        let m = e.to_string();
        assert!(m.contains("gpu.layout") && m.contains("was removed"), "{m}");
    }
    let other = map_from_toml(DEFAULT_MAP_TOML, "<test>", &["gpu.threads=4".into()]);
    let m = other.unwrap_err().to_string();
    assert!(m.contains("unknown key `gpu.threads`"), "{m}");
}

/// `gpu.kernel` is `auto` (the default) or `thread`; `workgroup` is refused with the reason it
/// was removed; anything else names the choices.
#[test]
fn gpu_kernel_is_auto_or_thread() {
    use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, GpuKernelChoice, map_from_toml};
    let read = |v: &str| map_from_toml(DEFAULT_MAP_TOML, "<test>", &[format!("gpu.kernel={v}")]);
    assert_eq!(
        map_from_toml(DEFAULT_MAP_TOML, "<test>", &[])
            .unwrap()
            .gpu_kernel,
        GpuKernelChoice::Auto
    );
    assert_eq!(
        read("\"thread\"").unwrap().gpu_kernel,
        GpuKernelChoice::Thread
    );
    let removed = read("\"workgroup\"").unwrap_err().to_string();
    assert!(
        removed.contains("gpu.kernel") && removed.contains("was removed"),
        "{removed}"
    );
    for bad in ["\"warp\"", "3"] {
        let m = read(bad).unwrap_err().to_string();
        assert!(
            m.contains("gpu.kernel") && m.contains("\"workgroup\""),
            "{bad}: {m}"
        );
    }
}

/// A map key that changes nothing is named before any work, as every switched-off feature's
/// keys are (issue 71): K's without K or the regime, R's without R, the period test's without
/// the period, the regime or the early stop, and where settling starts without settling.
#[test]
fn keys_of_an_indicator_the_map_does_not_form_are_named() {
    let notes = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        pendulum_atlas_core::config::load_map(None, &sets)
            .unwrap()
            .notes
            .join("\n")
    };
    let said = notes(&[
        "map.metrics=[\"hops\"]",
        "map.early_stop=false",
        "map.settle=false",
        "map.k_n_c=50",
        "map.r_max_samples=1024",
        "map.phase_convention=\"paper\"",
        "map.period_max=6",
        "map.period_window=12",
        "map.settle_from=\"start\"",
    ]);
    for (key, why) in [
        ("map.k_n_c", "neither K nor the regime"),
        ("map.r_max_samples", "R is not among map.metrics"),
        ("map.phase_convention", "R is not among map.metrics"),
        ("map.period_max", "neither the period nor the regime"),
        ("map.period_window", "neither the period nor the regime"),
        ("map.settle_from", "this map does not settle"),
    ] {
        let line = format!("{key} is set but not used: {why}");
        assert!(said.contains(&line), "no `{line}` in:\n{said}");
    }
    // The default map forms them all and settles: none is named.
    let said = notes(&[
        "map.k_n_c=50",
        "map.period_max=6",
        "map.settle_from=\"start\"",
    ]);
    assert!(!said.contains("is set but not used"), "{said}");
}

/// A log-scale axis listed with a value at or below 0 is refused by name (it cannot be drawn
/// in log space); a ranged one was already (its start must be above 0).
#[test]
fn a_log_axis_with_values_at_or_below_zero_is_refused() {
    let axis = |values: &str| {
        vec![format!(
            "map.axes=[{{key=\"excitation.frequency_hz\",values={values},scale=\"log\"}},{{key=\"excitation.amplitude_m\",values=[0.001]}}]"
        )]
    };
    let e = pendulum_atlas_core::config::load_map(None, &axis("[-1.0, 2.0, 4.0]"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("map.axes") && e.contains("log scale needs values above 0"),
        "{e}"
    );
    assert!(pendulum_atlas_core::config::load_map(None, &axis("[1.0, 2.0, 4.0]")).is_ok());
}
