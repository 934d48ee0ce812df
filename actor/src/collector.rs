//! Collecting fragments: a batched env stepped by policy inference.
//!
//! Data path: env → actor batch (the env's buffers) → [`Fragment`]. The
//! same collector runs in the learner's process (embedded training) and in
//! `actor` processes (distributed training).

use buridan_env::{BatchedEnv, EnvError, VecEnv};
use buridan_policy::{ActMode, Fragment, Inference, PolicyError, Weights};

use buridan_mapf::shield::rollout::{RolloutShield, RolloutShieldError};

/// The envs of a collector whose kind is chosen at run time: the grid
/// [`VecEnv`], a plant batch, or a [`crate::remote_env::RemoteEnv`] on an
/// external simulator. One virtual call per step; the buffers are the
/// env's own, read in place.
pub type ActorEnv = Box<dyn BatchedEnv + Send>;

/// Why a collector could not produce a fragment.
#[derive(Debug, thiserror::Error)]
pub enum CollectError {
    /// The env refused a step.
    #[error("the env failed")]
    Env(#[from] EnvError),
    /// Inference or loading weights failed.
    #[error("the policy failed")]
    Policy(#[from] PolicyError),
    /// The collision shield of shielded rollouts failed.
    #[error("the rollout shield failed")]
    Shield(#[from] RolloutShieldError),
}

/// An actor's envs and its copy of the policy.
///
/// ```
/// use std::sync::Arc;
/// use buridan_actor::Collector;
/// use buridan_env::{EnvConfig, Map, ObsKind, Starts, VecEnv};
/// use buridan_policy::{ActMode, Inference, ModelSpec, Mode, Policy};
/// let map = Arc::new(Map::load("rm-1.1").unwrap());
/// let env = EnvConfig { agents: 2, starts: Starts::Fixed, ..EnvConfig::default() };
/// let venv = VecEnv::new(map, env, 3, ObsKind::Local, 1).unwrap();
/// let policy = Policy::new(ModelSpec::new(Mode::Ctde, 2, venv.obs_dim()), 0).unwrap();
/// let mut c = Collector {
///     id: 0,
///     inference: Inference::new(policy, 6, 0),
///     behaviour: ActMode::Sample,
///     venv,
///     fragment_len: 10,
///     version: 0,
///     shield: None,
/// };
/// let f = c.collect().unwrap();
/// assert_eq!((f.len, f.rows, f.env_steps), (10, 6, 30));
/// ```
pub struct Collector<E = VecEnv> {
    /// Actor id, stamped on fragments.
    pub id: u32,
    /// The envs.
    pub venv: E,
    /// Policy and sampling state.
    pub inference: Inference,
    /// How rollouts choose actions: [`ActMode::Sample`], or
    /// [`ActMode::GreedyMix`] to rehearse greedy execution (IMPALA).
    pub behaviour: ActMode,
    /// Steps per fragment.
    pub fragment_len: usize,
    /// Weights version currently loaded.
    pub version: u64,
    /// Rollouts through the PIBT collision shield (`shield_rollouts`):
    /// the policy acts under wall masks and the env executes the shield's
    /// joint move ([`buridan_mapf::shield::rollout`]). `None`: the env executes the
    /// policy's actions.
    pub shield: Option<RolloutShield>,
}

impl<E: BatchedEnv> Collector<E> {
    /// Loads `weights` unless they are the version already loaded.
    pub fn load(&mut self, weights: &Weights) -> Result<(), PolicyError> {
        if weights.version != self.version {
            self.inference.policy().set_weights(weights)?;
            self.version = weights.version;
        }
        Ok(())
    }

    /// Env steps in one fragment (steps × envs).
    pub fn fragment_env_steps(&self) -> u64 {
        (self.fragment_len * self.venv.num_envs()) as u64
    }

    /// Collects one fragment of `fragment_len` steps with the loaded weights.
    pub fn collect(&mut self) -> Result<Fragment, CollectError> {
        let spec = self.inference.policy().spec();
        let (heads, actions_per_head) = (spec.heads, spec.actions);
        let (envs, rows, rows_per_env) = (
            self.venv.num_envs(),
            self.venv.rows(),
            self.venv.rows_per_env(),
        );
        let d = self.venv.obs_dim();
        let t_len = self.fragment_len;
        let mut f = Fragment::with_capacity(
            self.id,
            self.version,
            t_len,
            rows,
            rows_per_env,
            d,
            heads,
            actions_per_head,
        );
        f.initial_state = self.inference.state().cloned();
        let mut actions = vec![0u8; rows * heads];
        let mut logp = vec![0f32; rows];
        let mut row_rewards = vec![0f32; rows];
        let mut row_done = vec![0u8; rows];
        let (mut wall_masks, mut executed) = match self.shield {
            Some(_) => (vec![0u8; self.venv.masks().len()], vec![0u8; rows * heads]),
            None => (Vec::new(), Vec::new()),
        };
        for t in 0..t_len {
            f.obs.extend_from_slice(self.venv.obs());
            let masks = match &self.shield {
                Some(shield) => {
                    shield.write_masks(&self.venv, &mut wall_masks)?;
                    &wall_masks[..]
                }
                None => self.venv.masks(),
            };
            f.masks.extend_from_slice(masks);
            let logits = self.inference.act(
                self.venv.obs(),
                masks,
                self.behaviour,
                &mut actions,
                &mut logp,
            )?;
            f.behaviour_logits.extend_from_slice(logits);
            f.actions.extend_from_slice(&actions);
            f.behaviour_logp.extend_from_slice(&logp);
            match &mut self.shield {
                Some(shield) => {
                    shield.joint_move(&self.venv, &actions, logits, masks, &mut executed)?;
                    self.venv.step(&executed)?;
                }
                None => self.venv.step(&actions)?,
            }
            self.venv.write_row_rewards(&mut row_rewards);
            self.venv.write_row_done(&mut row_done);
            f.rewards.extend_from_slice(&row_rewards);
            self.record_ends(&mut f, t);
            // The learner replays the recurrent inputs from the fragment's
            // actions: the chosen ones, even where the shield moved otherwise.
            if let Some(st) = self.inference.state_mut() {
                st.observe(&actions, &row_rewards, &row_done);
            }
        }
        f.len = t_len;
        f.last_obs.extend_from_slice(self.venv.obs());
        f.episodes = self.venv.drain_episodes();
        f.env_steps = (t_len * envs) as u64;
        Ok(f)
    }

    /// Appends step `t`'s per-row done flags and, for truncated episodes,
    /// the final observations that bootstrap their values.
    fn record_ends(&self, f: &mut Fragment, t: usize) {
        let (rows, per_env, d) = (
            self.venv.rows(),
            self.venv.rows_per_env(),
            self.venv.obs_dim(),
        );
        let (term, trunc) = (self.venv.terminated(), self.venv.truncated());
        for r in 0..rows {
            let e = r / per_env;
            f.terminated.push(term[e]);
            f.truncated.push(trunc[e]);
            if trunc[e] != 0 {
                f.final_obs_index.push((t * rows + r) as u32);
                f.final_obs
                    .extend_from_slice(&self.venv.final_obs()[r * d..(r + 1) * d]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use buridan_env::{EnvConfig, Map, ObsKind, VecEnv, NUM_ACTIONS};
    use buridan_policy::{ActMode, Inference, Mode, ModelSpec, Policy};

    use super::*;

    /// An untrained policy on a crowded block layout: moves into occupied
    /// cells are frequent.
    fn crowded(shield: Option<RolloutShield>) -> Collector {
        let map = Arc::new(Map::load("rm-2.1").unwrap());
        let env = EnvConfig {
            agents: 12,
            t_max: 20,
            ..EnvConfig::default()
        };
        let venv = VecEnv::new(map, env, 4, ObsKind::Local, 1).unwrap();
        let policy = Policy::new(ModelSpec::new(Mode::Ctde, 12, venv.obs_dim()), 5).unwrap();
        Collector {
            id: 0,
            inference: Inference::new(policy, venv.rows(), 11),
            behaviour: ActMode::Sample,
            venv,
            fragment_len: 100,
            version: 0,
            shield,
        }
    }

    fn blocked_moves(f: &Fragment) -> u32 {
        f.episodes.iter().map(|e| e.blocked_moves).sum()
    }

    #[test]
    fn shielded_rollouts_never_block_a_move() {
        let mut plain = crowded(None);
        let f = plain.collect().unwrap();
        assert!(f.episodes.len() >= 16, "{} episodes", f.episodes.len());
        assert!(
            blocked_moves(&f) > 0,
            "an untrained crowd bumps into itself"
        );

        let mut shielded = crowded(Some(RolloutShield::new(5)));
        let f = shielded.collect().unwrap();
        assert!(f.episodes.len() >= 16, "{} episodes", f.episodes.len());
        assert_eq!(blocked_moves(&f), 0, "every shielded move succeeds");
        // The fragment records the masks the policy acted under, so the
        // learner's log-probabilities are those of the sampled actions.
        let legal_under_walls = f
            .actions
            .iter()
            .enumerate()
            .all(|(k, &a)| f.masks[k * NUM_ACTIONS + usize::from(a)] == 1);
        assert!(legal_under_walls);
        assert_eq!(f.masks.len(), f.actions.len() * NUM_ACTIONS);
    }
}
