//! The lab of pendulum-atlas: studies that fit or check the product, run by its developers,
//! never by a map (`pendulum-atlas-lab`, `benches/src/main.rs`). It sits on top of core and
//! map, beside the command line; nothing the product runs depends on it.
//!
//! Stages of the verdict study (`pendulum-atlas-lab verdict`, [`verdict::run_verdict`]):
//! 1. [`verdict`]: the plane's subgrid, its converged [`mod@reference`], the map's settings scored
//!    against it, the whole map's cost;
//! 2. [`reliability`]: whether `verdict_confidence` predicts the verdict's error, and the
//!    confidence tables fitted on the scored cells;
//! 3. [`settling`]: transient chaos, and settling's accuracy against its cost;
//! 4. [`verdict_report`]: `VERDICT.md` and `verdict.json`.
//!
//! [`nudged`] (`pendulum-atlas-lab nudged`) runs a plane's reference again from a start
//! nudged by 1e-6 deg/s, which splits its cells into predictable and sensitive ones.
//!
//! A study may keep an earlier study's references ([`kept`]), read back from its
//! `verdict.json` ([`study_file`]). Across studies: [`planes`] (`pendulum-atlas-lab verdict-fit`) fits the confidence tables
//! the map ships on several planes' studies and scores each plane held out.
//!
//! For the throughput studies the user runs (`pendulum-atlas bench --throughput`,
//! `--cpu-throughput`):
//! - [`flops`] (`pendulum-atlas-lab flops`): the flop count of one step, counted on the
//!   engine's own step, against the table the product ships (`bench::cost`);
//! - [`peer_case`] (`pendulum-atlas-lab peer-cases`): the cases the peers of `benches/peers/`
//!   integrate, with the state our f64 engine reaches, so that a peer shows it integrates the
//!   same model before it is timed.

pub mod flops;
pub mod kept;
pub mod nudged;
pub mod peer_case;
pub mod planes;
pub mod reference;
pub mod reliability;
pub mod settling;
pub mod study_file;
pub mod verdict;
pub mod verdict_report;
