//! Trials as `learner train` child processes ([`ProcessRunner`]), so that a
//! panicking or out-of-memory trial fails alone instead of taking the study
//! down.
//!
//! A child trains the base configuration with the trial's `--set`
//! overrides, seed and step budget into the trial's run directory, from the
//! checkpoint the trial continues from (`--resume`). Its `metrics.csv` feeds
//! the scheduler. A stop decision closes the child's stdin
//! (`--stop-when-stdin-closes`): it checkpoints and exits, or is killed
//! after a grace period. Its stdout and stderr go to `train.log` in the run
//! directory; a child that fails is a failed trial whose error ends with the
//! last lines of that log.

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use buridan_learner::train::{Summary, TrainConfig, METRICS_FILE, SUMMARY_FILE};
use buridan_study::{Measurement, Reporter, TrialError, TrialRunner, TrialSpec};
use std::sync::Arc;

use crate::metrics_tail::MetricsTail;
use crate::trial::{
    chain, measure, measurement, trial_config, trial_view, EvalProtocol, TrialDisplay,
    TrialRunError,
};

/// The child's stdout and stderr inside the trial's run directory.
pub const LOG_FILE: &str = "train.log";

/// How often the child's metrics and exit are checked.
const POLL: Duration = Duration::from_millis(200);

/// Lines of the log a failed trial's error ends with.
const TAIL_LINES: usize = 20;

