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
//! ([`crate::expert`]); states it cannot solve in time get no label. Or,
//! polishing a trained policy ([`Teacher::Shield`]), the policy's own
//! preferences in `s` through the deployment shield: `a*(s)` is the joint
//! move the shield makes of them ([`ShieldTeacher`]). Every
//! agent's observation is the one the policy sees in training and
//! execution, so the trained network is an ordinary checkpoint.

use buridan_env::{BatchedEnv, EnvSlot, VecEnv, NUM_ACTIONS};
use buridan_mapf::shield::rollout::RolloutShield;
use buridan_policy::dist::{greedy_head, sample_head};
use buridan_policy::infer::one_hot_prev;
use buridan_policy::{ActMode, Inference, Policy, NO_ACTION};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cloning::Cloner;
use crate::config::{deployment_shield, ImitationConfig, Rollout, Teacher, SHIELD_PATIENCE};
use crate::dataset::Dataset;
use crate::error::ImitationError;
use crate::expert::{Expert, Labels};
use crate::windows::{WindowStep, Windows};

/// DAgger's aggregate for one network: labelled rows for a feed-forward
/// policy, windows of consecutive steps for a recurrent one.
enum Data {
    Rows(Dataset),
    Windows(Windows),
}

impl Data {
    /// Rows held (for windows: steps in the windows held).
    fn held(&self) -> usize {
        match self {
            Data::Rows(rows) => rows.len(),
            Data::Windows(windows) => windows.len() * windows.steps(),
        }
    }
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
    /// Under [`Teacher::Shield`]: the share of this round's labels that
    /// are not the rolled-out policy's own action (the shield's
    /// overrides, before the round's fit); 0 for a planner teacher.
    #[serde(default)]
    pub overridden: f64,
    /// Wall seconds of the round.
    pub seconds: f64,
}

