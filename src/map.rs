//! A map from start to finish: plan the instances of a [`MapSpec`], integrate them on the
//! chosen engine, reduce each to its metrics. [`crate::output::map`] writes the files.

use crate::config::MapSpec;
use crate::integrate::ensemble::{EnsemblePlan, run_cpu};
use crate::integrate::gpu::{AdapterChoice, GpuContext, GpuReadback, GpuTimings, run_gpu};
use crate::reduce::{InstanceResult, ReduceOptions, from_cpu, from_gpu};
use anyhow::{Result, bail};
use serde::Serialize;
use std::time::Instant;

/// Which engine runs a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// A hardware GPU if present, else the software adapter lavapipe (measured about 3x faster
    /// than the CPU engine on the same cores; see the README), else the CPU engine.
    Auto,
    /// The GPU engine (wgpu): a hardware adapter, or lavapipe when that is all there is.
    Gpu,
    /// The CPU engine (rayon).
    Cpu,
}

/// Float type of the CPU engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision, as the GPU integrates.
    F32,
    /// Double precision: the reference.
    F64,
}

/// Wall time of each stage (s).
#[derive(Debug, Clone, Default, Serialize)]
pub struct MapTimings {
    /// Validating every instance's scene and choosing its step.
    pub plan_s: f64,
    /// Opening the GPU device (GPU runs).
    pub device_s: f64,
    /// Integration (on the GPU backend: everything on the device, reductions included; see
    /// `gpu` for the split).
    pub integrate_s: f64,
    /// Reductions on the host (CPU runs: K, R, period with the analysis library).
    pub reduce_s: f64,
    /// Everything.
    pub total_s: f64,
    /// The GPU's own stages.
    pub gpu: Option<GpuTimings>,
}

/// A finished map.
#[derive(Debug, Clone, Serialize)]
pub struct MapRun {
    /// Per-instance results in grid order (last axis fastest).
    #[serde(skip)]
    pub results: Vec<InstanceResult>,
    /// The instances' plans.
    #[serde(skip)]
    pub plan: EnsemblePlan,
    /// "gpu" or "cpu".
    pub backend: &'static str,
    /// Why this backend ran.
    pub backend_reason: String,
    /// The GPU adapter's name, or the CPU's thread count.
    pub device: String,
    /// Float type of the integration.
    pub precision: Precision,
    /// Wall time per stage.
    pub timings: MapTimings,
    /// Integration dispatches (GPU).
    pub dispatches: u32,
    /// Instances stopped early on a confirmed periodic orbit.
    pub stopped_early: usize,
    /// Stroboscopic tail per instance for the bifurcation diagram (empty unless asked for).
    #[serde(skip)]
    pub strobe_tail: Vec<Vec<f64>>,
}

impl MapRun {
    /// Instance-steps per second of the integration stage (the GPU's integration dispatches
    /// alone, without its reductions, on the GPU backend).
    pub fn instance_steps_per_s(&self) -> f64 {
        let t = match &self.timings.gpu {
            Some(g) => g.integrate_s,
            None => self.timings.integrate_s,
        };
        let steps: u64 = self.results.iter().map(|r| r.steps).sum();
        steps as f64 / t.max(1e-12)
    }

    /// Segment-steps per second (instance-steps × N).
    pub fn segment_steps_per_s(&self) -> f64 {
        self.instance_steps_per_s() * self.plan.segments as f64
    }
}

/// Progress callbacks: `(done, total, unit)`.
pub type Progress<'a> = &'a (dyn Fn(u64, u64, &str) + Sync);

/// Plan, integrate and reduce a map on the requested backend.
pub fn run_map(
    spec: &MapSpec,
    backend: Backend,
    precision: Precision,
    progress: Progress,
) -> Result<MapRun> {
    let t0 = Instant::now();
    let plan = EnsemblePlan::new(spec)?;
    let plan_s = t0.elapsed().as_secs_f64();
    let tail = spec
        .bifurcation
        .then_some(spec.bifurcation_samples as usize);
    let mut run = run_plan(
        plan,
        &ReduceOptions::from_spec(spec),
        tail,
        backend,
        precision,
        progress,
    )?;
    run.timings.plan_s = plan_s;
    run.timings.total_s += plan_s;
    Ok(run)
}

