//! Actor-side inference: observations and masks in flat buffers in, actions,
//! log-probabilities and raw logits out, with the LSTM state and previous
//! action/reward kept per row.

use candle_core::Tensor;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::dist::{greedy_head, greedy_mix_head, sample_head};
use crate::error::PolicyError;
use crate::net::RecurrentInput;
use crate::policy::Policy;

/// "No previous action" (episode start) in [`RecurrentState::prev_actions`].
pub const NO_ACTION: u8 = u8::MAX;

/// How actions are chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ActMode {
    /// Sample from the masked softmax (training rollouts).
    Sample,
    /// The most probable legal action (evaluation).
    Greedy,
    /// Training rollouts that rehearse greedy execution: with probability
    /// `g` the most probable legal action, else a sample, so the policy meets
    /// the standoffs its greedy actions run into. The behaviour distribution
    /// is `(1 − g)·π + g·δ_greedy`; [`Inference::act`] returns its
    /// log-probabilities in place of the logits, so an off-policy learner
    /// (IMPALA's V-trace) corrects for it exactly
    /// ([`crate::dist::greedy_mix_head`]).
    GreedyMix(f32),
}

impl ActMode {
    /// Rollouts with greedy steps at rate `greedy_mix`: plain sampling at 0.
    ///
    /// ```
    /// use buridan_policy::ActMode;
    /// assert_eq!(ActMode::rollout(0.0), ActMode::Sample);
    /// assert_eq!(ActMode::rollout(0.5).greedy_mix(), 0.5);
    /// ```
    pub fn rollout(greedy_mix: f32) -> Self {
        if greedy_mix > 0.0 {
            ActMode::GreedyMix(greedy_mix)
        } else {
            ActMode::Sample
        }
    }

    /// The rate of greedy steps of a rollout mode (0 unless
    /// [`ActMode::GreedyMix`]): the inverse of [`ActMode::rollout`].
    pub fn greedy_mix(self) -> f32 {
        match self {
            ActMode::GreedyMix(g) => g,
            _ => 0.0,
        }
    }
}

/// Per-row recurrent state: LSTM `(h, c)` and the previous action and
/// reward, all zero/[`NO_ACTION`] at an episode start.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecurrentState {
    /// Rows.
    pub rows: usize,
    /// LSTM cells.
    pub cells: usize,
    /// Heads per row.
    pub heads: usize,
    /// Hidden state `[rows, cells]`.
    pub h: Vec<f32>,
    /// Cell state `[rows, cells]`.
    pub c: Vec<f32>,
    /// Previous actions `[rows, heads]`, [`NO_ACTION`] at an episode start.
    pub prev_actions: Vec<u8>,
    /// Previous rewards `[rows]`.
    pub prev_rewards: Vec<f32>,
}

impl RecurrentState {
    /// A zero state for `rows` rows.
    pub fn new(rows: usize, cells: usize, heads: usize) -> Self {
        Self {
            rows,
            cells,
            heads,
            h: vec![0.0; rows * cells],
            c: vec![0.0; rows * cells],
            prev_actions: vec![NO_ACTION; rows * heads],
            prev_rewards: vec![0.0; rows],
        }
    }

    /// Resets row `r` to the episode-start state.
    pub fn reset_row(&mut self, r: usize) {
        let k = self.cells;
        self.h[r * k..(r + 1) * k].fill(0.0);
        self.c[r * k..(r + 1) * k].fill(0.0);
        self.prev_actions[r * self.heads..(r + 1) * self.heads].fill(NO_ACTION);
        self.prev_rewards[r] = 0.0;
    }

    /// After an env step: remembers `actions [rows, heads]` and `rewards
    /// [rows]` as the previous ones, and resets rows whose episode ended
    /// (`done[r] != 0`).
    pub fn observe(&mut self, actions: &[u8], rewards: &[f32], done: &[u8]) {
        self.prev_actions.copy_from_slice(actions);
        self.prev_rewards.copy_from_slice(rewards);
        for (r, &d) in done.iter().enumerate() {
            if d != 0 {
                self.reset_row(r);
            }
        }
    }
}

