//! The study driver: samples trials, runs them in parallel through a
//! [`TrialRunner`], lets the scheduler stop hopeless ones, persists every
//! change, and resumes without rerunning finished trials.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

use crate::config::StudyConfig;
use crate::objective::Measurement;
use crate::runner::{run_caught, Reporter, TrialRunner, TrialSpec};
use crate::sampler::Sampler;
use crate::scheduler::{Decision, Scheduler};
use crate::state::{Report, StateError, StudyState, TrialRecord, TrialStatus};

/// A study can neither be opened nor run.
///
/// ```
/// let e = buridan_study::StudyError::Mismatch { field: "space" };
/// assert!(e.to_string().contains("space"));
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyError {
    /// The state file cannot be read or written.
    #[error(transparent)]
    State(#[from] StateError),
    /// The directory holds a study with a different setting.
    #[error("the study directory holds a study with another `{field}`; use a new directory")]
    Mismatch {
        /// The setting that differs.
        field: &'static str,
    },
    /// An output file could not be written.
    #[error("{0}")]
    Output(String),
    /// PBT synchronises its whole population every round, so it cannot be
    /// planned as independent cluster trials.
    #[error("a PBT study cannot be planned as a batch: its members wait for each other every round; run it with `learner tune`")]
    PbtBatch,
}

/// Counts of a study's trials by status.
///
/// ```
/// let s = buridan_study::study::Progress::default();
/// assert_eq!(s.completed + s.stopped + s.failed, 0);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Progress {
    /// Trials that ran their budget.
    pub completed: usize,
    /// Trials stopped by the scheduler.
    pub stopped: usize,
    /// Trials that failed.
    pub failed: usize,
    /// Trials cut by the wall-time budget (they resume next time).
    pub interrupted: usize,
    /// Trials planned for a batch and not yet collected.
    pub planned: usize,
    /// Trials started in this session (including resumed ones).
    pub started_now: usize,
}

/// An open study directory.
///
/// ```no_run
/// # use buridan_study::*;
/// # fn runner() -> impl TrialRunner { struct R; impl TrialRunner for R { fn run(&self, _: &TrialSpec, _: &mut dyn Reporter) -> Result<Measurement, TrialError> { Ok(Measurement::default()) } } R }
/// let config = StudyConfig::from_file("tune-ppo-rm-2.1.toml".as_ref()).unwrap();
/// let mut study = Study::open("runs/tune-ppo-rm-2.1".as_ref(), config).unwrap();
/// study.run(&runner()).unwrap();          // resumes if the directory holds a study
/// study.write_outputs().unwrap();         // trials.csv/json, best.toml, PNGs
/// ```
pub struct Study {
    dir: PathBuf,
    config: StudyConfig,
    state: StudyState,
}

