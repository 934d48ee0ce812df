//! A trained policy as an evaluation [`Controller`] (`--controller checkpoint:DIR`).

use std::path::{Path, PathBuf};

use buridan_env::{GridEnv, ObsFeatures, NUM_ACTIONS};
use buridan_policy::{checkpoint, ActMode, Device, Inference, Mode, Policy, PolicyError};

use crate::{Controller, GiveUp};

/// Why a trained policy cannot drive an evaluation.
#[derive(Debug, thiserror::Error)]
pub enum PolicyLoadError {
    /// The checkpoint is missing or unreadable.
    #[error("loading a policy from {}", dir.display())]
    Checkpoint {
        /// The directory given.
        dir: PathBuf,
        /// What went wrong.
        source: PolicyError,
    },
    /// The policy was trained for another number of agents and cannot
    /// control this many (CTE joint policies, DTE per-agent nets).
    #[error("the {mode:?} policy in {} controls {trained} agents, not {asked}", dir.display())]
    AgentCount {
        /// The checkpoint.
        dir: PathBuf,
        /// Its mode.
        mode: Mode,
        /// Agents it was trained for.
        trained: usize,
        /// Agents asked for.
        asked: usize,
    },
}

/// Drives all agents with a trained policy: greedy or sampled actions.
pub struct PolicyController {
    runner: PolicyRunner,
    name: String,
    features: ObsFeatures,
    sensor_range: usize,
}

impl PolicyController {
    /// Loads the policy at `checkpoint` for episodes with `agents` agents.
    pub fn load(
        path: &Path,
        agents: usize,
        act_mode: ActMode,
        seed: u64,
    ) -> Result<Self, PolicyLoadError> {
        Self::load_on(path, agents, act_mode, seed, &Device::Cpu)
    }

    /// [`Self::load`] with the weights on `device` (inference there).
    pub fn load_on(
        path: &Path,
        agents: usize,
        act_mode: ActMode,
        seed: u64,
        device: &Device,
    ) -> Result<Self, PolicyLoadError> {
        let (_, policy, rows) = load_for_agents(path, agents, device)?;
        let spec = policy.spec().clone();
        Ok(Self {
            runner: PolicyRunner::new(policy, rows, act_mode, seed),
            name: format!("{:?}-policy", spec.mode).to_lowercase(),
            features: spec.features,
            sensor_range: spec.sensor_range,
        })
    }
}

/// A loaded policy with its inference buffers, as the grid's and the
/// plant's policy controllers drive it: the env writes `obs` and `masks`,
/// [`PolicyRunner::act`] chooses, [`PolicyRunner::observe`] feeds a
/// recurrent policy the step taken.
pub(crate) struct PolicyRunner {
    inference: Inference,
    /// The policy's mode (CTE: one row of the central observation).
    pub mode: Mode,
    act_mode: ActMode,
    /// Observation rows, written by the env before each decision.
    pub obs: Vec<f32>,
    /// Action masks, `NUM_ACTIONS` per agent, written by the env.
    pub masks: Vec<u8>,
    /// The actions of the last decision (or, after
    /// [`PolicyController::record_taken`], the ones executed).
    pub actions: Vec<u8>,
    logp: Vec<f32>,
}

impl PolicyRunner {
    /// `policy` run on `rows` rows ([`load_for_agents`]), acting by
    /// `act_mode` (sampling seeded `seed`).
    pub fn new(policy: Policy, rows: usize, act_mode: ActMode, seed: u64) -> Self {
        let spec = policy.spec().clone();
        Self {
            mode: spec.mode,
            act_mode,
            obs: vec![0.0; rows * spec.obs_dim],
            masks: vec![0; rows * spec.heads * NUM_ACTIONS],
            actions: vec![0; rows * spec.heads],
            logp: vec![0.0; rows],
            inference: Inference::new(policy, rows, seed),
        }
    }

    /// Floats of one observation row.
    pub fn obs_dim(&self) -> usize {
        self.obs.len() / self.inference.rows()
    }

    /// Chooses every agent's action from `obs` under `masks`.
    pub fn act(&mut self) -> Result<Decision<'_>, PolicyError> {
        let logits = self.inference.act(
            &self.obs,
            &self.masks,
            self.act_mode,
            &mut self.actions,
            &mut self.logp,
        )?;
        Ok(Decision {
            actions: &self.actions,
            logits,
            masks: &self.masks,
        })
    }

    /// Starts a new episode ([`reset_recurrent_state`]).
    pub fn begin_episode(&mut self) {
        reset_recurrent_state(&mut self.inference);
    }

    /// Feeds the step just taken with `actions` its `rewards`
    /// ([`observe_step`]).
    pub fn observe(&mut self, rewards: &[f32]) {
        observe_step(&mut self.inference, self.mode, &self.actions, rewards);
    }
}

