//! Per-update metrics (`metrics.csv`), the run summary (`summary.json`) and
//! the rolling episode window.

use std::collections::VecDeque;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use buridan_env::EpisodeStats;
use serde::{Deserialize, Serialize};

/// Episodes the reported means run over (RLlib's smoothing window).
pub const EPISODE_WINDOW: usize = 100;

/// The last [`EPISODE_WINDOW`] finished episodes.
#[derive(Debug, Clone, Default)]
pub struct EpisodeWindow {
    recent: VecDeque<EpisodeStats>,
    /// Episodes seen in total.
    pub total: u64,
}

impl EpisodeWindow {
    /// A window holding `recent` (the last episodes of a run that has seen
    /// `total`), as saved by [`Self::recent`].
    pub fn restore(total: u64, recent: &[EpisodeStats]) -> Self {
        let skip = recent.len().saturating_sub(EPISODE_WINDOW);
        Self {
            recent: recent[skip..].iter().copied().collect(),
            total,
        }
    }

    /// The episodes in the window, oldest first.
    pub fn recent(&self) -> Vec<EpisodeStats> {
        self.recent.iter().copied().collect()
    }

    /// Adds finished episodes.
    pub fn extend(&mut self, episodes: &[EpisodeStats]) {
        for e in episodes {
            if self.recent.len() == EPISODE_WINDOW {
                self.recent.pop_front();
            }
            self.recent.push_back(*e);
            self.total += 1;
        }
    }

    fn mean(&self, f: impl Fn(&EpisodeStats) -> f64) -> f64 {
        if self.recent.is_empty() {
            f64::NAN
        } else {
            self.recent.iter().map(f).sum::<f64>() / self.recent.len() as f64
        }
    }

    /// Mean episode return (summed over agents) over the window; NaN if empty.
    pub fn return_mean(&self) -> f64 {
        self.mean(|e| e.reward as f64)
    }

    /// Fraction of successful episodes in the window; NaN if empty.
    pub fn success_rate(&self) -> f64 {
        self.mean(|e| f64::from(u8::from(e.success)))
    }

    /// Mean episode length over the window; NaN if empty.
    pub fn len_mean(&self) -> f64 {
        self.mean(|e| e.length as f64)
    }

    /// Episodes currently in the window.
    pub fn len(&self) -> usize {
        self.recent.len()
    }

    /// Whether the window is empty.
    pub fn is_empty(&self) -> bool {
        self.recent.is_empty()
    }
}

/// One row of `metrics.csv`: the state after one learner update.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MetricsRow {
    /// Updates so far (= policy version).
    pub update: u64,
    /// Vectorised env steps sampled so far.
    pub env_steps: u64,
    /// Agent steps sampled so far (env steps × agents).
    pub agent_steps: u64,
    /// Seconds since the start of training (including resumed runs).
    pub wall_seconds: f64,
    /// Env steps per second since the previous row.
    pub steps_per_s: f64,
    /// Episodes finished so far.
    pub episodes: u64,
    /// Mean return of the last 100 episodes (sum over agents).
    pub episode_return_mean: f64,
    /// Success rate of the last 100 episodes.
    pub success_rate: f64,
    /// Mean length of the last 100 episodes.
    pub episode_len_mean: f64,
    /// Total loss.
    pub total_loss: f64,
    /// Policy loss.
    pub policy_loss: f64,
    /// Value loss.
    pub vf_loss: f64,
    /// Policy entropy.
    pub entropy: f64,
    /// KL(behaviour ‖ current).
    pub kl: f64,
    /// PPO KL coefficient after the update.
    pub kl_coeff: f64,
    /// Gradient norm before clipping.
    pub grad_norm: f64,
    /// Mean clipped importance weight (IMPALA).
    pub mean_rho: f64,
    /// Fragments dropped as too old, so far.
    pub stale_fragments: u64,
    /// Seconds the learner spent in this update.
    pub learn_seconds: f64,
}

/// Column names of `metrics.csv`, in order.
pub const METRICS_COLUMNS: &[&str] = &[
    "update",
    "env_steps",
    "agent_steps",
    "wall_seconds",
    "steps_per_s",
    "episodes",
    "episode_return_mean",
    "success_rate",
    "episode_len_mean",
    "total_loss",
    "policy_loss",
    "vf_loss",
    "entropy",
    "kl",
    "kl_coeff",
    "grad_norm",
    "mean_rho",
    "stale_fragments",
    "learn_seconds",
];

impl MetricsRow {
    fn csv_line(&self) -> String {
        format!(
            "{},{},{},{:.3},{:.1},{},{:.4},{:.4},{:.3},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{},{:.4}",
            self.update,
            self.env_steps,
            self.agent_steps,
            self.wall_seconds,
            self.steps_per_s,
            self.episodes,
            self.episode_return_mean,
            self.success_rate,
            self.episode_len_mean,
            self.total_loss,
            self.policy_loss,
            self.vf_loss,
            self.entropy,
            self.kl,
            self.kl_coeff,
            self.grad_norm,
            self.mean_rho,
            self.stale_fragments,
            self.learn_seconds,
        )
    }
}

/// Appends rows to `metrics.csv` (header written when the file is new).
pub struct MetricsWriter {
    file: std::fs::File,
    path: PathBuf,
}

impl MetricsWriter {
    /// Opens (appending) or creates `path`.
    pub fn open(path: &Path) -> Result<Self> {
        let exists = path.is_file() && std::fs::metadata(path)?.len() > 0;
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .with_context(|| format!("cannot open {}", path.display()))?;
        if !exists {
            writeln!(file, "{}", METRICS_COLUMNS.join(","))?;
        }
        Ok(Self {
            file,
            path: path.to_path_buf(),
        })
    }

    /// Writes one row and flushes.
    pub fn write(&mut self, row: &MetricsRow) -> Result<()> {
        writeln!(self.file, "{}", row.csv_line())
            .with_context(|| format!("cannot write {}", self.path.display()))?;
        self.file.flush()?;
        Ok(())
    }
}

/// What a training run amounted to; written as `summary.json`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// `ppo` or `impala`.
    pub algo: String,
    /// `cte`, `ctde` or `dte`.
    pub mode: String,
    /// Map id or path.
    pub map: String,
    /// Agents per env.
    pub agents: usize,
    /// `fixed` or `random`.
    pub starts: String,
    /// Vectorised env steps sampled.
    pub env_steps: u64,
    /// Agent steps sampled.
    pub agent_steps: u64,
    /// Learner updates.
    pub updates: u64,
    /// Wall-clock seconds (including resumed runs).
    pub wall_seconds: f64,
    /// Mean env steps per second.
    pub steps_per_s: f64,
    /// Episodes finished.
    pub episodes: u64,
    /// Mean return of the last 100 episodes.
    pub episode_return_mean: f64,
    /// Success rate of the last 100 episodes.
    pub success_rate: f64,
    /// Mean length of the last 100 episodes.
    pub episode_len_mean: f64,
    /// Fragments dropped as too old.
    pub stale_fragments: u64,
    /// Whether the stop criteria ended the run before the step budget.
    pub stopped_early: bool,
    /// Directory of the final checkpoint.
    pub final_checkpoint: PathBuf,
}
