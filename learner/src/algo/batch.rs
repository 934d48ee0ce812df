//! From fragments to train batches: rows grouped per weight set, plain
//! buffers turned into tensors, and the value pass that yields `V(s_t)` and
//! the bootstrap values `V(s_{t+1})` (see [`crate::algo::gae`]).

use buridan_policy::dist;
use buridan_policy::infer::{one_hot_prev, RecurrentState, NO_ACTION};
use buridan_policy::{Fragment, ModelSpec, Net};
use candle_core::{Device, Tensor};

use crate::algo::trajectory::Trajectory;
use crate::algo::{AlgoError, Result};

/// The experience of one weight set: `T` steps of `R` rows gathered from
/// fragments (all of the same length), time-major `[T, R]`.
#[derive(Debug, Clone, Default)]
pub struct NetBatch {
    /// Steps `T`.
    pub t: usize,
    /// Rows `R`.
    pub rows: usize,
    /// Floats per observation.
    pub obs_dim: usize,
    /// Heads.
    pub heads: usize,
    /// Actions per head.
    pub actions_per_head: usize,
    /// `[T, R, obs_dim]`.
    pub obs: Vec<f32>,
    /// `[T, R, heads·A]`.
    pub masks: Vec<u8>,
    /// `[T, R, heads]`.
    pub actions: Vec<u8>,
    /// `[T, R, heads·A]`.
    pub behaviour_logits: Vec<f32>,
    /// `[T, R]`.
    pub rewards: Vec<f32>,
    /// `[T, R]`.
    pub terminated: Vec<bool>,
    /// `[T, R]`.
    pub truncated: Vec<bool>,
    /// Final observations of truncated steps, `[K, obs_dim]`.
    pub final_obs: Vec<f32>,
    /// `t·R + r` of each final observation.
    pub final_index: Vec<usize>,
    /// Observation after the last step, `[R, obs_dim]`.
    pub last_obs: Vec<f32>,
    /// Recurrent state before step 0 (rows `R`).
    pub initial_state: Option<RecurrentState>,
    /// Env steps the fragments of this batch hold (the same for every weight set).
    pub env_steps: u64,
}

