//! What a soak found: the books, the training target, the misbehaving
//! client's tally and the learner's counters of trouble, with every check
//! that failed.

use buridan_actor::misbehave::MisbehaveTally;
use buridan_learner::train::TrainConfig;
use serde::Serialize;

use crate::actors::Actors;
use crate::books::{balance, Books};
use crate::sample::{fragments, Sample, Samples, REFUSALS};
use crate::scrape::Scrape;
use crate::SoakArgs;

/// What a soak run found.
#[derive(Debug, Clone, Serialize)]
pub struct SoakSummary {
    /// Seconds run (from the learner's start to the stop).
    pub seconds: f64,
    /// The learner's config file and overrides.
    pub config: String,
    /// Actor processes.
    pub actors: usize,
    /// Resident memory at the first and the last sample, and the most (KiB).
    pub rss_start_kib: u64,
    /// See `rss_start_kib`.
    pub rss_end_kib: u64,
    /// See `rss_start_kib`.
    pub rss_max_kib: u64,
    /// Env steps, updates.
    pub env_steps: u64,
    /// Policy version at the end.
    pub updates: u64,
    /// Training success over the last 100 episodes at the end.
    pub final_success: Option<f64>,
    /// The best sampled.
    pub best_success: Option<f64>,
    /// The target.
    pub target: f64,
    /// Seconds until the target was first reached.
    pub target_reached_s: Option<f64>,
    /// Fragments refused by outcome.
    pub refused: Vec<(String, u64)>,
    /// The books.
    pub books: Books,
    /// Actors killed, restarted, and exited on their own.
    pub kills: u64,
    /// See `kills`.
    pub restarts: u64,
    /// See `kills`.
    pub actor_exits: u64,
    /// The misbehaving client.
    pub misbehave: Option<MisbehaveJson>,
    /// RPC errors by code, undecodable messages, implausible fragments,
    /// refused joins, expired sessions (the learner's counters).
    pub learner_counters: Vec<(String, u64)>,
    /// The checkpoint the learner wrote on SIGTERM.
    pub checkpoint: Option<String>,
    /// Why the soak failed (empty: it passed).
    pub failures: Vec<String>,
}

/// [`MisbehaveTally`] as JSON.
#[derive(Debug, Clone, Serialize)]
pub struct MisbehaveJson {
    /// Rounds.
    pub rounds: u64,
    /// Undecodable sent / refused.
    pub undecodable: (u64, u64),
    /// Implausible sent / refused.
    pub implausible: (u64, u64),
    /// Stale replays sent / refused.
    pub stale: (u64, u64),
    /// Repeated sequence numbers sent / refused.
    pub replays: (u64, u64),
    /// Idle sessions opened / found expired.
    pub idle_sessions: (u64, u64),
    /// Joins refused at the cap.
    pub joins_refused_at_cap: u64,
    /// Taken when they should have been refused.
    pub wrongly_accepted: u64,
    /// Other statuses than expected.
    pub unexpected: u64,
    /// Connection failures.
    pub transport_errors: u64,
    /// The last problem.
    pub last_problem: String,
}

impl From<&MisbehaveTally> for MisbehaveJson {
    fn from(t: &MisbehaveTally) -> Self {
        Self {
            rounds: t.rounds,
            undecodable: (t.undecodable_sent, t.undecodable_refused),
            implausible: (t.implausible_sent, t.implausible_refused),
            stale: (t.stale_sent, t.stale_refused),
            replays: (t.replays_sent, t.replays_refused),
            idle_sessions: (t.idle_sessions, t.idle_sessions_expired),
            joins_refused_at_cap: t.joins_refused_at_cap,
            wrongly_accepted: t.wrongly_accepted,
            unexpected: t.unexpected,
            transport_errors: t.transport_errors,
            last_problem: t.last_problem.clone(),
        }
    }
}

/// What the stop sequence found.
pub(crate) struct Stopped {
    /// Seconds from the learner's start to its stop.
    pub(crate) seconds: f64,
    pub(crate) tally: Option<MisbehaveTally>,
    pub(crate) checkpoint: Option<String>,
    pub(crate) failures: Vec<String>,
}

/// Training success over the run.
struct SuccessRecord {
    last: Option<f64>,
    best: Option<f64>,
    /// Seconds until it first reached the target.
    target_reached_s: Option<f64>,
}

