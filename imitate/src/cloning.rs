//! Behaviour cloning: the negative log-likelihood of the expert's actions
//! under the masked policy, minimised by Adam over minibatches.

use candle_core::{DType, Tensor, Var, D};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use rand::seq::SliceRandom;
use rand::Rng;

use buridan_policy::dist::{mask_bias, masked_log_probs};
use buridan_policy::shards::{on_threads, share_count, share_range};
use buridan_policy::Policy;

use crate::dataset::Dataset;
use crate::error::ImitationError;
use crate::windows::{Window, Windows};

/// The cloning loss `−mean_{r,h} log π_h(a*_{r,h} | o_r)` over rows and
/// heads, with the policy's logits `[rows, heads·5]` masked by `bias`
/// (0 legal, −1e9 illegal) and the expert's actions `labels [rows, heads]`
/// (u32; one head for a policy acting for one agent, one per agent for
/// CTE's joint policy); also the fraction of (row, head) pairs whose most
/// probable legal action is the expert's.
///
/// ```
/// use candle_core::{Device, Tensor};
/// let logits = Tensor::new(&[[0f32, 1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0, 0.0]], &Device::Cpu).unwrap();
/// // Row 0: four legal actions, the expert's (1) has the top logit;
/// // row 1: the expert's action 1 is legal beside action 0 (logit 2).
/// let bias = Tensor::new(&[[0f32, 0.0, 0.0, 0.0, -1e9], [0.0, 0.0, -1e9, -1e9, -1e9]], &Device::Cpu).unwrap();
/// let labels = Tensor::new(&[[1u32], [1]], &Device::Cpu).unwrap();
/// let (loss, acc) = buridan_imitate::cloning::cloning_loss(&logits, &bias, &labels).unwrap();
/// // −(ln(e/(3+e)) + ln(1/(1+e²))) / 2 = (0.7437 + 2.1269) / 2
/// assert!((loss.to_scalar::<f32>().unwrap() - 1.4353).abs() < 1e-3);
/// assert_eq!(acc, 0.5); // row 0 agrees, row 1 prefers action 0
/// // The same two rows as one joint row of two heads: the same mean.
/// let joint = Tensor::new(&[[0f32, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0]], &Device::Cpu).unwrap();
/// let bias = Tensor::new(&[[0f32, 0.0, 0.0, 0.0, -1e9, 0.0, 0.0, -1e9, -1e9, -1e9]], &Device::Cpu).unwrap();
/// let labels = Tensor::new(&[[1u32, 1]], &Device::Cpu).unwrap();
/// let (loss, acc) = buridan_imitate::cloning::cloning_loss(&joint, &bias, &labels).unwrap();
/// assert!((loss.to_scalar::<f32>().unwrap() - 1.4353).abs() < 1e-3);
/// assert_eq!(acc, 0.5);
/// ```
pub fn cloning_loss(
    logits: &Tensor,
    bias: &Tensor,
    labels: &Tensor,
) -> Result<(Tensor, f64), ImitationError> {
    let count = labels.elem_count() as f32;
    let (loss, hits) = loss_part(logits, bias, labels, None, count)?;
    Ok((loss, hits / f64::from(count)))
}

/// [`cloning_loss`] over the rows whose `weights [rows]` are 1 (steps the
/// expert labelled); rows of weight 0 add nothing to the loss or the
/// agreement. At least one row must have weight 1.
///
/// ```
/// use candle_core::{Device, Tensor};
/// let logits = Tensor::new(&[[0f32, 1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0, 0.0]], &Device::Cpu).unwrap();
/// let bias = Tensor::new(&[[0f32, 0.0, 0.0, 0.0, -1e9], [0.0, 0.0, -1e9, -1e9, -1e9]], &Device::Cpu).unwrap();
/// let labels = Tensor::new(&[[1u32], [1]], &Device::Cpu).unwrap();
/// let weights = Tensor::new(&[1f32, 0.0], &Device::Cpu).unwrap();
/// let (loss, acc) = buridan_imitate::cloning::weighted_cloning_loss(&logits, &bias, &labels, &weights).unwrap();
/// // Row 0 alone: −ln(e/(3+e)) = 0.7437, and it agrees.
/// assert!((loss.to_scalar::<f32>().unwrap() - 0.7437).abs() < 1e-3);
/// assert_eq!(acc, 1.0);
/// ```
pub fn weighted_cloning_loss(
    logits: &Tensor,
    bias: &Tensor,
    labels: &Tensor,
    weights: &Tensor,
) -> Result<(Tensor, f64), ImitationError> {
    let count = weights.sum_all()?.to_scalar::<f32>()?.max(1.0) * labels.dim(D::Minus1)? as f32;
    let (loss, hits) = loss_part(logits, bias, labels, Some(weights), count)?;
    Ok((loss, hits / f64::from(count)))
}

