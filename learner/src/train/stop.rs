//! When a run stops: at its step budget, or earlier once it has learned.
//!
//! A budget alone makes a newcomer wait for steps the policy no longer
//! needs: the recipe's imitation phase often leaves a policy that already
//! solves its layout, and PPO then only has to keep it there. The rule
//! `[stop]` ends the run once the training success (the last
//! [`EPISODE_WINDOW`](super::metrics::EPISODE_WINDOW) episodes) has stayed
//! at or above `success` for `hold` env steps in a row; `steps` stays the
//! cap. The summary says which of these ended the run ([`StopReason`]).
//!
//! Training success is a sampled policy's, on the episodes it trains on;
//! what a user deploys is the greedy policy on episodes it has not seen.
//! `[stop.greedy]` ([`GreedyCheck`]) measures that directly: every `every`
//! env steps the learner plays `episodes` held-out episodes greedily (a
//! seed stream of their own, [`buridan_env::seed::greedy_check`], apart
//! from the training envs' and the seed-42 evaluation's) and stops once
//! their success reaches its level. Each check draws new episodes, so a
//! policy that passed once by luck is as likely to be caught as any other.
//!
//! With `keep_best = true` the checks also choose what the run keeps: the
//! weights the run starts from (after imitation, before the first update)
//! are checked first (a candidate; if they pass, confirmed, the run stops
//! after one train batch, which they play: a run reports episodes of its
//! own, and the first PPO update of a policy that has already learned can
//! only lose what it knows — on rm-1.1 one left a greedy policy that solved
//! none of 200 held-out episodes), the weights after its last update are
//! checked when it ends, and the final checkpoint holds the checked weights that solved
//! the most held-out episodes (the earlier on a tie: the first PPO updates
//! can blur what sampling does while the greedy policy still solves as
//! many). Whatever the updates in
//! between did, the run then ends no worse on its held-out check than
//! where it started — PPO cannot unlearn what imitation taught.
//!
//! The best of many checks is partly the luckiest: on rm-2.1 the kept
//! checks solved 97–99.5 % of their 200 episodes while the same weights
//! solved 95–99 % of the seed-42 protocol's. `[stop.greedy.finalists]`
//! ([`Finalists`]) keeps the `count` best checked weights and, when the
//! run ends, replays each of them on one more set of `episodes` held-out
//! episodes (a stream of its own, [`buridan_env::seed::greedy_final`],
//! the same episodes for every finalist); the run keeps the finalist
//! that solves the most of them (on a tie, the better check, then the
//! earlier). Each replay is a row of `finalists.csv` ([`FinalRecord`]).
//! The final episodes also guard the stop: with finalists a check that
//! reaches its level ends the run only if the same weights reach it on
//! the final episodes too ([`GreedyProbe::confirm`]; `greedy.csv`'s
//! `confirmed`), so a check passed by luck does not end a run early.
//! And they judge a `[polish]` after the run: the polished weights are
//! kept only if they solve more of them than the kept finalist, counting
//! the raw greedy plays and the plays through the deployment shield
//! `shield-lanes=16` together ([`GreedyProbe::judge_polish`]): the polish
//! fits the raw policy to what the shield does for it, and a polish that
//! gains raw episodes by losing shielded ones is no gain to a deployment.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use buridan_env::{seed, EnvConfig, Map};
use buridan_imitate::config::deployment_shield;
use buridan_mapf::shield::rollout::RolloutShield;
use buridan_policy::{ActMode, Policy, Weights};
use serde::{Deserialize, Serialize};

use super::metrics::CsvLog;
use super::target::{Mark, TimeToTarget};
use super::{rollout, TrainError};

/// Stop once the training success has held a level for a stretch of env
/// steps, TOML `[stop]`; or, with `[stop.greedy]`, once the greedy policy
/// solves enough held-out episodes.
///
/// ```
/// use buridan_learner::train::StopRule;
/// let rule: StopRule = toml::from_str("success = 0.98\nhold = 50000").unwrap();
/// assert_eq!((rule.success, rule.hold, rule.greedy), (0.98, 50_000, None));
/// rule.validate().unwrap();
/// let rule: StopRule = toml::from_str(
///     "success = 0.99\nhold = 200000\n[greedy]\nsuccess = 0.99\nepisodes = 200\nevery = 20000",
/// )
/// .unwrap();
/// let g = rule.greedy.unwrap();
/// assert_eq!((g.success, g.episodes, g.every, g.keep_best), (0.99, 200, 20_000, false));
/// assert_eq!(g.finalists, None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopRule {
    /// The training success level (0..=1) over the last 100 episodes.
    pub success: f64,
    /// Env steps the level must hold, every update at or above it, before
    /// the run stops.
    pub hold: u64,
    /// Also stop once a greedy evaluation on held-out episodes reaches its
    /// level, TOML `[stop.greedy]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub greedy: Option<GreedyCheck>,
}

