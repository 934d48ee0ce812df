//! `learner study EXPERIMENT.toml --out DIR`: runs an experiment's cells
//! (training runs, then their evaluations; planners on the same episodes),
//! `parallel` at a time, skipping what is finished; then writes the report
//! ([`buridan_experiment::report`]). `learner study report DIR` re-aggregates.
//!
//! Ctrl-C or SIGTERM stops a study gracefully: the training cells under way
//! checkpoint their current update (as `learner train` does), no new job
//! starts, evaluations under way finish, the report covers what is done,
//! and the same command later resumes the interrupted cells from their
//! checkpoints. A second signal exits at once.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use buridan_env::{Map, Rules};
use buridan_eval::output::write_report;
use buridan_eval::{evaluate, EvalSpec};
use buridan_learner::train::{MetricsRow, Progress, TrainConfig, TrainError, SUMMARY_FILE};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::signals::watch_signals;
use crate::train::train_interruptible;
use buridan_experiment::plan::{Evaluated, Experiment, PLAN_FILE};
use buridan_experiment::resolve::RunArgs;

/// Arguments of `learner study`.
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct StudyArgs {
    /// `report DIR`: re-aggregate an experiment directory.
    #[command(subcommand)]
    pub command: Option<StudyCommand>,
    /// The experiment file (examples in `learner/studies/`).
    pub experiment: Option<PathBuf>,
    /// The experiment directory (finished cells in it are skipped).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Cells at once (overrides the file's `parallel`).
    #[arg(long)]
    pub parallel: Option<usize>,
    /// No progress bars (log lines only).
    #[arg(long)]
    pub quiet: bool,
}

/// Subcommands of `learner study`.
#[derive(Debug, clap::Subcommand)]
pub enum StudyCommand {
    /// Re-aggregate the results in an experiment directory.
    Report {
        /// The experiment directory.
        dir: PathBuf,
    },
}

/// A unit of work: a training cell and its evaluations, or one planner evaluation.
#[derive(Debug, Clone)]
enum Job {
    Train { train: usize, evals: Vec<usize> },
    Eval { eval: usize },
}

struct Bars {
    multi: MultiProgress,
    quiet: bool,
}

impl Bars {
    fn say(&self, line: String) {
        if self.quiet {
            eprintln!("{line}");
        } else {
            let _ = self.multi.println(line);
        }
    }

    fn bar(&self, len: u64, prefix: String) -> ProgressBar {
        let bar = self.multi.add(ProgressBar::new(len));
        bar.set_style(
            ProgressStyle::with_template("{prefix:40} [{bar:20}] {human_pos}/{human_len} {msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_prefix(prefix);
        crate::heartbeat::watch(&bar);
        bar
    }

    fn done(&self, bar: &ProgressBar) {
        bar.finish_and_clear();
        self.multi.remove(bar);
    }
}

struct BarProgress<'a>(&'a ProgressBar);

impl Progress for BarProgress<'_> {
    fn on_start(&mut self, _cfg: &TrainConfig, total: u64, done: u64) {
        crate::heartbeat::start_at(self.0, total, done);
    }
    fn on_update(&mut self, row: &MetricsRow) {
        self.0.set_position(row.env_steps);
        self.0.set_message(format!(
            "success {:>5.1}%  {:>6.0} steps/s",
            100.0 * row.success_rate,
            row.steps_per_s
        ));
        tracing::info!(
            env_steps = row.env_steps,
            success_rate = row.success_rate,
            episode_len_mean = row.episode_len_mean,
            "update"
        );
    }
}

fn eval_done(out: &Path, dir: &Path) -> bool {
    out.join(dir).join("summary.json").is_file()
}

/// The evaluations of training cell `train` not finished yet.
fn pending_evals(x: &Experiment, out: &Path, train: usize) -> Vec<usize> {
    x.evals
        .iter()
        .enumerate()
        .filter(|(_, e)| matches!(e.evaluated, Evaluated::Policy { train: t, .. } if t == train))
        .filter(|(_, e)| !eval_done(out, &e.dir))
        .map(|(k, _)| k)
        .collect()
}

/// Whether the run in `run_dir` must (re)train: it has no summary, or it
/// has one but no checkpoint while some of its evaluations still need the
/// policy (`evals_pending`; finished cells copied from another machine keep
/// their results, not their checkpoints).
fn needs_training(run_dir: &Path, evals_pending: bool) -> bool {
    !run_dir.join(SUMMARY_FILE).is_file()
        || (evals_pending && buridan_policy::checkpoint::resolve(run_dir).is_err())
}

/// How a training cell ended in this invocation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Trained {
    /// Trained to its budget (now or before).
    Done,
    /// Stopped by a signal, with a checkpoint to resume from.
    Interrupted,
}

