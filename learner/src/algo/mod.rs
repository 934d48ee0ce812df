//! The learning algorithms, as pure functions (advantages, targets, losses)
//! and small stateful learners (optimiser, KL coefficient):
//!
//! - [`gae`]: GAE(λ) advantages and value targets, truncation-aware.
//! - [`vtrace`]: V-trace targets and policy-gradient advantages.
//! - [`ppo`]: clipped-surrogate PPO with RLlib's adaptive KL penalty.
//! - [`impala`]: the V-trace actor-critic update.
//! - [`batch`]: fragments → per-weight-set batches → tensors, value pass.
//! - [`optim`]: Adam and global-norm gradient clipping.

pub mod batch;
pub mod gae;
pub mod impala;
pub mod optim;
pub mod ppo;
pub mod vtrace;

use buridan_policy::Policy;
use candle_core::Var;

use crate::algo::ppo::LossTerms;

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

/// All variables of a policy ordered by weight set, with the index range of
/// each set (gradient clipping is per weight set, as RLlib clips per policy).
pub fn net_var_groups(policy: &Policy) -> (Vec<(String, Var)>, Vec<std::ops::Range<usize>>) {
    let mut vars = Vec::new();
    let mut groups = Vec::new();
    for k in 0..policy.spec().nets() {
        let start = vars.len();
        vars.extend(policy.net_vars(k));
        groups.push(start..vars.len());
    }
    (vars, groups)
}