impl Study {
    /// Opens `dir`: loads its state if it holds one (the sampler, seed,
    /// space, objective and steps per trial must match; trial count,
    /// parallelism, wall time and scheduler may change, except a PBT
    /// scheduler), else starts fresh.
    ///
    /// ```
    /// let cfg = buridan_study::StudyConfig::from_toml_str(
    ///     "[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }",
    /// ).unwrap();
    /// let dir = tempfile::tempdir().unwrap();
    /// let study = buridan_study::Study::open(dir.path(), cfg).unwrap();
    /// assert!(study.state().trials.is_empty());
    /// ```
    pub fn open(dir: &Path, config: StudyConfig) -> Result<Study, StudyError> {
        let state = match StudyState::load(dir)? {
            None => StudyState::new(&config),
            Some(state) => {
                let old = &state.config;
                // PBT's rounds and population are fixed once started.
                let pbt = old.scheduler.pbt().is_some() || config.scheduler.pbt().is_some();
                let checks: [(&'static str, bool); 7] = [
                    ("scheduler", !pbt || old.scheduler == config.scheduler),
                    ("space", old.space == config.space),
                    ("sampler", old.sampler == config.sampler),
                    ("grid_points", old.grid_points == config.grid_points),
                    ("seed", old.seed == config.seed),
                    ("objective", old.objective == config.objective),
                    (
                        "steps_per_trial",
                        old.steps_per_trial == config.steps_per_trial,
                    ),
                ];
                if let Some((field, _)) = checks.iter().find(|(_, same)| !same) {
                    return Err(StudyError::Mismatch { field });
                }
                StudyState {
                    config: config.clone(),
                    ..state
                }
            }
        };
        state.save(dir)?;
        Ok(Study {
            dir: dir.to_path_buf(),
            config,
            state,
        })
    }

    /// The study directory.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// let dir = tempfile::tempdir().unwrap();
    /// assert_eq!(buridan_study::Study::open(dir.path(), cfg).unwrap().dir(), dir.path());
    /// ```
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The configuration in force.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// # let dir = tempfile::tempdir().unwrap();
    /// assert_eq!(buridan_study::Study::open(dir.path(), cfg).unwrap().config().name, "x");
    /// ```
    pub fn config(&self) -> &StudyConfig {
        &self.config
    }

    /// The trials so far.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// # let dir = tempfile::tempdir().unwrap();
    /// assert_eq!(buridan_study::Study::open(dir.path(), cfg).unwrap().state().wall_seconds, 0.0);
    /// ```
    pub fn state(&self) -> &StudyState {
        &self.state
    }

    /// Counts of trials by status.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// # let dir = tempfile::tempdir().unwrap();
    /// assert_eq!(buridan_study::Study::open(dir.path(), cfg).unwrap().progress().completed, 0);
    /// ```
    pub fn progress(&self) -> Progress {
        let mut p = Progress::default();
        for t in &self.state.trials {
            match t.status {
                TrialStatus::Completed => p.completed += 1,
                TrialStatus::Stopped => p.stopped += 1,
                TrialStatus::Failed => p.failed += 1,
                TrialStatus::Interrupted => p.interrupted += 1,
                TrialStatus::Planned => p.planned += 1,
                TrialStatus::Running => {}
            }
        }
        p
    }

    /// The spec the runner gets for trial `record`.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 10\nseed = 5\n[space]\nx = { int = [1, 2] }").unwrap();
    /// # let dir = tempfile::tempdir().unwrap();
    /// let study = buridan_study::Study::open(dir.path(), cfg).unwrap();
    /// let spec = study.spec(&buridan_study::state::TrialRecord::new(2, Default::default()));
    /// assert_eq!((spec.seed, spec.steps), (7, 10));
    /// assert!(spec.run_dir.ends_with("trials/0002"));
    /// ```
    pub fn spec(&self, record: &TrialRecord) -> TrialSpec {
        spec_for(&self.dir, &self.config, record)
    }

    /// Runs trials until `trials` have been started and all have finished,
    /// the grid is exhausted, or the wall time is used; `parallel` at once.
    /// Trials found running, interrupted or planned run (again) first, with
    /// `resume = true`; finished trials never run again. A runner panic
    /// counts as a failed trial. A PBT study runs its population in rounds
    /// instead (`crate::population`), resuming after its last finished round.
    ///
    /// ```
    /// use buridan_study::*;
    /// struct Quadratic;
    /// impl TrialRunner for Quadratic {
    ///     fn run(&self, spec: &TrialSpec, r: &mut dyn Reporter) -> Result<Measurement, TrialError> {
    ///         let x = spec.overrides["x"].as_float().unwrap_or(0.0);
    ///         let m = Measurement { step: spec.steps, train_success: Some(1.0 - (x - 0.3).powi(2)), ..Default::default() };
    ///         r.report(&m);
    ///         Ok(m)
    ///     }
    /// }
    /// let cfg = StudyConfig::from_toml_str(
    ///     "[study]\nname = \"q\"\ntrials = 6\nparallel = 2\nsteps_per_trial = 1\n[space]\nx = { uniform = [0, 1] }",
    /// ).unwrap();
    /// let dir = tempfile::tempdir().unwrap();
    /// let mut study = Study::open(dir.path(), cfg).unwrap();
    /// assert_eq!(study.run(&Quadratic).unwrap().completed, 6);
    /// ```
    pub fn run(&mut self, runner: &dyn TrialRunner) -> Result<Progress, StudyError> {
        if self.config.scheduler.pbt().is_some() {
            let started_now =
                crate::population::run(&self.dir, &self.config, &mut self.state, runner)?;
            return Ok(Progress {
                started_now,
                ..self.progress()
            });
        }
        let sampler = self
            .config
            .sampler
            .build(self.config.seed, self.config.grid_points);
        let mut scheduler = self.config.scheduler.build(self.config.steps_per_trial);
        for t in &self.state.trials {
            for r in &t.reports {
                scheduler.report(t.id, r.step, r.value);
            }
        }
        let pending: VecDeque<u64> = self
            .state
            .trials
            .iter()
            .filter(|t| !t.status.is_finished())
            .map(|t| t.id)
            .collect();
        let shared = Shared {
            inner: Mutex::new(Inner {
                state: self.state.clone(),
                scheduler,
                pending,
                failure: None,
                started_now: 0,
                last_save: Instant::now(),
            }),
            dir: &self.dir,
            config: &self.config,
            sampler: sampler.as_ref(),
            clock: Clock::new(self.state.wall_seconds, self.config.wall_time),
        };
        std::thread::scope(|s| {
            for _ in 0..self.config.parallel.max(1) {
                s.spawn(|| worker(&shared, runner));
            }
        });
        let inner = shared.inner.into_inner().unwrap_or_else(|e| e.into_inner());
        self.state = inner.state;
        if let Some(e) = inner.failure {
            return Err(e);
        }
        Ok(Progress {
            started_now: inner.started_now,
            ..self.progress()
        })
    }

    /// Samples `count` new trials without running them (status `Planned`)
    /// and writes each one's `trial.json` spec into its run directory — the
    /// batch a Kubernetes Indexed Job runs, index = trial id. At most the
    /// study's `trials` exist in all (and a grid stops when exhausted).
    /// Returns the new ids. Samplers see only finished trials, so TPE plans a batch from
    /// what earlier batches found.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 4\nsteps_per_trial = 1\n[space]\nx = { int = [1, 9] }").unwrap();
    /// let dir = tempfile::tempdir().unwrap();
    /// let mut study = buridan_study::Study::open(dir.path(), cfg).unwrap();
    /// assert_eq!(study.plan(3).unwrap(), [0, 1, 2]);
    /// assert!(dir.path().join("trials/0002/trial.json").exists());
    /// ```
    pub fn plan(&mut self, count: u64) -> Result<Vec<u64>, StudyError> {
        if self.config.scheduler.pbt().is_some() {
            return Err(StudyError::PbtBatch);
        }
        let sampler = self
            .config
            .sampler
            .build(self.config.seed, self.config.grid_points);
        let history = self.state.observed();
        let mut ids = Vec::new();
        let room = self
            .config
            .trials
            .saturating_sub(self.state.trials.len() as u64);
        for _ in 0..count.min(room) {
            let id = self.state.trials.len() as u64;
            let Some(overrides) = sampler.suggest(&self.config.space, id, &history) else {
                break;
            };
            let mut record = TrialRecord::new(id, overrides);
            record.status = TrialStatus::Planned;
            crate::batch::write_spec(&self.dir, &self.spec(&record))?;
            self.state.trials.push(record);
            ids.push(id);
        }
        self.state.save(&self.dir)?;
        Ok(ids)
    }

    /// Reads the `result.json` of every planned trial that has one (written
    /// by [`crate::batch::run_trial`] in a pod) into the state.
    /// Returns how many were collected.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 4\nsteps_per_trial = 1\n[space]\nx = { int = [1, 9] }").unwrap();
    /// # let dir = tempfile::tempdir().unwrap();
    /// let mut study = buridan_study::Study::open(dir.path(), cfg).unwrap();
    /// study.plan(2).unwrap();
    /// assert_eq!(study.collect().unwrap(), 0); // nothing ran yet
    /// ```
    pub fn collect(&mut self) -> Result<usize, StudyError> {
        let mut n = 0;
        for t in self.state.trials.iter_mut() {
            if t.status != TrialStatus::Planned {
                continue;
            }
            let Some(result) = crate::batch::read_result(&self.dir.join(&t.run_dir))? else {
                continue;
            };
            t.reports = result.reports;
            t.seconds = result.seconds;
            t.starts = 1;
            match result.outcome {
                Ok(m) => {
                    t.score = self.config.objective.score(&m);
                    t.last = Some(m);
                    t.status = TrialStatus::Completed;
                }
                Err(e) => {
                    t.error = Some(e);
                    t.status = TrialStatus::Failed;
                }
            }
            n += 1;
        }
        self.state.save(&self.dir)?;
        Ok(n)
    }
}

pub(crate) fn spec_for(dir: &Path, config: &StudyConfig, record: &TrialRecord) -> TrialSpec {
    TrialSpec {
        id: record.id,
        overrides: record.overrides.clone(),
        steps: config.steps_per_trial,
        seed: config.seed.wrapping_add(record.id),
        run_dir: dir.join(&record.run_dir),
        resume: record.starts > 0,
        start_from: None,
        objective: config.objective,
    }
}

struct Inner {
    state: StudyState,
    scheduler: Box<dyn Scheduler>,
    pending: VecDeque<u64>,
    failure: Option<StudyError>,
    started_now: usize,
    last_save: Instant,
}

/// Reports are saved at most this often: they are many, and a lost one
/// only costs a scheduler sample.
pub(crate) const REPORT_SAVE_SECONDS: f64 = 5.0;

/// Wall time across sessions: the seconds of earlier sessions plus this
/// one's, against the study's budget.
pub(crate) struct Clock {
    base: f64,
    start: Instant,
    budget: Option<std::time::Duration>,
}

impl Clock {
    pub(crate) fn new(base: f64, budget: Option<std::time::Duration>) -> Clock {
        Clock {
            base,
            start: Instant::now(),
            budget,
        }
    }

