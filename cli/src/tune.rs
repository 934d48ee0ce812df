//! `learner tune`: a hyperparameter search over `TrainConfig` keys, run by
//! the study crate's driver with the learner as its trial runner — locally
//! (trials in parallel threads or `learner train` child processes,
//! resumable; PBT studies in rounds), or on a cluster (`plan`, one `trial`
//! per Kubernetes index, `collect`; `k8s` prints the Indexed Job).
//!
//! A study directory holds `study.json` (the state), `study.toml` and
//! `base.toml` (copies of the study file and the full base configuration,
//! so pods, child processes and later sessions need nothing else),
//! `trials/NNNN/` (one run directory per trial; for PBT one per member and
//! round, `trials/NNNN/round-RRR/`), and the outputs `trials.csv`,
//! `trials.json`, `best.toml` (the best overrides), `best-config.toml` (the
//! base with them merged: a complete `learner train --config` file),
//! `objective.png`, `params.png`, and for PBT `pbt.csv` (the lineage) and
//! `pbt-schedule.csv` (the best member's hyperparameters by round).

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use buridan_experiment::process::ProcessRunner;
use buridan_experiment::trial::{EvalProtocol, LearnerRunner, TrialDisplay};
pub use buridan_experiment::tune::{
    load_study_dir, load_study_file, resolve_relative, save_copies, trial_lines, write_outputs,
    BASE_FILE, BEST_CONFIG_FILE, STUDY_FILE,
};
use buridan_study::scheduler::SchedulerKind;
use buridan_study::state::{StudyState, TrialStatus};
use buridan_study::{Study, TrialRunner};
use indicatif::{MultiProgress, ProgressDrawTarget};

use crate::trial_bars::TrialBars;

/// Arguments of `learner tune`.
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct TuneArgs {
    /// Cluster steps: plan, trial, collect, k8s.
    #[command(subcommand)]
    pub command: Option<TuneCommand>,
    /// The study file (examples in `learner/studies/`).
    pub study: Option<PathBuf>,
    /// The study directory.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Trials at once (overrides the file's `parallel`).
    #[arg(long)]
    pub parallel: Option<usize>,
    /// Continue the study in `--out` (finished trials are not rerun).
    #[arg(long)]
    pub resume: bool,
    /// Episodes of the seed-42 evaluation (eval objectives).
    #[arg(long, default_value_t = 100)]
    pub eval_episodes: usize,
    /// No progress bars (log lines only).
    #[arg(long)]
    pub quiet: bool,
    /// Where trials train: `thread` (in this process) or `process` (one
    /// `learner train` child each: a crashing trial fails alone).
    #[arg(long, value_enum, default_value_t = RunnerKind::Thread)]
    pub runner: RunnerKind,
    /// The `learner` executable `--runner process` starts (default: this one).
    #[arg(long, value_name = "PATH")]
    pub learner_exe: Option<PathBuf>,
}

/// Where `learner tune` trains its trials.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum RunnerKind {
    /// In this process, one thread per running trial.
    #[default]
    Thread,
    /// One `learner train` child process per running trial.
    Process,
}

/// The cluster path of `learner tune`.
#[derive(Debug, clap::Subcommand)]
pub enum TuneCommand {
    /// Sample trials into a study directory on a shared volume, without running them.
    Plan {
        /// The study file.
        study: PathBuf,
        /// The study directory (created; an existing study is extended).
        #[arg(long)]
        out: PathBuf,
        /// Trials to plan (default: all the file's trials not planned yet).
        #[arg(long)]
        trials: Option<u64>,
    },
    /// Run one planned trial (what one pod of the Indexed Job does).
    Trial {
        /// The study directory.
        dir: PathBuf,
        /// Trial index (Kubernetes sets JOB_COMPLETION_INDEX).
        #[arg(long, env = "JOB_COMPLETION_INDEX")]
        index: u64,
        /// Episodes of the seed-42 evaluation (eval objectives).
        #[arg(long, default_value_t = 100)]
        eval_episodes: usize,
    },
    /// Read finished trials' results into the study and write its outputs.
    Collect {
        /// The study directory.
        dir: PathBuf,
    },
    /// Print the Kubernetes Indexed Job running the planned trials of a study.
    K8s {
        /// The study directory (as planned locally).
        dir: PathBuf,
        /// Container image whose entrypoint is `learner`.
        #[arg(long, default_value = "buridan/learner:dev")]
        image: String,
        /// The study directory as the pods see it (default: the mount path).
        #[arg(long)]
        pod_dir: Option<String>,
        /// Pods at once (default: all).
        #[arg(long)]
        parallelism: Option<u32>,
        /// PersistentVolumeClaim of the shared volume.
        #[arg(long, default_value = "buridan-study")]
        claim: String,
        /// Mount path of the volume in the pods.
        #[arg(long, default_value = "/study")]
        mount: String,
        /// CPU per pod.
        #[arg(long, default_value = "1")]
        cpu: String,
        /// Memory per pod.
        #[arg(long, default_value = "2Gi")]
        memory: String,
        /// Namespace.
        #[arg(long)]
        namespace: Option<String>,
    },
}