/// A share's part of a minibatch's cloning loss: `−Σ w_r log π_h(a*_{r,h}
/// | o_r) / count` over its rows and heads (`weights` 1 where the expert
/// labelled a step, all 1 without them), where `count` is the labelled
/// (row, head) pairs of the whole minibatch, so the parts of its shares sum
/// to its loss; also how many of the share's labelled pairs agree with the
/// expert.
fn loss_part(
    logits: &Tensor,
    bias: &Tensor,
    labels: &Tensor,
    weights: Option<&Tensor>,
    count: f32,
) -> Result<(Tensor, f64), ImitationError> {
    let (mut chosen, mut hits) = label_log_probs(logits, bias, labels)?;
    if let Some(w) = weights {
        let w = w.unsqueeze(D::Minus1)?;
        chosen = chosen.broadcast_mul(&w)?;
        hits = hits.broadcast_mul(&w)?;
    }
    let loss = (chosen.sum_all()?.neg()? / f64::from(count))?;
    Ok((loss, f64::from(hits.sum_all()?.to_scalar::<f32>()?)))
}

/// The log-probabilities of the expert's actions `[rows, heads]` and
/// whether each is the most probable legal action (1.0) or not (0.0).
fn label_log_probs(
    logits: &Tensor,
    bias: &Tensor,
    labels: &Tensor,
) -> Result<(Tensor, Tensor), ImitationError> {
    let heads = labels.dim(D::Minus1)?;
    let logp = masked_log_probs(logits, bias, heads)?;
    let chosen = logp
        .gather(&labels.unsqueeze(D::Minus1)?, D::Minus1)?
        .squeeze(D::Minus1)?;
    let hits = logp.argmax(D::Minus1)?.eq(labels)?.to_dtype(DType::F32)?;
    Ok((chosen, hits))
}

/// What one pass of fitting achieved.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FitStats {
    /// Mean cloning loss of the last epoch.
    pub loss: f64,
    /// Mean agreement with the expert of the last epoch.
    pub accuracy: f64,
    /// Gradient steps taken.
    pub steps: u64,
}

/// Adam over the weights of one of a policy's networks for behaviour
/// cloning (DTE's agents each have their own network and their own
/// optimiser: an agent's steps move only its own weights).
pub struct Cloner {
    net: usize,
    opt: AdamW,
    vars: Vec<Var>,
    minibatch: usize,
    threads: usize,
}

impl Cloner {
    /// An optimiser over every weight of network `net` of `policy` (Adam
    /// without decay), each step's minibatch cut across `threads` threads
    /// ([`buridan_policy::shards`]; 1 for one thread).
    pub fn new(
        policy: &Policy,
        net: usize,
        lr: f64,
        minibatch: usize,
        threads: usize,
    ) -> Result<Self, ImitationError> {
        let params = ParamsAdamW {
            lr,
            weight_decay: 0.0,
            ..ParamsAdamW::default()
        };
        let vars: Vec<Var> = policy.net_vars(net).into_iter().map(|(_, v)| v).collect();
        Ok(Self {
            net,
            opt: AdamW::new(vars.clone(), params)?,
            vars,
            minibatch,
            threads,
        })
    }

