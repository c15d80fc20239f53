//! The work-precision study behind `pendulum-atlas bench`: what accuracy a user gets for what
//! time, for each segment count N, time step (a multiple of the automatic step), float type
//! and backend; plus scaling measurements and the cost of the metrics a scene asks for.
//!
//! Errors are measured against the f64 model at N = 17 (the paper's discretisation):
//! (a) the holder angle over a short horizon, against the DOP853 reference integrator with
//! contact events, before chaos separates trajectories; (b) K, R and the regular/chaotic and
//! period classes on a small reference map, against the f64 RK4 engine at N = 17 and the
//! automatic step (part (a) shows that its integration error is negligible there).

pub mod report;

use crate::analysis::PhaseConvention;
use crate::config::{Metric, Scene};
use crate::integrate::ensemble::{EnsembleOptions, EnsemblePlan, run_instance};
use crate::integrate::gpu::{AdapterChoice, GpuContext, GpuReadback, run_gpu};
use crate::integrate::{Instance, Observer, ReferenceOptions, StepPlan, integrate_reference};
use crate::map::{Backend, MapRun, Precision, run_plan};
use crate::model::{CartState, Chain, ModelParams, Workspace, modes};
use crate::reduce::ReduceOptions;
use anyhow::{Result, bail};
use serde::Serialize;
use std::time::Instant;

/// One configuration of the study.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct BenchConfig {
    /// Segments N.
    pub segments: usize,
    /// Step as a multiple of the automatic step.
    pub dt_factor: f64,
    /// Float type.
    pub precision: Precision,
    /// Engine ("cpu" or "gpu").
    pub backend: Backend,
}

impl BenchConfig {
    /// The family a configuration belongs to (one curve of the work-precision plot).
    pub fn family(&self) -> String {
        format!(
            "{} {} dt={}x auto",
            match self.backend {
                Backend::Gpu => "gpu",
                _ => "cpu",
            },
            match self.precision {
                Precision::F32 => "f32",
                Precision::F64 => "f64",
            },
            self.dt_factor
        )
    }
}

/// What one configuration achieved.
#[derive(Debug, Clone, Serialize)]
pub struct ConfigResult {
    /// The configuration.
    pub config: BenchConfig,
    /// Largest step of its instances (s).
    pub dt_s: f64,
    /// Max |α − α_ref| over the horizon (rad).
    pub alpha_err_rad: f64,
    /// Wall time of the reference map's integration (s).
    pub map_wall_s: f64,
    /// Wall time per instance per simulated second on this machine (s/s).
    pub cost_per_instance_s: f64,
    /// Instance-steps per second.
    pub instance_steps_per_s: f64,
    /// Segment-steps per second.
    pub segment_steps_per_s: f64,
    /// Mean |K − K_ref| over the map's cells.
    pub mean_abs_dk: f64,
    /// Mean |R − R_ref|.
    pub mean_abs_dr: f64,
    /// Fraction of cells whose class (K > 0.5) differs from the reference.
    pub k_class_changed: f64,
    /// Fraction of cells whose period differs from the reference.
    pub period_changed: f64,
    /// Instances not `ok`.
    pub failed: usize,
}

/// Scaling measurements.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Scaling {
    /// (N, ns per RK4 step, ns per step and segment), one instance, f64, one thread.
    pub per_step_vs_segments: Vec<(usize, f64, f64)>,
    /// (instances, wall s), N = 3.
    pub wall_vs_instances: Vec<(usize, f64)>,
    /// (duration s, wall s), N = 3.
    pub wall_vs_duration: Vec<(f64, f64)>,
    /// Map wall time with 1 and with 2 rayon threads (s), and the speed-up.
    pub threads: Option<(f64, f64, f64)>,
    /// GPU adapter and its best segment-steps per second over the configurations (when run).
    pub gpu: Option<(String, f64)>,
}

/// Wall time of a K-only map against the same map with every metric.
#[derive(Debug, Clone, Serialize)]
pub struct KOnly {
    /// Engine.
    pub backend: Backend,
    /// All metrics but power (s).
    pub all_metrics_s: f64,
    /// K only (s).
    pub k_only_s: f64,
    /// Ratio.
    pub speedup: f64,
}