/// Trains `policy` in place by DAgger on the envs of `venv`; calls
/// `on_round` after every round.
///
/// Every mode learns from the expert's joint step: a CTDE policy from each
/// agent's action on that agent's row, each DTE agent's own network from
/// its own rows, CTE's joint policy from all agents' actions on the env's
/// one central row (one label per head). The env's observations must be
/// the ones the policy was built for. A recurrent policy (LSTM) is cloned
/// on windows of consecutive steps ([`crate::windows`]): its rollouts carry
/// the LSTM state, the previous action and reward from step to step as in
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
    let (d, w, heads) = (venv.obs_dim(), venv.mask_dim(), spec.heads);
    let (rows, per_env) = (venv.rows(), venv.rows_per_env());
    if per_env * heads != n {
        return Err(ImitationError::Unsupported {
            needed: "one head per agent on each env's rows",
            found: format!("{per_env} rows of {heads} heads for {n} agents"),
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut expert = Expert::new(cfg);
    let nets = policy.nets().len();
    let cap = (cfg.max_rows / nets).max(1);
    // The share of the data the shield teacher agrees with that is fitted
    // (a planner's labels are all kept).
    let agreeing_share = match cfg.teacher {
        Teacher::Shield => cfg.agreeing_share,
        Teacher::Planner => 1.0,
    };
    let mut data: Vec<Data> = (0..nets)
        .map(|_| match spec.lstm {
            None => Data::Rows(Dataset::new(d, w, heads, cap)),
            Some(_) => Data::Windows(
                Windows::new(d, w, cfg.window, (cap / cfg.window).max(1), rows)
                    .with_unmarked_share(agreeing_share),
            ),
        })
        .collect();
    let mut cloners = (0..nets)
        .map(|k| Cloner::new(policy, k, cfg.lr, cfg.minibatch, cfg.update_threads()))
        .collect::<Result<Vec<_>, _>>()?;
    let mut reports = Vec::with_capacity(cfg.rounds);
    let mode = match cfg.rollout {
        Rollout::Greedy | Rollout::Shielded => ActMode::Greedy,
        Rollout::Sampled => ActMode::Sample,
    };
    // Shielded rollouts: the policy acts greedily under the wall masks and
    // the shield's joint move replaces its actions (the expert's steps stay
    // the expert's), as the collector's `shield_rollouts` do.
    let mut shielded = (cfg.rollout == Rollout::Shielded).then(|| Shielded {
        shield: RolloutShield::new(seed).with_goal_settling(SHIELD_PATIENCE),
        walls: vec![0u8; rows * w],
        executed: vec![0u8; rows * heads],
    });
    let mut teacher = (cfg.teacher == Teacher::Shield)
        .then(|| ShieldTeacher::new(seed, envs, n, rng.random(), cfg.stepping_aside));
    // Actions are `[rows, heads]`: one per agent in every mode.
    let (mut actions, mut policy_actions, mut logp) = (
        vec![0u8; rows * heads],
        vec![0u8; rows * heads],
        vec![0f32; rows],
    );
    let (mut row_rewards, mut row_done) = (vec![0f32; rows], vec![0u8; rows]);
    let mut prev_one_hot = Vec::new();
    let mut actor: Option<Inference> = None;
    venv.drain_episodes();
    for round in 0..cfg.rounds {
        let t0 = std::time::Instant::now();
        let (calls0, failures0) = (expert.calls, expert.failures);
        let (mut taught, mut overrides) = (0u64, 0u64);
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
                let masks = match shielded.as_mut() {
                    Some(s) => {
                        s.shield.write_masks(&*venv, &mut s.walls)?;
                        &s.walls[..]
                    }
                    None => venv.masks(),
                };
                let logits = actor.act(venv.obs(), masks, mode, &mut policy_actions, &mut logp)?;
                if let Some(s) = shielded.as_mut() {
                    s.shield.joint_move(
                        &*venv,
                        &policy_actions,
                        logits,
                        &s.walls,
                        &mut s.executed,
                    )?;
                    policy_actions.copy_from_slice(&s.executed);
                }
                if let Some(t) = teacher.as_mut() {
                    t.label(&*venv, logits, &policy_actions)?;
                    taught += (n * envs) as u64;
                    overrides += t.overridden.iter().filter(|&&o| o).count() as u64;
                }
            }
            for e in 0..envs {
                let lo = e * n;
                let labels = match &teacher {
                    Some(t) => Some(&t.labels[e]),
                    None => expert.label(venv.envs()[e].env()),
                };
                for r in e * per_env..(e + 1) * per_env {
                    // The agents row `r` acts for: one, or all of CTE's.
                    let agents = (r - e * per_env) * heads..(r - e * per_env + 1) * heads;
                    // Under the shield teacher: whether it overrode an agent of the row.
                    let overridden = teacher
                        .as_ref()
                        .is_some_and(|t| t.overridden[lo..lo + n][agents.clone()].contains(&true));
                    let label = labels.map(|l| &l.actions[agents]);
                    let obs = &venv.obs()[r * d..(r + 1) * d];
                    let mask = &venv.masks()[r * w..(r + 1) * w];
                    match (&mut data[spec.net_of_row(r)], &before) {
                        (Data::Rows(labelled), _) => {
                            let kept = overridden
                                || agreeing_share >= 1.0
                                || rng.random_bool(agreeing_share);
                            if let (Some(label), true) = (label, kept) {
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
                                // "no previous action".
                                episode_start: st.prev_actions[r * heads] == NO_ACTION,
                                label,
                            };
                            let (h, c) = (&st.h[r * k..(r + 1) * k], &st.c[r * k..(r + 1) * k]);
                            if overridden {
                                windows.mark(r);
                            }
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
                    (Some(l), true) => chosen.copy_from_slice(&l.execute),
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
        // Each network fits its own data; the round reports their mean.
        let (mut loss, mut accuracy) = (0.0, 0.0);
        for (cloner, data) in cloners.iter_mut().zip(&data) {
            let fit = match data {
                Data::Rows(labelled) => cloner.fit(policy, labelled, cfg.epochs, &mut rng)?,
                Data::Windows(windows) => {
                    cloner.fit_windows(policy, windows, cfg.epochs, &mut rng)?
                }
            };
            loss += fit.loss / nets as f64;
            accuracy += fit.accuracy / nets as f64;
        }
        let report = RoundReport {
            round,
            env_steps: steps,
            rows: data.iter().map(Data::held).sum(),
            expert_calls: expert.calls - calls0,
            expert_failures: expert.failures - failures0,
            episodes: episodes.len(),
            success_rate,
            loss,
            accuracy,
            overridden: if taught == 0 {
                0.0
            } else {
                overrides as f64 / taught as f64
            },
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
            overridden = report.overridden,
            seconds = report.seconds,
            "imitation round"
        );
        on_round(&report);
        reports.push(report);
    }
    Ok(reports)
}

/// What [`Rollout::Shielded`] rollouts carry from step to step: the shield
/// of every env, the wall masks the policy acts under, and the joint move
/// the shield makes of its actions.
struct Shielded {
    shield: RolloutShield,
    walls: Vec<u8>,
    executed: Vec<u8>,
}

/// The [`Teacher::Shield`]: the policy's preferences through the
/// deployment shield (`shield-lanes=16`), one env's joint move as its
/// labels.
///
/// Each step the policy's logits rank every agent's moves under the wall
/// mask (a move into a neighbour's cell asks it to make way), as the
/// evaluation's shield ranks them, and the shield — which follows the
/// rollout's episode, its patience counting the steps the rolled-out
/// controller makes — resolves them into one joint move. An agent's label
/// is its move in it, or "stay" where that move enters a cell occupied at
/// the start of the step (the policy's mask forbids it); a rollout that
/// follows the teacher (probability `beta`) executes the joint move
/// itself.
///
/// Where the shield keeps the policy's own move in the rollout (its
/// greedy move in greedy rollouts), the label is a draw from the policy's
/// own distribution (under the env's mask), so
/// that the fit there keeps the distribution (the expected cross-entropy
/// is the policy's to itself) instead of sharpening it toward its first
/// choice — a sharper policy leaves the shield's later choices untrained.
/// Every agent is labelled: labels on the overrides alone pull the policy
/// away from everything else it does.
struct ShieldTeacher {
    shield: RolloutShield,
    walls: Vec<u8>,
    first: Vec<u8>,
    executed: Vec<u8>,
    /// This step's labels, one per env.
    labels: Vec<Labels>,
    /// Per agent, whether the shield's move is not the policy's own.
    overridden: Vec<bool>,
    rng: ChaCha8Rng,
}

impl ShieldTeacher {
    fn new(seed: u64, envs: usize, agents: usize, draws: u64, aside: bool) -> Self {
        Self {
            shield: deployment_shield(seed, aside),
            walls: vec![0; envs * agents * NUM_ACTIONS],
            first: vec![0; envs * agents],
            executed: vec![0; envs * agents],
            overridden: vec![false; envs * agents],
            rng: ChaCha8Rng::seed_from_u64(draws),
            labels: vec![
                Labels {
                    actions: vec![0; agents],
                    execute: vec![0; agents],
                };
                envs
            ],
        }
    }

    /// Labels every env's state from the policy's `logits` (every agent's
    /// five, env-major and agent-minor, as the rows of a local or central
    /// policy lay them out) and its greedy actions `own`.
    fn label<E: BatchedEnv + ?Sized>(
        &mut self,
        venv: &E,
        logits: &[f32],
        own: &[u8],
    ) -> Result<(), ImitationError> {
        self.shield.write_masks(venv, &mut self.walls)?;
        let moves = logits
            .chunks(NUM_ACTIONS)
            .zip(self.walls.chunks(NUM_ACTIONS));
        for (first, (l, m)) in self.first.iter_mut().zip(moves) {
            // Staying is always legal, so every agent has a first choice.
            *first = greedy_head(l, m).map_or(0, |(a, _)| a);
        }
        self.shield
            .joint_move(venv, &self.first, logits, &self.walls, &mut self.executed)?;
        let n = venv.agents();
        let env_masks = venv.masks();
        for (e, labels) in self.labels.iter_mut().enumerate() {
            for i in 0..n {
                let k = e * n + i;
                let a = self.executed[k];
                labels.execute[i] = a;
                let moves = k * NUM_ACTIONS..(k + 1) * NUM_ACTIONS;
                let a = if env_masks[moves.start + a as usize] != 0 {
                    a
                } else {
                    0
                };
                self.overridden[k] = a != own[k];
                labels.actions[i] = if self.overridden[k] {
                    a
                } else {
                    sample_head(&logits[moves.clone()], &env_masks[moves], &mut self.rng)
                        .map_or(a, |(drawn, _)| drawn)
                };
            }
        }
        Ok(())
    }
}
