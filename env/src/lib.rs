//! Buridan's grid environments: the deadlock reference models of the
//! dissertation as a fast multi-agent simulator.
//!
//! - [`map`]: MovingAI `.map`/`.scen` loading, the 17 bundled reference models.
//! - [`generate`]: seeded map generators (mazes, random obstacles, warehouses).
//! - [`world`]: [`GridEnv`], one env under either rule set.
//! - [`rules`]: the rule sets, [`Rules::Thesis`] (sequential moves, the
//!   default) and [`Rules::Pogema`] (POGEMA 1.4.0's simultaneous moves).
//! - [`obs`]: CTDE/DTE local and CTE central observations, action masks.
//! - [`vec_env`]: [`VecEnv`], a batch of envs with auto-reset.
//! - [`mixture`]: [`LayoutMixture`], one env over several layouts with weights.
//! - [`replay`]: [`replay::FailureReplay`], a slot that plays its failed episodes again.
//! - [`monitor`]: deadlock and livelock detection.
//! - [`api`]: [`BatchedEnv`], the batched interface actors drive.
//! - [`seed`]: how one run seed becomes every random stream's seed.
//! - [`text_serde`]: serde through a type's text ([`serde_as_text!`]).
//!
//! ```
//! use buridan_env::{EnvConfig, GridEnv, Map, Starts};
//! let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
//! let cfg = EnvConfig { agents: 2, starts: Starts::Fixed, ..EnvConfig::default() };
//! let mut env = GridEnv::new(map, cfg).unwrap();
//! let mut obs = vec![0.0; env.local_obs_dim()];
//! env.write_local_obs(0, &mut obs).unwrap();
//! assert_eq!(obs.len(), 129);
//! ```

pub mod api;
pub mod buffers;
pub mod config;
pub mod error;
pub mod generate;
pub mod map;
pub mod mixture;
pub mod monitor;
pub mod obs;
pub mod recipe;
pub mod replay;
pub mod reward;
pub mod rules;
pub mod seed;
pub mod stats;
pub mod text_serde;
pub mod vec_env;
pub mod world;

pub use api::BatchedEnv;
pub use buffers::StepBuffers;
pub use config::{episode_instance, episode_rng, EnvConfig, Starts};
pub use error::{EnvError, MapError};
pub use map::{Cell, Grid, Map, MapSource, Scenario, REFERENCE_MODELS};
pub use mixture::{LayoutMixture, WeightedLayout};
pub use obs::{central_obs_dim, local_obs_dim, ObsKind};
pub use recipe::{
    intent_feature_dim, order_feature_dim, priority_feature_dim, ObsFeatures, Shaping,
    UnknownFeature, PATH_FEATURE_DIM, PRESSURE_FEATURE_DIM,
};
pub use reward::RewardRange;
pub use rules::{Rules, UnknownRules, POGEMA_T_MAX, THESIS_T_MAX};
pub use stats::EpisodeStats;
pub use vec_env::{EnvSlot, VecEnv};
pub use world::{GridEnv, StepOutcome, NUM_ACTIONS};