impl StopRule {
    /// Checks the levels and the stretches; the message names the bad key.
    pub fn validate(&self) -> Result<(), &'static str> {
        check_level(self.success, "stop.success must lie in (0, 1]")?;
        if self.hold == 0 {
            return Err("stop.hold must be at least 1 env step");
        }
        if let Some(g) = &self.greedy {
            g.validate()?;
        }
        Ok(())
    }
}

/// `Ok` for a success level in (0, 1], else `err` (the message naming
/// the key).
fn check_level(success: f64, err: &'static str) -> Result<(), &'static str> {
    if success > 0.0 && success <= 1.0 {
        Ok(())
    } else {
        Err(err)
    }
}

/// A greedy evaluation on held-out episodes between updates, TOML
/// `[stop.greedy]`: the run stops once the share of `episodes` episodes
/// the greedy policy solves reaches `success` (with `finalists`, once the
/// same weights reach it on the final episodes too); with `keep_best` its
/// final checkpoint holds the checked weights that solved the most.
///
/// ```
/// use buridan_learner::train::stop::{Finalists, GreedyCheck};
/// let check = GreedyCheck { success: 0.99, episodes: 200, every: 20_000, keep_best: true, finalists: None };
/// check.validate().unwrap();
/// assert!(check.passes(198, 200) && !check.passes(197, 200));
/// assert!(GreedyCheck { episodes: 0, ..check }.validate().is_err());
/// let finalists = Some(Finalists { count: 4, episodes: 1000 });
/// GreedyCheck { finalists, ..check }.validate().unwrap();
/// let without_keep_best = GreedyCheck { finalists, keep_best: false, ..check };
/// assert_eq!(
///     without_keep_best.validate(),
///     Err("stop.greedy.finalists chooses among the kept weights: it needs stop.greedy.keep_best = true")
/// );
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GreedyCheck {
    /// The level (0..=1): the share of the held-out episodes solved.
    pub success: f64,
    /// Held-out episodes per check (all played at once, one env each).
    pub episodes: usize,
    /// Env steps between checks; the first follows the first update
    /// (with `keep_best`, precedes it).
    pub every: u64,
    /// Keep the checked weights that solved the most held-out episodes
    /// (the earlier on a tie) as the final checkpoint, the run's starting
    /// weights and its last among them. Off by default; the recipe's.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub keep_best: bool,
    /// With `keep_best`: replay the best few checked weights on more
    /// held-out episodes when the run ends and keep the best of them,
    /// TOML `[stop.greedy.finalists]`. Off by default; the recipe replays 4 on 1,000 episodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finalists: Option<Finalists>,
}

/// The final choice among a run's best checked weights, TOML
/// `[stop.greedy.finalists]`: the `count` checks that solved the most
/// held-out episodes are each replayed on the same `episodes` further
/// held-out episodes, and the run keeps the one that solves the most.
/// The same final episodes confirm a check's pass before it stops the
/// run and judge a `[polish]` ([`GreedyProbe::judge_polish`]).
///
/// ```
/// use buridan_learner::train::stop::Finalists;
/// let f: Finalists = toml::from_str("count = 4\nepisodes = 1000").unwrap();
/// assert_eq!(f, Finalists { count: 4, episodes: 1000 });
/// assert!(f.validate().is_ok());
/// assert!(Finalists { count: 1, ..f }.validate().is_err());
/// assert!(Finalists { episodes: 0, ..f }.validate().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Finalists {
    /// How many of the best checks are replayed (at least 2).
    pub count: usize,
    /// Held-out episodes each of them plays (the same for all).
    pub episodes: usize,
}

impl Finalists {
    /// Checks the count and the episode count.
    pub fn validate(&self) -> Result<(), &'static str> {
        if self.count < 2 {
            return Err("stop.greedy.finalists.count must be at least 2");
        }
        if self.episodes == 0 {
            return Err("stop.greedy.finalists.episodes must be at least 1");
        }
        Ok(())
    }
}

