//! Imitation of a classical planner with on-policy correction.
//!
//! Reinforcement learning finds the easy half of deadlock handling by
//! itself — walk the shortest path, step aside when pushed — but on layouts
//! with dead ends it rarely discovers the long manoeuvres (back out of the
//! aisle, let the other one pass, go back in) that a planner finds in
//! milliseconds. This crate teaches those manoeuvres directly: a planner
//! from `buridan-mapf` labels the states a policy visits with its next
//! joint step, and the policy network is fitted to the labels by behaviour
//! cloning, round after round ([`dagger`], DAgger). The result is an
//! ordinary checkpoint: it can be evaluated as it is, or fine-tuned by PPO
//! or IMPALA (`[imitation]` in a training config does both: the learner
//! imitates first, then learns from rewards).
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::{EnvConfig, Map, ObsKind, VecEnv};
//! use buridan_imitate::{dagger, ImitationConfig};
//! use buridan_policy::{Mode, ModelSpec, Policy};
//!
//! let map = Arc::new(Map::load("rm-1.1").unwrap());
//! let env = EnvConfig { agents: 2, ..EnvConfig::default() };
//! let mut venv = VecEnv::new(map, env, 4, ObsKind::Local, 1).unwrap();
//! let policy = Policy::new(ModelSpec::new(Mode::Ctde, 2, venv.obs_dim()), 0).unwrap();
//! let cfg = ImitationConfig { rounds: 2, steps_per_round: 400, ..ImitationConfig::default() };
//! let reports = dagger(&cfg, &policy, &mut venv, 7, &mut |_| {}).unwrap();
//! assert_eq!(reports.len(), 2);
//! assert!(reports[0].success_rate > 0.9, "the expert solves rm-1.1");
//! assert!(reports[1].accuracy > reports[0].accuracy - 0.05);
//! ```

pub mod cloning;
pub mod config;
pub mod dagger;
pub mod dataset;
pub mod error;
pub mod expert;
pub mod windows;

pub use config::{ImitationConfig, LabelStyle, Rollout, Teacher};
pub use dagger::{dagger, RoundReport};
pub use dataset::Dataset;
pub use error::ImitationError;
pub use expert::{Expert, Labels};
pub use windows::Windows;
