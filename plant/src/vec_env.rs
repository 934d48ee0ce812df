//! [`PlantVecEnv`]: many plant episodes stepped as one batch with
//! auto-reset, behind [`buridan_env::BatchedEnv`].
//!
//! The buffer contract is the grid [`buridan_env::VecEnv`]'s: after every
//! step `obs` holds the observation to act on next (after an episode ended,
//! the next episode's first), `final_obs` the last observation of episodes
//! that ended in the step, `masks` `action_slots` bytes per agent (local)
//! or per agent of the env (central). Env `e` plays episodes `e, e + N, …`.
//! Episodes end only at `t_max` (truncated); nothing terminates them.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::{BatchedEnv, ObsKind};
//! use buridan_plant::{Plant, PlantConfig, PlantVecEnv};
//! let plant = Arc::new(Plant::load("dissertation").unwrap());
//! let cfg = PlantConfig { agents: 2, ..PlantConfig::default() };
//! let mut venv = PlantVecEnv::new(plant, cfg, 3, ObsKind::Local).unwrap();
//! assert_eq!((venv.rows(), venv.obs_dim()), (6, 11));
//! venv.step(&[1u8; 6]).unwrap();
//! assert_eq!(venv.rewards().len(), 6);
//! ```

use std::sync::Arc;

use buridan_env::{batched_env_buffers, BatchedEnv, EnvError, ObsKind, StepBuffers};

use crate::env::{PlantConfig, PlantEnv, NUM_ACTIONS};
use crate::kpi::Kpis;
use crate::plant::Plant;

/// A batch of plant envs with flat buffers and auto-reset.
#[derive(Debug, Clone)]
pub struct PlantVecEnv {
    envs: Vec<PlantEnv>,
    kind: ObsKind,
    agents: usize,
    obs_dim: usize,
    mask_dim: usize,
    buffers: StepBuffers,
    kpis: Vec<Kpis>,
}

impl PlantVecEnv {
    /// `num_envs` envs of `plant`, observations of `kind`.
    pub fn new(
        plant: Arc<Plant>,
        cfg: PlantConfig,
        num_envs: usize,
        kind: ObsKind,
    ) -> Result<Self, EnvError> {
        if num_envs == 0 {
            return Err(EnvError::InvalidConfig(
                "a PlantVecEnv needs at least one env".into(),
            ));
        }
        let envs = (0..num_envs)
            .map(|e| PlantEnv::with_episode(plant.clone(), cfg.clone(), e as u64))
            .collect::<Result<Vec<_>, _>>()?;
        let agents = cfg.agents;
        let (obs_dim, mask_dim) = match kind {
            ObsKind::Local => (envs[0].local_obs_dim(), cfg.action_slots),
            ObsKind::Central => (envs[0].central_obs_dim(), cfg.action_slots * agents),
        };
        let rows = num_envs * kind.rows_per_env(agents);
        let mut venv = Self {
            envs,
            kind,
            agents,
            obs_dim,
            mask_dim,
            buffers: StepBuffers::new(num_envs, agents, rows * obs_dim, rows * mask_dim),
            kpis: Vec::new(),
        };
        for e in 0..num_envs {
            venv.write_env_obs(e, false)?;
        }
        Ok(venv)
    }

    /// The envs, for inspection and for controllers that read env state.
    pub fn envs(&self) -> &[PlantEnv] {
        &self.envs
    }

    /// Mask bytes per row.
    pub fn mask_dim(&self) -> usize {
        self.mask_dim
    }

    /// Takes the KPIs of the episodes finished since the last call (kept
    /// apart from [`BatchedEnv::drain_episodes`], which drains the
    /// [`buridan_env::EpisodeStats`]).
    pub fn drain_kpis(&mut self) -> Vec<Kpis> {
        std::mem::take(&mut self.kpis)
    }

    /// Writes env `e`'s observation and masks into `obs` (or `final_obs`).
    fn write_env_obs(&mut self, e: usize, last: bool) -> Result<(), EnvError> {
        let rows = self.kind.rows_per_env(self.agents);
        let (o, m) = (rows * self.obs_dim, rows * self.mask_dim);
        let env = &self.envs[e];
        let obs = if last {
            &mut self.buffers.final_obs[e * o..(e + 1) * o]
        } else {
            &mut self.buffers.obs[e * o..(e + 1) * o]
        };
        let masks = &mut self.buffers.masks[e * m..(e + 1) * m];
        let slots = env.config().action_slots;
        match self.kind {
            ObsKind::Local => {
                for i in 0..self.agents {
                    env.write_local_obs(i, &mut obs[i * self.obs_dim..(i + 1) * self.obs_dim])?;
                }
            }
            ObsKind::Central => env.write_central_obs(obs)?,
        }
        for i in 0..self.agents {
            env.write_mask(i, &mut masks[i * slots..(i + 1) * slots])?;
        }
        Ok(())
    }
}

impl BatchedEnv for PlantVecEnv {
    fn num_envs(&self) -> usize {
        self.envs.len()
    }
    fn agents(&self) -> usize {
        self.agents
    }
    fn kind(&self) -> ObsKind {
        self.kind
    }
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Steps every env (`num_envs · agents` actions, env-major); invalid
    /// actions are rejected before any env moves.
    fn step(&mut self, actions: &[u8]) -> Result<(), EnvError> {
        let n = self.agents;
        EnvError::check_len("actions", self.envs.len() * n, actions.len())?;
        if let Some(k) = actions.iter().position(|&a| usize::from(a) >= NUM_ACTIONS) {
            return Err(EnvError::InvalidConfig(format!(
                "env {} agent {}: action {} is outside 0..3 (0 hold, 1 forward, 2 backward)",
                k / n,
                k % n,
                actions[k]
            )));
        }
        let stride = self.envs.len() as u64;
        for e in 0..self.envs.len() {
            let out = self.envs[e].step(
                &actions[e * n..(e + 1) * n],
                &mut self.buffers.rewards[e * n..(e + 1) * n],
            )?;
            self.buffers.terminated[e] = 0;
            self.buffers.truncated[e] = u8::from(out.truncated);
            if out.truncated {
                self.write_env_obs(e, true)?;
                let kpis = self.envs[e].kpis();
                self.buffers.episodes.push(kpis.episode_stats());
                self.kpis.push(kpis);
                self.envs[e].reset_next(stride);
            }
            self.write_env_obs(e, false)?;
        }
        Ok(())
    }

    batched_env_buffers!(buffers);
}
