//! `pendulum-atlas modes`: the linearisation about the straight upright beam.

use super::SceneArgs;

/// Arguments of `modes`.
#[derive(Debug, clap::Args)]
pub struct ModesArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Print JSON: {"frequencies_hz": [...], "unstable_rates_per_s": [...], "dt_auto_s": ...}.
    #[arg(long)]
    json: bool,
}

/// Print the modes of the scene.
pub fn run(a: ModesArgs) -> anyhow::Result<()> {
    let scene = a.scene.load()?;
    let m = scene.modes();
    if a.json {
        println!("{}", serde_json::to_string_pretty(&m)?);
    } else {
        println!("natural frequencies (Hz):");
        for (i, f) in m.frequencies_hz.iter().enumerate() {
            println!("  {:>3}  {f:.6}", i + 1);
        }
        println!("unstable growth rates (1/s): {:?}", m.unstable_rates_per_s);
        println!(
            "max|lambda| = {:.4e} 1/s, dt_auto = {:.4e} s, RK4 stable limit = {:.4e} s",
            m.spectral_radius_per_s, m.dt_auto_s, m.dt_stable_s
        );
    }
    Ok(())
}
