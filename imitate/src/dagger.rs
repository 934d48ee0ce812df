//! DAgger (Ross, Gordon & Bagnell, AISTATS 2011): imitation with on-policy
//! correction.
//!
//! Behaviour cloning alone trains on the states the expert visits; the
//! learned policy then drifts into states the expert never showed it — for
//! us, the standoffs of symmetric agents — and has no idea how to leave
//! them. DAgger asks the expert about the states the *policy* visits:
//!
//! ```text
//! D ← ∅
//! for round k = 0 .. K−1:
//!     roll out π_k      (round 0: the expert itself;
//!                        later: the policy, the expert with probability β)
//!     D ← D ∪ {(o, a*(s)) for every visited state s, every agent}
//!     π_{k+1} ← argmin_π  −Σ_D log π(a* | o)     (behaviour cloning on D)
//! ```
//!
//! The expert `a*(s)` is a planner's next joint step from `s`
//! ([`crate::expert`]); states it cannot solve in time get no label. Every
//! agent's observation is the one the policy sees in training and
//! execution, so the trained network is an ordinary checkpoint.

use buridan_env::{EnvSlot, VecEnv};
use buridan_policy::{ActMode, Inference, Policy};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cloning::Cloner;
use crate::config::{ImitationConfig, Rollout};
use crate::dataset::Dataset;
use crate::error::ImitationError;
use crate::expert::Expert;

/// What one DAgger round did.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoundReport {
    /// Round index (0: the expert's rollouts).
    pub round: usize,
    /// Env steps collected in this round.
    pub env_steps: u64,
    /// Labelled rows held after the round.
    pub rows: usize,
    /// Planner calls in this round.
    pub expert_calls: u64,
    /// Planner calls of this round that found no plan in time.
    pub expert_failures: u64,
    /// Episodes finished in this round's rollouts.
    pub episodes: usize,
    /// Their success rate (the rolled-out controller's, before this round's fit).
    pub success_rate: f64,
    /// Cloning loss after the round's fit.
    pub loss: f64,
    /// Agreement with the expert after the round's fit.
    pub accuracy: f64,
    /// Wall seconds of the round.
    pub seconds: f64,
}

/// Trains `policy` in place by DAgger on the envs of `venv` (local
/// observations, one row per agent); calls `on_round` after every round.
///
/// The policy must be feed-forward with one shared network and one action
/// head (CTDE); the env's observations must be the ones the policy was
/// built for.
pub fn dagger<S: EnvSlot>(
    cfg: &ImitationConfig,
    policy: &Policy,
    venv: &mut VecEnv<S>,
    seed: u64,
    on_round: &mut dyn FnMut(&RoundReport),
) -> Result<Vec<RoundReport>, ImitationError> {
    cfg.validate()?;
    let spec = policy.spec();
    if spec.lstm.is_some() || policy.nets().len() != 1 || spec.heads != 1 {
        return Err(ImitationError::Unsupported {
            needed: "a feed-forward policy shared by all agents (CTDE)",
            found: format!(
                "{} ({} networks, {} heads{})",
                spec.mode,
                policy.nets().len(),
                spec.heads,
                if spec.lstm.is_some() { ", LSTM" } else { "" }
            ),
        });
    }
    if venv.obs_dim() != spec.obs_dim || venv.mask_dim() != spec.logits_dim() {
        return Err(ImitationError::Unsupported {
            needed: "the env's observations of the policy",
            found: format!(
                "built for {} inputs and {} mask entries, the env gives {} and {}",
                spec.obs_dim,
                spec.logits_dim(),
                venv.obs_dim(),
                venv.mask_dim()
            ),
        });
    }
    let (n, envs) = (venv.agents(), venv.num_envs());
    let (d, w) = (venv.obs_dim(), venv.mask_dim());
    let rows = n * envs;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut expert = Expert::new(cfg);
    let mut data = Dataset::new(d, w, cfg.max_rows);
    let mut cloner = Cloner::new(policy, cfg.lr, cfg.minibatch)?;
    let mut reports = Vec::with_capacity(cfg.rounds);
    let mode = match cfg.rollout {
        Rollout::Greedy => ActMode::Greedy,
        Rollout::Sampled => ActMode::Sample,
    };
    let (mut actions, mut policy_actions, mut logp) =
        (vec![0u8; rows], vec![0u8; rows], vec![0f32; rows]);
    venv.drain_episodes();
    for round in 0..cfg.rounds {
        let t0 = std::time::Instant::now();
        let (calls0, failures0) = (expert.calls, expert.failures);
        let mut actor = if round == 0 {
            None
        } else {
            let copy = Policy::new(spec.clone(), seed)?;
            copy.copy_from(policy)?;
            Some(Inference::new(copy, rows, rng.random()))
        };
        let mut steps = 0u64;
        while steps < cfg.steps_per_round {
            if let Some(actor) = actor.as_mut() {
                actor.act(
                    venv.obs(),
                    venv.masks(),
                    mode,
                    &mut policy_actions,
                    &mut logp,
                )?;
            }
            for e in 0..envs {
                let lo = e * n;
                let labels = expert.label(venv.envs()[e].env());
                if let Some(l) = labels {
                    for a in 0..n {
                        let r = lo + a;
                        data.push(
                            &venv.obs()[r * d..(r + 1) * d],
                            &venv.masks()[r * w..(r + 1) * w],
                            l.policy[a],
                            &mut rng,
                        );
                    }
                }
                let follow_expert = actor.is_none() || rng.random_bool(cfg.beta);
                let chosen = &mut actions[lo..lo + n];
                match (labels, follow_expert) {
                    (Some(l), true) => chosen.copy_from_slice(&l.plan),
                    // Round 0 without a plan: wait (the episode truncates).
                    _ if actor.is_none() => chosen.fill(0),
                    _ => chosen.copy_from_slice(&policy_actions[lo..lo + n]),
                }
            }
            venv.step(&actions)?;
            steps += envs as u64;
        }
        let episodes = venv.drain_episodes();
        let success_rate = if episodes.is_empty() {
            f64::NAN
        } else {
            episodes.iter().filter(|e| e.success).count() as f64 / episodes.len() as f64
        };
        let fit = cloner.fit(policy, &data, cfg.epochs, &mut rng)?;
        let report = RoundReport {
            round,
            env_steps: steps,
            rows: data.len(),
            expert_calls: expert.calls - calls0,
            expert_failures: expert.failures - failures0,
            episodes: episodes.len(),
            success_rate,
            loss: fit.loss,
            accuracy: fit.accuracy,
            seconds: t0.elapsed().as_secs_f64(),
        };
        tracing::info!(
            round,
            rows = report.rows,
            expert_calls = report.expert_calls,
            expert_failures = report.expert_failures,
            success = report.success_rate,
            loss = report.loss,
            accuracy = report.accuracy,
            seconds = report.seconds,
            "imitation round"
        );
        on_round(&report);
        reports.push(report);
    }
    Ok(reports)
}
