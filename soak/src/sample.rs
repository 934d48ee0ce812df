//! Samples of the learner (memory and metrics), and `soak.csv`, written a
//! row at a time.

use std::path::Path;

use indicatif::ProgressBar;
use serde::Serialize;

use crate::actors::Actors;
use crate::learner::Learner;
use crate::scrape::{scrape, Scrape};
use crate::{SoakError, TARGET};

/// One sample of the learner: memory and metrics.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Sample {
    /// Seconds since the learner was started.
    pub seconds: f64,
    /// The learner's resident memory (KiB).
    pub rss_kib: u64,
    /// Fragments accepted (queued).
    pub accepted: u64,
    /// Fragments refused (stale, surplus, invalid, duplicate).
    pub refused: u64,
    /// … of which invalid (malformed, implausible, unknown session).
    pub invalid: u64,
    /// … of which duplicates.
    pub duplicate: u64,
    /// Fragments consumed by updates.
    pub consumed: u64,
    /// Env steps of the consumed fragments.
    pub consumed_steps: u64,
    /// Accepted fragments the learner dropped as too old when it took them.
    pub stale_at_learner: u64,
    /// Env steps taken from the queue.
    pub env_steps: u64,
    /// Policy version (updates).
    pub policy_version: u64,
    /// Training success over the last 100 episodes (empty before any).
    pub success: Option<f64>,
    /// Episodes finished.
    pub episodes: u64,
    /// Sessions open.
    pub sessions: u64,
    /// Actor processes running.
    pub actors_running: usize,
    /// Actors killed so far.
    pub kills: u64,
}

/// The outcomes of `buridan_fragments_total` that refuse a fragment.
pub const REFUSALS: [&str; 4] = ["stale", "surplus", "invalid", "duplicate"];

/// Fragments with `outcome` in `scrape` (see [`REFUSALS`]; also
/// `accepted` and `stale_at_learner`).
pub fn fragments(scrape: &Scrape, outcome: &str) -> u64 {
    scrape.labelled("buridan_fragments_total", "outcome", outcome) as u64
}

impl Sample {
    /// The learner's metrics in `scrape`; time, memory and actors left at 0.
    pub fn from_scrape(scrape: &Scrape) -> Self {
        let total = |name: &str| scrape.total(name) as u64;
        let gauge = |name: &str| scrape.get(name).unwrap_or(0.0) as u64;
        let episodes = gauge("buridan_episodes");
        Self {
            accepted: fragments(scrape, "accepted"),
            refused: REFUSALS.iter().map(|o| fragments(scrape, o)).sum(),
            invalid: fragments(scrape, "invalid"),
            duplicate: fragments(scrape, "duplicate"),
            consumed: total("buridan_fragments_consumed_total"),
            consumed_steps: total("buridan_fragment_steps_consumed_total"),
            stale_at_learner: fragments(scrape, "stale_at_learner"),
            env_steps: total("buridan_env_steps_total"),
            policy_version: gauge("buridan_policy_version"),
            // Until there were 100 episodes it is not the rate over the last 100.
            success: scrape
                .get("buridan_success_rate")
                .filter(|_| episodes >= 100),
            episodes,
            sessions: gauge("buridan_sessions"),
            ..Self::default()
        }
    }
}

/// The samples, each written to `soak.csv` as it is taken so a soak cut
/// short still leaves its rows.
pub(crate) struct Samples {
    csv: csv::Writer<std::fs::File>,
    pub(crate) rows: Vec<Sample>,
    /// The last scrape that answered: a failed scrape repeats its numbers.
    pub(crate) last_scrape: Scrape,
}

impl Samples {
    pub(crate) fn create(out: &Path) -> Result<Self, SoakError> {
        let path = out.join("soak.csv");
        let csv = csv::Writer::from_path(&path)?;
        Ok(Self {
            csv,
            rows: Vec::new(),
            last_scrape: Scrape::default(),
        })
    }

    /// Writes `s` out and keeps it.
    pub(crate) fn record(&mut self, s: Sample) -> Result<&Sample, SoakError> {
        self.csv.serialize(&s)?;
        self.csv
            .flush()
            .map_err(SoakError::io("writing soak.csv"))?;
        self.rows.push(s);
        Ok(&self.rows[self.rows.len() - 1])
    }

    /// Scrapes the learner and records a sample.
    pub(crate) fn take(
        &mut self,
        learner: &Learner,
        actors: &Actors,
        bar: &ProgressBar,
    ) -> Result<&Sample, SoakError> {
        match scrape(learner.metrics) {
            Ok(s) => self.last_scrape = s,
            Err(e) => bar.suspend(|| tracing::warn!(target: TARGET, "soak: scrape failed: {e:#}")),
        }
        let s = learner.sample(&self.last_scrape, actors.running().count(), actors.kills);
        self.record(s)
    }
}