/// Integrate and reduce an already planned ensemble (see [`EnsemblePlan::from_scenes`]) on the
/// requested backend. `strobe_tail` keeps that many trailing stroboscopic samples per instance.
pub fn run_plan(
    plan: EnsemblePlan,
    opts: &ReduceOptions,
    strobe_tail: Option<usize>,
    backend: Backend,
    precision: Precision,
    progress: Progress,
) -> Result<MapRun> {
    let t_all = Instant::now();
    let plan_s = 0.0;
    let t0 = Instant::now();
    let (ctx, reason) = match backend {
        Backend::Cpu => (None, "requested with --backend cpu".to_string()),
        Backend::Gpu => {
            if precision == Precision::F64 {
                bail!(
                    "the GPU engine integrates in f32: drop --precision f64 or use --backend cpu"
                );
            }
            let ctx = GpuContext::new(AdapterChoice::Any)?;
            let why = format!("requested with --backend gpu ({})", ctx.adapter_name);
            (Some(ctx), why)
        }
        Backend::Auto if precision == Precision::F64 => {
            (None, "auto: --precision f64 runs on the CPU engine".into())
        }
        Backend::Auto => match GpuContext::new(AdapterChoice::Any) {
            Ok(ctx) => {
                let why = if ctx.is_software {
                    format!(
                        "auto: no hardware GPU; the software adapter `{}` runs maps about 3x faster than the CPU engine on the same cores (README, Backends)",
                        ctx.adapter_name
                    )
                } else {
                    format!("auto: hardware GPU `{}`", ctx.adapter_name)
                };
                (Some(ctx), why)
            }
            Err(_) => (
                None,
                "auto: no GPU adapter at all (not even lavapipe): CPU engine".into(),
            ),
        },
    };
    let device_s = t0.elapsed().as_secs_f64();
    let keep_tail = strobe_tail.is_some() && plan.want_strobe;
    let tail_len = strobe_tail.unwrap_or(0);
    let tail = |s: &[f64]| s[s.len().saturating_sub(tail_len)..].to_vec();
    let mut timings = MapTimings {
        plan_s,
        device_s,
        ..Default::default()
    };
    let mut plan = plan;
    let mut stopped_early = 0;
    if ctx.is_some() && plan.early_stop.take().is_some() {
        plan.warnings.push(
            "map.early_stop is ignored on the GPU backend: a stopped invocation idles until its whole workgroup finishes, so the saving there is small; runs go to the end".into(),
        );
    }
    let (results, strobe_tail, device, backend_name, dispatches, precision) = match ctx {
        Some(ctx) => {
            let t0 = Instant::now();
            let total = plan
                .instances
                .iter()
                .map(|p| p.total_steps())
                .max()
                .unwrap_or(0);
            let run = run_gpu(
                &ctx,
                &plan,
                &opts.for_gpu(),
                GpuReadback {
                    strobe: keep_tail,
                    r_series: false,
                },
                &|done, _| progress(done, total, "steps"),
            )?;
            timings.integrate_s = t0.elapsed().as_secs_f64();
            let results = from_gpu(&plan, &run);
            let stride = plan.strobe_stride as usize;
            let strobe_tail = if keep_tail {
                plan.instances
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let s: Vec<f64> = run.strobe
                            [i * stride..i * stride + p.strobe_count as usize]
                            .iter()
                            .map(|&v| f64::from(v))
                            .collect();
                        tail(&s)
                    })
                    .collect()
            } else {
                Vec::new()
            };
            timings.gpu = Some(run.timings.clone());
            (
                results,
                strobe_tail,
                ctx.adapter_name.clone(),
                "gpu",
                run.dispatches,
                Precision::F32,
            )
        }
        None => {
            let t0 = Instant::now();
            let n = plan.instances.len() as u64;
            let cb = |done: u64| progress(done, n, "instances");
            let raw = match precision {
                Precision::F64 => run_cpu::<f64>(&plan, &cb),
                Precision::F32 => run_cpu::<f32>(&plan, &cb),
            };
            timings.integrate_s = t0.elapsed().as_secs_f64();
            let t0 = Instant::now();
            let results = from_cpu(&plan, &raw, opts);
            stopped_early = raw.iter().filter(|r| r.stopped_early.is_some()).count();
            timings.reduce_s = t0.elapsed().as_secs_f64();
            let strobe_tail = if keep_tail {
                raw.iter().map(|r| tail(&r.strobe)).collect()
            } else {
                Vec::new()
            };
            (
                results,
                strobe_tail,
                format!("CPU, {} rayon threads", rayon::current_num_threads()),
                "cpu",
                0,
                precision,
            )
        }
    };
    timings.total_s = t_all.elapsed().as_secs_f64();
    Ok(MapRun {
        results,
        plan,
        backend: backend_name,
        backend_reason: reason,
        device,
        precision,
        timings,
        dispatches,
        stopped_early,
        strobe_tail,
    })
}
