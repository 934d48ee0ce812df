//! A trained policy as an evaluation [`Controller`] (`--controller checkpoint:DIR`).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use buridan_env::{GridEnv, NUM_ACTIONS};
use buridan_eval::{Controller, GiveUp};
use buridan_policy::{ActMode, Inference, Mode, Policy};

/// Resolves a checkpoint argument: a `learner train --out` directory (its
/// `checkpoints/final`, else the newest `checkpoints/update-*`) or a
/// checkpoint directory itself.
pub fn resolve_checkpoint(dir: &Path) -> Result<PathBuf> {
    if dir.join("spec.json").is_file() {
        return Ok(dir.to_path_buf());
    }
    let root = dir.join("checkpoints");
    let last = root.join("final");
    if last.join("spec.json").is_file() {
        return Ok(last);
    }
    let mut updates: Vec<PathBuf> = std::fs::read_dir(&root)
        .with_context(|| {
            format!(
                "{} holds no checkpoint (no spec.json, no checkpoints/ folder)",
                dir.display()
            )
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("spec.json").is_file())
        .collect();
    updates.sort();
    updates
        .pop()
        .with_context(|| format!("{} holds no checkpoint", root.display()))
}

/// Drives all agents with a trained policy: greedy or sampled actions.
pub struct PolicyController {
    inference: Inference,
    mode: Mode,
    act_mode: ActMode,
    obs: Vec<f32>,
    masks: Vec<u8>,
    actions: Vec<u8>,
    logp: Vec<f32>,
    name: String,
}

impl PolicyController {
    /// Loads the policy at `checkpoint` for episodes with `agents` agents.
    pub fn load(checkpoint: &Path, agents: usize, act_mode: ActMode, seed: u64) -> Result<Self> {
        let dir = resolve_checkpoint(checkpoint)?;
        let policy =
            Policy::load(&dir).with_context(|| format!("loading policy from {}", dir.display()))?;
        let spec = policy.spec().clone();
        let rows = match spec.mode {
            Mode::Cte => {
                if spec.agents != agents {
                    bail!(
                        "the CTE policy in {} controls {} agents, not {agents}",
                        dir.display(),
                        spec.agents
                    );
                }
                1
            }
            Mode::Dte if spec.agents != agents => {
                bail!(
                    "the DTE policy in {} has one net per agent for {} agents, not {agents}",
                    dir.display(),
                    spec.agents
                )
            }
            Mode::Ctde | Mode::Dte => agents,
        };
        // A CTDE policy trained with n agents runs with any number (scalability).
        let inference = Inference::new(policy, rows, seed);
        let heads = spec.heads;
        Ok(Self {
            mode: spec.mode,
            act_mode,
            obs: vec![0.0; rows * spec.obs_dim],
            masks: vec![0; rows * heads * NUM_ACTIONS],
            actions: vec![0; rows * heads],
            logp: vec![0.0; rows],
            name: format!("{:?}-policy", spec.mode).to_lowercase(),
            inference,
        })
    }
}

impl Controller for PolicyController {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        let expected = self.obs.len() / self.inference.rows();
        let dim = if self.mode == Mode::Cte {
            env.central_obs_dim()
        } else {
            env.local_obs_dim()
        };
        if dim != expected {
            return Err(GiveUp::Other(format!(
                "the policy expects {expected} observation floats, this env gives {dim}"
            )));
        }
        if let Some(state) = self.inference.state_mut() {
            for r in 0..state.rows {
                state.reset_row(r);
            }
        }
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        if self.mode == Mode::Cte {
            env.write_central_obs(&mut self.obs).expect("sized at load");
            env.write_joint_mask(&mut self.masks)
                .expect("sized at load");
        } else {
            let d = env.local_obs_dim();
            for i in 0..env.agents() {
                env.write_local_obs(i, &mut self.obs[i * d..(i + 1) * d])
                    .expect("sized at load");
                env.write_action_mask(i, &mut self.masks[i * NUM_ACTIONS..(i + 1) * NUM_ACTIONS])
                    .expect("sized at load");
            }
        }
        match self.inference.act(
            &self.obs,
            &self.masks,
            self.act_mode,
            &mut self.actions,
            &mut self.logp,
        ) {
            Ok(_) => actions.copy_from_slice(&self.actions),
            // Stay is always legal, so an empty mask cannot occur; be safe anyway.
            Err(_) => actions.fill(0),
        }
    }

    fn after_step(&mut self, rewards: &[f32]) {
        let rows = self.inference.rows();
        let row_rewards: Vec<f32> = if self.mode == Mode::Cte {
            vec![rewards.iter().sum()]
        } else {
            rewards.to_vec()
        };
        let actions = self.actions.clone();
        if let Some(state) = self.inference.state_mut() {
            state.observe(&actions, &row_rewards, &vec![0; rows]);
        }
    }
}