    /// Wall seconds used by all sessions so far.
    pub(crate) fn used(&self) -> f64 {
        self.base + self.start.elapsed().as_secs_f64()
    }

    pub(crate) fn out_of_time(&self) -> bool {
        self.budget.is_some_and(|b| self.used() >= b.as_secs_f64())
    }
}

struct Shared<'a> {
    inner: Mutex<Inner>,
    dir: &'a Path,
    config: &'a StudyConfig,
    sampler: &'a dyn Sampler,
    clock: Clock,
}

impl Shared<'_> {
    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Saves after a report, at most every [`REPORT_SAVE_SECONDS`].
    fn save_throttled(&self, inner: &mut Inner) {
        if inner.last_save.elapsed().as_secs_f64() >= REPORT_SAVE_SECONDS {
            self.save(inner);
        }
    }

    fn save(&self, inner: &mut Inner) {
        inner.last_save = Instant::now();
        save_state(self.dir, &self.clock, &mut inner.state, &mut inner.failure);
    }
}

/// Saves `state` with the wall time used so far; a failure is kept in
/// `failure`, which stops the study.
pub(crate) fn save_state(
    dir: &Path,
    clock: &Clock,
    state: &mut StudyState,
    failure: &mut Option<StudyError>,
) {
    state.wall_seconds = clock.used();
    if let Err(e) = state.save(dir) {
        failure.get_or_insert(StudyError::State(e));
    }
}

