//! The batched multi-agent env interface an actor drives: the grid
//! [`crate::VecEnv`] implements it, and so can any other simulator (an AGV
//! plant, a remote env) without the actor knowing which.
//!
//! All buffers are flat and env-major. A *row* is what the policy sees at
//! once: one agent (local observations) or one whole env (central ones).
//!
//! ```
//! use buridan_env::{BatchedEnv, EnvConfig, Map, ObsKind, VecEnv};
//! let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
//! let mut venv = VecEnv::new(map, EnvConfig::default(), 3, ObsKind::Local, 1).unwrap();
//! assert_eq!((venv.rows_per_env(), venv.rows()), (4, 12));
//! venv.step(&[0u8; 12]).unwrap();
//! let mut rewards = [9.0f32; 12];
//! venv.write_row_rewards(&mut rewards);
//! assert!(rewards.iter().all(|&r| r == 0.0)); // everybody stayed
//! ```

use crate::error::EnvError;
use crate::obs::ObsKind;
use crate::stats::EpisodeStats;
use crate::world::GridEnv;

/// Envs stepped as one batch with auto-reset (see [`crate::VecEnv`] for the
/// buffer contract).
pub trait BatchedEnv {
    /// Number of envs.
    fn num_envs(&self) -> usize;
    /// Agents per env.
    fn agents(&self) -> usize;
    /// The observation kind (one row per agent, or per env).
    fn kind(&self) -> ObsKind;
    /// Floats per observation row.
    fn obs_dim(&self) -> usize;
    /// Current observations, `rows × obs_dim`.
    fn obs(&self) -> &[f32];
    /// Current action masks, row-major.
    fn masks(&self) -> &[u8];
    /// Steps every env with one action per agent (env-major).
    fn step(&mut self, actions: &[u8]) -> Result<(), EnvError>;
    /// Rewards of the last step, per agent, env-major.
    fn rewards(&self) -> &[f32];
    /// Per env: the last step ended the episode with all agents at their goals.
    fn terminated(&self) -> &[u8];
    /// Per env: the last step ended the episode at the time limit.
    fn truncated(&self) -> &[u8];
    /// Last observations of the episodes that ended in the last step
    /// (rows of other envs are stale).
    fn final_obs(&self) -> &[f32];
    /// Statistics of the episodes finished since the last call.
    fn drain_episodes(&mut self) -> Vec<EpisodeStats>;

    /// Env `e` as a grid world (map, positions, goals), for what acts on
    /// the grid beside the policy — a collision shield in rollouts. `None`
    /// (the default) for envs that are no grid world, such as a plant.
    fn grid_env(&self, _e: usize) -> Option<&GridEnv> {
        None
    }

    /// Rows per env: agents for local observations, 1 for central ones.
    fn rows_per_env(&self) -> usize {
        self.kind().rows_per_env(self.agents())
    }

    /// Rows of the whole batch.
    fn rows(&self) -> usize {
        self.num_envs() * self.rows_per_env()
    }

    /// Writes each row's reward of the last step: the agent's own (local
    /// rows) or the sum over the env's agents (a central row).
    fn write_row_rewards(&self, out: &mut [f32]) {
        let (n, per_env) = (self.agents(), self.rows_per_env());
        let rewards = self.rewards();
        for (e, rows) in out.chunks_mut(per_env).enumerate() {
            let env_rewards = &rewards[e * n..(e + 1) * n];
            if per_env == 1 && n != 1 {
                rows[0] = env_rewards.iter().sum();
            } else {
                rows.copy_from_slice(env_rewards);
            }
        }
    }

    /// Writes 1 for each row whose env's episode ended in the last step, else 0.
    fn write_row_done(&self, out: &mut [u8]) {
        let (term, trunc) = (self.terminated(), self.truncated());
        for (e, rows) in out.chunks_mut(self.rows_per_env()).enumerate() {
            rows.fill(u8::from(term[e] != 0 || trunc[e] != 0));
        }
    }
}

/// A boxed batch is a batch: an actor can drive `Box<dyn BatchedEnv + Send>`
/// when the kind of env is chosen at run time (one map or several).
///
/// ```
/// use buridan_env::{BatchedEnv, EnvConfig, Map, ObsKind, VecEnv};
/// let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
/// let venv = VecEnv::new(map, EnvConfig::default(), 2, ObsKind::Local, 1).unwrap();
/// let boxed: Box<dyn BatchedEnv + Send> = Box::new(venv);
/// assert_eq!(boxed.rows(), 8);
/// ```
impl<E: BatchedEnv + ?Sized> BatchedEnv for Box<E> {
    fn num_envs(&self) -> usize {
        (**self).num_envs()
    }
    fn agents(&self) -> usize {
        (**self).agents()
    }
    fn kind(&self) -> ObsKind {
        (**self).kind()
    }
    fn obs_dim(&self) -> usize {
        (**self).obs_dim()
    }
    fn obs(&self) -> &[f32] {
        (**self).obs()
    }
    fn masks(&self) -> &[u8] {
        (**self).masks()
    }
    fn step(&mut self, actions: &[u8]) -> Result<(), EnvError> {
        (**self).step(actions)
    }
    fn rewards(&self) -> &[f32] {
        (**self).rewards()
    }
    fn terminated(&self) -> &[u8] {
        (**self).terminated()
    }
    fn truncated(&self) -> &[u8] {
        (**self).truncated()
    }
    fn final_obs(&self) -> &[f32] {
        (**self).final_obs()
    }
    fn drain_episodes(&mut self) -> Vec<EpisodeStats> {
        (**self).drain_episodes()
    }
    fn grid_env(&self, e: usize) -> Option<&GridEnv> {
        (**self).grid_env(e)
    }
    fn rows_per_env(&self) -> usize {
        (**self).rows_per_env()
    }
    fn rows(&self) -> usize {
        (**self).rows()
    }
    fn write_row_rewards(&self, out: &mut [f32]) {
        (**self).write_row_rewards(out)
    }
    fn write_row_done(&self, out: &mut [u8]) {
        (**self).write_row_done(out)
    }
}
