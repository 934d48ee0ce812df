//! [`StepBuffers`]: the flat buffers a [`crate::BatchedEnv`] hands its actor
//! after every step, one type for every batch (the grid [`crate::VecEnv`],
//! a plant batch, a remote env), and [`batched_env_buffers!`], which reads
//! them out in a `BatchedEnv` impl.
//!
//! ```
//! use buridan_env::StepBuffers;
//! let mut b = StepBuffers::new(2, 3, 2 * 3 * 4, 2 * 3 * 5);
//! assert_eq!((b.obs.len(), b.masks.len(), b.rewards.len(), b.truncated.len()), (24, 30, 6, 2));
//! assert!(b.drain_episodes().is_empty());
//! ```

use crate::stats::EpisodeStats;

/// What a batch of envs shows after a step, flat and env-major (the
/// contract is [`crate::VecEnv`]'s).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepBuffers {
    /// The observations to act on next (after an episode ended, the next
    /// episode's first).
    pub obs: Vec<f32>,
    /// The last observations of the episodes that ended in the last step
    /// (rows of other envs are stale).
    pub final_obs: Vec<f32>,
    /// The current action masks, row-major.
    pub masks: Vec<u8>,
    /// Rewards of the last step, per agent.
    pub rewards: Vec<f32>,
    /// Per env: 1 if the last step ended its episode with all agents home.
    pub terminated: Vec<u8>,
    /// Per env: 1 if the last step ended its episode at the time limit.
    pub truncated: Vec<u8>,
    /// Statistics of the episodes finished and not yet drained.
    pub episodes: Vec<EpisodeStats>,
}

impl StepBuffers {
    /// Zeroed buffers for `num_envs` envs of `agents` agents, with
    /// `obs_len` observation floats (also the final observations') and
    /// `mask_len` mask bytes in all.
    pub fn new(num_envs: usize, agents: usize, obs_len: usize, mask_len: usize) -> Self {
        Self {
            obs: vec![0.0; obs_len],
            final_obs: vec![0.0; obs_len],
            masks: vec![0; mask_len],
            rewards: vec![0.0; num_envs * agents],
            terminated: vec![0; num_envs],
            truncated: vec![0; num_envs],
            episodes: Vec::new(),
        }
    }

    /// Takes the statistics of the episodes finished since the last call.
    pub fn drain_episodes(&mut self) -> Vec<EpisodeStats> {
        std::mem::take(&mut self.episodes)
    }
}

/// The [`crate::BatchedEnv`] methods that read a batch's [`StepBuffers`]
/// (`obs`, `masks`, `rewards`, `terminated`, `truncated`, `final_obs`,
/// `drain_episodes`), written inside an `impl BatchedEnv for …` block from
/// the field that holds them. A macro: the trait's other impls (a boxed
/// batch) rule out a blanket impl over types that hold buffers.
///
/// ```
/// use buridan_env::{batched_env_buffers, BatchedEnv, EnvError, ObsKind, StepBuffers};
/// struct Idle {
///     buffers: StepBuffers,
/// }
/// impl BatchedEnv for Idle {
///     fn num_envs(&self) -> usize { 1 }
///     fn agents(&self) -> usize { 2 }
///     fn kind(&self) -> ObsKind { ObsKind::Local }
///     fn obs_dim(&self) -> usize { 3 }
///     fn step(&mut self, _actions: &[u8]) -> Result<(), EnvError> { Ok(()) }
///     batched_env_buffers!(buffers);
/// }
/// let idle = Idle { buffers: StepBuffers::new(1, 2, 6, 10) };
/// assert_eq!((idle.obs().len(), idle.rewards().len()), (6, 2));
/// ```
#[macro_export]
macro_rules! batched_env_buffers {
    ($field:ident) => {
        fn obs(&self) -> &[f32] {
            &self.$field.obs
        }
        fn masks(&self) -> &[u8] {
            &self.$field.masks
        }
        fn rewards(&self) -> &[f32] {
            &self.$field.rewards
        }
        fn terminated(&self) -> &[u8] {
            &self.$field.terminated
        }
        fn truncated(&self) -> &[u8] {
            &self.$field.truncated
        }
        fn final_obs(&self) -> &[f32] {
            &self.$field.final_obs
        }
        fn drain_episodes(&mut self) -> Vec<$crate::EpisodeStats> {
            self.$field.drain_episodes()
        }
    };
}
