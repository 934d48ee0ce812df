//! Proximal policy optimisation (Schulman et al. 2017) as RLlib's PPO does
//! it: clipped surrogate, squared value error clipped at `vf_clip`,
//! entropy bonus, an adaptive KL penalty, `epochs` passes over the train
//! batch in shuffled minibatches, Adam and optional global-norm clipping.
//!
//! `total = mean(−min(A·ρ, A·clip(ρ, 1−ε, 1+ε)) + c_vf·min((V − R)², vf_clip)
//! − c_ent·H) + β·mean(KL(μ ‖ π))`, with `ρ = π(a|s) / μ(a|s)` the ratio to
//! the behaviour policy, `A` GAE advantages standardised over the train
//! batch, `R` the GAE value targets. After each train batch, `β` (initially
//! 0.2) is multiplied by 1.5 if the mean KL exceeded `2·kl_target` and by
//! 0.5 if it fell below `kl_target / 2` (RLlib's `update_kl`).
//!
//! # Critic warm-up
//!
//! A policy warm-started by imitation comes with a critic that has never
//! seen a return. Its first advantages are noise, and with an LSTM the
//! value head reads the same recurrent features as the policy, so the
//! value loss (large while the critic is random) rewrites the features the
//! imitation taught. While [`Ppo::critic_only`] is set, an update fits the
//! value weights alone (`value.*`, and `vf.*` of a separate value MLP) to
//! `c_vf·mean(min((V − R)², vf_clip))`; every other weight keeps its value
//! (its gradient is zeroed, Adam's moments stay at zero) and the KL
//! coefficients do not adapt. Each such update first shifts the value
//! bias by the batch's mean of `R − V`, the best constant correction: a
//! fresh head predicts about 0 where returns are several units, a scale
//! gradient steps at the policy's learning rate take thousands of steps
//! to reach. The learner sets it for the first `critic_warmup` env steps
//! of the run.

use buridan_policy::{dist, Policy};
use candle_core::Tensor;
use rand::seq::SliceRandom;
use rand::Rng;

use crate::algo::batch::{build_net_batches, evaluate, BatchTensors, NetBatch};
use crate::algo::gae::{gae, standardize, GaeParams};
use crate::algo::optim::{zeros_like, ClippedAdam};
use crate::algo::shards::{sharded_gradient, share_count, share_range};
use crate::algo::{add_loss, scalar, AlgoError, Result, UpdateStats};

/// Coefficients of the PPO loss.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PpoLossParams {
    /// Surrogate clip ε.
    pub clip: f32,
    /// Value loss coefficient.
    pub vf_coeff: f32,
    /// Upper clamp of the squared value error (RLlib `vf_clip_param`).
    pub vf_clip: f32,
    /// Entropy bonus coefficient.
    pub entropy_coeff: f32,
    /// Current KL penalty coefficient β (0 disables the KL term).
    pub kl_coeff: f32,
}

/// Mean loss terms of one loss evaluation (plain numbers for metrics).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LossTerms {
    /// Total loss.
    pub total: f64,
    /// Policy (surrogate) loss `−mean(surrogate)`.
    pub policy: f64,
    /// Value loss (before its coefficient).
    pub vf: f64,
    /// Mean entropy.
    pub entropy: f64,
    /// Mean `KL(behaviour ‖ current)`.
    pub kl: f64,
}

impl LossTerms {
    /// Every term times `w` (a share's weight in a mean over shares).
    pub(crate) fn scaled(self, w: f64) -> Self {
        Self {
            total: self.total * w,
            policy: self.policy * w,
            vf: self.vf * w,
            entropy: self.entropy * w,
            kl: self.kl * w,
        }
    }

    /// Term-wise sum.
    pub(crate) fn plus(self, o: &Self) -> Self {
        Self {
            total: self.total + o.total,
            policy: self.policy + o.policy,
            vf: self.vf + o.vf,
            entropy: self.entropy + o.entropy,
            kl: self.kl + o.kl,
        }
    }
}

