//! The `learner` command line over the learner library: each subcommand's
//! arguments (clap), its progress bar (indicatif), its report, and the
//! Prometheus exporter. Logic lives in `buridan-learner`, `buridan-eval`
//! and `buridan-mapf`; this crate only parses, calls and presents.

pub mod aggregate;
pub mod bench;
pub mod bench_soak;
pub mod bench_train;
pub mod dashboard;
pub mod eval;
pub mod experiment;
pub mod heartbeat;
pub mod metrics_tail;
pub mod process;
pub mod replay;
pub mod serve;
pub mod signals;
pub mod study;
pub mod train;
pub mod trial;
pub mod tune;