impl GreedyCheck {
    /// Checks the level, the episode count and the interval.
    pub fn validate(&self) -> Result<(), &'static str> {
        check_level(self.success, "stop.greedy.success must lie in (0, 1]")?;
        if self.episodes == 0 {
            return Err("stop.greedy.episodes must be at least 1");
        }
        if self.every == 0 {
            return Err("stop.greedy.every must be at least 1 env step");
        }
        if let Some(f) = &self.finalists {
            if !self.keep_best {
                return Err("stop.greedy.finalists chooses among the kept weights: it needs stop.greedy.keep_best = true");
            }
            f.validate()?;
        }
        Ok(())
    }

    /// Whether `solved` of `played` episodes reach the level (counted in
    /// episodes, so 0.99 of 200 is 198 and no rounding lets 197 through).
    pub fn passes(&self, solved: usize, played: usize) -> bool {
        played > 0 && solved as f64 >= (self.success * played as f64 - 1e-9).ceil()
    }
}

/// The `[stop.greedy]` checks of a run, one CSV row each ([`GreedyRecord`]).
pub const GREEDY_FILE: &str = "greedy.csv";

/// The `[stop.greedy.finalists]` replays of a run, one CSV row each
/// ([`FinalRecord`]).
pub const FINALISTS_FILE: &str = "finalists.csv";

/// Where a run's greedy checks and finalists' replays play: `map` under
/// `env`'s rules, episode seeds drawn from the held-out streams of the
/// run's seed, `env.seed` ([`seed::greedy_check`], [`seed::greedy_final`]).
#[derive(Debug, Clone)]
pub struct Ground {
    /// The layout played.
    pub map: Arc<Map>,
    /// Its rules and limits, and the run's seed (each check plays from a
    /// seed of its own, derived from it).
    pub env: EnvConfig,
    /// The deployment shield also steps aside (`[polish] stepping_aside`):
    /// `shield[patience=16,ordered,lanes,aside]`, not `shield-lanes=16`.
    pub stepping_aside: bool,
}

/// A [`GreedyCheck`] through a run: when the next check is due, the seed
/// of each, and their log `greedy.csv` in the run's directory (appended
/// to on resume; the checks themselves start afresh).
pub struct GreedyProbe {
    check: GreedyCheck,
    next: u64,
    done: u64,
    last: Option<GreedyRecord>,
    /// With `keep_best`: the best checks so far and the weights they
    /// played, most solved first (the earlier among equals); one, or
    /// `finalists.count`.
    best: Vec<(GreedyRecord, Weights)>,
    log: CsvLog,
    out: std::path::PathBuf,
}

impl GreedyProbe {
    /// No check done yet; the first is due at once. Opens `greedy.csv` in
    /// `out`.
    pub fn new(check: GreedyCheck, out: &Path) -> Result<Self, TrainError> {
        Ok(Self {
            check,
            next: 0,
            done: 0,
            last: None,
            best: Vec::new(),
            log: CsvLog::append_upgrading::<GreedyRecord>(&out.join(GREEDY_FILE))?,
            out: out.to_path_buf(),
        })
    }

    /// The latest check, if any ran.
    pub fn last(&self) -> Option<GreedyRecord> {
        self.last
    }

    /// Whether a check is due after `env_steps` env steps.
    pub fn due(&self, env_steps: u64) -> bool {
        env_steps >= self.next
    }

    /// Whether the checks choose the weights the run keeps (`keep_best`).
    pub fn keeps_best(&self) -> bool {
        self.check.keep_best
    }

    /// Whether the latest check played the weights of update `update`.
    pub fn checked(&self, update: u64) -> bool {
        self.last.is_some_and(|r| r.update == update)
    }