/// Why a child-process trial failed.
#[derive(Debug, thiserror::Error)]
pub enum ProcessError {
    /// The trial's configuration, checkpoint or evaluation.
    #[error(transparent)]
    Trial(Box<TrialRunError>),
    /// The child could not be started or watched.
    #[error("running {}", exe.display())]
    Spawn {
        /// The executable.
        exe: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The child ended unsuccessfully without being asked to stop.
    #[error("`learner train` ended with {status}; the end of {}:\n{tail}", log.display())]
    Exited {
        /// How it ended (exit code or signal).
        status: ExitStatus,
        /// Its log file.
        log: PathBuf,
        /// The last lines of the log.
        tail: String,
    },
    /// The child succeeded but its summary cannot be read.
    #[error("reading {}: {message}", path.display())]
    Summary {
        /// The summary file.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

impl From<TrialRunError> for ProcessError {
    fn from(e: TrialRunError) -> ProcessError {
        ProcessError::Trial(Box::new(e))
    }
}

/// Runs each trial as a `learner train` child process.
pub struct ProcessRunner {
    /// The `learner` executable (normally the running one).
    pub exe: PathBuf,
    /// The complete base configuration file children read (`--config`).
    pub base_file: PathBuf,
    /// The same configuration, parsed: overrides are checked against it
    /// before a child starts, and eval objectives read it.
    pub base: TrainConfig,
    /// The evaluation an `eval_*` objective runs (in this process, on the
    /// child's final checkpoint).
    pub eval: EvalProtocol,
    /// Where to show each running trial (none: nowhere).
    pub display: Option<Arc<dyn TrialDisplay>>,
    /// How long a child asked to stop may take to checkpoint and exit
    /// before it is killed.
    pub grace: Duration,
}

impl ProcessRunner {
    /// A runner starting `exe train --config base_file …`, showing nothing,
    /// with a grace period of 60 s.
    pub fn new(exe: PathBuf, base_file: PathBuf, base: TrainConfig) -> ProcessRunner {
        ProcessRunner {
            exe,
            base_file,
            base,
            eval: EvalProtocol::default(),
            display: None,
            grace: Duration::from_secs(60),
        }
    }

    /// The child's command line for trial `spec`, starting from `checkpoint`.
    pub fn command(&self, spec: &TrialSpec, checkpoint: Option<&Path>) -> Command {
        let mut cmd = Command::new(&self.exe);
        cmd.arg("train").arg("--config").arg(&self.base_file);
        for set in spec.set_args() {
            cmd.arg("--set").arg(set);
        }
        cmd.arg("--seed")
            .arg(spec.seed.to_string())
            .arg("--steps")
            .arg(spec.steps.to_string())
            .arg("--out")
            .arg(&spec.run_dir)
            .args(["--quiet", "--stop-when-stdin-closes"]);
        if let Some(c) = checkpoint {
            cmd.arg("--resume").arg(c);
        }
        cmd
    }

    /// Trains trial `spec` in a child and measures it; `Ok` also when the
    /// study stopped it.
    pub fn run_trial(
        &self,
        spec: &TrialSpec,
        reporter: &mut dyn Reporter,
    ) -> Result<Measurement, ProcessError> {
        // Checks the overrides and finds the checkpoint before any child starts.
        let cfg = trial_config(&self.base, spec)?;
        let spawn_failed = |source| ProcessError::Spawn {
            exe: self.exe.clone(),
            source,
        };
        std::fs::create_dir_all(&spec.run_dir).map_err(spawn_failed)?;
        let log_path = spec.run_dir.join(LOG_FILE);
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log_path)
            .map_err(spawn_failed)?;
        let mut cmd = self.command(spec, cfg.run.resume.as_deref());
        cmd.stdin(Stdio::piped())
            .stdout(log.try_clone().map_err(spawn_failed)?)
            .stderr(log);
        let mut metrics = MetricsTail::from_end(&spec.run_dir.join(METRICS_FILE));
        let log_start = std::fs::metadata(&log_path).map_or(0, |m| m.len());
        tracing::info!(trial = spec.id, command = ?cmd, "trial starts");
        let mut child = KillOnDrop(cmd.spawn().map_err(spawn_failed)?);
        let mut stdin = child.0.stdin.take();
        let mut view = trial_view(self.display.as_ref(), spec);
        let mut last = Measurement::default();
        let mut stopped: Option<Instant> = None;
        let status = loop {
            // Exit first, then the rows: none written before the exit is missed.
            let exited = child.0.try_wait().map_err(spawn_failed)?;
            for row in metrics.poll() {
                if let Some(view) = &mut view {
                    view.row(&row);
                }
                last = measurement(&row);
                if stopped.is_none() && !reporter.report(&last).keeps_going() {
                    // End of stdin: the child checkpoints after this update.
                    drop(stdin.take());
                    stopped = Some(Instant::now());
                }
            }
            if let Some(status) = exited {
                break status;
            }
            if stopped.is_some_and(|t| t.elapsed() > self.grace) {
                tracing::warn!(
                    trial = spec.id,
                    "the stopped trial did not exit: killing it"
                );
                let _ = child.0.kill();
            }
            std::thread::sleep(POLL);
        };
        drop(view);
        if stopped.is_some() {
            tracing::info!(trial = spec.id, step = last.step, %status, "trial stopped");
            return Ok(last);
        }
        if !status.success() {
            return Err(ProcessError::Exited {
                status,
                tail: log_tail(&log_path, log_start),
                log: log_path,
            });
        }
        let path = spec.run_dir.join(SUMMARY_FILE);
        let summary: Summary = std::fs::read_to_string(&path)
            .map_err(|e| e.to_string())
            .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
            .map_err(|message| ProcessError::Summary {
                path: path.clone(),
                message,
            })?;
        Ok(measure(&cfg, spec, &self.eval, &summary)?)
    }
}

impl TrialRunner for ProcessRunner {
    fn run(
        &self,
        spec: &TrialSpec,
        reporter: &mut dyn Reporter,
    ) -> Result<Measurement, TrialError> {
        self.run_trial(spec, reporter)
            .map_err(|e| TrialError::new(chain(&e)))
    }
}

/// A child that is killed if the runner unwinds before it has exited.
struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// The last [`TAIL_LINES`] lines the child wrote to `log` (after byte `start`).
fn log_tail(log: &Path, start: u64) -> String {
    let mut text = Vec::new();
    if let Ok(mut f) = std::fs::File::open(log) {
        let len = f.metadata().map_or(0, |m| m.len());
        let from = start.max(len.saturating_sub(8192));
        if f.seek(SeekFrom::Start(from)).is_ok() {
            let _ = f.read_to_end(&mut text);
        }
    }
    let text = String::from_utf8_lossy(&text);
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(TAIL_LINES)..].join("\n")
}
