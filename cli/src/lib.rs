//! The `learner` command line over the learner library: each subcommand's
//! arguments (clap), its progress bar (indicatif), its report, and the
//! Prometheus exporter. Logic lives in `buridan-learner`, `buridan-eval`,
//! `buridan-mapf` and `buridan-experiment` (the study planner, its report,
//! the trial drivers); this crate only parses, calls and presents.

pub mod bench;
pub mod bench_train;
pub mod dashboard;
pub mod eval;
pub mod heartbeat;
pub mod maps;
pub mod replay;
pub mod serve;
pub mod signals;
pub mod study;
pub mod train;
pub mod trial_bars;
pub mod tune;

pub use buridan_experiment::plan as experiment;
pub use buridan_experiment::report as aggregate;
pub use buridan_experiment::{metrics_tail, process, trial};
