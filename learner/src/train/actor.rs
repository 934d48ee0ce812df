//! In-process actors: a [`VecEnv`] plus policy inference, producing
//! [`Fragment`]s for the learner and picking up new weights between
//! fragments.
//!
//! Data path: env → actor batch (`VecEnv` buffers) → [`Fragment`] →
//! bounded queue → learner batch → new [`Weights`] in [`Shared`] → actors.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Condvar, Mutex, RwLock};

use anyhow::{Context, Result};
use buridan_env::{ObsKind, VecEnv};
use buridan_policy::{ActMode, Fragment, Inference, Weights};

/// What the learner shares with its actors.
pub struct Shared {
    weights: RwLock<Arc<Weights>>,
    gate: Mutex<Gate>,
    wake: Condvar,
    stop: AtomicBool,
}

/// On-policy gating: how many more fragments may be collected with which
/// policy version.
struct Gate {
    version: u64,
    remaining: usize,
}

impl Shared {
    /// Starts with `weights`; actors may not collect until [`Self::open`]
    /// (on-policy) unless `unlimited`.
    pub fn new(weights: Weights, unlimited: bool) -> Self {
        let version = weights.version;
        Self {
            weights: RwLock::new(Arc::new(weights)),
            gate: Mutex::new(Gate {
                version,
                remaining: if unlimited { usize::MAX } else { 0 },
            }),
            wake: Condvar::new(),
            stop: AtomicBool::new(false),
        }
    }

    /// Publishes new weights (actors load them before their next fragment).
    pub fn publish(&self, weights: Weights) {
        *self.weights.write().expect("weights lock") = Arc::new(weights);
    }

    /// The latest weights.
    pub fn latest(&self) -> Arc<Weights> {
        self.weights.read().expect("weights lock").clone()
    }

    /// Allows `fragments` more fragments with policy `version` (PPO: the
    /// weights of that version must already be published).
    pub fn open(&self, version: u64, fragments: usize) {
        let mut g = self.gate.lock().expect("gate lock");
        g.version = version;
        g.remaining = fragments;
        self.wake.notify_all();
    }

    /// Asks every actor to stop.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
        let _g = self.gate.lock().expect("gate lock");
        self.wake.notify_all();
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Takes a ticket for one fragment; `None` once stopped.
    fn ticket(&self) -> Option<u64> {
        let mut g = self.gate.lock().expect("gate lock");
        loop {
            if self.stopped() {
                return None;
            }
            if g.remaining > 0 {
                if g.remaining != usize::MAX {
                    g.remaining -= 1;
                }
                return Some(g.version);
            }
            g = self.wake.wait(g).expect("gate lock");
        }
    }
}

/// One actor: its envs, its copy of the policy, its queue end.
pub struct Actor {
    /// Actor id.
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

impl Actor {
    /// Runs until the learner stops it or hangs up.
    pub fn run(mut self, shared: Arc<Shared>, tx: SyncSender<Fragment>) -> Result<()> {
        while let Some(_ticket) = shared.ticket() {
            let latest = shared.latest();
            if latest.version != self.version {
                self.inference
                    .policy()
                    .set_weights(&latest)
                    .context("actor cannot load weights")?;
                self.version = latest.version;
            }
            let fragment = self.collect()?;
            if tx.send(fragment).is_err() {
                break;
            }
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