impl NetBatch {
    /// Samples `T·R`.
    pub fn len(&self) -> usize {
        self.t * self.rows
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Rows `rows` of every step: the trajectories of those rows, a batch of
    /// its own (V-trace and GAE run per row, so a row range is a share of
    /// the batch's update, [`crate::algo::shards`]).
    ///
    /// ```
    /// use buridan_learner::algo::batch::NetBatch;
    /// let b = NetBatch {
    ///     t: 2, rows: 3, obs_dim: 1, heads: 1, actions_per_head: 1,
    ///     obs: vec![0., 1., 2., 10., 11., 12.],
    ///     masks: vec![1; 6], actions: vec![0; 6], behaviour_logits: vec![0.; 6],
    ///     rewards: vec![0., 1., 2., 10., 11., 12.],
    ///     terminated: vec![false; 6], truncated: vec![false, false, false, false, true, false],
    ///     final_obs: vec![99.], final_index: vec![4],
    ///     last_obs: vec![20., 21., 22.],
    ///     ..Default::default()
    /// };
    /// let s = b.select_rows(1..3);
    /// assert_eq!((s.t, s.rows), (2, 2));
    /// assert_eq!(s.obs, [1., 2., 11., 12.]);
    /// assert_eq!(s.final_index, [2]); // step 1, row 0 of the share
    /// assert_eq!(s.last_obs, [21., 22.]);
    /// ```
    pub fn select_rows(&self, rows: std::ops::Range<usize>) -> NetBatch {
        let (t, r, n) = (self.t, self.rows, rows.len());
        fn per_row<T: Clone>(v: &[T], t: usize, r: usize, rows: &std::ops::Range<usize>) -> Vec<T> {
            let width = v.len() / (t * r).max(1);
            (0..t)
                .flat_map(|s| &v[(s * r + rows.start) * width..(s * r + rows.end) * width])
                .cloned()
                .collect()
        }
        let (mut final_obs, mut final_index) = (Vec::new(), Vec::new());
        for (q, &idx) in self.final_index.iter().enumerate() {
            let (s, j) = (idx / r, idx % r);
            if rows.contains(&j) {
                final_index.push(s * n + j - rows.start);
                final_obs
                    .extend_from_slice(&self.final_obs[q * self.obs_dim..(q + 1) * self.obs_dim]);
            }
        }
        let initial_state = self.initial_state.as_ref().map(|st| RecurrentState {
            rows: n,
            cells: st.cells,
            heads: st.heads,
            h: st.h[rows.start * st.cells..rows.end * st.cells].to_vec(),
            c: st.c[rows.start * st.cells..rows.end * st.cells].to_vec(),
            prev_actions: st.prev_actions[rows.start * st.heads..rows.end * st.heads].to_vec(),
            prev_rewards: st.prev_rewards[rows.clone()].to_vec(),
        });
        NetBatch {
            t,
            rows: n,
            obs_dim: self.obs_dim,
            heads: self.heads,
            actions_per_head: self.actions_per_head,
            obs: per_row(&self.obs, t, r, &rows),
            masks: per_row(&self.masks, t, r, &rows),
            actions: per_row(&self.actions, t, r, &rows),
            behaviour_logits: per_row(&self.behaviour_logits, t, r, &rows),
            rewards: per_row(&self.rewards, t, r, &rows),
            terminated: per_row(&self.terminated, t, r, &rows),
            truncated: per_row(&self.truncated, t, r, &rows),
            final_obs,
            final_index,
            last_obs: self.last_obs[rows.start * self.obs_dim..rows.end * self.obs_dim].to_vec(),
            initial_state,
            env_steps: self.env_steps,
        }
    }
}

/// Splits fragments into one [`NetBatch`] per weight set of `spec`
/// (one for CTE/CTDE, one per agent id for DTE).
pub fn build_net_batches(fragments: &[Fragment], spec: &ModelSpec) -> Result<Vec<NetBatch>> {
    check_fragments(fragments, spec)?;
    let env_steps: u64 = fragments.iter().map(|f| f.env_steps).sum();
    (0..spec.nets())
        .map(|k| {
            let sel = rows_of_net(fragments, spec, k);
            let mut b = gather_steps(fragments, spec, &sel);
            gather_final_obs(fragments, &sel, &mut b);
            if let Some(lstm) = &spec.lstm {
                b.initial_state = Some(gather_initial_state(
                    fragments, &sel, lstm.cells, spec.heads,
                )?);
            }
            b.env_steps = env_steps;
            Ok(b)
        })
        .collect()
}

/// Fragments fit together and fit the model.
fn check_fragments(fragments: &[Fragment], spec: &ModelSpec) -> Result<()> {
    let first = fragments
        .first()
        .ok_or_else(|| AlgoError::Batch("no fragments to build a batch from".into()))?;
    for f in fragments {
        f.validate()?;
        check(f.len == first.len, || {
            format!(
                "fragments of different lengths ({} and {})",
                f.len, first.len
            )
        })?;
        check(f.obs_dim == spec.obs_dim && f.heads == spec.heads, || {
            format!(
                "fragment shape (obs {}, heads {}) does not match the model (obs {}, heads {})",
                f.obs_dim, f.heads, spec.obs_dim, spec.heads
            )
        })?;
        check(f.initial_state.is_some() == spec.is_recurrent(), || {
            "fragment recurrent state does not match the model".into()
        })?;
    }
    Ok(())
}

fn check(ok: bool, why: impl FnOnce() -> String) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(AlgoError::Batch(why()))
    }
}

/// The `(fragment, row)` pairs of weight set `k`, in batch row order.
fn rows_of_net(fragments: &[Fragment], spec: &ModelSpec, k: usize) -> Vec<(usize, usize)> {
    fragments
        .iter()
        .enumerate()
        .flat_map(|(fi, f)| {
            (0..f.rows)
                .filter(move |&r| spec.net_of_row(r) == k)
                .map(move |r| (fi, r))
        })
        .collect()
}