/// The PPO loss over one minibatch: `logits [N, heads·A]` and `values [N]`
/// from the current network, behaviour data from `bt`, standardised
/// `advantages [N]` and value `targets [N]`.
pub fn ppo_loss(
    logits: &Tensor,
    values: &Tensor,
    bt: &BatchTensors,
    advantages: &Tensor,
    targets: &Tensor,
    p: &PpoLossParams,
) -> Result<(Tensor, LossTerms)> {
    let (lp_all, logp) = bt.log_probs(logits)?;
    let ratio = (logp - &bt.behaviour_logp)?.exp()?;
    let unclipped = (&ratio * advantages)?;
    let clipped = (ratio.clamp(1.0 - p.clip, 1.0 + p.clip)? * advantages)?;
    let surrogate = unclipped.minimum(&clipped)?;
    let vf = clipped_value_error(values, targets, p.vf_clip)?;
    let entropy = dist::entropy(&lp_all)?;
    let kl = bt.kl_from_behaviour(&lp_all)?;
    let per_sample =
        ((surrogate.neg()? + (&vf * p.vf_coeff as f64)?)? - (&entropy * p.entropy_coeff as f64)?)?;
    let mut total = per_sample.mean_all()?;
    if p.kl_coeff > 0.0 {
        total = (total + (&kl * p.kl_coeff as f64)?)?;
    }
    let terms = LossTerms {
        total: scalar(&total)?,
        policy: -scalar(&surrogate.mean_all()?)?,
        vf: scalar(&vf.mean_all()?)?,
        entropy: scalar(&entropy.mean_all()?)?,
        kl: scalar(&kl)?,
    };
    Ok((total, terms))
}

/// The critic warm-up's loss ([module docs](self#critic-warm-up)):
/// `c_vf·mean(min((V − R)², vf_clip))`; the terms report the policy's
/// entropy and KL to the behaviour policy as they stand (the surrogate as
/// 0).
pub fn critic_loss(
    logits: &Tensor,
    values: &Tensor,
    bt: &BatchTensors,
    targets: &Tensor,
    p: &PpoLossParams,
) -> Result<(Tensor, LossTerms)> {
    let lp_all = dist::masked_log_probs(logits, &bt.mask_bias, bt.heads)?;
    let vf = clipped_value_error(values, targets, p.vf_clip)?.mean_all()?;
    let total = (&vf * p.vf_coeff as f64)?;
    let terms = LossTerms {
        total: scalar(&total)?,
        policy: 0.0,
        vf: scalar(&vf)?,
        entropy: scalar(&dist::entropy(&lp_all)?.mean_all()?)?,
        kl: scalar(&bt.kl_from_behaviour(&lp_all)?)?,
    };
    Ok((total, terms))
}

/// The value loss per sample, `min((V − R)², vf_clip)` (RLlib's
/// `vf_clip_param`), of the PPO loss and the critic warm-up alike.
fn clipped_value_error(values: &Tensor, targets: &Tensor, vf_clip: f32) -> Result<Tensor> {
    Ok((values - targets)?.sqr()?.clamp(0.0, vf_clip)?)
}

/// RLlib's adaptive KL coefficient rule.
///
/// ```
/// use buridan_learner::algo::ppo::update_kl_coeff;
/// assert_eq!(update_kl_coeff(0.2, 0.03, 0.01), 0.30000000000000004); // > 2·target → ×1.5
/// assert_eq!(update_kl_coeff(0.2, 0.004, 0.01), 0.1); // < target/2 → ×0.5
/// assert_eq!(update_kl_coeff(0.2, 0.01, 0.01), 0.2);
/// ```
pub fn update_kl_coeff(coeff: f64, kl: f64, target: f64) -> f64 {
    if kl > 2.0 * target {
        coeff * 1.5
    } else if kl < 0.5 * target {
        coeff * 0.5
    } else {
        coeff
    }
}

/// PPO hyperparameters used by [`Ppo`].
#[derive(Debug, Clone, PartialEq)]
pub struct PpoSettings {
    /// Learning rate.
    pub lr: f64,
    /// Passes over each train batch.
    pub epochs: usize,
    /// Samples (agent steps of one weight set) per minibatch; each weight
    /// set's batch is split into `ceil(samples / minibatch_size)` shuffled
    /// minibatches per epoch (whole sequences for recurrent nets).
    pub minibatch_size: usize,
    /// Surrogate clip ε.
    pub clip: f32,
    /// Value loss coefficient.
    pub vf_coeff: f32,
    /// Squared value error clamp.
    pub vf_clip: f32,
    /// Entropy coefficient.
    pub entropy_coeff: f32,
    /// Initial KL coefficient (0 disables the KL penalty).
    pub kl_coeff: f64,
    /// KL target.
    pub kl_target: f64,
    /// Discount γ.
    pub gamma: f32,
    /// GAE λ.
    pub lambda: f32,
    /// Global-norm gradient clip per weight set (`None`: no clipping).
    pub grad_clip: Option<f64>,
    /// Standardise advantages over the train batch.
    pub standardize_advantages: bool,
    /// Truncated-BPTT length for recurrent nets.
    pub max_seq_len: usize,
    /// Threads that share each minibatch's forward and backward pass (1:
    /// the caller's thread only). See [`Ppo::minibatch_grads`].
    pub update_threads: usize,
}