fn next_trial(shared: &Shared<'_>, inner: &mut Inner) -> Option<TrialSpec> {
    if inner.failure.is_some() || shared.clock.out_of_time() {
        return None;
    }
    let id = match inner.pending.pop_front() {
        Some(id) => id,
        None => {
            let started = inner.state.trials.len() as u64;
            if started >= shared.config.trials {
                return None;
            }
            let history = inner.state.observed();
            let overrides = shared
                .sampler
                .suggest(&shared.config.space, started, &history)?;
            inner
                .state
                .trials
                .push(TrialRecord::new(started, overrides));
            started
        }
    };
    let record = inner.state.trials.get_mut(id as usize)?;
    let spec = spec_for(shared.dir, shared.config, record);
    record.status = TrialStatus::Running;
    record.starts += 1;
    inner.started_now += 1;
    Some(spec)
}

fn worker(shared: &Shared<'_>, runner: &dyn TrialRunner) {
    loop {
        let spec = {
            let mut inner = shared.lock();
            let Some(spec) = next_trial(shared, &mut inner) else {
                return;
            };
            shared.save(&mut inner);
            spec
        };
        let started = Instant::now();
        let mut reporter = StudyReporter {
            shared,
            id: spec.id,
            stopped: false,
            cut: false,
        };
        let outcome = run_caught(runner, &spec, &mut reporter);
        let (stopped, cut) = (reporter.stopped, reporter.cut);
        let mut inner = shared.lock();
        let objective = shared.config.objective;
        if let Some(t) = inner.state.trials.get_mut(spec.id as usize) {
            t.seconds += started.elapsed().as_secs_f64();
            match outcome {
                Ok(m) => {
                    t.score = objective
                        .score(&m)
                        .or_else(|| stopped.then(|| objective.intermediate(&m)).flatten());
                    t.last = Some(m);
                    t.error = None;
                    t.status = if cut && t.last.as_ref().is_some_and(|m| m.step < spec.steps) {
                        TrialStatus::Interrupted
                    } else if stopped {
                        TrialStatus::Stopped
                    } else {
                        TrialStatus::Completed
                    };
                }
                Err(e) => {
                    t.error = Some(e.message);
                    t.status = TrialStatus::Failed;
                }
            }
        }
        shared.save(&mut inner);
    }
}

