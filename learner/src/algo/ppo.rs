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

use anyhow::Result;
use buridan_policy::{dist, Policy};
use candle_core::{Device, Tensor};
use rand::seq::SliceRandom;
use rand::Rng;

use crate::algo::batch::{build_net_batches, evaluate, BatchTensors, NetBatch};
use crate::algo::gae::{gae, standardize};
use crate::algo::optim::{clip_global_norm, collect_grads, Adam};
use crate::algo::{net_var_groups, UpdateStats};

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
    let lp_all = dist::masked_log_probs(logits, &bt.mask_bias, bt.heads)?;
    let logp = dist::joint_log_prob(&lp_all, &bt.actions)?;
    let ratio = (logp - &bt.behaviour_logp)?.exp()?;
    let unclipped = (&ratio * advantages)?;
    let clipped = (ratio.clamp(1.0 - p.clip, 1.0 + p.clip)? * advantages)?;
    let surrogate = unclipped.minimum(&clipped)?;
    let vf = (values - targets)?.sqr()?.clamp(0.0, p.vf_clip)?;
    let entropy = dist::entropy(&lp_all)?;
    let kl = dist::kl(&bt.behaviour_log_probs, &lp_all)?.mean_all()?;
    let per_sample =
        ((surrogate.neg()? + (&vf * p.vf_coeff as f64)?)? - (&entropy * p.entropy_coeff as f64)?)?;
    let mut total = per_sample.mean_all()?;
    if p.kl_coeff > 0.0 {
        total = (total + (&kl * p.kl_coeff as f64)?)?;
    }
    let terms = LossTerms {
        total: total.to_scalar::<f32>()? as f64,
        policy: -surrogate.mean_all()?.to_scalar::<f32>()? as f64,
        vf: vf.mean_all()?.to_scalar::<f32>()? as f64,
        entropy: entropy.mean_all()?.to_scalar::<f32>()? as f64,
        kl: kl.to_scalar::<f32>()? as f64,
    };
    Ok((total, terms))
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
}

/// PPO learner state: optimiser and one KL coefficient per weight set.
pub struct Ppo {
    /// Settings.
    pub settings: PpoSettings,
    /// Current KL coefficients, one per weight set.
    pub kl_coeffs: Vec<f64>,
    /// The optimiser over all weights.
    pub adam: Adam,
    groups: Vec<std::ops::Range<usize>>,
}