/// PPO learner state: optimiser and one KL coefficient per weight set.
pub struct Ppo {
    /// Settings.
    pub settings: PpoSettings,
    /// Current KL coefficients, one per weight set.
    pub kl_coeffs: Vec<f64>,
    /// The optimiser over all weights.
    pub optim: ClippedAdam,
    /// Fit the value weights alone ([critic warm-up](self#critic-warm-up)).
    pub critic_only: bool,
    /// Per optimiser variable: whether it is a value weight.
    value_vars: Vec<bool>,
}

/// One weight set's train batch with its GAE advantages and value targets.
struct Prepared {
    bt: BatchTensors,
    advantages: Tensor,
    targets: Tensor,
    /// Mean of `targets − V` over the batch (before standardising).
    residual: f64,
}

/// One minibatch's gradient (one buffer per variable, in the optimiser's
/// order) and each weight set's loss terms (`None`: no units this time).
struct MinibatchGrads {
    grads: Vec<Vec<f32>>,
    terms: Vec<Option<LossTerms>>,
}

/// One epoch's shuffled units of a weight set (samples, or whole sequences
/// for recurrent nets) and how many minibatches they make.
struct EpochPlan {
    order: Vec<u32>,
    minibatches: usize,
}

impl EpochPlan {
    /// Shuffles the units of `b`; minibatches of `minibatch_size` samples,
    /// rounded up (RLlib splits each policy's batch by agent steps).
    fn shuffled<R: Rng>(b: &NetBatch, recurrent: bool, minibatch_size: usize, rng: &mut R) -> Self {
        let units = if recurrent { b.rows } else { b.len() };
        let mut order: Vec<u32> = (0..units as u32).collect();
        order.shuffle(rng);
        let minibatches = b
            .len()
            .div_ceil(minibatch_size.max(1))
            .clamp(1, units.max(1));
        Self { order, minibatches }
    }

    /// The units of minibatch `mb`, if it has any.
    fn units(&self, mb: usize) -> Option<&[u32]> {
        let n = self.order.len();
        let (lo, hi) = (mb * n / self.minibatches, (mb + 1) * n / self.minibatches);
        (mb < self.minibatches && hi > lo).then(|| &self.order[lo..hi])
    }
}

impl Ppo {
    /// A PPO learner for `policy`.
    pub fn new(policy: &Policy, settings: PpoSettings) -> Self {
        let optim = ClippedAdam::new(policy, settings.lr, settings.grad_clip);
        let value_vars = optim
            .adam
            .vars()
            .iter()
            .map(|(name, _)| is_value_weight(name))
            .collect();
        Self {
            kl_coeffs: vec![settings.kl_coeff; policy.spec().nets()],
            optim,
            settings,
            critic_only: false,
            value_vars,
        }
    }

    /// One training iteration on a train batch of fragments.
    pub fn update<R: Rng>(
        &mut self,
        policy: &Policy,
        fragments: &[buridan_policy::Fragment],
        rng: &mut R,
    ) -> Result<UpdateStats> {
        let batches = build_net_batches(fragments, policy.spec())?;
        self.update_batches(policy, &batches, rng)
    }

