//! Hyperparameter searches and multi-seed studies for Buridan.
//!
//! The crate sits below the learner: it samples configurations, decides
//! which trials deserve more steps, keeps a resumable record of a study,
//! computes bootstrap statistics and writes reports, figures and
//! Kubernetes manifests. It runs trials through the [`TrialRunner`] trait,
//! which the learner implements (in process or as `learner train` child
//! processes), so it never imports the learner.
//!
//! - [`space`]: search spaces from TOML (choice, uniform, log-uniform, int).
//! - [`overrides`]: a trial's configuration as `--set` flags or a TOML table.
//! - [`sampler`]: grid, random and TPE samplers behind one trait.
//! - [`scheduler`]: ASHA, the median stopping rule, PBT's exploit-and-explore.
//! - [`objective`]: training success or seed-42 evaluation; ties to shorter episodes.
//! - [`runner`]: the [`TrialRunner`] and [`Reporter`] traits.
//! - [`config`]: study files.
//! - [`state`]: the persisted study (`study.json`).
//! - [`study`]: the driver — parallel trials, budgets, resume.
//! - [`population`]: the PBT driver — the population in rounds, exploit and explore.
//! - [`lineage`]: PBT's record — who copied whom, the best member's schedule.
//! - [`lock`]: one `learner tune` or `learner study` per directory.
//! - [`batch`]: trial specs and results on a shared volume for cluster runs.
//! - [`k8s`]: Kubernetes Indexed Job manifests.
//! - [`stats`]: mean, IQM, percentile-bootstrap intervals.
//! - [`report`]: Markdown, CSV and JSON tables.
//! - [`output`], [`plot`]: a study's CSV/JSON/TOML files and PNG figures.
//! - [`figures`]: an experiment's bars with CI whiskers and lines with CI bands.
//!
//! ```
//! use buridan_study::*;
//! // The learner's side: train `spec.overrides` for `spec.steps` steps.
//! struct Synthetic;
//! impl TrialRunner for Synthetic {
//!     fn run(&self, spec: &TrialSpec, reporter: &mut dyn Reporter) -> Result<Measurement, TrialError> {
//!         let lr = spec.overrides["ppo.lr"].as_float().unwrap_or(0.0);
//!         let mut m = Measurement::default();
//!         for step in (1000..=spec.steps).step_by(1000) {
//!             m = Measurement { step, train_success: Some(1.0 - (lr.log10() + 3.0).abs() / 3.0), ..m };
//!             if !reporter.report(&m).keeps_going() { break; }
//!         }
//!         Ok(m)
//!     }
//! }
//! let config = StudyConfig::from_toml_str(r#"
//!     [study]
//!     name = "demo"
//!     sampler = "tpe"
//!     trials = 12
//!     parallel = 2
//!     steps_per_trial = 9000
//!     [study.scheduler]
//!     kind = "asha"
//!     grace_steps = 1000
//!     [space]
//!     "ppo.lr" = { log_uniform = [1e-5, 1e-1] }
//! "#).unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! let mut study = Study::open(dir.path(), config).unwrap();
//! let progress = study.run(&Synthetic).unwrap();
//! assert_eq!(progress.completed + progress.stopped, 12);
//! assert!(study.state().best().is_some());
//! ```

#![warn(missing_docs)]

pub mod batch;
pub mod config;
pub mod figures;
pub mod k8s;
pub mod lineage;
pub mod lock;
pub mod objective;
pub mod output;
pub mod overrides;
pub mod plot;
pub mod population;
pub mod report;
pub mod runner;
pub mod sampler;
pub mod scheduler;
pub mod space;
pub mod state;
pub mod stats;
pub mod study;

pub use config::StudyConfig;
pub use objective::{Measurement, Objective, Score};
pub use overrides::Overrides;
pub use runner::{Reporter, TrialError, TrialRunner, TrialSpec};
pub use scheduler::Decision;
pub use space::SearchSpace;
pub use study::{Study, StudyError};
