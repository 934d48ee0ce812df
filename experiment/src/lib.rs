//! Experiments over the learner, below the `learner` command line:
//!
//! - [`plan`]: a declarative experiment (`learner study`) — layouts ×
//!   methods × seeds, planners, evaluation cells, their command lines;
//! - [`report`]: its report, every cell read back from its typed run and
//!   evaluation summaries and aggregated over seeds;
//! - [`resolve`]: a training run's configuration from its arguments, as
//!   `learner train` resolves them;
//! - [`trial`] and [`process`]: the study crate's trial runners — in this
//!   process, or as `learner train` children ([`metrics_tail`] follows
//!   their metrics);
//! - [`tune`]: `learner tune`'s study files, directories and outputs.
//!
//! Progress is the caller's: runners show trials through [`trial::TrialDisplay`].

pub mod agents;
pub mod metrics_tail;
pub mod plan;
pub mod process;
pub mod report;
pub mod resolve;
pub mod trial;
pub mod tune;