    /// One training iteration on prepared per-net batches: advantages from
    /// the behaviour (= current) weights, then `epochs` passes of shuffled
    /// minibatches, then the KL coefficients adapt.
    pub fn update_batches<R: Rng>(
        &mut self,
        policy: &Policy,
        batches: &[NetBatch],
        rng: &mut R,
    ) -> Result<UpdateStats> {
        let prepared = batches
            .iter()
            .enumerate()
            .map(|(k, b)| self.prepare(policy, k, b))
            .collect::<Result<Vec<_>>>()?;
        if self.critic_only {
            for (k, p) in prepared.iter().enumerate() {
                self.shift_value_bias(k, p.residual)?;
            }
        }
        let recurrent = policy.spec().is_recurrent();
        let mut stats = UpdateStats::default();
        let mut kl_sums = vec![0.0f64; batches.len()];
        for _epoch in 0..self.settings.epochs {
            let plans: Vec<EpochPlan> = batches
                .iter()
                .map(|b| EpochPlan::shuffled(b, recurrent, self.settings.minibatch_size, rng))
                .collect();
            let minibatches = plans.iter().map(|p| p.minibatches).max().unwrap_or(1);
            for mb in 0..minibatches {
                let units: Vec<Option<&[u32]>> = plans.iter().map(|p| p.units(mb)).collect();
                let Some(MinibatchGrads { mut grads, terms }) =
                    self.minibatch_grads(policy, &prepared, &units)?
                else {
                    continue;
                };
                for (k, t) in terms.iter().enumerate() {
                    kl_sums[k] += t.map_or(0.0, |t| t.kl);
                }
                if self.critic_only {
                    for (g, value) in grads.iter_mut().zip(&self.value_vars) {
                        if !value {
                            g.fill(0.0);
                        }
                    }
                }
                let grad_norm = self.optim.step_grads(&mut grads)?;
                stats.add_minibatch(&terms.into_iter().flatten().collect::<Vec<_>>(), grad_norm);
            }
        }
        let kl_mean = self.adapt_kl(&kl_sums, stats.grad_steps);
        stats.finish();
        stats.kl = kl_mean;
        stats.kl_coeff = self.kl_coeffs.iter().sum::<f64>() / self.kl_coeffs.len() as f64;
        stats.samples = batches.iter().map(|b| b.len()).sum();
        Ok(stats)
    }

    /// Gradients of one minibatch's loss (summed over weight sets) and each
    /// weight set's loss terms (`None` where it has no units in this
    /// minibatch), or `None` if no weight set has any.
    ///
    /// The units are cut into `update_threads` shares, one per thread
    /// ([`crate::algo::shards`]): the same gradient, up to float rounding.
    fn minibatch_grads(
        &self,
        policy: &Policy,
        prepared: &[Prepared],
        units: &[Option<&[u32]>],
    ) -> Result<Option<MinibatchGrads>> {
        let samples: usize = units
            .iter()
            .zip(prepared)
            .map(|(u, p)| {
                let rows_per_unit = if p.bt.recurrent.is_some() { p.bt.t } else { 1 };
                u.map_or(0, |u| u.len() * rows_per_unit)
            })
            .sum();
        if samples == 0 {
            return Ok(None);
        }
        let shares = share_count(self.settings.update_threads, samples);
        let vars = self.optim.adam.vars();
        let (grads, terms) = sharded_gradient(
            shares,
            vars,
            |i| {
                let mut total = None;
                let mut terms = Vec::with_capacity(units.len());
                for (k, u) in units.iter().enumerate() {
                    let Some(u) = u else {
                        terms.push(None);
                        continue;
                    };
                    let part = share_range(i, shares, u.len());
                    if part.is_empty() {
                        terms.push(None);
                        continue;
                    }
                    let weight = part.len() as f64 / u.len() as f64;
                    let (loss, t) = self.minibatch_loss(policy, k, &prepared[k], &u[part])?;
                    terms.push(Some(t.scaled(weight)));
                    total = add_loss(total, (loss * weight)?)?;
                }
                Ok((total, terms))
            },
            |sums, parts| {
                sums.into_iter()
                    .zip(parts)
                    .map(|pair| match pair {
                        (Some(a), Some(b)) => Some(a.plus(&b)),
                        (a, b) => a.or(b),
                    })
                    .collect()
            },
        )?;
        let grads = grads.unwrap_or_else(|| zeros_like(vars));
        Ok(Some(MinibatchGrads { grads, terms }))
    }

    /// GAE advantages (standardised if configured) and value targets of
    /// weight set `k`'s batch, from the current weights.
    fn prepare(&self, policy: &Policy, k: usize, b: &NetBatch) -> Result<Prepared> {
        let s = &self.settings;
        let dev = policy.device().clone();
        let bt = BatchTensors::new(b, &dev)?;
        let ev = evaluate(policy.net(k), b, &bt, s.max_seq_len, &dev)?;
        let g = gae(
            &ev.trajectory(b),
            GaeParams {
                gamma: s.gamma,
                lambda: s.lambda,
            },
        );
        let mut advantages = g.advantages;
        let residual =
            advantages.iter().map(|&a| f64::from(a)).sum::<f64>() / advantages.len().max(1) as f64;
        if s.standardize_advantages {
            standardize(&mut advantages);
        }
        let n = b.len();
        Ok(Prepared {
            bt,
            advantages: Tensor::from_vec(advantages, n, &dev)?,
            targets: Tensor::from_vec(g.targets, n, &dev)?,
            residual,
        })
    }