/// Every step of the selected rows, time-major, and their last observations.
fn gather_steps(fragments: &[Fragment], spec: &ModelSpec, sel: &[(usize, usize)]) -> NetBatch {
    let (t, rows) = (fragments[0].len, sel.len());
    let (d, h, w) = (spec.obs_dim, spec.heads, spec.logits_dim());
    let n = t * rows;
    let mut b = NetBatch {
        t,
        rows,
        obs_dim: d,
        heads: h,
        actions_per_head: spec.actions,
        obs: Vec::with_capacity(n * d),
        masks: Vec::with_capacity(n * w),
        actions: Vec::with_capacity(n * h),
        behaviour_logits: Vec::with_capacity(n * w),
        rewards: Vec::with_capacity(n),
        terminated: Vec::with_capacity(n),
        truncated: Vec::with_capacity(n),
        last_obs: Vec::with_capacity(rows * d),
        ..NetBatch::default()
    };
    for s in 0..t {
        for &(fi, r) in sel {
            let f = &fragments[fi];
            let i = s * f.rows + r;
            b.obs.extend_from_slice(&f.obs[i * d..(i + 1) * d]);
            b.masks.extend_from_slice(&f.masks[i * w..(i + 1) * w]);
            b.actions.extend_from_slice(&f.actions[i * h..(i + 1) * h]);
            b.behaviour_logits
                .extend_from_slice(&f.behaviour_logits[i * w..(i + 1) * w]);
            b.rewards.push(f.rewards[i]);
            b.terminated.push(f.terminated[i] != 0);
            b.truncated.push(f.truncated[i] != 0);
        }
    }
    for &(fi, r) in sel {
        b.last_obs
            .extend_from_slice(&fragments[fi].last_obs[r * d..(r + 1) * d]);
    }
    b
}

/// The final observations of truncated steps of the selected rows, indexed
/// by their place in the batch.
fn gather_final_obs(fragments: &[Fragment], sel: &[(usize, usize)], b: &mut NetBatch) {
    let d = b.obs_dim;
    // (fragment, row) → batch row.
    let mut batch_row: Vec<Vec<Option<usize>>> =
        fragments.iter().map(|f| vec![None; f.rows]).collect();
    for (j, &(fi, r)) in sel.iter().enumerate() {
        batch_row[fi][r] = Some(j);
    }
    for (fi, f) in fragments.iter().enumerate() {
        for (q, &idx) in f.final_obs_index.iter().enumerate() {
            let (s, r) = (idx as usize / f.rows, idx as usize % f.rows);
            if let Some(j) = batch_row[fi][r] {
                b.final_index.push(s * b.rows + j);
                b.final_obs
                    .extend_from_slice(&f.final_obs[q * d..(q + 1) * d]);
            }
        }
    }
}

/// The recurrent state before step 0 of the selected rows.
fn gather_initial_state(
    fragments: &[Fragment],
    sel: &[(usize, usize)],
    cells: usize,
    heads: usize,
) -> Result<RecurrentState> {
    let mut st = RecurrentState::new(sel.len(), cells, heads);
    for (j, &(fi, r)) in sel.iter().enumerate() {
        let src = fragments[fi]
            .initial_state
            .as_ref()
            .ok_or_else(|| AlgoError::Batch("a fragment lacks its recurrent state".into()))?;
        check(src.cells == cells, || {
            format!("fragment LSTM has {} cells, model {cells}", src.cells)
        })?;
        st.h[j * cells..(j + 1) * cells].copy_from_slice(&src.h[r * cells..(r + 1) * cells]);
        st.c[j * cells..(j + 1) * cells].copy_from_slice(&src.c[r * cells..(r + 1) * cells]);
        st.prev_actions[j * heads..(j + 1) * heads]
            .copy_from_slice(&src.prev_actions[r * heads..(r + 1) * heads]);
        st.prev_rewards[j] = src.prev_rewards[r];
    }
    Ok(st)
}

/// Recurrent inputs of a batch as tensors.
#[derive(Debug, Clone)]
pub struct RecurrentTensors {
    /// Previous action one-hot per step, `[T·R, heads·A]`.
    pub prev_action: Tensor,
    /// Previous reward per step, `[T·R, 1]`.
    pub prev_reward: Tensor,
    /// 0 where a step starts a new episode inside the sequence, `[T·R, 1]`.
    pub keep: Tensor,
    /// LSTM state before step 0, `[R, cells]`.
    pub h0: Tensor,
    /// LSTM cell state before step 0, `[R, cells]`.
    pub c0: Tensor,
}

/// A [`NetBatch`] as tensors (all time-major, flattened `[T·R, …]`).
#[derive(Debug, Clone)]
pub struct BatchTensors {
    /// Steps.
    pub t: usize,
    /// Rows.
    pub rows: usize,
    /// Heads.
    pub heads: usize,
    /// `[T·R, obs_dim]`.
    pub obs: Tensor,
    /// Additive action mask, `[T·R, heads·A]`.
    pub mask_bias: Tensor,
    /// Actions, u32 `[T·R, heads]`.
    pub actions: Tensor,
    /// Behaviour log-probabilities of all actions, `[T·R, heads, A]`.
    pub behaviour_log_probs: Tensor,
    /// Behaviour joint log-prob of the action taken, `[T·R]`.
    pub behaviour_logp: Tensor,
    /// Recurrent inputs, if the net is recurrent.
    pub recurrent: Option<RecurrentTensors>,
}