    /// With `keep_best`: puts the kept weights into `policy` and returns
    /// their check (`None` without `keep_best` or before any check;
    /// `policy` is then left as it is). With `finalists` and more than one
    /// candidate, first replays each candidate on the final held-out
    /// episodes of `ground` ([`seed::greedy_final`] of its run seed),
    /// books the replays in `finalists.csv` and keeps the one that solved
    /// the most (the earlier candidate on a tie); the replay is returned
    /// beside the check.
    pub fn restore_best(
        &self,
        policy: &Policy,
        ground: &Ground,
    ) -> Result<Option<(GreedyRecord, Option<FinalRecord>)>, TrainError> {
        let Some((first, weights)) = self.best.first() else {
            return Ok(None);
        };
        let Some(finalists) = self.check.finalists.filter(|_| self.best.len() > 1) else {
            if self.last != Some(*first) {
                policy.set_weights(weights)?;
            }
            return Ok(Some((*first, None)));
        };
        let n = finalists.episodes;
        let mut log = CsvLog::append(&self.out.join(FINALISTS_FILE))?;
        let mut kept: Option<(usize, FinalRecord)> = None;
        for (k, (check, weights)) in self.best.iter().enumerate() {
            policy.set_weights(weights)?;
            let (solved, seconds) = solve_final(policy, ground, n)?;
            let record = FinalRecord {
                update: check.update,
                check_solved: check.solved,
                episodes: n,
                solved,
                seconds,
            };
            tracing::info!(
                update = record.update,
                solved = record.solved,
                episodes = n,
                "finalist {} (check: {} of {}) solved {} of {n} final held-out episodes",
                k + 1,
                check.solved,
                check.episodes,
                record.solved
            );
            log.write(&record)?;
            if kept.is_none_or(|(_, best)| record.solved > best.solved) {
                kept = Some((k, record));
            }
        }
        let (k, replay) = kept.expect("at least two finalists");
        let (check, weights) = &self.best[k];
        policy.set_weights(weights)?;
        Ok(Some((*check, Some(replay))))
    }

    /// What a `[polish]` that follows [`Self::restore_best`] is judged
    /// against: the kept finalist's raw replay `kept`, the same final
    /// held-out episodes played by the weights in `policy` (the kept
    /// finalist's, those of update `update`) through the deployment shield,
    /// and those weights.
    pub fn unpolished(
        &self,
        policy: &Policy,
        ground: &Ground,
        kept: FinalRecord,
        update: u64,
    ) -> Result<Unpolished, TrainError> {
        let (shielded, _) = solve_final_shielded(policy, ground, kept.episodes)?;
        Ok(Unpolished {
            kept,
            shielded,
            weights: policy.weights(update)?,
        })
    }