struct StudyReporter<'s, 'a> {
    shared: &'s Shared<'a>,
    id: u64,
    stopped: bool,
    cut: bool,
}

impl Reporter for StudyReporter<'_, '_> {
    fn report(&mut self, m: &Measurement) -> Decision {
        if self.stopped || self.cut {
            return Decision::Stop;
        }
        let mut inner = self.shared.lock();
        let mut decision = Decision::Continue;
        if let Some(score) = self.shared.config.objective.intermediate(m) {
            let value = score.key();
            let id = self.id as usize;
            // A resumed trial re-reports steps it reported before: skip those.
            let fresh = inner
                .state
                .trials
                .get(id)
                .is_some_and(|t| t.reports.last().is_none_or(|r| m.step > r.step));
            if fresh {
                if let Some(t) = inner.state.trials.get_mut(id) {
                    t.reports.push(Report {
                        step: m.step,
                        value,
                    });
                    t.last = Some(m.clone());
                }
                decision = inner.scheduler.report(self.id, m.step, value);
            }
        }
        if !decision.keeps_going() {
            self.stopped = true;
        }
        if self.shared.clock.out_of_time() {
            self.cut = true;
            decision = Decision::Stop;
        }
        self.shared.save_throttled(&mut inner);
        decision
    }
}

impl Study {
    /// Writes `trials.csv`, `trials.json`, `best.toml` (once a trial has a
    /// score), `objective.png` and `params.png` into the study directory.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// let dir = tempfile::tempdir().unwrap();
    /// let study = buridan_study::Study::open(dir.path(), cfg).unwrap();
    /// let files = study.write_outputs().unwrap();
    /// assert!(files.iter().any(|f| f.ends_with("trials.csv")));
    /// ```
    pub fn write_outputs(&self) -> Result<Vec<PathBuf>, StudyError> {
        crate::output::write_all(&self.dir, &self.state)
            .map_err(|e| StudyError::Output(e.to_string()))
    }
}