impl Ppo {
    /// A PPO learner for `policy`.
    pub fn new(policy: &Policy, settings: PpoSettings) -> Self {
        let (vars, groups) = net_var_groups(policy);
        Self {
            kl_coeffs: vec![settings.kl_coeff; policy.spec().nets()],
            adam: Adam::new(vars, settings.lr),
            settings,
            groups,
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

    /// One training iteration on prepared per-net batches.
    pub fn update_batches<R: Rng>(
        &mut self,
        policy: &Policy,
        batches: &[NetBatch],
        rng: &mut R,
    ) -> Result<UpdateStats> {
        let s = self.settings.clone();
        let dev = Device::Cpu;
        let recurrent = policy.spec().is_recurrent();
        // Targets from the behaviour (= current) weights, computed once.
        let mut prepared = Vec::with_capacity(batches.len());
        for (k, b) in batches.iter().enumerate() {
            let bt = BatchTensors::new(b, &dev)?;
            let ev = evaluate(policy.net(k), b, &bt, s.max_seq_len, &dev)?;
            let g = gae(
                &b.rewards,
                &ev.values_vec,
                &ev.next_values,
                &b.terminated,
                &b.truncated,
                b.t,
                b.rows,
                s.gamma,
                s.lambda,
            );
            let mut adv = g.advantages;
            if s.standardize_advantages {
                standardize(&mut adv);
            }
            let n = b.len();
            prepared.push((
                bt,
                Tensor::from_vec(adv, n, &dev)?,
                Tensor::from_vec(g.targets, n, &dev)?,
            ));
        }
        let mut stats = UpdateStats::default();
        let mut kl_sums = vec![0.0f64; batches.len()];
        let mut steps = 0usize;
        for _epoch in 0..s.epochs {
            // Shuffled chunks per net: samples (feed-forward) or sequences (LSTM).
            let orders: Vec<Vec<u32>> = batches
                .iter()
                .map(|b| {
                    let units = if recurrent { b.rows } else { b.len() };
                    let mut o: Vec<u32> = (0..units as u32).collect();
                    o.shuffle(rng);
                    o
                })
                .collect();
            // Minibatches per net: its samples / minibatch_size, rounded up
            // (RLlib splits each policy's batch by agent steps).
            let chunks: Vec<usize> = batches
                .iter()
                .zip(&orders)
                .map(|(b, o)| {
                    b.len()
                        .div_ceil(s.minibatch_size.max(1))
                        .clamp(1, o.len().max(1))
                })
                .collect();
            let mbs = chunks.iter().copied().max().unwrap_or(1);
            for mb in 0..mbs {
                let mut total: Option<Tensor> = None;
                let mut terms_mb = Vec::new();
                for (k, (bt, adv, tgt)) in prepared.iter().enumerate() {
                    let units = orders[k].len();
                    let lo = mb * units / chunks[k];
                    let hi = (mb + 1) * units / chunks[k];
                    if mb >= chunks[k] || hi <= lo {
                        continue;
                    }
                    let idx = Tensor::from_slice(&orders[k][lo..hi], hi - lo, &dev)?;
                    let net = policy.net(k);
                    let (sub, sub_adv, sub_tgt, logits, values) = if recurrent {
                        let sub = bt.select_rows(&idx)?;
                        let rc = sub.recurrent.as_ref().expect("recurrent");
                        let un = net.unroll(
                            &sub.obs,
                            &rc.prev_action,
                            &rc.prev_reward,
                            &rc.keep,
                            &rc.h0,
                            &rc.c0,
                            sub.t,
                            s.max_seq_len,
                        )?;
                        let a =
                            BatchTensors::select_rows_of(&adv.unsqueeze(1)?, bt.t, bt.rows, &idx)?
                                .squeeze(1)?;
                        let t =
                            BatchTensors::select_rows_of(&tgt.unsqueeze(1)?, bt.t, bt.rows, &idx)?
                                .squeeze(1)?;
                        (sub, a, t, un.logits, un.value)
                    } else {
                        let sub = bt.select_samples(&idx)?;
                        let out = net.forward(&sub.obs)?;
                        let a = adv.index_select(&idx, 0)?;
                        let t = tgt.index_select(&idx, 0)?;
                        (sub, a, t, out.logits, out.value)
                    };
                    let p = PpoLossParams {
                        clip: s.clip,
                        vf_coeff: s.vf_coeff,
                        vf_clip: s.vf_clip,
                        entropy_coeff: s.entropy_coeff,
                        kl_coeff: self.kl_coeffs[k] as f32,
                    };
                    let (loss, terms) = ppo_loss(&logits, &values, &sub, &sub_adv, &sub_tgt, &p)?;
                    kl_sums[k] += terms.kl;
                    terms_mb.push(terms);
                    total = Some(match total {
                        None => loss,
                        Some(t) => (t + loss)?,
                    });
                }
                let Some(total) = total else { continue };
                let grads = total.backward()?;
                let mut g = collect_grads(&grads, self.adam.vars())?;
                let mut norm_sq = 0.0;
                for range in &self.groups {
                    let n = match s.grad_clip {
                        Some(c) => clip_global_norm(&mut g[range.clone()], c),
                        None => crate::algo::optim::global_norm(
                            &g[range.clone()]
                                .iter()
                                .map(|x| x.as_slice())
                                .collect::<Vec<_>>(),
                        ),
                    };
                    norm_sq += n * n;
                }
                self.adam.step(&g)?;
                stats.add_minibatch(&terms_mb, norm_sq.sqrt());
                steps += 1;
            }
        }
        let mut kl_mean = 0.0;
        for (k, kl_sum) in kl_sums.iter().enumerate() {
            let kl = kl_sum / steps.max(1) as f64;
            kl_mean += kl / batches.len() as f64;
            if self.settings.kl_coeff > 0.0 {
                self.kl_coeffs[k] = update_kl_coeff(self.kl_coeffs[k], kl, s.kl_target);
            }
        }
        stats.finish();
        stats.kl = kl_mean;
        stats.kl_coeff = self.kl_coeffs.iter().sum::<f64>() / self.kl_coeffs.len() as f64;
        stats.samples = batches.iter().map(|b| b.len()).sum();
        Ok(stats)
    }
}