/// One-hot encoding of previous actions `[rows, heads]` (flat) into
/// `[rows, heads·actions]`: each action gets `actions` slots, so the head
/// count is implied by the buffer (zeros for [`NO_ACTION`]).
///
/// ```
/// use buridan_policy::infer::{one_hot_prev, NO_ACTION};
/// let mut out = Vec::new();
/// one_hot_prev(&[2, NO_ACTION], 3, &mut out);
/// assert_eq!(out, vec![0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
/// ```
pub fn one_hot_prev(prev: &[u8], actions: usize, out: &mut Vec<f32>) {
    out.clear();
    out.resize(prev.len() * actions, 0.0);
    for (k, &a) in prev.iter().enumerate() {
        if a != NO_ACTION {
            out[k * actions + a as usize] = 1.0;
        }
    }
}

/// A policy plus the buffers and RNG of one actor.
///
/// ```
/// use buridan_policy::{ActMode, Inference, ModelSpec, Mode, Policy};
/// let policy = Policy::new(ModelSpec::new(Mode::Ctde, 2, 4), 0).unwrap();
/// let mut inf = Inference::new(policy, 2, 1);
/// let obs = [0.0f32; 8];
/// let masks = [1, 0, 0, 0, 0, 1, 1, 1, 1, 1];
/// let (mut actions, mut logp) = ([0u8; 2], [0f32; 2]);
/// inf.act(&obs, &masks, ActMode::Sample, &mut actions, &mut logp).unwrap();
/// assert_eq!(actions[0], 0); // only "stay" is legal for row 0
/// assert!(logp[0].abs() < 1e-6);
/// ```
pub struct Inference {
    policy: Policy,
    rows: usize,
    rng: ChaCha8Rng,
    logits: Vec<f32>,
    state: Option<RecurrentState>,
    scratch_obs: Vec<f32>,
    scratch_a: Vec<f32>,
    scratch_r: Vec<f32>,
    scratch_h: Vec<f32>,
    scratch_c: Vec<f32>,
    row_index: Vec<Vec<usize>>,
}

impl Inference {
    /// Inference for batches of `rows` observation rows, sampling with a
    /// RNG seeded by `seed`.
    pub fn new(policy: Policy, rows: usize, seed: u64) -> Self {
        let spec = policy.spec().clone();
        let state = spec
            .lstm
            .map(|l| RecurrentState::new(rows, l.cells, spec.heads));
        let nets = spec.nets();
        let mut row_index = vec![Vec::new(); nets];
        for r in 0..rows {
            row_index[spec.net_of_row(r)].push(r);
        }
        Self {
            rows,
            rng: ChaCha8Rng::seed_from_u64(seed),
            logits: vec![0.0; rows * spec.logits_dim()],
            state,
            scratch_obs: Vec::new(),
            scratch_a: Vec::new(),
            scratch_r: Vec::new(),
            scratch_h: Vec::new(),
            scratch_c: Vec::new(),
            row_index,
            policy,
        }
    }

    /// The policy (e.g. to load new weights with [`Policy::set_weights`]).
    pub fn policy(&self) -> &Policy {
        &self.policy
    }

    /// Rows per batch.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The recurrent state, if the policy has an LSTM.
    pub fn state(&self) -> Option<&RecurrentState> {
        self.state.as_ref()
    }

    /// Mutable recurrent state (to call [`RecurrentState::observe`] after a step).
    pub fn state_mut(&mut self) -> Option<&mut RecurrentState> {
        self.state.as_mut()
    }

