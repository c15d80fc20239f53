//! `pendulum-atlas modes`: the linearisation about the straight upright beam, the joint
//! damping it implies, and the automatic steps of both integration methods.

use super::SceneArgs;
use pendulum_atlas_core::config::DampingReport;
use pendulum_atlas_core::engine::method::{MethodSteps, choose_method};
use pendulum_atlas_core::model::Modes;
use serde::Serialize;

/// Arguments of `modes`.
#[derive(Debug, clap::Args)]
pub struct ModesArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Print JSON: {"frequencies_hz": [...], "unstable_rates_per_s": [...], "dt_auto_s": ...,
    /// "damping": {...}, "method_steps": {...}, "method": ..., "method_reason": ...}.
    #[arg(long)]
    json: bool,
}

/// What `modes --json` prints.
#[derive(Serialize)]
struct ModesReport {
    #[serde(flatten)]
    modes: Modes,
    damping: DampingReport,
    method_steps: MethodSteps,
    method: &'static str,
    method_reason: String,
}

/// Print the modes of the scene.
pub fn run(a: ModesArgs) -> anyhow::Result<()> {
    let scene = a.scene.load()?;
    let steps = MethodSteps::of_scene(&scene)?;
    let chosen = choose_method(scene.integration.method, scene.integration.dt_s, &steps);
    let r = ModesReport {
        modes: scene.modes()?,
        damping: scene.damping_report()?,
        method_steps: steps,
        method: chosen.method.name(),
        method_reason: chosen.reason,
    };
    if a.json {
        say!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print_text(&r);
    }
    Ok(())
}

fn print_text(r: &ModesReport) {
    let m = &r.modes;
    say!("natural frequencies (Hz):");
    for (i, f) in m.frequencies_hz.iter().enumerate() {
        say!("  {:>3}  {f:.6}", i + 1);
    }
    let rates: Vec<String> = m
        .unstable_rates_per_s
        .iter()
        .map(|r| format!("{r:.6}"))
        .collect();
    say!("unstable growth rates (1/s): {}", rates.join(", "));
    let d = &r.damping;
    say!(
        "joint damping: beta = {:.4e} s, b = {:.4e} N m s/rad per joint, zeta_1 = {:.4}",
        d.damping_time_s,
        d.joint_damping_nms,
        d.first_mode_damping_ratio
    );
    say!(
        "max|lambda| = {:.4e} 1/s, RK4 dt_auto = {:.4e} s, RK4 stable limit = {:.4e} s",
        m.spectral_radius_per_s,
        m.dt_auto_s,
        m.dt_stable_s
    );
    say!(
        "IMEX dt_auto = {:.4e} s (explicit part's max|lambda| = {:.4e} 1/s, first clamped mode {:.2} Hz)",
        r.method_steps.imex_auto_s,
        r.method_steps.explicit_radius_per_s,
        r.method_steps.first_mode_hz
    );
    say!("method: {} ({})", r.method, r.method_reason);
}