    /// `epochs` passes over `data` in shuffled minibatches.
    pub fn fit<R: Rng + ?Sized>(
        &mut self,
        policy: &Policy,
        data: &Dataset,
        epochs: usize,
        rng: &mut R,
    ) -> Result<FitStats, ImitationError> {
        let device = policy.device().clone();
        let (d, w, h) = (data.obs_dim(), data.mask_dim(), data.heads());
        let (minibatch, net) = (self.minibatch, policy.net(self.net));
        let labelled = |chunk: &[usize]| (chunk.len() * h) as f32;
        self.descend(
            data.len(),
            minibatch,
            epochs,
            rng,
            1,
            labelled,
            |share, count| {
                let rows = share.len();
                let mut obs = Vec::with_capacity(rows * d);
                let mut masks = Vec::with_capacity(rows * w);
                let mut labels = Vec::with_capacity(rows * h);
                for &r in share {
                    obs.extend_from_slice(&data.obs[r * d..(r + 1) * d]);
                    masks.extend_from_slice(&data.masks[r * w..(r + 1) * w]);
                    labels.extend(
                        data.labels[r * h..(r + 1) * h]
                            .iter()
                            .map(|&a| u32::from(a)),
                    );
                }
                let obs = Tensor::from_vec(obs, (rows, d), &device)?;
                let bias = mask_bias(&masks, rows, w, &device)?;
                let labels = Tensor::from_vec(labels, (rows, h), &device)?;
                let logits = net.forward(&obs)?.logits;
                loss_part(&logits, &bias, &labels, None, count)
            },
        )
    }

    /// `epochs` passes over recurrent `data` in shuffled minibatches of
    /// whole windows (about `minibatch` steps each), each replayed by
    /// [`replay_windows`] through this cloner's network, the loss taken
    /// over the labelled steps. The policy must be recurrent.
    pub fn fit_windows<R: Rng + ?Sized>(
        &mut self,
        policy: &Policy,
        data: &Windows,
        epochs: usize,
        rng: &mut R,
    ) -> Result<FitStats, ImitationError> {
        let (steps, heads) = (data.steps(), data.heads());
        let (per_batch, net) = ((self.minibatch / steps).max(1), self.net);
        let labelled = |chunk: &[usize]| {
            let held = data.held();
            let labelled_steps: f32 = chunk
                .iter()
                .map(|&i| held[i].weights.iter().sum::<f32>())
                .sum();
            labelled_steps.max(1.0) * heads as f32
        };
        self.descend(
            data.len(),
            per_batch,
            epochs,
            rng,
            steps,
            labelled,
            |share, count| {
                let replay = replay_windows(policy, net, data, share)?;
                loss_part(
                    &replay.logits,
                    &replay.bias,
                    &replay.labels,
                    Some(&replay.weights),
                    count,
                )
            },
        )
    }

    /// `epochs` passes over `items` items (of `item_steps` samples each) in
    /// shuffled chunks of `per_batch`: one Adam step on each chunk. A chunk
    /// holds `labelled(chunk)` labelled (row, head) pairs; it is cut into
    /// shares ([`share_count`] of the cloner's threads), and `part(share,
    /// count)` gives a share's part of the loss and the pairs it agrees on,
    /// each share on a thread of its own, the gradients summed in share
    /// order.
    #[allow(clippy::too_many_arguments)]
    fn descend<R: Rng + ?Sized>(
        &mut self,
        items: usize,
        per_batch: usize,
        epochs: usize,
        rng: &mut R,
        item_steps: usize,
        labelled: impl Fn(&[usize]) -> f32,
        part: impl Fn(&[usize], f32) -> Result<(Tensor, f64), ImitationError> + Sync,
    ) -> Result<FitStats, ImitationError> {
        let mut order: Vec<usize> = (0..items).collect();
        let mut stats = FitStats::default();
        for _ in 0..epochs {
            order.shuffle(rng);
            let (mut loss_sum, mut acc_sum, mut batches) = (0.0, 0.0, 0usize);
            for chunk in order.chunks(per_batch) {
                let count = labelled(chunk);
                let shares = share_count(self.threads, chunk.len() * item_steps).min(chunk.len());
                let (loss, hits) = if shares == 1 {
                    let (loss, hits) = part(chunk, count)?;
                    self.opt.backward_step(&loss)?;
                    (f64::from(loss.to_scalar::<f32>()?), hits)
                } else {
                    self.sharded_step(chunk, shares, count, &part)?
                };
                loss_sum += loss;
                acc_sum += hits / f64::from(count);
                batches += 1;
                stats.steps += 1;
            }
            stats.loss = loss_sum / batches.max(1) as f64;
            stats.accuracy = acc_sum / batches.max(1) as f64;
        }
        Ok(stats)
    }