impl BatchTensors {
    /// Converts a batch; behaviour log-probs come from the stored logits
    /// with the same masking as the learner's own.
    pub fn new(b: &NetBatch, device: &Device) -> Result<Self> {
        let n = b.len();
        let w = b.heads * b.actions_per_head;
        let mask_bias = dist::mask_bias(&b.masks, n, w, device)?;
        let logits = Tensor::from_slice(&b.behaviour_logits, (n, w), device)?;
        let actions: Vec<u32> = b.actions.iter().map(|&a| a as u32).collect();
        let actions = Tensor::from_vec(actions, (n, b.heads), device)?;
        let (behaviour_log_probs, behaviour_logp) =
            masked_policy(&logits, &mask_bias, b.heads, &actions)?;
        let recurrent = match &b.initial_state {
            None => None,
            Some(st) => Some(recurrent_inputs(b, st, device)?),
        };
        Ok(Self {
            t: b.t,
            rows: b.rows,
            heads: b.heads,
            obs: Tensor::from_slice(&b.obs, (n, b.obs_dim), device)?,
            mask_bias,
            actions,
            behaviour_log_probs,
            behaviour_logp,
            recurrent,
        })
    }

    /// A policy's view of this batch from its `logits [T·R, heads·A]`:
    /// the log-probabilities of all actions under the batch's masks,
    /// `[T·R, heads, A]`, and the joint log-prob of the actions taken,
    /// `[T·R]`.
    pub fn log_probs(&self, logits: &Tensor) -> Result<(Tensor, Tensor)> {
        masked_policy(logits, &self.mask_bias, self.heads, &self.actions)
    }

    /// Mean `KL(behaviour ‖ current)` over the batch, for the current
    /// policy's log-probabilities `lp_all` (as [`Self::log_probs`] gives
    /// them).
    pub fn kl_from_behaviour(&self, lp_all: &Tensor) -> Result<Tensor> {
        Ok(dist::kl(&self.behaviour_log_probs, lp_all)?.mean_all()?)
    }

    /// Runs a recurrent `net` over this batch's sequences (truncated BPTT
    /// every `max_seq_len` steps).
    pub fn unroll(
        &self,
        net: &Net,
        rc: &RecurrentTensors,
        max_seq_len: usize,
    ) -> Result<buridan_policy::net::UnrollOutput> {
        Ok(net.unroll(
            &self.obs,
            &rc.prev_action,
            &rc.prev_reward,
            &rc.keep,
            &rc.h0,
            &rc.c0,
            self.t,
            max_seq_len,
        )?)
    }

    /// The samples at flat indices `idx` (feed-forward minibatches).
    pub fn select_samples(&self, idx: &Tensor) -> Result<Self> {
        check(self.recurrent.is_none(), || {
            "sample selection on a recurrent batch".into()
        })?;
        Ok(Self {
            t: 1,
            rows: idx.elem_count(),
            heads: self.heads,
            obs: self.obs.index_select(idx, 0)?,
            mask_bias: self.mask_bias.index_select(idx, 0)?,
            actions: self.actions.index_select(idx, 0)?,
            behaviour_log_probs: self.behaviour_log_probs.index_select(idx, 0)?,
            behaviour_logp: self.behaviour_logp.index_select(idx, 0)?,
            recurrent: None,
        })
    }

    /// Whole sequences of rows `rows` (recurrent minibatches); the result
    /// stays time-major.
    pub fn select_rows(&self, rows: &Tensor) -> Result<Self> {
        let (t, r) = (self.t, self.rows);
        let sel = |x: &Tensor| Self::select_rows_of(x, t, r, rows);
        let recurrent = match &self.recurrent {
            None => None,
            Some(rc) => Some(RecurrentTensors {
                prev_action: sel(&rc.prev_action)?,
                prev_reward: sel(&rc.prev_reward)?,
                keep: sel(&rc.keep)?,
                h0: rc.h0.index_select(rows, 0)?,
                c0: rc.c0.index_select(rows, 0)?,
            }),
        };
        Ok(Self {
            t,
            rows: rows.elem_count(),
            heads: self.heads,
            obs: sel(&self.obs)?,
            mask_bias: sel(&self.mask_bias)?,
            actions: sel(&self.actions)?,
            behaviour_log_probs: sel(&self.behaviour_log_probs)?,
            behaviour_logp: sel(&self.behaviour_logp)?,
            recurrent,
        })
    }