/// Runs `learner tune`.
pub fn run(args: &TuneArgs) -> Result<StudyState> {
    if let Some(command) = &args.command {
        return run_command(command);
    }
    let (Some(file), Some(out)) = (&args.study, &args.out) else {
        bail!("usage: learner tune STUDY.toml --out DIR [--parallel N] [--resume] (or plan|trial|collect|k8s)");
    };
    let (mut config, base) = load_study_file(file)?;
    if let Some(p) = args.parallel {
        if p == 0 {
            bail!("--parallel must be at least 1");
        }
        config.parallel = p;
    }
    if out.join(buridan_study::state::STATE_FILE).exists() && !args.resume {
        bail!(
            "{} already holds a study; pass --resume to continue it, or choose another --out",
            out.display()
        );
    }
    let _lock = buridan_study::lock::DirLock::acquire(out)?;
    save_copies(out, file, &base)?;
    let mut study = Study::open(out, config.clone())?;
    let multi = MultiProgress::with_draw_target(if args.quiet {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    });
    let say = |line: String| {
        if args.quiet || multi.is_hidden() {
            eprintln!("{line}");
        } else {
            let _ = multi.println(line);
        }
    };
    let before = study.progress();
    let plan = match &config.scheduler {
        SchedulerKind::Pbt { interval_steps, .. } => format!(
            "PBT: {} members in rounds of {interval_steps} env steps, {} rounds done",
            config.trials,
            study.state().pbt.as_ref().map_or(0, |p| p.rounds_done)
        ),
        _ => format!("{} trials", config.trials),
    };
    say(format!(
        "study `{}`: {plan} of {} env steps, {} sampler, {} at once ({}), objective {}; {} finished already -> {}",
        config.name,
        config.steps_per_trial,
        format!("{:?}", config.sampler).to_lowercase(),
        config.parallel,
        format!("{:?}", args.runner).to_lowercase(),
        config.objective.name(),
        before.completed + before.stopped + before.failed,
        out.display()
    ));
    let eval = EvalProtocol {
        episodes: args.eval_episodes,
        ..EvalProtocol::default()
    };
    let display =
        (!args.quiet).then(|| Arc::new(TrialBars(multi.clone())) as Arc<dyn TrialDisplay>);
    let runner: Box<dyn TrialRunner> = match args.runner {
        RunnerKind::Thread => {
            // Trials in threads share the cores by plan, as a study's runs.
            buridan_learner::train::cores::plan_runs(config.parallel);
            Box::new(LearnerRunner {
                base: base.clone(),
                eval,
                display,
            })
        }
        RunnerKind::Process => {
            let exe = match &args.learner_exe {
                Some(exe) => exe.clone(),
                None => std::env::current_exe().context("locating the learner executable")?,
            };
            Box::new(ProcessRunner {
                eval,
                display,
                ..ProcessRunner::new(exe, out.join(BASE_FILE), base.clone())
            })
        }
    };
    let started = Instant::now();
    let progress = study.run(runner.as_ref())?;
    let files = write_outputs(&study, &base)?;
    for line in trial_lines(study.state()) {
        say(line);
    }
    say(format!(
        "{} completed, {} stopped early, {} failed, {} interrupted; {} started in {:.0} s",
        progress.completed,
        progress.stopped,
        progress.failed,
        progress.interrupted,
        progress.started_now,
        started.elapsed().as_secs_f64()
    ));
    if let Some(best) = study.state().best() {
        say(format!(
            "best: trial {} ({}) -> {}",
            best.id,
            buridan_study::overrides::describe(&best.overrides),
            out.join(BEST_CONFIG_FILE).display()
        ));
    }
    tracing::info!(files = ?files, "study outputs");
    Ok(study.state().clone())
}