    /// Chooses actions for all rows: `obs [rows, obs_dim]`, `masks [rows,
    /// heads·5]`; writes `actions [rows, heads]` and the joint log-prob
    /// `logp [rows]`, and returns the logits `[rows, heads·5]` of the
    /// distribution the actions came from (the net's raw logits, except
    /// under [`ActMode::GreedyMix`]). For a
    /// recurrent policy the LSTM state advances (call
    /// [`RecurrentState::observe`] after the env step).
    pub fn act(
        &mut self,
        obs: &[f32],
        masks: &[u8],
        mode: ActMode,
        actions: &mut [u8],
        logp: &mut [f32],
    ) -> Result<&[f32], PolicyError> {
        let spec = self.policy.spec();
        let (rows, d, w, heads, na) = (
            self.rows,
            spec.obs_dim,
            spec.logits_dim(),
            spec.heads,
            spec.actions,
        );
        for (what, expected, got) in [
            ("observations", rows * d, obs.len()),
            ("masks", rows * w, masks.len()),
            ("actions", rows * heads, actions.len()),
            ("log-probs", rows, logp.len()),
        ] {
            if expected != got {
                return Err(PolicyError::WrongLength {
                    what,
                    expected,
                    got,
                });
            }
        }
        self.compute_logits(obs)?;
        for r in 0..rows {
            let mut total = 0.0;
            for h in 0..heads {
                let lo = r * w + h * na;
                let l = &mut self.logits[lo..lo + na];
                let m = &masks[lo..lo + na];
                let (a, lp) = match mode {
                    ActMode::Sample => sample_head(l, m, &mut self.rng),
                    ActMode::Greedy => greedy_head(l, m),
                    ActMode::GreedyMix(g) => greedy_mix_head(l, m, g, &mut self.rng),
                }
                .ok_or(PolicyError::EmptyMask { row: r, head: h })?;
                actions[r * heads + h] = a;
                total += lp;
            }
            logp[r] = total;
        }
        Ok(&self.logits)
    }

    fn compute_logits(&mut self, obs: &[f32]) -> Result<(), PolicyError> {
        let spec = self.policy.spec().clone();
        let d = spec.obs_dim;
        let w = spec.logits_dim();
        let dev = self.policy.device().clone();
        let nets = spec.nets();
        for k in 0..nets {
            let idx = &self.row_index[k];
            let n = idx.len();
            if n == 0 {
                continue;
            }
            let obs_t = if nets == 1 {
                Tensor::from_slice(obs, (n, d), &dev)?
            } else {
                self.scratch_obs.clear();
                for &r in idx {
                    self.scratch_obs.extend_from_slice(&obs[r * d..(r + 1) * d]);
                }
                Tensor::from_slice(&self.scratch_obs, (n, d), &dev)?
            };
            let net = self.policy.net(k);
            let logits = if let Some(st) = &mut self.state {
                let cells = st.cells;
                self.scratch_h.clear();
                self.scratch_c.clear();
                self.scratch_r.clear();
                let mut prev = Vec::with_capacity(n * spec.heads);
                for &r in idx {
                    self.scratch_h
                        .extend_from_slice(&st.h[r * cells..(r + 1) * cells]);
                    self.scratch_c
                        .extend_from_slice(&st.c[r * cells..(r + 1) * cells]);
                    self.scratch_r.push(st.prev_rewards[r]);
                    prev.extend_from_slice(&st.prev_actions[r * spec.heads..(r + 1) * spec.heads]);
                }
                one_hot_prev(&prev, spec.actions, &mut self.scratch_a);
                let input = RecurrentInput {
                    prev_action: Tensor::from_slice(&self.scratch_a, (n, w), &dev)?,
                    prev_reward: Tensor::from_slice(&self.scratch_r, (n, 1), &dev)?,
                    h: Tensor::from_slice(&self.scratch_h, (n, cells), &dev)?,
                    c: Tensor::from_slice(&self.scratch_c, (n, cells), &dev)?,
                };
                let (logits, (h, c)) = net.step_logits(&obs_t, &input)?;
                let h = h.flatten_all()?.to_vec1::<f32>()?;
                let c = c.flatten_all()?.to_vec1::<f32>()?;
                for (j, &r) in idx.iter().enumerate() {
                    st.h[r * cells..(r + 1) * cells]
                        .copy_from_slice(&h[j * cells..(j + 1) * cells]);
                    st.c[r * cells..(r + 1) * cells]
                        .copy_from_slice(&c[j * cells..(j + 1) * cells]);
                }
                logits
            } else {
                net.forward_logits(&obs_t)?
            };
            let flat = logits.flatten_all()?;
            if nets == 1 {
                flat.to_vec1::<f32>()
                    .map(|v| self.logits.copy_from_slice(&v))?;
            } else {
                let v = flat.to_vec1::<f32>()?;
                for (j, &r) in idx.iter().enumerate() {
                    self.logits[r * w..(r + 1) * w].copy_from_slice(&v[j * w..(j + 1) * w]);
                }
            }
        }
        Ok(())
    }
}
