//! The algorithm behind a run: PPO or IMPALA, with the settings a run
//! changes between updates (cores, schedules) and the optimiser state a
//! checkpoint saves and restores.

use std::path::Path;

use buridan_policy::checkpoint::OPTIMIZER_FILE;
use buridan_policy::{Fragment, Policy};
use rand_chacha::ChaCha8Rng;

use super::config::{Algorithm, TrainConfig};
use super::state::TrainerState;
use super::TrainError;
use crate::algo::impala::Impala;
use crate::algo::optim::ClippedAdam;
use crate::algo::ppo::Ppo;
use crate::algo::{AlgoError, UpdateStats};

/// A run's learner: one of the two algorithms.
pub(super) enum Learner {
    Ppo(Ppo),
    Impala(Impala),
}

impl Learner {
    pub(super) fn new(cfg: &TrainConfig, policy: &Policy) -> Self {
        match &cfg.algorithm {
            Algorithm::Ppo(p) => Learner::Ppo(Ppo::new(policy, cfg.ppo_settings(p))),
            Algorithm::Impala(i) => Learner::Impala(Impala::new(policy, cfg.impala_settings(i))),
        }
    }

    pub(super) fn optim(&mut self) -> &mut ClippedAdam {
        match self {
            Learner::Ppo(p) => &mut p.optim,
            Learner::Impala(i) => &mut i.optim,
        }
    }

    /// Sizes the update to the cores this run may use now
    /// ([`cores::share`] unless `update_threads` fixes it).
    pub(super) fn follow_cores(&mut self, cfg: &TrainConfig) {
        let threads = cfg.update_threads(cfg.algorithm.update_threads());
        match self {
            Learner::Ppo(p) => p.settings.update_threads = threads,
            Learner::Impala(i) => i.settings.update_threads = threads,
        }
    }

    /// Sets the learning rate and entropy coefficient the config's
    /// schedules give at `env_steps` (unscheduled ones stay as configured).
    /// Also keeps PPO to its critic warm-up while fewer than
    /// `ppo.critic_warmup` env steps have been sampled.
    pub(super) fn follow_schedules(&mut self, cfg: &TrainConfig, env_steps: u64) {
        if let (Learner::Ppo(p), Some(ppo)) = (&mut *self, cfg.algorithm.ppo()) {
            p.critic_only = env_steps < ppo.critic_warmup;
        }
        let (lr, entropy) = cfg.algorithm.schedules();
        if let Some(lr) = lr {
            self.optim().adam.lr = lr.value(env_steps);
        }
        if let Some(entropy) = entropy {
            *self.entropy_coeff() = entropy.value(env_steps) as f32;
        }
    }

    pub(super) fn entropy_coeff(&mut self) -> &mut f32 {
        match self {
            Learner::Ppo(p) => &mut p.settings.entropy_coeff,
            Learner::Impala(i) => &mut i.settings.entropy_coeff,
        }
    }

    /// The learning rate and entropy coefficient of the next update.
    pub(super) fn rates(&mut self) -> (f64, f64) {
        let entropy = *self.entropy_coeff() as f64;
        (self.optim().adam.lr, entropy)
    }

    pub(super) fn kl_coeffs(&self) -> Vec<f64> {
        match self {
            Learner::Ppo(p) => p.kl_coeffs.clone(),
            Learner::Impala(_) => Vec::new(),
        }
    }

    pub(super) fn update(
        &mut self,
        policy: &Policy,
        batch: &[Fragment],
        rng: &mut ChaCha8Rng,
    ) -> Result<UpdateStats, AlgoError> {
        match self {
            Learner::Ppo(p) => p.update(policy, batch, rng),
            Learner::Impala(i) => i.update(policy, batch),
        }
    }

    /// Restores the optimiser moments and KL coefficients of a checkpoint.
    pub(super) fn restore(&mut self, dir: &Path, state: &TrainerState) -> Result<(), TrainError> {
        let path = dir.join(OPTIMIZER_FILE);
        if path.is_file() {
            self.optim()
                .adam
                .load(&path, state.adam_steps)
                .map_err(|source| TrainError::Optimizer { path, source })?;
        } else {
            tracing::warn!(
                "{} lacks {OPTIMIZER_FILE}: fresh optimiser state",
                dir.display()
            );
        }
        if let Learner::Ppo(p) = self {
            if state.kl_coeffs.len() == p.kl_coeffs.len() {
                p.kl_coeffs = state.kl_coeffs.clone();
            }
        }
        Ok(())
    }
}
