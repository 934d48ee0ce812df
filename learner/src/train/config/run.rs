//! How a run is carried out ([`RunConfig`]): its seed and budget, the
//! actors that collect its experience, its checkpoints and when it stops.

use std::path::PathBuf;

use buridan_policy::DeviceSpec;

use crate::train::stop::StopRule;

/// How a run is carried out, TOML top-level keys `seed`, `steps`,
/// `num_actors`, `envs_per_actor`, `actor_nice`, `fragment_len`,
/// `checkpoint_every`, `stop_return`, `stop_len`, `[stop]`, `resume` and
/// `device` (the file keeps them flat; [`super::TrainConfig`] groups them here).
///
/// ```
/// use buridan_learner::train::TrainConfig;
/// let cfg: TrainConfig = toml::from_str("seed = 7\nsteps = 1000\nenvs_per_actor = 4").unwrap();
/// assert_eq!((cfg.run.seed, cfg.run.steps, cfg.run.envs_per_actor), (7, 1000, 4));
/// assert_eq!((cfg.run.num_actors, cfg.run.fragment_len), (1, 50));
/// assert_eq!(cfg.run.device, buridan_policy::DeviceSpec::Cpu);
/// let gpu: TrainConfig = toml::from_str("device = \"cuda:1\"").unwrap();
/// assert_eq!(gpu.run.device, buridan_policy::DeviceSpec::Cuda(1));
/// assert!(toml::from_str::<TrainConfig>("device = \"gpu\"").is_err());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct RunConfig {
    /// Seed of weights, sampling and the env episodes (actor `i` uses env seed `seed + i`).
    pub seed: u64,
    /// Env-step budget.
    pub steps: u64,
    /// Actor threads.
    pub num_actors: usize,
    /// Envs per actor (one VecEnv each).
    pub envs_per_actor: usize,
    /// Niceness of the embedded actor threads (0–19; 0: the learner's
    /// priority), as `actor --nice` sets it for an actor process. Measured
    /// on 2 cores it leaves an embedded IMPALA run's speed unchanged (0.99)
    /// while it speeds up an actor process beside the learner; the
    /// transport bench sets both alike (README, "Measured on this 2-core
    /// machine").
    pub actor_nice: u8,
    /// Rollout fragment length T (50).
    pub fragment_len: usize,
    /// Save a checkpoint every this many updates (0: only the final one).
    pub checkpoint_every: u64,
    /// Stop early once the mean return of the last 100 episodes reaches this.
    pub stop_return: Option<f64>,
    /// …and (if set) their mean length is at most this.
    pub stop_len: Option<f64>,
    /// Stop once the policy has learned, TOML `[stop]`: the training
    /// success has held `success` for `hold` env steps, or (`[stop.greedy]`)
    /// the greedy policy solves a share of held-out episodes (`steps` stays
    /// the cap; [`crate::train::stop`]). Off by default; the recipe sets it.
    pub stop: Option<StopRule>,
    /// Continue from this checkpoint directory (weights, optimiser, counters).
    pub resume: Option<PathBuf>,
    /// Where the learner's weights and updates live (`cpu`, `cuda[:N]`;
    /// a GPU needs a `cuda` build, [`buridan_policy::device`]). Actors,
    /// imitation's expert and the evaluations act on the CPU whatever it
    /// is; only the gradient steps (PPO, IMPALA, cloning) move.
    pub device: DeviceSpec,
}

impl Default for RunConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            steps: 2_000_000,
            num_actors: 1,
            envs_per_actor: 16,
            actor_nice: 0,
            fragment_len: 50,
            checkpoint_every: 50,
            stop_return: None,
            stop_len: None,
            stop: None,
            resume: None,
            device: DeviceSpec::Cpu,
        }
    }
}
