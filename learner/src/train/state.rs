//! The counters a checkpoint carries (`trainer.json`), and how a resumed
//! run gets its windows back from them.

use std::path::Path;

use buridan_policy::checkpoint::TRAINER_FILE;
use serde::{Deserialize, Serialize};

use super::metrics::LayoutWindows;
use super::{target, TrainError};

/// Counters saved with a checkpoint (`trainer.json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainerState {
    /// Learner updates (= policy version).
    pub updates: u64,
    /// Env steps sampled.
    pub env_steps: u64,
    /// Agent steps sampled.
    pub agent_steps: u64,
    /// Episodes finished.
    pub episodes: u64,
    /// Wall seconds spent so far.
    pub wall_seconds: f64,
    /// Adam steps taken.
    pub adam_steps: u64,
    /// PPO KL coefficients per weight set.
    pub kl_coeffs: Vec<f64>,
    /// Fragments dropped as stale.
    pub stale_fragments: u64,
    /// The last episodes (the metrics window), so a resumed run reports
    /// from its first update on.
    #[serde(default)]
    pub recent_episodes: Vec<buridan_env::EpisodeStats>,
    /// Runs on several layouts: each layout's episode count and window.
    #[serde(default)]
    pub layouts: Vec<LayoutRecord>,
    /// When the training success reached each [`target::TARGET_SUCCESS`]
    /// level (empty in checkpoints of older versions: filled on resume).
    #[serde(default)]
    pub time_to_target: Vec<target::TimeToTarget>,
}

/// One training layout's counters in a checkpoint: a resumed run picks
/// them up by map name (so a resume on other layouts starts those afresh).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LayoutRecord {
    /// The map.
    pub map: String,
    /// Episodes finished on it.
    pub episodes: u64,
    /// Its last episodes (its metrics window).
    pub recent: Vec<buridan_env::EpisodeStats>,
}

/// The per-layout windows of a run over `names`, with the counters of the
/// checkpoint's layouts of the same names.
pub(super) fn restore_layout_windows(names: &[String], saved: &[LayoutRecord]) -> LayoutWindows {
    let found: Vec<Option<&LayoutRecord>> = names
        .iter()
        .map(|n| saved.iter().find(|r| r.map == *n))
        .collect();
    let totals: Vec<u64> = found.iter().map(|r| r.map_or(0, |r| r.episodes)).collect();
    let recent: Vec<Vec<buridan_env::EpisodeStats>> = found
        .iter()
        .map(|r| r.map_or_else(Vec::new, |r| r.recent.clone()))
        .collect();
    LayoutWindows::restore(names.len(), &totals, &recent)
}

/// The trainer counters of checkpoint `dir`.
pub(super) fn read_trainer_state(dir: &Path) -> Result<TrainerState, TrainError> {
    let path = dir.join(TRAINER_FILE);
    let text =
        std::fs::read_to_string(&path).map_err(|e| TrainError::io("cannot read", &path, e))?;
    serde_json::from_str(&text).map_err(|source| TrainError::TrainerState { path, source })
}