/// `learner train`'s arguments for a run's arguments (no bar: the study draws its own).
fn train_args(a: RunArgs) -> crate::train::TrainArgs {
    crate::train::TrainArgs {
        map: a.map,
        maps: a.maps,
        plant: a.plant,
        agents: a.agents,
        algo: a.algo,
        mode: a.mode,
        starts: a.starts,
        rules: a.rules,
        config: a.config,
        steps: a.steps,
        seed: a.seed,
        device: a.device,
        resume: a.resume,
        metrics: None,
        overrides: a.overrides,
        no_imitation: a.no_imitation,
        no_stop: a.no_stop,
        out: a.out,
        quiet: true,
        stop_when_stdin_closes: false,
        dashboard: Default::default(),
    }
}

fn run_train(
    x: &Experiment,
    out: &Path,
    index: usize,
    evals_pending: bool,
    bars: &Bars,
    stop: &Arc<AtomicBool>,
) -> Result<Trained> {
    let cell = &x.train[index];
    let run_dir = out.join(&cell.run_dir);
    if !needs_training(&run_dir, evals_pending) {
        return Ok(Trained::Done);
    }
    let args = train_args(cell.run_args(out));
    let cfg = crate::train::resolve_config(&args)?;
    let what = format!("{} {} seed {}", cell.layout, cell.method, cell.seed);
    bars.say(format!(
        "train {what}{}: {}",
        if cfg.run.resume.is_some() {
            " (resumed)"
        } else {
            ""
        },
        cell.command(out)
    ));
    let bar = bars.bar(cfg.run.steps, what.clone());
    let result = train_interruptible(&cfg, &run_dir, &mut BarProgress(&bar), stop.clone());
    bars.done(&bar);
    let summary = match result {
        Ok(summary) => summary,
        Err(e) if matches!(*e, TrainError::Interrupted(_)) => {
            bars.say(format!("stopped {what}: {e}"));
            return Ok(Trained::Interrupted);
        }
        Err(e) => {
            return Err(anyhow::Error::new(*e))
                .with_context(|| format!("training {what} in {}", run_dir.display()))
        }
    };
    let title = format!("{} on {}, seed {}", cell.method, cell.layout, cell.seed);
    crate::train::write_curves(&run_dir, &title)?;
    bars.say(format!(
        "trained {what}: {} env steps in {:.0} s, training success {:.1}%",
        summary.env_steps,
        summary.wall_seconds,
        100.0 * summary.success_rate
    ));
    Ok(Trained::Done)
}

fn run_eval(x: &Experiment, out: &Path, index: usize, bars: &Bars) -> Result<()> {
    let cell = &x.evals[index];
    if eval_done(out, &cell.dir) {
        return Ok(());
    }
    let e = &x.eval;
    // Time limits were checked positive when the study file was read.
    let limits = crate::eval::planner_limits(x.time_limit(cell), e.memory_limit)?;
    let map = Arc::new(Map::load(&cell.layout)?);
    let controller = x.controller(cell, out)?;
    // The env's thesis rules: this caller does not choose a rule set yet.
    let make = controller.factory(cell.agents, e.seed, limits, Rules::Thesis)?;
    let spec = EvalSpec {
        agents: cell.agents,
        episodes: e.episodes,
        seed: e.seed,
        starts: e.starts,
        t_max: e.t_max,
        jobs: 1,
        // The env's thesis rules: this caller does not choose a rule set yet.
        ..EvalSpec::default()
    };
    let what = match &cell.evaluated {
        Evaluated::Policy { train, actions } => format!(
            "eval {} {} seed {} {} n={}",
            cell.layout,
            cell.method,
            x.train[*train].seed,
            actions.name(),
            cell.agents
        ),
        Evaluated::Planner => format!("eval {} {} n={}", cell.layout, cell.method, cell.agents),
    };
    let bar = bars.bar(e.episodes as u64, what.clone());
    let solved = AtomicUsize::new(0);
    let on_episode = |r: &buridan_eval::EpisodeRecord| {
        solved.fetch_add(usize::from(r.success), Ordering::Relaxed);
        bar.inc(1);
    };
    let report = evaluate(&map, &spec, &*make, &on_episode);
    bars.done(&bar);
    let report = report.with_context(|| what.clone())?;
    let dir = out.join(&cell.dir);
    write_report(&dir, &report, &map.grid)?;
    std::fs::write(dir.join("command.txt"), x.eval_command(cell, out) + "\n")?;
    bars.say(format!(
        "{what}: success {:.1}%",
        100.0 * report.summary.success_rate
    ));
    Ok(())
}

fn run_job(
    x: &Experiment,
    out: &Path,
    job: &Job,
    bars: &Bars,
    stop: &Arc<AtomicBool>,
) -> Result<()> {
    match job {
        Job::Train { train, evals } => {
            if run_train(x, out, *train, !evals.is_empty(), bars, stop)? == Trained::Interrupted {
                return Ok(());
            }
            for &e in evals {
                run_eval(x, out, e, bars)?;
            }
            Ok(())
        }
        Job::Eval { eval } => run_eval(x, out, *eval, bars),
    }
}