fn run_command(command: &TuneCommand) -> Result<StudyState> {
    match command {
        TuneCommand::Plan { study, out, trials } => {
            let (config, base) = load_study_file(study)?;
            save_copies(out, study, &base)?;
            let mut s = Study::open(out, config.clone())?;
            let count = trials.unwrap_or(config.trials);
            let ids = s.plan(count)?;
            eprintln!(
                "planned {} trials ({}) in {}; run each with `learner tune trial {} --index I`, then `learner tune collect {}`",
                ids.len(),
                match (ids.first(), ids.last()) {
                    (Some(a), Some(b)) => format!("indices {a}..={b}"),
                    _ => "none".into(),
                },
                out.display(),
                out.display(),
                out.display()
            );
            Ok(s.state().clone())
        }
        TuneCommand::Trial {
            dir,
            index,
            eval_episodes,
        } => {
            let (config, base) = load_study_dir(dir)?;
            let runner = LearnerRunner {
                eval: EvalProtocol {
                    episodes: *eval_episodes,
                    ..EvalProtocol::default()
                },
                ..LearnerRunner::new(base)
            };
            let result = buridan_study::batch::run_trial(dir, *index, &runner)?;
            match &result.outcome {
                Ok(m) => eprintln!(
                    "trial {index}: {} = {:?} after {} steps ({:.0} s)",
                    config.objective.name(),
                    config.objective.score(m).map(|s| s.value),
                    m.step,
                    result.seconds
                ),
                Err(e) => bail!("trial {index} failed: {e}"),
            }
            Ok(buridan_study::state::StudyState::load(dir)?
                .unwrap_or_else(|| StudyState::new(&config)))
        }
        TuneCommand::Collect { dir } => {
            let (config, base) = load_study_dir(dir)?;
            let mut study = Study::open(dir, config)?;
            let n = study.collect()?;
            write_outputs(&study, &base)?;
            for line in trial_lines(study.state()) {
                eprintln!("{line}");
            }
            let waiting = study
                .state()
                .trials
                .iter()
                .filter(|t| t.status == TrialStatus::Planned)
                .count();
            eprintln!("collected {n} trials; {waiting} still planned");
            Ok(study.state().clone())
        }
        TuneCommand::K8s {
            dir,
            image,
            pod_dir,
            parallelism,
            claim,
            mount,
            cpu,
            memory,
            namespace,
        } => {
            let (config, _) = load_study_dir(dir)?;
            let state = StudyState::load(dir)?.unwrap_or_else(|| StudyState::new(&config));
            let planned = state.trials.len() as u32;
            if planned == 0 {
                bail!(
                    "{} has no planned trials: run `learner tune plan` first",
                    dir.display()
                );
            }
            let pod_dir = pod_dir.clone().unwrap_or_else(|| mount.clone());
            let name: String = format!("tune-{}", config.name)
                .to_ascii_lowercase()
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
                .take(63)
                .collect::<String>()
                .trim_end_matches('-')
                .to_string();
            let mut job = buridan_study::k8s::IndexedJob::new(
                &name,
                image,
                vec![
                    "tune".into(),
                    "trial".into(),
                    pod_dir,
                    "--index={index}".into(),
                ],
                planned,
            );
            job.parallelism = parallelism.unwrap_or(planned).max(1);
            job.volume_claim = claim.clone();
            job.mount_path = mount.clone();
            job.cpu = cpu.clone();
            job.memory = memory.clone();
            job.namespace = namespace.clone();
            print!("{}", job.to_yaml()?);
            Ok(state)
        }
    }
}
