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
//!     roll out π_k      (round 0: the expert itself, or π_0 when polishing;
//!                        later: the policy, the expert with probability β)
//!     D ← D ∪ {(o, a*(s)) for every visited state s, every agent}
//!     π_{k+1} ← argmin_π  −Σ_D log π(a* | o)     (behaviour cloning on D)
//! ```
//!
//! The expert `a*(s)` is a planner's next joint step from `s`
//! ([`crate::expert`]); states it cannot solve in time get no label. Every
//! agent's observation is the one the policy sees in training and
//! execution, so the trained network is an ordinary checkpoint.

use buridan_env::{BatchedEnv, EnvSlot, VecEnv};
use buridan_policy::infer::one_hot_prev;
use buridan_policy::{ActMode, Inference, Policy, NO_ACTION};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cloning::Cloner;
use crate::config::{ImitationConfig, Rollout};
use crate::dataset::Dataset;
use crate::error::ImitationError;
use crate::expert::Expert;
use crate::windows::{WindowStep, Windows};

/// DAgger's aggregate: labelled rows for a feed-forward policy, windows of
/// consecutive steps for a recurrent one.
enum Data {
    Rows(Dataset),
    Windows(Windows),
}

/// What one DAgger round did.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoundReport {
    /// Round index (0: the expert's rollouts, unless `expert_first` is off).
    pub round: usize,
    /// Env steps collected in this round.
    pub env_steps: u64,
    /// Labelled rows held after the round (for a recurrent policy: steps
    /// in the windows held, labelled or not).
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
/// The policy must have one network shared by all agents and one action
/// head (CTDE); the env's observations must be the ones the policy was
/// built for. A recurrent policy (LSTM) is cloned on windows of
/// consecutive steps ([`crate::windows`]): its rollouts carry the LSTM
/// state, the previous action and reward from step to step as in
/// training, also in round 0, where the expert acts and the policy only
/// watches.
pub fn dagger<S: EnvSlot>(
    cfg: &ImitationConfig,
    policy: &Policy,
    venv: &mut VecEnv<S>,
    seed: u64,
    on_round: &mut dyn FnMut(&RoundReport),
) -> Result<Vec<RoundReport>, ImitationError> {
    cfg.validate()?;
    let spec = policy.spec();
    if policy.nets().len() != 1 || spec.heads != 1 {
        return Err(ImitationError::Unsupported {
            needed: "a policy shared by all agents (CTDE)",
            found: format!(
                "{} ({} networks, {} heads)",
                spec.mode,
                policy.nets().len(),
                spec.heads,
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
    let mut data = match spec.lstm {
        None => Data::Rows(Dataset::new(d, w, cfg.max_rows)),
        Some(_) => Data::Windows(Windows::new(
            d,
            w,
            cfg.window,
            (cfg.max_rows / cfg.window).max(1),
            rows,
        )),
    };
    let mut cloner = Cloner::new(policy, cfg.lr, cfg.minibatch)?;
    let mut reports = Vec::with_capacity(cfg.rounds);
    let mode = match cfg.rollout {
        Rollout::Greedy => ActMode::Greedy,
        Rollout::Sampled => ActMode::Sample,
    };
    let (mut actions, mut policy_actions, mut logp) =
        (vec![0u8; rows], vec![0u8; rows], vec![0f32; rows]);
    let (mut row_rewards, mut row_done) = (vec![0f32; rows], vec![0u8; rows]);
    let mut prev_one_hot = Vec::new();
    let mut actor: Option<Inference> = None;
    venv.drain_episodes();
    for round in 0..cfg.rounds {
        let t0 = std::time::Instant::now();
        let (calls0, failures0) = (expert.calls, expert.failures);
        // Round 0 follows the expert (unless `expert_first` is off). A
        // recurrent policy watches it all the same, so that its state is the
        // one it would have after these steps, and keeps its memory from
        // round to round as an actor does (with new weights); a feed-forward
        // one starts afresh each round.
        let expert_only = round == 0 && cfg.expert_first;
        match actor.as_mut() {
            Some(recurrent) if spec.lstm.is_some() => recurrent.policy().copy_from(policy)?,
            _ if expert_only && spec.lstm.is_none() => {}
            _ => {
                let copy = Policy::new(spec.clone(), seed)?;
                copy.copy_from(policy)?;
                actor = Some(Inference::new(copy, rows, rng.random()));
            }
        }
        let mut steps = 0u64;
        while steps < cfg.steps_per_round {
            // The recurrent inputs of this step, before `act` advances them.
            let before = actor.as_ref().and_then(|a| a.state().cloned());
            if let Some(st) = &before {
                one_hot_prev(&st.prev_actions, spec.actions, &mut prev_one_hot);
            }
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
                for a in 0..n {
                    let r = lo + a;
                    let label = labels.map(|l| l.policy[a]);
                    let obs = &venv.obs()[r * d..(r + 1) * d];
                    let mask = &venv.masks()[r * w..(r + 1) * w];
                    match (&mut data, &before) {
                        (Data::Rows(labelled), _) => {
                            if let Some(label) = label {
                                labelled.push(obs, mask, label, &mut rng);
                            }
                        }
                        (Data::Windows(windows), Some(st)) => {
                            let k = st.cells;
                            let step = WindowStep {
                                obs,
                                mask,
                                prev_action: &prev_one_hot[r * w..(r + 1) * w],
                                prev_reward: st.prev_rewards[r],
                                // The state marks a row's episode start with
                                // "no previous action" (one head: CTDE).
                                episode_start: st.prev_actions[r] == NO_ACTION,
                                label,
                            };
                            let (h, c) = (&st.h[r * k..(r + 1) * k], &st.c[r * k..(r + 1) * k]);
                            windows.push(r, step, h, c, &mut rng);
                        }
                        // Windows are kept for a recurrent policy only,
                        // whose actor always has a state.
                        (Data::Windows(_), None) => {}
                    }
                }
                let follow_expert = expert_only || rng.random_bool(cfg.beta);
                let chosen = &mut actions[lo..lo + n];
                match (labels, follow_expert) {
                    (Some(l), true) => chosen.copy_from_slice(&l.plan),
                    // Round 0 without a plan: wait (the episode truncates).
                    _ if expert_only => chosen.fill(0),
                    _ => chosen.copy_from_slice(&policy_actions[lo..lo + n]),
                }
            }
            venv.step(&actions)?;
            if let Some(st) = actor.as_mut().and_then(|a| a.state_mut()) {
                // The actions taken, the expert's or the policy's, are the
                // ones the LSTM sees as "previous".
                venv.write_row_rewards(&mut row_rewards);
                venv.write_row_done(&mut row_done);
                st.observe(&actions, &row_rewards, &row_done);
            }
            steps += envs as u64;
        }
        let episodes = venv.drain_episodes();
        let success_rate = if episodes.is_empty() {
            f64::NAN
        } else {
            episodes.iter().filter(|e| e.success).count() as f64 / episodes.len() as f64
        };
        let (fit, held) = match &data {
            Data::Rows(labelled) => (
                cloner.fit(policy, labelled, cfg.epochs, &mut rng)?,
                labelled.len(),
            ),
            Data::Windows(windows) => (
                cloner.fit_windows(policy, windows, cfg.epochs, &mut rng)?,
                windows.len() * windows.steps(),
            ),
        };
        let report = RoundReport {
            round,
            env_steps: steps,
            rows: held,
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