    /// Adds `by` to weight set `k`'s value bias: the closed-form best
    /// constant correction of a critic whose scale is off (a fresh value
    /// head predicts about 0 where returns are several units).
    fn shift_value_bias(&self, k: usize, by: f64) -> Result<()> {
        let name = format!("net{k}.value.bias");
        if let Some((_, var)) = self.optim.adam.vars().iter().find(|(n, _)| *n == name) {
            var.set(&(var.as_tensor() + by)?)?;
        }
        Ok(())
    }

    /// The PPO loss of weight set `k` on the given units (samples, or
    /// sequences of a recurrent net).
    fn minibatch_loss(
        &self,
        policy: &Policy,
        k: usize,
        p: &Prepared,
        units: &[u32],
    ) -> Result<(Tensor, LossTerms)> {
        let s = &self.settings;
        let idx = Tensor::from_slice(units, units.len(), policy.device())?;
        let net = policy.net(k);
        let (sub, advantages, targets, logits, values) = if p.bt.recurrent.is_some() {
            let sub = p.bt.select_rows(&idx)?;
            let rc = sub.recurrent.as_ref().ok_or_else(|| {
                AlgoError::Batch("row selection lost the recurrent inputs".into())
            })?;
            let out = sub.unroll(net, rc, s.max_seq_len)?;
            let rows_of = |x: &Tensor| -> Result<Tensor> {
                Ok(
                    BatchTensors::select_rows_of(&x.unsqueeze(1)?, p.bt.t, p.bt.rows, &idx)?
                        .squeeze(1)?,
                )
            };
            let (a, t) = (rows_of(&p.advantages)?, rows_of(&p.targets)?);
            (sub, a, t, out.logits, out.value)
        } else {
            let sub = p.bt.select_samples(&idx)?;
            let out = net.forward(&sub.obs)?;
            let advantages = p.advantages.index_select(&idx, 0)?;
            let targets = p.targets.index_select(&idx, 0)?;
            (sub, advantages, targets, out.logits, out.value)
        };
        let params = PpoLossParams {
            clip: s.clip,
            vf_coeff: s.vf_coeff,
            vf_clip: s.vf_clip,
            entropy_coeff: s.entropy_coeff,
            kl_coeff: self.kl_coeffs[k] as f32,
        };
        if self.critic_only {
            critic_loss(&logits, &values, &sub, &targets, &params)
        } else {
            ppo_loss(&logits, &values, &sub, &advantages, &targets, &params)
        }
    }

    /// RLlib's `update_kl` per weight set from the mean KL of its gradient
    /// steps (not during a critic warm-up); returns the mean KL over weight
    /// sets.
    fn adapt_kl(&mut self, kl_sums: &[f64], grad_steps: usize) -> f64 {
        let mut kl_mean = 0.0;
        for (k, kl_sum) in kl_sums.iter().enumerate() {
            let kl = kl_sum / grad_steps.max(1) as f64;
            kl_mean += kl / kl_sums.len() as f64;
            // A critic warm-up leaves the policy, and so its KL, alone.
            if self.settings.kl_coeff > 0.0 && !self.critic_only {
                self.kl_coeffs[k] = update_kl_coeff(self.kl_coeffs[k], kl, self.settings.kl_target);
            }
        }
        kl_mean
    }
}

/// Whether the optimiser variable `name` (`net{k}.…`, [`buridan_policy::Net`]'s
/// names) is a value weight: the value head or the separate value MLP.
///
/// ```
/// use buridan_learner::algo::ppo::is_value_weight;
/// assert!(is_value_weight("net0.value.weight") && is_value_weight("net1.vf.0.bias"));
/// assert!(!is_value_weight("net0.pi.0.weight") && !is_value_weight("net0.lstm.weight_hh_l0"));
/// assert!(!is_value_weight("net0.logits.bias"));
/// ```
pub fn is_value_weight(name: &str) -> bool {
    let local = name.split_once('.').map_or(name, |(_, rest)| rest);
    local.starts_with("value.") || local.starts_with("vf.")
}