    /// Judges a `[polish]`: replays the polished weights in `policy` on
    /// the final held-out episodes of `before`, raw and through the
    /// deployment shield `shield-lanes=16`, and keeps them only if they
    /// solve more of them, both plays counted together, than the kept
    /// finalist did; otherwise puts `before`'s weights back. The polish
    /// fits the policy to moves other than those it was chosen for, and
    /// what that does to the greedy policy, raw or shielded, depends on
    /// the layout and the run: this way a run ends no worse on its final
    /// held-out episodes than its kept finalist.
    pub fn judge_polish(
        &self,
        policy: &Policy,
        ground: &Ground,
        before: &Unpolished,
    ) -> Result<PolishReplay, TrainError> {
        let started = Instant::now();
        let n = before.kept.episodes;
        let (solved, _) = solve_final(policy, ground, n)?;
        let (shielded, _) = solve_final_shielded(policy, ground, n)?;
        let polished_kept = solved + shielded > before.kept.solved + before.shielded;
        if !polished_kept {
            policy.set_weights(&before.weights)?;
        }
        tracing::info!(
            solved,
            shielded,
            kept_solved = before.kept.solved,
            kept_shielded = before.shielded,
            episodes = n,
            "the polished weights solved {solved} raw and {shielded} shielded of {n} final held-out episodes, the kept finalist {} and {}: {}",
            before.kept.solved,
            before.shielded,
            if polished_kept { "keeping the polished weights" } else { "keeping the finalist" }
        );
        Ok(PolishReplay {
            episodes: n,
            solved,
            kept_solved: before.kept.solved,
            shielded,
            kept_shielded: before.shielded,
            polished_kept,
            seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// With `finalists`: replays the weights in `policy` on the final
    /// held-out episodes; whether they reach the check's level there too,
    /// and how many they solved (`None` without finalists, which then
    /// confirm every pass). A check that passed by luck would end the run
    /// early; [`Self::run`] lets a pass stand only if it is confirmed.
    pub fn confirm(
        &self,
        policy: &Policy,
        ground: &Ground,
    ) -> Result<(bool, Option<usize>), TrainError> {
        let Some(f) = self.check.finalists else {
            return Ok((true, None));
        };
        let (solved, _) = solve_final(policy, ground, f.episodes)?;
        let stands = self.check.passes(solved, f.episodes);
        tracing::info!(
            solved,
            episodes = f.episodes,
            "the pass replayed on the final held-out episodes: {solved} of {} solved, {}",
            f.episodes,
            if stands { "confirmed" } else { "not confirmed" }
        );
        Ok((stands, Some(solved)))
    }

    /// [`GreedyProbe::run`] on the weights a run starts from (`keep_best`):
    /// a candidate to keep, and the next check still follows the first
    /// update. Whether they passed (confirmed): the run then stops after
    /// its first train batch.
    pub fn run_first(
        &mut self,
        policy: &Policy,
        ground: &Ground,
        at: Mark,
    ) -> Result<bool, TrainError> {
        let next = self.next;
        let passed = self.run(policy, ground, at)?;
        self.next = next;
        Ok(passed)
    }

    /// Plays the check at `at`: `episodes` episodes of `ground`, greedily,
    /// from the check's own seed ([`seed::greedy_check`] of its run
    /// seed); books them in `greedy.csv` and says whether they reach the
    /// level.
    pub fn run(&mut self, policy: &Policy, ground: &Ground, at: Mark) -> Result<bool, TrainError> {
        self.next = at.env_steps + self.check.every;
        let seed = seed::greedy_check(ground.env.seed, self.done);
        self.done += 1;
        let n = self.check.episodes;
        let (solved, seconds) = solve_greedily(policy, ground, n, seed, None)?;
        tracing::info!(
            env_steps = at.env_steps,
            solved,
            episodes = n,
            seconds,
            "greedy check on held-out episodes: {solved} of {n} solved"
        );
        let (passed, confirmed) = if self.check.passes(solved, n) {
            self.confirm(policy, ground)?
        } else {
            (false, None)
        };
        let record = GreedyRecord {
            update: at.update,
            env_steps: at.env_steps,
            wall_seconds: at.wall_seconds,
            episodes: n,
            solved,
            seconds,
            confirmed,
        };
        self.log.write(&record)?;
        self.last = Some(record);
        if self.check.keep_best {
            let room = self.check.finalists.map_or(1, |f| f.count);
            // After every candidate that solved as many: the earlier wins ties.
            let place = self.best.partition_point(|(b, _)| b.solved >= solved);
            if place < room {
                self.best
                    .insert(place, (record, policy.weights(record.update)?));
                self.best.truncate(room);
            }
        }
        Ok(passed)
    }
}

/// Plays `n` episodes of `ground` greedily, all at once, from episode
/// seed `seed`, through `shield` where given: how many it solved, and the
/// seconds that took. What a check and a finalist's replay play.
fn solve_greedily(
    policy: &Policy,
    ground: &Ground,
    n: usize,
    seed: u64,
    shield: Option<RolloutShield>,
) -> Result<(usize, f64), TrainError> {
    let started = Instant::now();
    let env = EnvConfig {
        seed,
        ..ground.env.clone()
    };
    let map = ground.map.clone();
    let episodes = rollout::rollout_through(policy, map, env, n, n, ActMode::Greedy, seed, shield)
        .map_err(|source| TrainError::GreedyCheck { source })?;
    let solved = episodes.iter().filter(|e| e.success).count();
    Ok((solved, started.elapsed().as_secs_f64()))
}

/// [`solve_greedily`] on the first `n` of the final held-out episodes
/// ([`seed::greedy_final`] of the run's seed): the same episodes for
/// every finalist, a pass's confirmation and a polish's judgement.
fn solve_final(policy: &Policy, ground: &Ground, n: usize) -> Result<(usize, f64), TrainError> {
    solve_greedily(policy, ground, n, seed::greedy_final(ground.env.seed), None)
}

/// [`solve_final`] through the deployment shield ([`deployment_shield`],
/// stepping aside with [`Ground::stepping_aside`]), tie-breaks drawn from
/// the final episodes' seed.
fn solve_final_shielded(
    policy: &Policy,
    ground: &Ground,
    n: usize,
) -> Result<(usize, f64), TrainError> {
    let seed = seed::greedy_final(ground.env.seed);
    let shield = deployment_shield(seed, ground.stepping_aside);
    solve_greedily(policy, ground, n, seed, Some(shield))
}

/// One greedy check of a run, a row of `greedy.csv`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct GreedyRecord {
    /// Updates done when the check ran.
    pub update: u64,
    /// Env steps sampled by then.
    pub env_steps: u64,
    /// The run's wall seconds by then.
    pub wall_seconds: f64,
    /// Held-out episodes played.
    pub episodes: usize,
    /// Of these, solved.
    pub solved: usize,
    /// Seconds the check took.
    pub seconds: f64,
    /// With `[stop.greedy.finalists]`, for a check that reached the
    /// level: of the final held-out episodes, the ones the same weights
    /// solved (the run stops only if they reach the level too).
    #[serde(default)]
    pub confirmed: Option<usize>,
}

/// One finalist's replay on the final held-out episodes, a row of
/// `finalists.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FinalRecord {
    /// The finalist: the weights of this update (its check is the row of
    /// `greedy.csv` with the same update).
    pub update: u64,
    /// Held-out episodes its check solved, which made it a finalist.
    pub check_solved: usize,
    /// Final held-out episodes played (the same for every finalist).
    pub episodes: usize,
    /// Of these, the ones it solved.
    pub solved: usize,
    /// Seconds the replay took.
    pub seconds: f64,
}

/// The kept finalist a `[polish]` is judged against
/// ([`GreedyProbe::unpolished`]).
pub struct Unpolished {
    /// Its raw replay on the final held-out episodes.
    pub kept: FinalRecord,
    /// Of the same episodes, the ones it solved through the deployment
    /// shield.
    pub shielded: usize,
    /// Its weights, put back if the polish does not do better.
    pub weights: Weights,
}

/// The replay that judged a run's `[polish]` ([`GreedyProbe::judge_polish`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PolishReplay {
    /// Final held-out episodes played (the finalists' episodes).
    pub episodes: usize,
    /// Of these, the ones the polished weights solved (raw greedy).
    pub solved: usize,
    /// The ones the kept finalist solved, before the polish.
    pub kept_solved: usize,
    /// The ones the polished weights solved through `shield-lanes=16`
    /// (0 in summaries written before the shielded judgement).
    #[serde(default)]
    pub shielded: usize,
    /// The ones the kept finalist solved through `shield-lanes=16`.
    #[serde(default)]
    pub kept_shielded: usize,
    /// Whether the run kept the polished weights (raw and shielded
    /// together, they solved more).
    pub polished_kept: bool,
    /// Seconds the replays of the polished weights took.
    pub seconds: f64,
}

