//! The soak harness behind `learner bench soak` (the CLI's non-default
//! `soak` feature): `learner serve` and `actor` processes on loopback for N
//! minutes, with a misbehaving client mixed in
//! (`buridan_actor::misbehave`) and actors killed (SIGKILL) and restarted
//! at random. Every few seconds it samples the learner's resident memory
//! (`VmRSS`) and scrapes its Prometheus endpoint; at the end it stops the
//! actors, lets the learner drain its queue, stops the learner with
//! SIGTERM (it checkpoints) and balances the fragment books:
//!
//! - every consumed fragment was whole: steps consumed = fragments
//!   consumed × fragment length × envs, and the learner's env-step counter
//!   is a whole number of fragments;
//! - none was used twice: fragments consumed + dropped as stale at the
//!   learner ≤ fragments taken from the queue ≤ fragments accepted;
//! - lost = accepted − consumed, split into dropped as stale at the
//!   learner and held at the end (queue and partial batch, dropped by the
//!   stop).
//!
//! Outputs in `--out`: `soak.csv` (one row per sample), `soak.json`,
//! `soak.png` (memory and training success over time), `soak.md`, and the
//! processes' logs. [`run`] fails ([`SoakError::Failed`]) if the learner
//! died, a book does not balance, the misbehaving client got anything but
//! the refusals it expected, or training success never reached `--target`.
//!
//! A dev-only crate: the production `learner` and `actor` builds leave it,
//! and the misbehaving client it needs, out.

use std::path::PathBuf;

use indicatif::ProgressBar;

mod actors;
mod args;
mod books;
mod child;
mod dice;
mod error;
mod learner;
mod markdown;
mod png;
mod run;
mod sample;
mod scrape;
mod summary;

pub use args::SoakArgs;
pub use books::{balance, Books};
pub use error::{ScrapeError, SoakError};
pub use markdown::markdown;
pub use png::draw;
pub use run::run;
pub use sample::Sample;
pub use scrape::{scrape, Scrape};
pub use summary::{MisbehaveJson, SoakSummary};

/// The `tracing` target of the soak's progress lines: the `learner`
/// binary's progress target (`buridan_cli::heartbeat::TARGET`), which it
/// shows at `info`.
pub const TARGET: &str = "progress";

/// What the soak needs from the program that runs it.
#[derive(Debug, Clone)]
pub struct Host {
    /// The `learner` executable whose `serve` is soaked.
    pub learner_exe: PathBuf,
    /// Called once on the soak's progress bar (the `learner` binary logs
    /// the bar's state through `tracing` when stderr is not a terminal).
    pub watch: fn(&ProgressBar),
}