    /// One Adam step on `chunk` cut into `shares` shares, each share's
    /// forward and backward pass on a thread of its own, the gradients
    /// summed in share order; the chunk's loss and agreeing pairs.
    fn sharded_step(
        &mut self,
        chunk: &[usize],
        shares: usize,
        count: f32,
        part: &(impl Fn(&[usize], f32) -> Result<(Tensor, f64), ImitationError> + Sync),
    ) -> Result<(f64, f64), ImitationError> {
        let parts = on_threads(shares, |i| {
            let (loss, hits) = part(&chunk[share_range(i, shares, chunk.len())], count)?;
            Ok::<_, ImitationError>((loss.backward()?, f64::from(loss.to_scalar::<f32>()?), hits))
        })?;
        let mut parts = parts.into_iter();
        let (mut grads, mut loss, mut hits) = parts.next().expect("at least one share");
        for (more, l, h) in parts {
            for var in &self.vars {
                if let Some(g) = more.get(var) {
                    let sum = match grads.get(var) {
                        Some(sum) => (sum + g)?,
                        None => g.clone(),
                    };
                    grads.insert(var, sum);
                }
            }
            loss += l;
            hits += h;
        }
        self.opt.step(&grads)?;
        Ok((loss, hits))
    }
}

/// Windows replayed through a recurrent policy, time-major: row `s·b + j`
/// is step `s` of the `j`-th window asked for (`b` windows).
#[derive(Debug)]
pub struct WindowReplay {
    /// The policy's raw logits `[t·b, 5]`.
    pub logits: Tensor,
    /// The steps' action masks as a logit bias `[t·b, 5]` (0 legal, −1e9 not).
    pub bias: Tensor,
    /// The expert's actions `[t·b, heads]` (u32).
    pub labels: Tensor,
    /// 1 where the expert labelled the step `[t·b]`.
    pub weights: Tensor,
}

/// Replays `windows` of `data` through network `net` of `policy`: each
/// from its stored LSTM state, with the state reset where an episode starts
/// inside it — the logits an actor computed step by step, recomputed with
/// gradients (`Net::unroll`, the same path PPO and IMPALA train through).
pub fn replay_windows(
    policy: &Policy,
    net: usize,
    data: &Windows,
    windows: &[usize],
) -> Result<WindowReplay, ImitationError> {
    let device = policy.device().clone();
    let (t, d, w, k) = (
        data.steps(),
        data.obs_dim(),
        data.mask_dim(),
        policy.net(net).cells(),
    );
    let h = data.heads();
    let picked: Vec<&Window> = windows.iter().map(|&i| &data.held()[i]).collect();
    let b = picked.len();
    let rows = t * b;
    let mut obs = Vec::with_capacity(rows * d);
    let mut masks = Vec::with_capacity(rows * w);
    let mut prev_a = Vec::with_capacity(rows * w);
    let (mut prev_r, mut keep, mut labels, mut weights) = (
        Vec::with_capacity(rows),
        Vec::with_capacity(rows),
        Vec::with_capacity(rows),
        Vec::with_capacity(rows),
    );
    for s in 0..t {
        for win in &picked {
            obs.extend_from_slice(&win.obs[s * d..(s + 1) * d]);
            masks.extend_from_slice(&win.masks[s * w..(s + 1) * w]);
            prev_a.extend_from_slice(&win.prev_actions[s * w..(s + 1) * w]);
            prev_r.push(win.prev_rewards[s]);
            keep.push(win.keep[s]);
            labels.extend(win.labels[s * h..(s + 1) * h].iter().map(|&a| u32::from(a)));
            weights.push(win.weights[s]);
        }
    }
    let h0: Vec<f32> = picked
        .iter()
        .flat_map(|win| win.h0.iter().copied())
        .collect();
    let c0: Vec<f32> = picked
        .iter()
        .flat_map(|win| win.c0.iter().copied())
        .collect();
    let out = policy.net(net).unroll(
        &Tensor::from_vec(obs, (rows, d), &device)?,
        &Tensor::from_vec(prev_a, (rows, w), &device)?,
        &Tensor::from_vec(prev_r, (rows, 1), &device)?,
        &Tensor::from_vec(keep, (rows, 1), &device)?,
        &Tensor::from_vec(h0, (b, k), &device)?,
        &Tensor::from_vec(c0, (b, k), &device)?,
        t,
        t,
    )?;
    Ok(WindowReplay {
        logits: out.logits,
        bias: mask_bias(&masks, rows, w, &device)?,
        labels: Tensor::from_vec(labels, (rows, h), &device)?,
        weights: Tensor::from_vec(weights, rows, &device)?,
    })
}