/// The work left: training cells (with their evaluations) not finished, and
/// planner evaluations not finished.
fn jobs(x: &Experiment, out: &Path) -> Vec<Job> {
    let mut jobs = Vec::new();
    for (i, t) in x.train.iter().enumerate() {
        let evals = pending_evals(x, out, i);
        if !evals.is_empty() || needs_training(&out.join(&t.run_dir), false) {
            jobs.push(Job::Train { train: i, evals });
        }
    }
    for (k, e) in x.evals.iter().enumerate() {
        if e.evaluated == Evaluated::Planner && !eval_done(out, &e.dir) {
            jobs.push(Job::Eval { eval: k });
        }
    }
    jobs
}

/// What a `learner study` invocation did.
#[derive(Debug, Clone, Default)]
pub struct StudyOutcome {
    /// Jobs run in this invocation (training cells with their evaluations,
    /// planner evaluations).
    pub jobs_run: usize,
    /// Jobs that failed, with their errors.
    pub failures: Vec<String>,
    /// Report files written.
    pub files: Vec<PathBuf>,
}

/// Runs `learner study`.
pub fn run(args: &StudyArgs) -> Result<StudyOutcome> {
    if let Some(StudyCommand::Report { dir }) = &args.command {
        let x = buridan_experiment::report::read_plan(dir)?;
        let files = buridan_experiment::report::write_report(&x, dir)?;
        eprintln!("{}", std::fs::read_to_string(dir.join("table.md"))?);
        return Ok(StudyOutcome {
            files,
            ..StudyOutcome::default()
        });
    }
    let (Some(file), Some(out)) = (&args.experiment, &args.out) else {
        bail!("usage: learner study EXPERIMENT.toml --out DIR [--parallel N] (or: learner study report DIR)");
    };
    let mut x = Experiment::from_file(file)?;
    if let Some(p) = args.parallel {
        if p == 0 {
            bail!("--parallel must be at least 1");
        }
        x.parallel = p;
    }
    let _lock = buridan_study::lock::DirLock::acquire(out)?;
    std::fs::write(out.join(PLAN_FILE), serde_json::to_string_pretty(&x)?)?;
    std::fs::copy(file, out.join("experiment.toml"))?;
    let todo = jobs(&x, out);
    let bars = Bars {
        multi: MultiProgress::with_draw_target(if args.quiet {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        }),
        quiet: args.quiet,
    };
    bars.say(format!(
        "experiment `{}`: {} training runs, {} evaluations; {} jobs left, {} at once -> {}",
        x.name,
        x.train.len(),
        x.evals.len(),
        todo.len(),
        x.parallel,
        out.display()
    ));
    let started = Instant::now();
    let total = bars.multi.add(ProgressBar::new(todo.len() as u64));
    total.set_style(
        ProgressStyle::with_template("{prefix:40} [{bar:20}] {pos}/{len} jobs ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    total.set_prefix(x.name.clone());
    crate::heartbeat::watch(&total);
    let stop = Arc::new(AtomicBool::new(false));
    watch_signals(stop.clone());
    // Each run's threads fixed for its whole life: its numbers then do not
    // depend on what the run beside it is doing.
    buridan_learner::train::cores::plan_runs(x.parallel);
    let queue = Mutex::new(todo.iter().collect::<VecDeque<_>>());
    let failures = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..x.parallel.min(todo.len()).max(1) {
            s.spawn(|| loop {
                if stop.load(Ordering::SeqCst) {
                    return;
                }
                let Some(job) = queue.lock().expect("queue lock").pop_front() else {
                    return;
                };
                if let Err(e) = run_job(&x, out, job, &bars, &stop) {
                    let line = format!("{e:#}");
                    bars.say(format!("FAILED: {line}"));
                    failures.lock().expect("failure lock").push(line);
                }
                total.inc(1);
            });
        }
    });
    total.finish_and_clear();
    let failures = failures.into_inner().expect("failure lock");
    let files = buridan_experiment::report::write_report(&x, out)?;
    bars.say(std::fs::read_to_string(out.join("table.md"))?);
    bars.say(format!(
        "{} jobs in {:.0} s, {} failed; report in {}",
        todo.len(),
        started.elapsed().as_secs_f64(),
        failures.len(),
        out.display()
    ));
    if stop.load(Ordering::SeqCst) {
        let left = jobs(&x, out).len();
        bail!(
            "stopped by a signal with {left} of {} jobs left{}; rerun the same command to \
             continue (interrupted training runs resume from their checkpoints)",
            todo.len(),
            if failures.is_empty() {
                String::new()
            } else {
                format!(" and {} failed ({})", failures.len(), failures.join("; "))
            }
        );
    }
    if !failures.is_empty() {
        bail!(
            "{} of {} jobs failed (the others are saved; rerun to retry): {}",
            failures.len(),
            todo.len(),
            failures.join("; ")
        );
    }
    Ok(StudyOutcome {
        jobs_run: todo.len(),
        failures,
        files,
    })
}