    /// Picks `x` (a `[T·R, …]` tensor aligned with this batch's source) the
    /// same way as [`Self::select_rows`].
    pub fn select_rows_of(x: &Tensor, t: usize, r: usize, rows: &Tensor) -> Result<Tensor> {
        let dims = x.dims().to_vec();
        let mut shape = vec![t, r];
        shape.extend_from_slice(&dims[1..]);
        let y = x.reshape(shape)?.index_select(rows, 1)?;
        let mut flat = vec![t * rows.elem_count()];
        flat.extend_from_slice(&dims[1..]);
        Ok(y.reshape(flat)?)
    }
}

/// Log-probabilities of all actions, `[N, heads, A]`, of `logits [N,
/// heads·A]` masked by `mask_bias`, and the joint log-prob of `actions`,
/// `[N]`.
fn masked_policy(
    logits: &Tensor,
    mask_bias: &Tensor,
    heads: usize,
    actions: &Tensor,
) -> Result<(Tensor, Tensor)> {
    let lp_all = dist::masked_log_probs(logits, mask_bias, heads)?;
    let logp = dist::joint_log_prob(&lp_all, actions)?;
    Ok((lp_all, logp))
}

fn recurrent_inputs(
    b: &NetBatch,
    st: &RecurrentState,
    device: &Device,
) -> Result<RecurrentTensors> {
    let (t, r, h, na) = (b.t, b.rows, b.heads, b.actions_per_head);
    let w = h * na;
    let mut prev_actions = vec![NO_ACTION; t * r * h];
    let mut prev_rewards = vec![0.0f32; t * r];
    let mut keep = vec![1.0f32; t * r];
    for j in 0..r {
        prev_actions[j * h..(j + 1) * h].copy_from_slice(&st.prev_actions[j * h..(j + 1) * h]);
        prev_rewards[j] = st.prev_rewards[j];
    }
    for s in 1..t {
        for j in 0..r {
            let prev = (s - 1) * r + j;
            let k = s * r + j;
            if b.terminated[prev] || b.truncated[prev] {
                keep[k] = 0.0;
            } else {
                prev_actions[k * h..(k + 1) * h]
                    .copy_from_slice(&b.actions[prev * h..(prev + 1) * h]);
                prev_rewards[k] = b.rewards[prev];
            }
        }
    }
    let mut onehot = Vec::new();
    one_hot_prev(&prev_actions, na, &mut onehot);
    Ok(RecurrentTensors {
        prev_action: Tensor::from_vec(onehot, (t * r, w), device)?,
        prev_reward: Tensor::from_vec(prev_rewards, (t * r, 1), device)?,
        keep: Tensor::from_vec(keep, (t * r, 1), device)?,
        h0: Tensor::from_slice(&st.h, (r, st.cells), device)?,
        c0: Tensor::from_slice(&st.c, (r, st.cells), device)?,
    })
}

/// Logits and values of a batch under the current weights, plus the
/// bootstrap values `V(s_{t+1})` in [`crate::algo::gae`]'s convention.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// Raw logits `[T·R, heads·A]` (with gradient).
    pub logits: Tensor,
    /// Values `[T·R]` (with gradient).
    pub values: Tensor,
    /// `V(s_t)`, detached, `[T·R]`.
    pub values_vec: Vec<f32>,
    /// `V(s_{t+1})`, detached, `[T·R]`.
    pub next_values: Vec<f32>,
}

impl Evaluation {
    /// The trajectory GAE and V-trace read: batch `b`'s rewards and flags
    /// with these values.
    pub fn trajectory<'a>(&'a self, b: &'a NetBatch) -> Trajectory<'a> {
        Trajectory {
            t_len: b.t,
            rows: b.rows,
            rewards: &b.rewards,
            values: &self.values_vec,
            next_values: &self.next_values,
            terminated: &b.terminated,
            truncated: &b.truncated,
        }
    }
}

