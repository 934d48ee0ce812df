//! `soak.md`: the summary as a two-column Markdown table.

use buridan_study::figures::clock;

use crate::summary::{percent, SoakSummary};

/// The summary as Markdown.
pub fn markdown(s: &SoakSummary) -> String {
    let mib = |k: u64| format!("{:.1} MiB", k as f64 / 1024.0);
    let b = &s.books;
    let mut rows: Vec<(String, String)> = vec![
        (
            "run".into(),
            format!(
                "{} of `learner serve` ({}) with {} actors",
                clock(s.seconds),
                s.config,
                s.actors
            ),
        ),
        (
            "learner resident memory: start → end (max)".into(),
            format!(
                "{} → {} ({})",
                mib(s.rss_start_kib),
                mib(s.rss_end_kib),
                mib(s.rss_max_kib)
            ),
        ),
        (
            "env steps taken, updates".into(),
            format!("{}, {}", s.env_steps, s.updates),
        ),
        (
            "training success (last 100 episodes): final / best".into(),
            format!("{} / {}", percent(s.final_success), percent(s.best_success)),
        ),
        (
            format!("target {:.0} % first reached after", 100.0 * s.target),
            s.target_reached_s.map_or("never".into(), clock),
        ),
        (
            "fragments accepted / refused".into(),
            format!(
                "{} / {} ({})",
                b.accepted,
                s.refused.iter().map(|(_, n)| n).sum::<u64>(),
                s.refused
                    .iter()
                    .map(|(o, n)| format!("{o} {n}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ),
        (
            "fragments consumed by updates (env steps)".into(),
            format!(
                "{} ({} = {} × {} steps)",
                b.consumed, b.consumed_steps, b.consumed, b.steps_per_fragment
            ),
        ),
        (
            "used twice / used in part".into(),
            format!("{} / {}", b.used_twice, b.consumed_in_part),
        ),
        (
            "lost (accepted, not consumed)".into(),
            format!(
                "{}: {} dropped as stale by the learner, {} queued and {} in the unfinished batch at the stop",
                b.lost, b.stale_at_learner, b.queued_at_end, b.partial_batch_at_end
            ),
        ),
        (
            "actors killed (SIGKILL) / restarted / exited on their own".into(),
            format!("{} / {} / {}", s.kills, s.restarts, s.actor_exits),
        ),
    ];
    if let Some(m) = &s.misbehave {
        rows.push((
            "misbehaving client (sent → refused as expected)".into(),
            format!(
                "{} rounds; undecodable {} → {} INVALID_ARGUMENT; implausible {} → {} INVALID_ARGUMENT; old fragments {} → {} stale; repeated sequence numbers {} → {} ALREADY_EXISTS; idle sessions {} ({} found expired); joins refused at the cap {}; wrongly accepted {}, unexpected {}, connection failures {}",
                m.rounds,
                m.undecodable.0,
                m.undecodable.1,
                m.implausible.0,
                m.implausible.1,
                m.stale.0,
                m.stale.1,
                m.replays.0,
                m.replays.1,
                m.idle_sessions.0,
                m.idle_sessions.1,
                m.joins_refused_at_cap,
                m.wrongly_accepted,
                m.unexpected,
                m.transport_errors
            ),
        ));
    }
    rows.push((
        "learner counters".into(),
        s.learner_counters
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", "),
    ));
    rows.push((
        "stop (SIGTERM)".into(),
        s.checkpoint
            .as_ref()
            .map_or("no checkpoint".into(), |c| format!("checkpoint `{c}`")),
    ));
    rows.push((
        "result".into(),
        if s.failures.is_empty() {
            "**passed**".into()
        } else {
            format!("**failed**: {}", s.failures.join("; "))
        },
    ));
    let mut md = String::from("| soak | |\n|---|---|\n");
    for (k, v) in rows {
        md.push_str(&format!("| {k} | {v} |\n"));
    }
    md
}