/// The whole study.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// `--quick` or full.
    pub quick: bool,
    /// Machine description.
    pub machine: String,
    /// Horizon of the holder-angle error (s).
    pub horizon_s: f64,
    /// Reference map: axes, duration.
    pub reference_map: String,
    /// Wall time of the DOP853 reference over the horizon (s).
    pub reference_wall_s: f64,
    /// Wall time of the reference map (s).
    pub reference_map_wall_s: f64,
    /// One entry per configuration.
    pub configs: Vec<ConfigResult>,
    /// Scaling.
    pub scaling: Scaling,
    /// A K-only scene against an all-metrics scene, per backend.
    pub k_only: Vec<KOnly>,
    /// Total wall time of the study (s).
    pub total_s: f64,
}

/// Settings of a study.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Fewer configurations, shorter runs.
    pub quick: bool,
    /// Engines to measure.
    pub backends: Vec<Backend>,
}

/// The scene of the study at N segments (Table 1, 8 Hz, 9 mm, limiter at 20°).
fn scene_with(n: usize, extra: &[String]) -> Result<Scene> {
    let mut sets = vec![format!("beam.segments={n}")];
    sets.extend_from_slice(extra);
    Ok(Scene::from_toml(
        crate::config::PAPER_SCENE_TOML,
        "<bench>",
        &sets,
    )?)
}

/// Observer keeping α at every output row.
struct AlphaRows(Vec<f64>);

impl Observer<f64> for AlphaRows {
    fn sample(
        &mut self,
        _: u64,
        _: f64,
        _: &CartState,
        y: &[f64],
        _: &Chain<f64>,
        _: &mut Workspace<f64>,
    ) {
        self.0.push(y[0]);
    }
}

const SAMPLES_PER_PERIOD: u32 = 16;

fn options(metrics: Vec<Metric>) -> EnsembleOptions {
    EnsembleOptions {
        metrics,
        keep_strobe: false,
        samples_per_period: SAMPLES_PER_PERIOD,
        strobe_phase: 0.0,
        r_max_samples: 1024,
        early_stop: None,
    }
}

fn reduce_options() -> ReduceOptions {
    ReduceOptions {
        zero_one: crate::analysis::ZeroOneOptions::default(),
        convention: PhaseConvention::Standard,
        period_max: 8,
        period_window: 16,
        period_tol_rad: 1e-3,
    }
}

/// Explicit step for a configuration: `factor` times the automatic step of N.
fn step_sets(n: usize, factor: f64) -> Result<(Vec<String>, f64)> {
    let m = modes(&scene_with(n, &[])?);
    let dt = factor * m.dt_auto_s;
    Ok((vec![format!("integration.dt_s={dt:e}")], dt))
}

/// Max |α − α_ref| over the horizon for one configuration.
fn horizon_error(
    cfg: &BenchConfig,
    horizon: f64,
    reference: &[f64],
    gpu: Option<&GpuContext>,
) -> Result<(f64, f64)> {
    let (mut sets, _) = step_sets(cfg.segments, cfg.dt_factor)?;
    sets.push(format!("integration.duration_s={horizon}"));
    sets.push("integration.transient_s=0.125".into());
    let scene = scene_with(cfg.segments, &sets)?;
    let plan = EnsemblePlan::from_scenes(&[scene], &options(vec![Metric::R]))?;
    let p = &plan.instances[0];
    let alpha: Vec<f64> = match (cfg.backend, cfg.precision) {
        (Backend::Gpu, _) => {
            let Some(ctx) = gpu else {
                bail!("no GPU adapter for a GPU configuration")
            };
            let run = run_gpu(
                ctx,
                &plan,
                &reduce_options().for_gpu(),
                GpuReadback {
                    strobe: false,
                    r_series: true,
                },
                &|_, _| {},
            )?;
            run.r_series[..p.r_count as usize]
                .iter()
                .map(|&v| f64::from(v))
                .collect()
        }
        (_, Precision::F32) => run_instance::<f32>(p, false, true).r_alpha,
        (_, Precision::F64) => run_instance::<f64>(p, false, true).r_alpha,
    };
    // R sample j is at t = (r_start/r_every + j)/(f · samples_per_period): reference row k.
    let first = (p.r_start / p.r_every) as usize;
    let err = alpha
        .iter()
        .enumerate()
        .map(|(j, a)| match reference.get(first + j) {
            Some(r) => (a - r).abs(),
            None => f64::NAN,
        })
        .fold(0.0, f64::max);
    Ok((err, p.dt_s))
}

