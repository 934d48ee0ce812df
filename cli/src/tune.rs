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

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use buridan_learner::train::TrainConfig;
use buridan_study::scheduler::SchedulerKind;
use buridan_study::state::{StudyState, TrialStatus};
use buridan_study::{Study, StudyConfig, TrialRunner};
use indicatif::{MultiProgress, ProgressDrawTarget};

use crate::process::ProcessRunner;
use crate::trial::{apply_overrides, EvalProtocol, LearnerRunner};

/// The copy of the study file inside a study directory.
pub const STUDY_FILE: &str = "study.toml";
/// The full base configuration inside a study directory.
pub const BASE_FILE: &str = "base.toml";
/// The best configuration merged into the base.
pub const BEST_CONFIG_FILE: &str = "best-config.toml";

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

/// A path named in a file: absolute, else relative to the working
/// directory if it exists there, else relative to the file's directory.
///
/// ```
/// use std::path::Path;
/// let p = buridan_cli::tune::resolve_relative(Path::new("/a/b/study.toml"), "../c.toml");
/// assert_eq!(p, Path::new("/a/b/../c.toml"));
/// ```
pub fn resolve_relative(file: &Path, named: &str) -> PathBuf {
    let p = PathBuf::from(named);
    if p.is_absolute() || p.exists() {
        return p;
    }
    file.parent().unwrap_or(Path::new(".")).join(p)
}

/// Reads a study file and its base configuration (defaults if none).
pub fn load_study_file(path: &Path) -> Result<(StudyConfig, TrainConfig)> {
    let config = StudyConfig::from_file(path).with_context(|| format!("{}", path.display()))?;
    let base = match &config.base_config {
        Some(b) => {
            let p = resolve_relative(path, b);
            TrainConfig::from_toml_file(&p)
                .with_context(|| format!("{}: base_config", path.display()))?
        }
        None => TrainConfig::default(),
    };
    // Every key of the space must be a configuration key: check with a sample now.
    let sample: buridan_study::Overrides = config
        .space
        .params()
        .iter()
        .map(|p| {
            let (low, _) = p.domain.internal_bounds();
            (p.key.clone(), p.domain.value_at(low))
        })
        .collect();
    apply_overrides(&base, &sample).with_context(|| {
        format!(
            "{}: [space] does not fit the base configuration",
            path.display()
        )
    })?;
    Ok((config, base))
}

/// Reads a study directory's copies of the study file and base configuration.
pub fn load_study_dir(dir: &Path) -> Result<(StudyConfig, TrainConfig)> {
    let study = dir.join(STUDY_FILE);
    let config = StudyConfig::from_file(&study).with_context(|| {
        format!(
            "{} is not a study directory (no readable {STUDY_FILE})",
            dir.display()
        )
    })?;
    let base = TrainConfig::from_toml_file(&dir.join(BASE_FILE))?;
    Ok((config, base))
}

fn save_copies(dir: &Path, study_file: &Path, base: &TrainConfig) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let text = std::fs::read_to_string(study_file)?;
    std::fs::write(dir.join(STUDY_FILE), text)?;
    std::fs::write(dir.join(BASE_FILE), base.to_toml())?;
    Ok(())
}

/// Writes the study's outputs and `best-config.toml`; returns the files.
pub fn write_outputs(study: &Study, base: &TrainConfig) -> Result<Vec<PathBuf>> {
    let mut files = study.write_outputs()?;
    if let Some(best) = study.state().best() {
        let cfg = apply_overrides(base, &best.overrides)?;
        let path = study.dir().join(BEST_CONFIG_FILE);
        let header = format!(
            "# Best trial {} of study `{}` ({}) merged into its base configuration.\n",
            best.id,
            study.config().name,
            best.run_dir.display()
        );
        std::fs::write(&path, header + &cfg.to_toml())?;
        files.push(path);
    }
    Ok(files)
}

/// One line per trial: id, status, objective, overrides.
pub fn trial_lines(state: &StudyState) -> Vec<String> {
    state
        .trials
        .iter()
        .map(|t| {
            format!(
                "trial {:>3} {:<11} objective {:>7} len {:>6} after {:>9} steps  {}{}",
                t.id,
                t.status.name(),
                t.score
                    .map(|s| format!("{:.3}", s.value))
                    .unwrap_or_else(|| "-".into()),
                t.score
                    .and_then(|s| s.episode_len)
                    .map(|l| format!("{l:.1}"))
                    .unwrap_or_else(|| "-".into()),
                t.last.as_ref().map(|m| m.step).unwrap_or(0),
                buridan_study::overrides::describe(&t.overrides),
                t.error
                    .as_ref()
                    .map(|e| format!("  error: {e}"))
                    .unwrap_or_default()
            )
        })
        .collect()
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
    let bars = (!args.quiet).then(|| multi.clone());
    let runner: Box<dyn TrialRunner> = match args.runner {
        RunnerKind::Thread => Box::new(LearnerRunner {
            base: base.clone(),
            eval,
            bars,
        }),
        RunnerKind::Process => {
            let exe = match &args.learner_exe {
                Some(exe) => exe.clone(),
                None => std::env::current_exe().context("locating the learner executable")?,
            };
            Box::new(ProcessRunner {
                eval,
                bars,
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
