//! The learning algorithms, as pure functions (advantages, targets, losses)
//! and small stateful learners (optimiser, KL coefficient):
//!
//! - [`trajectory`]: the time-major experience GAE and V-trace read.
//! - [`gae`]: GAE(λ) advantages and value targets, truncation-aware.
//! - [`vtrace`]: V-trace targets and policy-gradient advantages.
//! - [`ppo`]: clipped-surrogate PPO with RLlib's adaptive KL penalty.
//! - [`impala`]: the V-trace actor-critic update.
//! - [`batch`]: fragments → per-weight-set batches → tensors, value pass.
//! - [`optim`]: Adam and global-norm gradient clipping.
//! - [`shards`]: one gradient computed on several threads.
//! - [`schedule`]: piecewise-linear learning-rate and entropy schedules.

pub mod batch;
pub mod gae;
pub mod impala;
pub mod optim;
pub mod ppo;
pub mod schedule;
pub mod shards;
pub mod trajectory;
pub mod vtrace;

use buridan_policy::PolicyError;
use candle_core::Tensor;

use crate::algo::ppo::LossTerms;

/// Why an update could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum AlgoError {
    /// The fragments do not form a train batch for this model.
    #[error("invalid train batch: {0}")]
    Batch(String),
    /// A fragment or the policy is inconsistent.
    #[error(transparent)]
    Policy(#[from] PolicyError),
    /// A tensor operation failed.
    #[error(transparent)]
    Candle(#[from] candle_core::Error),
    /// A thread of a sharded update panicked.
    #[error(transparent)]
    Thread(#[from] buridan_policy::shards::SharePanicked),
}

/// The result of the algorithms' functions.
pub type Result<T, E = AlgoError> = std::result::Result<T, E>;

/// What one learner update reports (means over its gradient steps and
/// weight sets).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UpdateStats {
    /// Total loss.
    pub total_loss: f64,
    /// Policy loss.
    pub policy_loss: f64,
    /// Value loss (before its coefficient).
    pub vf_loss: f64,
    /// Mean policy entropy.
    pub entropy: f64,
    /// Mean `KL(behaviour ‖ current)`.
    pub kl: f64,
    /// KL coefficient after the update (PPO; mean over weight sets).
    pub kl_coeff: f64,
    /// Global gradient norm before clipping (mean over gradient steps).
    pub grad_norm: f64,
    /// Mean clipped importance weight ρ (IMPALA).
    pub mean_rho: f64,
    /// Gradient steps taken.
    pub grad_steps: usize,
    /// Samples (rows × steps) in the train batch.
    pub samples: usize,
}

impl UpdateStats {
    fn add_minibatch(&mut self, terms: &[LossTerms], grad_norm: f64) {
        let n = terms.len().max(1) as f64;
        self.total_loss += terms.iter().map(|t| t.total).sum::<f64>();
        self.policy_loss += terms.iter().map(|t| t.policy).sum::<f64>() / n;
        self.vf_loss += terms.iter().map(|t| t.vf).sum::<f64>() / n;
        self.entropy += terms.iter().map(|t| t.entropy).sum::<f64>() / n;
        self.kl += terms.iter().map(|t| t.kl).sum::<f64>() / n;
        self.grad_norm += grad_norm;
        self.grad_steps += 1;
    }

    fn finish(&mut self) {
        let n = self.grad_steps.max(1) as f64;
        self.total_loss /= n;
        self.policy_loss /= n;
        self.vf_loss /= n;
        self.entropy /= n;
        self.kl /= n;
        self.grad_norm /= n;
    }
}

/// The value of a scalar f32 tensor (a loss term), as a plain number.
fn scalar(t: &Tensor) -> Result<f64> {
    Ok(t.to_scalar::<f32>()? as f64)
}

/// `total + loss`, starting from nothing: the sum of the weight sets' losses.
fn add_loss(total: Option<Tensor>, loss: Tensor) -> Result<Option<Tensor>> {
    Ok(Some(match total {
        None => loss,
        Some(t) => (t + loss)?,
    }))
}