/// The reference map's scenes for N segments and step factor.
fn map_scenes(n: usize, factor: Option<f64>, quick: bool) -> Result<Vec<Scene>> {
    let (fs, amps, duration, transient): (Vec<f64>, Vec<f64>, f64, f64) = if quick {
        (
            vec![5.0, 7.5, 10.0, 12.0],
            vec![0.006, 0.012, 0.02],
            6.0,
            2.0,
        )
    } else {
        (
            vec![5.0, 7.0, 9.5, 12.0],
            vec![0.006, 0.01, 0.015, 0.02],
            12.0,
            4.0,
        )
    };
    let mut base = vec![
        format!("integration.duration_s={duration}"),
        format!("integration.transient_s={transient}"),
    ];
    if let Some(f) = factor {
        base.extend(step_sets(n, f)?.0);
    }
    let mut out = Vec::new();
    for &f in &fs {
        for &a in &amps {
            let mut s = base.clone();
            s.push(format!("excitation.frequency_hz={f}"));
            s.push(format!("excitation.amplitude_m={a}"));
            out.push(scene_with(n, &s)?);
        }
    }
    Ok(out)
}

fn run_map_scenes(
    scenes: &[Scene],
    metrics: Vec<Metric>,
    backend: Backend,
    precision: Precision,
) -> Result<MapRun> {
    let plan = EnsemblePlan::from_scenes(scenes, &options(metrics))?;
    run_plan(
        plan,
        &reduce_options(),
        None,
        backend,
        precision,
        &|_, _, _| {},
    )
}

const MAP_METRICS: [Metric; 3] = [Metric::K, Metric::R, Metric::Period];