/// Loads the policy at `path` (a checkpoint or a run directory) for
/// episodes with `agents` agents: its checkpoint directory, the policy and
/// the inference rows it needs (CTDE: one per agent, with any agent count;
/// CTE: one; DTE: one per agent, with the count it was trained with).
pub(crate) fn load_for_agents(
    path: &Path,
    agents: usize,
    device: &Device,
) -> Result<(PathBuf, Policy, usize), PolicyLoadError> {
    let failed = |source| PolicyLoadError::Checkpoint {
        dir: path.to_path_buf(),
        source,
    };
    let dir = checkpoint::resolve(path).map_err(failed)?;
    let policy = Policy::load_on(&dir, device).map_err(failed)?;
    let spec = policy.spec();
    let rows = match spec.mode {
        // A CTDE policy trained with n agents runs with any number (scalability).
        Mode::Ctde => agents,
        Mode::Cte | Mode::Dte if spec.agents != agents => {
            return Err(PolicyLoadError::AgentCount {
                dir,
                mode: spec.mode,
                trained: spec.agents,
                asked: agents,
            })
        }
        Mode::Cte => 1,
        Mode::Dte => agents,
    };
    Ok((dir, policy, rows))
}

/// Starts a new episode for a recurrent policy: every row's LSTM state
/// and previous action and reward go back to their start values (nothing
/// for a feed-forward policy).
pub(crate) fn reset_recurrent_state(inference: &mut Inference) {
    if let Some(state) = inference.state_mut() {
        for r in 0..state.rows {
            state.reset_row(r);
        }
    }
}

/// Feeds a recurrent policy the step it just took: the chosen actions and
/// each row's reward (CTE's one row gets the sum over agents). Episodes of
/// an evaluation end only between calls to [`reset_recurrent_state`], so
/// no row is done here.
pub(crate) fn observe_step(inference: &mut Inference, mode: Mode, actions: &[u8], rewards: &[f32]) {
    let rows = inference.rows();
    let row_rewards: Vec<f32> = if mode == Mode::Cte {
        vec![rewards.iter().sum()]
    } else {
        rewards.to_vec()
    };
    if let Some(state) = inference.state_mut() {
        state.observe(actions, &row_rewards, &vec![0; rows]);
    }
}

/// Which action mask the policy's distribution is taken under.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MaskKind {
    /// The env's mask (walls and cells other agents hold are illegal), as
    /// in training.
    Env,
    /// Walls only: moves into cells other agents hold stay possible.
    Walls,
}

/// One inference for all agents; agent `i`'s entries of `logits` and
/// `masks` are `5i..5i + 5` (CTDE/DTE: row `i`; CTE: head `i` of row 0).
pub(crate) struct Decision<'a> {
    /// The chosen (greedy or sampled) action of each agent.
    pub actions: &'a [u8],
    /// Raw logits.
    pub logits: &'a [f32],
    /// The mask the actions were chosen under.
    pub masks: &'a [u8],
}

impl PolicyController {
    /// Runs the policy on the env's state: each agent's action chosen under
    /// `mask` (greedy or sampled, as loaded), with the raw logits. A
    /// recurrent policy's state advances; [`PolicyController::record_taken`]
    /// tells it what was executed instead, if anything.
    pub(crate) fn decide(
        &mut self,
        env: &GridEnv,
        mask: MaskKind,
    ) -> Result<Decision<'_>, PolicyError> {
        let r = &mut self.runner;
        if r.mode == Mode::Cte {
            env.write_central_obs(&mut r.obs).expect("sized at load");
            env.write_joint_mask(&mut r.masks).expect("sized at load");
        } else {
            let d = env.local_obs_dim();
            for i in 0..env.agents() {
                env.write_local_obs(i, &mut r.obs[i * d..(i + 1) * d])
                    .expect("sized at load");
                env.write_action_mask(i, &mut r.masks[i * NUM_ACTIONS..(i + 1) * NUM_ACTIONS])
                    .expect("sized at load");
            }
        }
        if mask == MaskKind::Walls {
            for (i, out) in r.masks.chunks_mut(NUM_ACTIONS).enumerate() {
                env.write_wall_mask(i, out).expect("sized at load");
            }
        }
        r.act()
    }

    /// Records the actions actually sent to the env, which a recurrent
    /// policy sees as its previous actions at the next step.
    pub(crate) fn record_taken(&mut self, actions: &[u8]) {
        self.runner.actions.copy_from_slice(actions);
    }
}

impl Controller for PolicyController {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn obs_features(&self) -> ObsFeatures {
        self.features
    }

    fn obs_sensor_range(&self) -> usize {
        self.sensor_range
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        let expected = self.runner.obs_dim();
        let dim = if self.runner.mode == Mode::Cte {
            env.central_obs_dim()
        } else {
            env.local_obs_dim()
        };
        if dim != expected {
            return Err(GiveUp::Other(format!(
                "the policy expects {expected} observation floats, this env gives {dim}"
            )));
        }
        self.runner.begin_episode();
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        match self.decide(env, MaskKind::Env) {
            Ok(d) => actions.copy_from_slice(d.actions),
            // Stay is always legal, so an empty mask cannot occur; be safe anyway.
            Err(_) => actions.fill(0),
        }
    }

    fn after_step(&mut self, rewards: &[f32]) {
        self.runner.observe(rewards);
    }
}