impl SuccessRecord {
    fn of(samples: &[Sample], target: f64) -> Self {
        Self {
            last: samples.iter().rev().find_map(|s| s.success),
            best: samples.iter().filter_map(|s| s.success).reduce(f64::max),
            target_reached_s: samples
                .iter()
                .find(|s| s.success.is_some_and(|v| v >= target))
                .map(|s| s.seconds),
        }
    }
}

/// What the misbehaving client's tally says went wrong.
fn misbehaver_failures(t: &MisbehaveTally) -> Vec<String> {
    let mut failures = Vec::new();
    if t.wrongly_accepted > 0 || t.unexpected > 0 {
        failures.push(format!(
            "the misbehaving client: {} wrongly accepted, {} unexpected answers (last: {})",
            t.wrongly_accepted, t.unexpected, t.last_problem
        ));
    }
    if t.sent() == 0 {
        failures.push("the misbehaving client sent nothing (never connected)".into());
    }
    failures
}

/// The learner's counters of trouble: RPC errors by code, undecodable
/// messages, implausible fragments, refused joins, expired sessions.
fn learner_counters(scrape: &Scrape) -> Vec<(String, u64)> {
    let mut counters: Vec<(String, u64)> = [
        ("undecodable messages", "buridan_undecodable_messages_total"),
        (
            "implausible fragments",
            "buridan_implausible_fragments_total",
        ),
        ("joins refused (cap)", "buridan_joins_refused_total"),
        ("sessions expired", "buridan_sessions_expired_total"),
    ]
    .into_iter()
    .map(|(name, key)| (name.into(), scrape.total(key) as u64))
    .collect();
    for (code, n) in scrape.by_label("buridan_rpc_errors_total") {
        counters.push((format!("rpc errors {code}"), n));
    }
    counters
}

/// Balances the books and checks the run against `--target` and the
/// misbehaving client's tally: the summary, with every failure.
pub(crate) fn summarize(
    args: &SoakArgs,
    cfg: &TrainConfig,
    samples: &Samples,
    actors: &Actors,
    stopped: Stopped,
) -> SoakSummary {
    let Stopped {
        seconds,
        tally,
        checkpoint,
        mut failures,
    } = stopped;
    let last = samples.rows.last().cloned().unwrap_or_default();
    let books = balance(
        &last,
        (cfg.run.fragment_len * cfg.run.envs_per_actor) as u64,
        cfg.fragments_per_batch() as u64,
        &mut failures,
    );
    let success = SuccessRecord::of(&samples.rows, args.target);
    if success.target_reached_s.is_none() {
        failures.push(format!(
            "training success never reached {:.0} % (best {})",
            100.0 * args.target,
            percent(success.best)
        ));
    }
    if let Some(t) = &tally {
        failures.extend(misbehaver_failures(t));
    }
    // A sample without the learner's memory (it had gone) says nothing of it.
    let rss: Vec<u64> = samples
        .rows
        .iter()
        .map(|s| s.rss_kib)
        .filter(|&r| r > 0)
        .collect();
    SoakSummary {
        seconds,
        config: args.config_line(),
        actors: args.actors,
        rss_start_kib: rss.first().copied().unwrap_or(0),
        rss_end_kib: rss.last().copied().unwrap_or(0),
        rss_max_kib: rss.iter().copied().max().unwrap_or(0),
        env_steps: last.env_steps,
        updates: last.policy_version,
        final_success: success.last,
        best_success: success.best,
        target: args.target,
        target_reached_s: success.target_reached_s,
        refused: REFUSALS
            .iter()
            .map(|&o| (o.to_string(), fragments(&samples.last_scrape, o)))
            .collect(),
        books,
        kills: actors.kills,
        restarts: actors.restarts,
        actor_exits: actors.exits,
        misbehave: tally.as_ref().map(MisbehaveJson::from),
        learner_counters: learner_counters(&samples.last_scrape),
        checkpoint,
        failures,
    }
}

/// A success rate as a percentage, "–" if there is none.
pub(crate) fn percent(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{:.1} %", 100.0 * v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn success_record_finds_last_best_and_first_at_target() {
        let samples: Vec<Sample> = [None, Some(0.5), Some(0.9), Some(0.7), None]
            .into_iter()
            .enumerate()
            .map(|(k, success)| Sample {
                seconds: k as f64,
                success,
                ..Sample::default()
            })
            .collect();
        let r = SuccessRecord::of(&samples, 0.8);
        assert_eq!(
            (r.last, r.best, r.target_reached_s),
            (Some(0.7), Some(0.9), Some(2.0))
        );
        assert_eq!(SuccessRecord::of(&samples, 0.95).target_reached_s, None);
    }
}