/// Run the study. `progress` receives a line per finished step.
pub fn run_bench(opts: &BenchOptions, progress: &dyn Fn(&str)) -> Result<BenchReport> {
    let t_all = Instant::now();
    let quick = opts.quick;
    // Long enough for several impacts, short enough that N = 17 variants have not separated.
    let horizon = 0.5;
    let gpu = if opts.backends.contains(&Backend::Gpu) {
        Some(GpuContext::new(AdapterChoice::Any)?)
    } else {
        None
    };

    // (a) The reference trajectory: DOP853 at N = 17 over the horizon, rows at 16 per period.
    let t0 = Instant::now();
    let ref_scene = scene_with(
        17,
        &[
            format!("integration.duration_s={horizon}"),
            format!(
                "output.sample_rate_hz={}",
                8.0 * f64::from(SAMPLES_PER_PERIOD)
            ),
        ],
    )?;
    let params = ModelParams::from_scene(&ref_scene);
    let inst: Instance<f64> = Instance::from_scene(&ref_scene, &params);
    let plan = StepPlan::for_scene(&ref_scene, &modes(&ref_scene));
    let mut rows = AlphaRows(Vec::new());
    integrate_reference(&inst, &plan, &ReferenceOptions::default(), &mut rows)
        .map_err(|e| anyhow::anyhow!("reference integration failed: {e}"))?;
    let reference_wall_s = t0.elapsed().as_secs_f64();
    progress(&format!(
        "reference trajectory: N = 17, {horizon} s, DOP853, {reference_wall_s:.1} s"
    ));

    // (b) The reference map: f64 RK4 at N = 17, automatic step.
    let t0 = Instant::now();
    let ref_map = run_map_scenes(
        &map_scenes(17, None, quick)?,
        MAP_METRICS.to_vec(),
        Backend::Cpu,
        Precision::F64,
    )?;
    let reference_map_wall_s = t0.elapsed().as_secs_f64();
    progress(&format!(
        "reference map: {} instances at N = 17, {reference_map_wall_s:.1} s",
        ref_map.results.len()
    ));

    let mut configs = Vec::new();
    let ns: &[usize] = if quick {
        &[1, 3, 5, 9]
    } else {
        &[1, 3, 5, 9, 17]
    };
    for &n in ns {
        let mut list = vec![
            (Backend::Cpu, Precision::F64, 1.0),
            (Backend::Cpu, Precision::F64, 0.5),
            (Backend::Cpu, Precision::F32, 1.0),
        ];
        // N = 17 at smaller steps costs minutes per map and (part a shows) changes nothing.
        if !quick && n < 17 {
            list.push((Backend::Cpu, Precision::F64, 0.25));
            list.push((Backend::Cpu, Precision::F32, 0.5));
        }
        if n == 17 {
            list.retain(|c| c.2 == 1.0);
        }
        if gpu.is_some() {
            list.push((Backend::Gpu, Precision::F32, 1.0));
            if !quick && n < 17 {
                list.push((Backend::Gpu, Precision::F32, 0.5));
            }
        }
        for (backend, precision, dt_factor) in list {
            if !opts.backends.contains(&backend) {
                continue;
            }
            let cfg = BenchConfig {
                segments: n,
                dt_factor,
                precision,
                backend,
            };
            let (alpha_err_rad, dt_s) = horizon_error(&cfg, horizon, &rows.0, gpu.as_ref())?;
            // N = 17, f64, automatic step on the CPU is the reference map itself.
            let is_reference = n == 17
                && backend == Backend::Cpu
                && precision == Precision::F64
                && dt_factor == 1.0;
            let map = if is_reference {
                ref_map.clone()
            } else {
                run_map_scenes(
                    &map_scenes(n, Some(dt_factor), quick)?,
                    MAP_METRICS.to_vec(),
                    backend,
                    precision,
                )?
            };
            let cells = map.results.len() as f64;
            let pairs = || map.results.iter().zip(&ref_map.results);
            let mean = |f: &dyn Fn(f64, f64) -> f64,
                        g: fn(&crate::reduce::InstanceResult) -> f64| {
                pairs()
                    .map(|(a, b)| f(g(a), g(b)))
                    .filter(|v| v.is_finite())
                    .sum::<f64>()
                    / cells
            };
            let wall = match &map.timings.gpu {
                Some(g) => g.integrate_s + g.reduce_s,
                None => map.timings.integrate_s + map.timings.reduce_s,
            };
            let sim_s: f64 = map
                .plan
                .instances
                .iter()
                .map(|p| p.total_periods as f64 / p.frequency_hz)
                .sum();
            let r = ConfigResult {
                config: cfg,
                dt_s,
                alpha_err_rad,
                map_wall_s: wall,
                cost_per_instance_s: wall / sim_s,
                instance_steps_per_s: map.instance_steps_per_s(),
                segment_steps_per_s: map.segment_steps_per_s(),
                mean_abs_dk: mean(&|a, b| (a - b).abs(), |r| r.k),
                mean_abs_dr: mean(&|a, b| (a - b).abs(), |r| r.r),
                k_class_changed: pairs().filter(|(a, b)| (a.k > 0.5) != (b.k > 0.5)).count() as f64
                    / cells,
                period_changed: pairs().filter(|(a, b)| a.period != b.period).count() as f64
                    / cells,
                failed: map
                    .results
                    .iter()
                    .filter(|r| r.status != crate::integrate::Status::Ok)
                    .count(),
            };
            progress(&format!(
                "N = {n:2} {:<22} α error {:.2e} rad, map {:.1} s, |ΔK| {:.3}, class changes {:.0} %",
                cfg.family(),
                r.alpha_err_rad,
                r.map_wall_s,
                r.mean_abs_dk,
                100.0 * r.k_class_changed
            ));
            configs.push(r);
        }
    }

    let mut scaling = scaling(opts, progress)?;
    scaling.gpu = gpu.as_ref().and_then(|g| {
        configs
            .iter()
            .filter(|c| c.config.backend == Backend::Gpu)
            .map(|c| c.segment_steps_per_s)
            .reduce(f64::max)
            .map(|v| (g.adapter_name.clone(), v))
    });
    // K only against all metrics: an 8 x 8 map at N = 3, 20 s, on every backend measured.
    let mut scenes3 = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            scenes3.push(scene_with(
                3,
                &[
                    format!("excitation.frequency_hz={}", 4.0 + i as f64),
                    format!("excitation.amplitude_m={}", 0.004 + 0.002 * j as f64),
                    "integration.duration_s=20.0".into(),
                    "integration.transient_s=5.0".into(),
                ],
            )?);
        }
    }
    let mut k_only = Vec::new();
    for &backend in &opts.backends {
        let precision = if backend == Backend::Gpu {
            Precision::F32
        } else {
            Precision::F64
        };
        let wall = |m: &MapRun| match &m.timings.gpu {
            Some(g) => g.integrate_s + g.reduce_s,
            None => m.timings.integrate_s + m.timings.reduce_s,
        };
        let all = run_map_scenes(&scenes3, Metric::ALL[..6].to_vec(), backend, precision)?;
        let k = run_map_scenes(&scenes3, vec![Metric::K], backend, precision)?;
        let entry = KOnly {
            backend,
            all_metrics_s: wall(&all),
            k_only_s: wall(&k),
            speedup: wall(&all) / wall(&k),
        };
        progress(&format!(
            "K only vs all metrics ({backend:?}, N = 3, 64 instances): {:.2} s vs {:.2} s",
            entry.k_only_s, entry.all_metrics_s
        ));
        k_only.push(entry);
    }

    Ok(BenchReport {
        quick,
        machine: format!(
            "{} CPU threads (rayon){}",
            rayon::current_num_threads(),
            gpu.as_ref()
                .map(|g| format!(", GPU adapter {}", g.adapter_name))
                .unwrap_or_default()
        ),
        horizon_s: horizon,
        reference_map: if quick {
            "f in {5, 7.5, 10, 12} Hz x A in {6, 12, 20} mm, 6 s (transient 2 s)".into()
        } else {
            "f in {5, 7, 9.5, 12} Hz x A in {6, 10, 15, 20} mm, 12 s (transient 4 s)".into()
        },
        reference_wall_s,
        reference_map_wall_s,
        configs,
        scaling,
        k_only,
        total_s: t_all.elapsed().as_secs_f64(),
    })
}

