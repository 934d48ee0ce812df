//! Trajectory fragments: what an actor sends to the learner.
//!
//! A [`Fragment`] holds `T` consecutive steps of `B` rows (a row is one
//! agent of one env for local observations, one env for central ones; rows
//! are env-major). All buffers are plain, time-major `Vec`s with their shape
//! in the fields, so the type can be carried over the wire as is.

use buridan_env::EpisodeStats;
use serde::{Deserialize, Serialize};

use crate::error::PolicyError;
use crate::infer::RecurrentState;

/// Default rollout fragment length (SPEC §4).
pub const DEFAULT_FRAGMENT_LEN: usize = 50;

/// `T` steps of `B` rows of experience collected with one policy version.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Fragment {
    /// Which actor produced it.
    pub actor: u32,
    /// Policy version the actions were sampled with.
    pub policy_version: u64,
    /// Steps `T`.
    pub len: usize,
    /// Rows `B`.
    pub rows: usize,
    /// Rows per env (agents for local observations, 1 for central).
    pub rows_per_env: usize,
    /// Floats per observation.
    pub obs_dim: usize,
    /// Heads per row.
    pub heads: usize,
    /// Actions per head.
    pub actions_per_head: usize,
    /// Observations acted on, `[T, B, obs_dim]`.
    pub obs: Vec<f32>,
    /// Action masks, `[T, B, heads·actions_per_head]`.
    pub masks: Vec<u8>,
    /// Actions taken, `[T, B, heads]`.
    pub actions: Vec<u8>,
    /// Behaviour policy's raw logits, `[T, B, heads·actions_per_head]`.
    pub behaviour_logits: Vec<f32>,
    /// Behaviour policy's joint log-prob of the action taken, `[T, B]`.
    pub behaviour_logp: Vec<f32>,
    /// Rewards `[T, B]` (per agent for local rows, summed over agents for central rows).
    pub rewards: Vec<f32>,
    /// 1 where the episode terminated (success) with this step, `[T, B]`.
    pub terminated: Vec<u8>,
    /// 1 where the episode was truncated with this step, `[T, B]`.
    pub truncated: Vec<u8>,
    /// For each truncated `(t, row)`, in increasing `t·B + row` order: the
    /// final observation (to bootstrap its value), `[K, obs_dim]`.
    pub final_obs: Vec<f32>,
    /// `t·B + row` of each `final_obs` row.
    pub final_obs_index: Vec<u32>,
    /// Observation after the last step, `[B, obs_dim]` (bootstrap of the
    /// fragment end; meaningless for rows whose episode ended at `T−1`).
    pub last_obs: Vec<f32>,
    /// Recurrent state before step 0, if the policy is recurrent.
    pub initial_state: Option<RecurrentState>,
    /// Episodes that finished during the fragment.
    pub episodes: Vec<EpisodeStats>,
    /// Vectorised env steps in the fragment: `T · envs`.
    pub env_steps: u64,
}

impl Fragment {
    /// An empty fragment with buffers sized for `len` steps.
    #[allow(clippy::too_many_arguments)]
    pub fn with_capacity(
        actor: u32,
        policy_version: u64,
        len: usize,
        rows: usize,
        rows_per_env: usize,
        obs_dim: usize,
        heads: usize,
        actions_per_head: usize,
    ) -> Self {
        let w = heads * actions_per_head;
        Self {
            actor,
            policy_version,
            len: 0,
            rows,
            rows_per_env,
            obs_dim,
            heads,
            actions_per_head,
            obs: Vec::with_capacity(len * rows * obs_dim),
            masks: Vec::with_capacity(len * rows * w),
            actions: Vec::with_capacity(len * rows * heads),
            behaviour_logits: Vec::with_capacity(len * rows * w),
            behaviour_logp: Vec::with_capacity(len * rows),
            rewards: Vec::with_capacity(len * rows),
            terminated: Vec::with_capacity(len * rows),
            truncated: Vec::with_capacity(len * rows),
            final_obs: Vec::new(),
            final_obs_index: Vec::new(),
            last_obs: Vec::with_capacity(rows * obs_dim),
            initial_state: None,
            episodes: Vec::new(),
            env_steps: 0,
        }
    }

    /// Envs in the fragment.
    pub fn envs(&self) -> usize {
        self.rows / self.rows_per_env.max(1)
    }

    /// Whether row `r`'s episode ended (terminated or truncated) at step `t`.
    pub fn done(&self, t: usize, r: usize) -> bool {
        let k = t * self.rows + r;
        self.terminated[k] != 0 || self.truncated[k] != 0
    }

    /// Checks that every buffer has the length its shape fields imply.
    pub fn validate(&self) -> Result<(), PolicyError> {
        // Saturating: shapes come from the wire, and their products may not
        // fit a usize (found by proto/tests/fuzz.rs); a saturated size
        // matches no buffer, so such a shape is refused as a length error.
        let mul = |xs: &[usize]| xs.iter().fold(1usize, |n, &x| n.saturating_mul(x));
        let (t, b, d) = (self.len, self.rows, self.obs_dim);
        let w = mul(&[self.heads, self.actions_per_head]);
        let k = self.final_obs_index.len();
        let steps = mul(&[t, b]);
        for (what, expected, got) in [
            ("fragment obs", mul(&[steps, d]), self.obs.len()),
            ("fragment masks", mul(&[steps, w]), self.masks.len()),
            (
                "fragment actions",
                mul(&[steps, self.heads]),
                self.actions.len(),
            ),
            (
                "fragment logits",
                mul(&[steps, w]),
                self.behaviour_logits.len(),
            ),
            ("fragment logp", steps, self.behaviour_logp.len()),
            ("fragment rewards", steps, self.rewards.len()),
            ("fragment terminated", steps, self.terminated.len()),
            ("fragment truncated", steps, self.truncated.len()),
            ("fragment final_obs", mul(&[k, d]), self.final_obs.len()),
            ("fragment last_obs", mul(&[b, d]), self.last_obs.len()),
        ] {
            if expected != got {
                return Err(PolicyError::WrongLength {
                    what,
                    expected,
                    got,
                });
            }
        }
        let truncated = self.truncated.iter().filter(|&&x| x != 0).count();
        if truncated != k {
            return Err(PolicyError::WrongLength {
                what: "fragment final_obs_index (one per truncated step)",
                expected: truncated,
                got: k,
            });
        }
        Ok(())
    }
}
