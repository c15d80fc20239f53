//! `pendulum-atlas reproduce`: every case of the paper, its Table 2, figures and a report.

use anyhow::Context;
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_studies::reproduce::{ReproduceOptions, paper_cases, reproduce};
use std::path::PathBuf;

/// Arguments of `reproduce`.
#[derive(Debug, clap::Args)]
pub struct ReproduceArgs {
    /// Output folder (created if needed).
    #[arg(long, default_value = "runs/reproduce")]
    out: PathBuf,
    /// Fewer segments (N = 3) and 12 s runs: the same pipeline in seconds, for CI and a first look.
    #[arg(long)]
    quick: bool,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    force: bool,
}

/// Run all cases (in parallel) and write table2.csv/.md, REPORT.md and the figures.
pub fn run(a: ReproduceArgs) -> anyhow::Result<()> {
    super::claim_out(Product::Reproduce, &a.out, a.force)?;
    tell!(
        "reproducing {} cases of the paper{} on {} threads into {}",
        paper_cases().len(),
        if a.quick { " (quick)" } else { "" },
        rayon::current_num_threads(),
        a.out.display()
    );
    let opts = ReproduceOptions { quick: a.quick };
    let r = reproduce(&a.out, &opts, &|line| tell!("  {line}"))
        .with_context(|| format!("reproduce into {}", a.out.display()))?;
    tell!(
        "wrote {} files in {:.1} s; see {}",
        r.files.len(),
        r.wall_s,
        a.out.join("REPORT.md").display()
    );
    Ok(())
}