fn scaling(opts: &BenchOptions, progress: &dyn Fn(&str)) -> Result<Scaling> {
    let mut s = Scaling::default();
    // Per-step cost against N: a fixed step and no dampers so every N runs the same steps.
    let ns: &[usize] = if opts.quick {
        &[1, 4, 16, 64]
    } else {
        &[1, 2, 4, 8, 16, 32, 64]
    };
    for &n in ns {
        let scene = scene_with(
            n,
            &[
                "beam.damping_ratio=0.0".into(),
                "integration.dt_s=1e-6".into(),
                "excitation.frequency_hz=50.0".into(),
                "integration.duration_s=0.04".into(),
                "integration.transient_s=0.02".into(),
            ],
        )?;
        let plan = EnsemblePlan::from_scenes(&[scene], &options(vec![Metric::Hops]))?;
        let t0 = Instant::now();
        let raw = run_instance::<f64>(&plan.instances[0], false, false);
        let ns_step = t0.elapsed().as_secs_f64() * 1e9 / raw.steps_done as f64;
        s.per_step_vs_segments
            .push((n, ns_step, ns_step / n as f64));
    }
    progress("scaling: per-step cost against N done");
    // Wall time against grid size and run length, N = 3.
    let base = |count: usize, duration: f64| -> Result<Vec<Scene>> {
        (0..count)
            .map(|i| {
                scene_with(
                    3,
                    &[
                        format!(
                            "excitation.frequency_hz={}",
                            5.0 + 7.0 * i as f64 / count as f64
                        ),
                        format!("integration.duration_s={duration}"),
                        "integration.transient_s=1.0".into(),
                    ],
                )
            })
            .collect()
    };
    let metrics = vec![Metric::Hops, Metric::AlphaRange];
    for count in [16usize, 64, 256] {
        let m = run_map_scenes(
            &base(count, 4.0)?,
            metrics.clone(),
            Backend::Cpu,
            Precision::F64,
        )?;
        s.wall_vs_instances.push((count, m.timings.integrate_s));
    }
    for duration in [2.0, 4.0, 8.0] {
        let m = run_map_scenes(
            &base(64, duration)?,
            metrics.clone(),
            Backend::Cpu,
            Precision::F64,
        )?;
        s.wall_vs_duration.push((duration, m.timings.integrate_s));
    }
    let scenes = base(128, 4.0)?;
    let mut times = Vec::new();
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let m = pool
            .install(|| run_map_scenes(&scenes, metrics.clone(), Backend::Cpu, Precision::F64))?;
        times.push(m.timings.integrate_s);
    }
    s.threads = Some((times[0], times[1], times[0] / times[1]));
    progress("scaling: grid size, run length and threads done");
    Ok(s)
}
