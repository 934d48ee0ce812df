//! Per-update metrics (`metrics.csv`), the run summary (`summary.json`) and
//! the rolling episode window.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use buridan_env::EpisodeStats;
use serde::{Deserialize, Serialize};

/// Episodes the reported means run over (RLlib's smoothing window).
pub const EPISODE_WINDOW: usize = 100;

/// The last [`EPISODE_WINDOW`] finished fresh episodes (replays of failed
/// ones, `[replay]`, are practice and not counted).
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

    /// Adds finished episodes (replays skipped).
    ///
    /// ```
    /// use buridan_env::EpisodeStats;
    /// use buridan_learner::train::EpisodeWindow;
    /// let mut w = EpisodeWindow::default();
    /// let fresh = EpisodeStats { success: true, ..Default::default() };
    /// let replayed = EpisodeStats { success: false, replay: 1, ..Default::default() };
    /// w.extend(&[fresh, replayed]);
    /// assert_eq!((w.total, w.success_rate()), (1, 1.0));
    /// ```
    pub fn extend(&mut self, episodes: &[EpisodeStats]) {
        for e in episodes.iter().filter(|e| e.replay == 0) {
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

/// One [`EpisodeWindow`] per training layout: episodes go to the window of
/// their [`EpisodeStats::layout`], so each layout's success is over its own
/// last [`EPISODE_WINDOW`] episodes.
///
/// ```
/// use buridan_env::EpisodeStats;
/// use buridan_learner::train::LayoutWindows;
/// let mut w = LayoutWindows::new(2);
/// let ep = |layout, success| EpisodeStats { layout, success, ..Default::default() };
/// w.extend(&[ep(0, true), ep(1, false), ep(0, false), ep(0, true)]);
/// assert_eq!(w.totals(), vec![3, 1]);
/// assert!((w.success_rates()[0] - 2.0 / 3.0).abs() < 1e-12);
/// assert_eq!(w.success_rates()[1], 0.0);
/// ```
#[derive(Debug, Clone, Default)]
pub struct LayoutWindows {
    windows: Vec<EpisodeWindow>,
}

impl LayoutWindows {
    /// Empty windows for `layouts` layouts.
    pub fn new(layouts: usize) -> Self {
        Self {
            windows: vec![EpisodeWindow::default(); layouts],
        }
    }

    /// Windows of `layouts` layouts holding what [`Self::totals`] and
    /// [`Self::recent`] saved (missing entries start empty).
    pub fn restore(layouts: usize, totals: &[u64], recent: &[Vec<EpisodeStats>]) -> Self {
        let windows = (0..layouts)
            .map(|l| {
                EpisodeWindow::restore(
                    totals.get(l).copied().unwrap_or(0),
                    recent.get(l).map_or(&[][..], Vec::as_slice),
                )
            })
            .collect();
        Self { windows }
    }

    /// Adds finished episodes, each to its layout's window (episodes of an
    /// unknown layout are ignored here; the overall window has them).
    pub fn extend(&mut self, episodes: &[EpisodeStats]) {
        for e in episodes {
            if let Some(w) = self.windows.get_mut(e.layout as usize) {
                w.extend(std::slice::from_ref(e));
            }
        }
    }

    /// Episodes seen per layout.
    pub fn totals(&self) -> Vec<u64> {
        self.windows.iter().map(|w| w.total).collect()
    }

    /// Each layout's window, oldest first.
    pub fn recent(&self) -> Vec<Vec<EpisodeStats>> {
        self.windows.iter().map(EpisodeWindow::recent).collect()
    }

    /// Each layout's success rate over its window (NaN while empty).
    pub fn success_rates(&self) -> Vec<f64> {
        self.windows
            .iter()
            .map(EpisodeWindow::success_rate)
            .collect()
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
    /// Learning rate of this update (its schedule's value, if scheduled).
    #[serde(default)]
    pub lr: f64,
    /// Entropy coefficient of this update (its schedule's value, if scheduled).
    #[serde(default)]
    pub entropy_coeff: f64,
}

/// Why one of a run's CSV files (`metrics.csv`, `greedy.csv`) could not be
/// written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}", path.display())]
pub struct MetricsError {
    /// The file.
    pub path: PathBuf,
    /// What the CSV writer says (I/O included).
    pub source: csv::Error,
}

/// A CSV file a run appends rows to: the header (the row type's field
/// names) when the file is new or empty, none when a resumed run reopens
/// it; every row flushed as it is written.
pub struct CsvLog {
    writer: csv::Writer<std::fs::File>,
    path: PathBuf,
}

impl CsvLog {
    /// Opens `path` for appending, creating it if needed.
    pub fn append(path: &Path) -> Result<Self, MetricsError> {
        let is_new = std::fs::metadata(path).map_or(true, |m| m.len() == 0);
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|e| MetricsError {
                path: path.to_path_buf(),
                source: e.into(),
            })?;
        let writer = csv::WriterBuilder::new()
            .has_headers(is_new)
            .from_writer(file);
        Ok(Self {
            writer,
            path: path.to_path_buf(),
        })
    }

    /// Opens `path` for appending rows of `T`, creating it if needed; a
    /// file written by an older version with fewer columns (a run resumed
    /// after an upgrade) is first rewritten under `T`'s header, its rows
    /// kept and the new columns at their defaults, so the file stays one
    /// table.
    pub fn append_upgrading<T>(path: &Path) -> Result<Self, MetricsError>
    where
        T: Default + Serialize + serde::de::DeserializeOwned,
    {
        if std::fs::metadata(path).is_ok_and(|m| m.len() > 0) {
            upgrade_header::<T>(path).map_err(|source| MetricsError {
                path: path.to_path_buf(),
                source,
            })?;
        }
        Self::append(path)
    }

    /// Writes one row and flushes.
    pub fn write<T: Serialize>(&mut self, row: &T) -> Result<(), MetricsError> {
        let failed = |source: csv::Error| MetricsError {
            path: self.path.clone(),
            source,
        };
        self.writer.serialize(row).map_err(failed)?;
        self.writer.flush().map_err(|e| failed(e.into()))
    }
}

/// Appends rows to `metrics.csv`: the header (the [`MetricsRow`] field
/// names) when the file is new, then one flushed line per update.
///
/// A file written by an older version with fewer columns (a run resumed
/// after an upgrade) is first rewritten under the current header, its rows
/// kept and the new columns at their defaults, so the file stays one table.
pub struct MetricsWriter {
    log: CsvLog,
}

impl MetricsWriter {
    /// Opens (appending) or creates `path`.
    pub fn open(path: &Path) -> Result<Self, MetricsError> {
        Ok(Self {
            log: CsvLog::append_upgrading::<MetricsRow>(path)?,
        })
    }

    /// Writes one row and flushes.
    pub fn write(&mut self, row: &MetricsRow) -> Result<(), MetricsError> {
        self.log.write(row)
    }
}

/// The header a CSV of `T` rows has today: `T`'s field names.
fn current_header<T: Default + Serialize>() -> csv::StringRecord {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.serialize(T::default()).expect("a default row serialises");
    let bytes = w.into_inner().expect("writing to memory");
    csv::Reader::from_reader(bytes.as_slice())
        .headers()
        .expect("the header just written")
        .clone()
}

/// Rewrites `path` under the current header if its header differs (rows
/// read by column name; columns it lacks take their defaults). Written to a
/// temporary file first and renamed over, so a failure leaves the old file.
fn upgrade_header<T>(path: &Path) -> Result<(), csv::Error>
where
    T: Default + Serialize + serde::de::DeserializeOwned,
{
    let mut reader = csv::Reader::from_path(path)?;
    if *reader.headers()? == current_header::<T>() {
        return Ok(());
    }
    let rows: Vec<T> = reader.deserialize().collect::<Result<_, _>>()?;
    let tmp = path.with_extension("csv.upgrade");
    let mut w = csv::Writer::from_path(&tmp)?;
    for row in &rows {
        w.serialize(row)?;
    }
    w.flush()?;
    drop(w);
    std::fs::rename(&tmp, path)?;
    tracing::info!(
        "{}: {} rows rewritten under the current header (columns added since it was written)",
        path.display(),
        rows.len()
    );
    Ok(())
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
    /// What ended the run: its step budget, the `[stop]` rule or the
    /// return goal.
    #[serde(default)]
    pub stop_reason: super::stop::StopReason,
    /// The training layouts (one for a single-map run).
    #[serde(default)]
    pub maps: Vec<String>,
    /// Runs on several layouts: per layout, the success rate of its last
    /// 100 episodes.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub success_by_map: BTreeMap<String, f64>,
    /// Runs on several layouts: per layout, the episodes finished.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub episodes_by_map: BTreeMap<String, u64>,
    /// When the training success first reached 90 % and 96 %, and from
    /// when on it stayed there ([`super::target`]).
    #[serde(default)]
    pub time_to_target: Vec<super::target::TimeToTarget>,
    /// The last `[stop.greedy]` check, if the run made any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub greedy_check: Option<super::stop::GreedyRecord>,
    /// With `[stop.greedy] keep_best`: the check whose weights the final
    /// checkpoint holds (before any `[polish]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kept_check: Option<super::stop::GreedyRecord>,
    /// With `[stop.greedy.finalists]`: the kept weights' replay on the
    /// final held-out episodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kept_replay: Option<super::stop::FinalRecord>,
    /// With `[polish]` after `[stop.greedy.finalists]`: the polished
    /// weights' replay on the same final held-out episodes, and whether
    /// the run kept them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub polish_replay: Option<super::stop::PolishReplay>,
    /// Directory of the final checkpoint.
    pub final_checkpoint: PathBuf,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_with_an_older_header_is_rewritten_under_the_current_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("metrics.csv");
        // A row as written before the lr and entropy_coeff columns existed.
        std::fs::write(
            &path,
            "update,env_steps,agent_steps,wall_seconds,steps_per_s,episodes,episode_return_mean,\
             success_rate,episode_len_mean,total_loss,policy_loss,vf_loss,entropy,kl,kl_coeff,\
             grad_norm,mean_rho,stale_fragments,learn_seconds\n\
             1,500,2000,1.5,333.0,4,2.5,0.5,40.0,0.1,0.2,0.3,1.6,0.0,0.2,1.0,1.0,0,0.01\n",
        )
        .unwrap();
        let mut w = MetricsWriter::open(&path).unwrap();
        w.write(&MetricsRow {
            update: 2,
            env_steps: 1000,
            lr: 5e-4,
            ..Default::default()
        })
        .unwrap();
        drop(w);
        let text = std::fs::read_to_string(&path).unwrap();
        let header = current_header::<MetricsRow>();
        assert_eq!(
            text.lines().next().unwrap(),
            header.iter().collect::<Vec<_>>().join(",")
        );
        let rows: Vec<MetricsRow> = csv::Reader::from_path(&path)
            .unwrap()
            .deserialize()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(
            (rows[0].env_steps, rows[0].success_rate, rows[0].lr),
            (500, 0.5, 0.0)
        );
        assert_eq!((rows[1].env_steps, rows[1].lr), (1000, 5e-4));
        // A current file is left as it is.
        let before = std::fs::read_to_string(&path).unwrap();
        drop(MetricsWriter::open(&path).unwrap());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), before);
    }

    /// `greedy.csv` of a run written before checks booked their
    /// confirmation: reopened, it gains the column, its rows kept.
    #[test]
    fn an_older_greedy_log_gains_the_new_column_on_resume() {
        use crate::train::stop::GreedyRecord;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("greedy.csv");
        let old =
            "update,env_steps,wall_seconds,episodes,solved,seconds\n3,12000,4.5,200,197,0.2\n";
        std::fs::write(&path, old).unwrap();
        let mut log = CsvLog::append_upgrading::<GreedyRecord>(&path).unwrap();
        log.write(&GreedyRecord {
            update: 4,
            solved: 199,
            confirmed: Some(990),
            ..Default::default()
        })
        .unwrap();
        drop(log);
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<_> = text.lines().collect();
        assert_eq!(
            lines,
            [
                "update,env_steps,wall_seconds,episodes,solved,seconds,confirmed",
                "3,12000,4.5,200,197,0.2,",
                "4,0,0.0,0,199,0.0,990",
            ]
        );
    }
}