/// Runs a net over a whole batch (feed-forward or unrolled), with the
/// bootstrap observations (last and final) in the same pass.
pub fn evaluate(
    net: &Net,
    b: &NetBatch,
    bt: &BatchTensors,
    max_seq_len: usize,
    device: &Device,
) -> Result<Evaluation> {
    let (t, r, d) = (b.t, b.rows, b.obs_dim);
    let n = t * r;
    let k = b.final_index.len();
    let (logits, values, last_v, final_v) = match &bt.recurrent {
        None => {
            let mut parts = vec![bt.obs.clone()];
            parts.push(Tensor::from_slice(&b.last_obs, (r, d), device)?);
            if k > 0 {
                parts.push(Tensor::from_slice(&b.final_obs, (k, d), device)?);
            }
            let all = Tensor::cat(&parts, 0)?;
            let out = net.forward(&all)?;
            let v: Vec<f32> = out.value.detach().to_vec1()?;
            let logits = out.logits.narrow(0, 0, n)?;
            let values = out.value.narrow(0, 0, n)?;
            (logits, values, v[n..n + r].to_vec(), v[n + r..].to_vec())
        }
        Some(rc) => {
            let un = bt.unroll(net, rc, max_seq_len)?;
            let (na, h) = (b.actions_per_head, b.heads);
            let w = h * na;
            // Bootstrap of the fragment end: state after T−1, inputs a_{T−1}, r_{T−1}.
            let (hl, cl) = un.states[t - 1].clone();
            let last_idx: Vec<usize> = ((t - 1) * r..t * r).collect();
            let (pa, pr) = prev_inputs_of(b, &last_idx, w, device)?;
            let last_out = net.step(
                &Tensor::from_slice(&b.last_obs, (r, d), device)?,
                &buridan_policy::RecurrentInput {
                    prev_action: pa,
                    prev_reward: pr,
                    h: hl.detach(),
                    c: cl.detach(),
                },
            )?;
            let last_v: Vec<f32> = last_out.0.value.detach().to_vec1()?;
            let final_v = if k > 0 {
                let mut hs = Vec::with_capacity(k);
                let mut cs = Vec::with_capacity(k);
                for &idx in &b.final_index {
                    let (s, j) = (idx / r, idx % r);
                    hs.push(un.states[s].0.narrow(0, j, 1)?.detach());
                    cs.push(un.states[s].1.narrow(0, j, 1)?.detach());
                }
                let (pa, pr) = prev_inputs_of(b, &b.final_index, w, device)?;
                let out = net.step(
                    &Tensor::from_slice(&b.final_obs, (k, d), device)?,
                    &buridan_policy::RecurrentInput {
                        prev_action: pa,
                        prev_reward: pr,
                        h: Tensor::cat(&hs, 0)?,
                        c: Tensor::cat(&cs, 0)?,
                    },
                )?;
                out.0.value.detach().to_vec1()?
            } else {
                Vec::new()
            };
            (un.logits, un.value, last_v, final_v)
        }
    };
    let values_vec: Vec<f32> = values.detach().to_vec1()?;
    // V(s_{t+1}): the next step's value inside the fragment, the bootstrap
    // value of the last observation at its end.
    let mut next_values = Vec::with_capacity(n);
    next_values.extend_from_slice(&values_vec[r.min(n)..]);
    next_values.extend_from_slice(&last_v);
    for (q, &idx) in b.final_index.iter().enumerate() {
        next_values[idx] = final_v[q];
    }
    Ok(Evaluation {
        logits,
        values,
        values_vec,
        next_values,
    })
}

/// One-hot actions and rewards of the given flat steps (inputs of the step after them).
fn prev_inputs_of(
    b: &NetBatch,
    idx: &[usize],
    w: usize,
    device: &Device,
) -> Result<(Tensor, Tensor)> {
    let h = b.heads;
    let mut acts = Vec::with_capacity(idx.len() * h);
    let mut rews = Vec::with_capacity(idx.len());
    for &i in idx {
        acts.extend_from_slice(&b.actions[i * h..(i + 1) * h]);
        rews.push(b.rewards[i]);
    }
    let mut onehot = Vec::new();
    one_hot_prev(&acts, b.actions_per_head, &mut onehot);
    Ok((
        Tensor::from_vec(onehot, (idx.len(), w), device)?,
        Tensor::from_vec(rews, (idx.len(), 1), device)?,
    ))
}
