//! IMPALA's learner update (Espeholt et al. 2018): V-trace targets and
//! policy-gradient advantages from the current weights, then one gradient
//! step on
//!
//! `total = −mean(log π(a|s)·A^vtrace) + c_vf·½·mean((V(s) − v_s)²) − c_ent·mean(H)`
//!
//! with global-norm gradient clipping (RLlib default 40). Means rather than
//! sums over the batch, as RLlib's new-stack IMPALA learner does. Optimiser:
//! Adam (RLlib IMPALA's default `opt_type="adam"`; the paper used RMSProp).

use buridan_policy::{dist, Policy};
use candle_core::Tensor;

use crate::algo::batch::{build_net_batches, evaluate, BatchTensors, NetBatch};
use crate::algo::optim::ClippedAdam;
use crate::algo::ppo::LossTerms;
use crate::algo::shards::{sharded_gradient, share_count, share_range};
use crate::algo::vtrace::{vtrace, VTraceParams};
use crate::algo::{add_loss, scalar, Result, UpdateStats};

/// Coefficients of the IMPALA loss.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpalaLossParams {
    /// Value loss coefficient.
    pub vf_coeff: f32,
    /// Entropy coefficient.
    pub entropy_coeff: f32,
}

/// The V-trace actor-critic loss: `logits [N, heads·A]`, `values [N]` from
/// the current network, `pg_advantages [N]` and value targets `vs [N]`
/// (constants).
pub fn impala_loss(
    logits: &Tensor,
    values: &Tensor,
    bt: &BatchTensors,
    pg_advantages: &Tensor,
    vs: &Tensor,
    p: &ImpalaLossParams,
) -> Result<(Tensor, LossTerms)> {
    let (lp_all, logp) = bt.log_probs(logits)?;
    let pi_loss = (logp * pg_advantages)?.mean_all()?.neg()?;
    let vf_loss = ((values - vs)?.sqr()?.mean_all()? * 0.5)?;
    let entropy = dist::entropy(&lp_all)?.mean_all()?;
    let total =
        ((&pi_loss + (&vf_loss * p.vf_coeff as f64)?)? - (&entropy * p.entropy_coeff as f64)?)?;
    let kl = bt.kl_from_behaviour(&lp_all.detach())?;
    let terms = LossTerms {
        total: scalar(&total)?,
        policy: scalar(&pi_loss)?,
        vf: scalar(&vf_loss)?,
        entropy: scalar(&entropy)?,
        kl: scalar(&kl)?,
    };
    Ok((total, terms))
}

/// IMPALA hyperparameters used by [`Impala`].
#[derive(Debug, Clone, PartialEq)]
pub struct ImpalaSettings {
    /// Learning rate.
    pub lr: f64,
    /// Value loss coefficient.
    pub vf_coeff: f32,
    /// Entropy coefficient.
    pub entropy_coeff: f32,
    /// Global-norm gradient clip per weight set.
    pub grad_clip: Option<f64>,
    /// V-trace clipping and discounting.
    pub vtrace: VTraceParams,
    /// Truncated-BPTT length for recurrent nets.
    pub max_seq_len: usize,
    /// Threads that share the train batch's gradient (rows cut into
    /// shares, [`crate::algo::shards`]); 0 or 1: the calling thread alone.
    pub update_threads: usize,
}

/// IMPALA learner state.
pub struct Impala {
    /// Settings.
    pub settings: ImpalaSettings,
    /// The optimiser over all weights.
    pub optim: ClippedAdam,
}

impl Impala {
    /// An IMPALA learner for `policy`.
    pub fn new(policy: &Policy, settings: ImpalaSettings) -> Self {
        Self {
            optim: ClippedAdam::new(policy, settings.lr, settings.grad_clip),
            settings,
        }
    }

    /// One gradient step on a train batch of fragments.
    pub fn update(
        &mut self,
        policy: &Policy,
        fragments: &[buridan_policy::Fragment],
    ) -> Result<UpdateStats> {
        let batches = build_net_batches(fragments, policy.spec())?;
        self.update_batches(policy, &batches)
    }

    /// One gradient step on prepared per-net batches: the V-trace loss of
    /// every weight set, summed. With `update_threads` above 1 each weight
    /// set's rows (whole trajectories) are cut into shares, one per thread,
    /// each share's loss weighted by its fraction of the rows: the same
    /// gradient, up to float rounding ([`crate::algo::shards`]).
    pub fn update_batches(&mut self, policy: &Policy, batches: &[NetBatch]) -> Result<UpdateStats> {
        let samples = batches.iter().map(NetBatch::len).sum();
        let shares = share_count(self.settings.update_threads, samples);
        let (grads, (terms, rho_sum)) = sharded_gradient(
            shares,
            self.optim.adam.vars(),
            |i| {
                let mut total = None;
                let mut terms = Vec::with_capacity(batches.len());
                let mut rho_sum = 0.0;
                for (k, b) in batches.iter().enumerate() {
                    let rows = share_range(i, shares, b.rows);
                    if rows.is_empty() {
                        terms.push(LossTerms::default());
                        continue;
                    }
                    let weight = rows.len() as f64 / b.rows as f64;
                    let (loss, t, mean_rho) = if shares == 1 {
                        self.net_loss(policy, k, b)?
                    } else {
                        self.net_loss(policy, k, &b.select_rows(rows))?
                    };
                    terms.push(t.scaled(weight));
                    rho_sum += mean_rho * weight;
                    total = add_loss(total, (loss * weight)?)?;
                }
                Ok((total, (terms, rho_sum)))
            },
            |(sums, rho), (parts, part_rho)| {
                let terms = sums.iter().zip(&parts).map(|(a, b)| a.plus(b)).collect();
                (terms, rho + part_rho)
            },
        )?;
        let mut stats = UpdateStats::default();
        if let Some(mut grads) = grads {
            let grad_norm = self.optim.step_grads(&mut grads)?;
            stats.add_minibatch(&terms, grad_norm);
        }
        stats.finish();
        stats.mean_rho = rho_sum / batches.len().max(1) as f64;
        stats.samples = samples;
        Ok(stats)
    }

    /// Weight set `k`'s loss: V-trace targets from the current weights'
    /// ratios to the behaviour policy, then the actor-critic loss; also the
    /// mean clipped ratio ρ.
    fn net_loss(
        &self,
        policy: &Policy,
        k: usize,
        b: &NetBatch,
    ) -> Result<(Tensor, LossTerms, f64)> {
        let s = &self.settings;
        let dev = policy.device().clone();
        let bt = BatchTensors::new(b, &dev)?;
        let ev = evaluate(policy.net(k), b, &bt, s.max_seq_len, &dev)?;
        let (_, target_logp) = bt.log_probs(&ev.logits.detach())?;
        let log_rhos: Vec<f32> = (target_logp - &bt.behaviour_logp)?.to_vec1()?;
        let vt = vtrace(&ev.trajectory(b), &log_rhos, s.vtrace);
        let mean_rho = vt.rhos.iter().map(|&x| x as f64).sum::<f64>() / vt.rhos.len().max(1) as f64;
        let n = b.len();
        let pg_advantages = Tensor::from_vec(vt.pg_advantages, n, &dev)?;
        let vs = Tensor::from_vec(vt.vs, n, &dev)?;
        let params = ImpalaLossParams {
            vf_coeff: s.vf_coeff,
            entropy_coeff: s.entropy_coeff,
        };
        let (loss, terms) = impala_loss(&ev.logits, &ev.values, &bt, &pg_advantages, &vs, &params)?;
        Ok((loss, terms, mean_rho))
    }
}