/// Why a run ended.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// It used its step budget (`steps`).
    #[default]
    Budget,
    /// The training success held `[stop]`'s level for its stretch.
    Learned,
    /// The mean return reached `stop_return` (and the length `stop_len`).
    ReturnGoal,
    /// The greedy policy solved `[stop.greedy]`'s share of held-out episodes.
    Greedy,
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StopReason::Budget => "the step budget was used",
            StopReason::Learned => "the training success held its target",
            StopReason::ReturnGoal => "the return goal was reached",
            StopReason::Greedy => "the greedy policy solved its share of held-out episodes",
        })
    }
}

/// Follows a [`StopRule`] update by update: the stretch at or above its
/// level is a [`TimeToTarget`]'s `held` mark.
///
/// ```
/// use buridan_learner::train::{StopRule, stop::Holding};
/// use buridan_learner::train::target::Mark;
/// let at = |k: u64| Mark { update: k, env_steps: 1000 * k, wall_seconds: k as f64 };
/// let mut h = Holding::new(StopRule { success: 0.9, hold: 2000, greedy: None });
/// assert!(!h.observe(0.95, true, at(1))); // held from 1000 steps on
/// assert!(!h.observe(0.85, true, at(2))); // fell: starts over
/// assert!(!h.observe(0.92, true, at(3)));
/// assert!(!h.observe(0.93, false, at(4))); // not a full window: starts over
/// assert!(!h.observe(0.93, true, at(5)));
/// assert!(!h.observe(0.91, true, at(6)));
/// assert!(h.observe(0.99, true, at(7))); // 5000 → 7000: held 2000 steps
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Holding {
    hold: u64,
    level: TimeToTarget,
}

impl Holding {
    /// Nothing held yet.
    pub fn new(rule: StopRule) -> Self {
        Self {
            hold: rule.hold,
            level: TimeToTarget::new(rule.success),
        }
    }

    /// Books one update's training success (`full_window`: over a full
    /// episode window); `true` once the level has held for the stretch.
    pub fn observe(&mut self, success: f64, full_window: bool, at: Mark) -> bool {
        self.level.observe(success, full_window, at);
        self.level
            .held
            .is_some_and(|since| at.env_steps.saturating_sub(since.env_steps) >= self.hold)
    }
}
