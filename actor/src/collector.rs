//! Collecting fragments: a [`VecEnv`] stepped by policy inference.
//!
//! Data path: env → actor batch (the `VecEnv` buffers) → [`Fragment`]. The
//! same collector runs in the learner's process (embedded training) and in
//! `actor` processes (distributed training).

use anyhow::{Context, Result};
use buridan_env::{ObsKind, VecEnv};
use buridan_policy::{ActMode, Fragment, Inference, Weights};

/// An actor's envs and its copy of the policy.
///
/// ```
/// use std::sync::Arc;
/// use buridan_actor::Collector;
/// use buridan_env::{EnvConfig, Map, ObsKind, Starts, VecEnv};
/// use buridan_policy::{Inference, ModelSpec, Mode, Policy};
/// let map = Arc::new(Map::load("rm-1.1").unwrap());
/// let env = EnvConfig { agents: 2, starts: Starts::Fixed, ..EnvConfig::default() };
/// let venv = VecEnv::new(map, env, 3, ObsKind::Local, 1).unwrap();
/// let policy = Policy::new(ModelSpec::new(Mode::Ctde, 2, venv.obs_dim()), 0).unwrap();
/// let mut c = Collector { id: 0, inference: Inference::new(policy, 6, 0), venv, fragment_len: 10, version: 0 };
/// let f = c.collect().unwrap();
/// assert_eq!((f.len, f.rows, f.env_steps), (10, 6, 30));
/// ```
pub struct Collector {
    /// Actor id, stamped on fragments.
    pub id: u32,
    /// The envs.
    pub venv: VecEnv,
    /// Policy and sampling state.
    pub inference: Inference,
    /// Steps per fragment.
    pub fragment_len: usize,
    /// Weights version currently loaded.
    pub version: u64,
}

impl Collector {
    /// Loads `weights` unless they are the version already loaded.
    pub fn load(&mut self, weights: &Weights) -> Result<()> {
        if weights.version != self.version {
            self.inference
                .policy()
                .set_weights(weights)
                .context("cannot load the learner's weights")?;
            self.version = weights.version;
        }
        Ok(())
    }

    /// Collects one fragment of `fragment_len` steps with the loaded weights.
    pub fn collect(&mut self) -> Result<Fragment> {
        let spec = self.inference.policy().spec().clone();
        let (heads, na) = (spec.heads, spec.actions);
        let n = self.venv.agents();
        let envs = self.venv.num_envs();
        let rows_per_env = match self.venv.kind() {
            ObsKind::Local => n,
            ObsKind::Central => 1,
        };
        let rows = envs * rows_per_env;
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
            na,
        );
        f.initial_state = self.inference.state().cloned();
        let mut actions = vec![0u8; rows * heads];
        let mut logp = vec![0f32; rows];
        let mut row_rewards = vec![0f32; rows];
        let mut row_done = vec![0u8; rows];
        for t in 0..t_len {
            f.obs.extend_from_slice(self.venv.obs());
            f.masks.extend_from_slice(self.venv.masks());
            let logits = self.inference.act(
                self.venv.obs(),
                self.venv.masks(),
                ActMode::Sample,
                &mut actions,
                &mut logp,
            )?;
            f.behaviour_logits.extend_from_slice(logits);
            f.actions.extend_from_slice(&actions);
            f.behaviour_logp.extend_from_slice(&logp);
            self.venv.step(&actions)?;
            let rewards = self.venv.rewards();
            match self.venv.kind() {
                ObsKind::Local => row_rewards.copy_from_slice(rewards),
                ObsKind::Central => {
                    for (e, r) in row_rewards.iter_mut().enumerate() {
                        *r = rewards[e * n..(e + 1) * n].iter().sum();
                    }
                }
            }
            f.rewards.extend_from_slice(&row_rewards);
            let (term, trunc) = (self.venv.terminated(), self.venv.truncated());
            for e in 0..envs {
                for j in 0..rows_per_env {
                    let r = e * rows_per_env + j;
                    f.terminated.push(term[e]);
                    f.truncated.push(trunc[e]);
                    row_done[r] = u8::from(term[e] != 0 || trunc[e] != 0);
                    if trunc[e] != 0 {
                        f.final_obs_index.push((t * rows + r) as u32);
                        f.final_obs
                            .extend_from_slice(&self.venv.final_obs()[r * d..(r + 1) * d]);
                    }
                }
            }
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
}
