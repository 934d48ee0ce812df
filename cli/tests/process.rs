//! Trials as real `learner train` child processes (`learner tune --runner
//! process`): progress, a stop with a checkpoint and its resume, crashing
//! children as failed trials of a study that goes on, and PBT end to end
//! with either runner.

mod common;

use std::path::{Path, PathBuf};

use buridan_cli::process::{ProcessRunner, LOG_FILE};
use buridan_cli::trial::EvalProtocol;
use buridan_cli::tune::{self, RunnerKind, TuneArgs};
use buridan_learner::train::{MetricsRow, Summary, TrainConfig};
use buridan_policy::checkpoint;
use buridan_study::{Decision, Measurement, Objective, Reporter, Study, StudyConfig, TrialSpec};

/// The `learner` binary cargo built for these tests.
fn learner() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_learner"))
}

/// The shared tiny PPO config on rm-1.1, written into `dir`, and parsed.
fn tiny_base(dir: &Path) -> (PathBuf, TrainConfig) {
    let path = common::tiny_config(dir);
    let cfg = TrainConfig::from_toml_file(&path).unwrap();
    (path, cfg)
}

struct StopAfter {
    reports: Vec<Measurement>,
    stop_at: usize,
}

impl Reporter for StopAfter {
    fn report(&mut self, m: &Measurement) -> Decision {
        self.reports.push(m.clone());
        if self.reports.len() >= self.stop_at {
            Decision::Stop
        } else {
            Decision::Continue
        }
    }
}

#[test]
fn a_child_trial_reports_progress_stops_with_a_checkpoint_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let (file, base) = tiny_base(dir.path());
    let runner = ProcessRunner {
        eval: EvalProtocol {
            episodes: 3,
            seed: 42,
        },
        ..ProcessRunner::new(learner(), file, base)
    };
    let run_dir = dir.path().join("trial");
    // A budget the child cannot reach before the stop arrives.
    let spec = TrialSpec {
        id: 0,
        overrides: [("ppo.lr".to_string(), toml::Value::Float(3e-4))].into(),
        steps: 1_000_000,
        seed: 5,
        run_dir: run_dir.clone(),
        resume: false,
        start_from: None,
        objective: Objective::TrainSuccess,
    };
    let mut stop = StopAfter {
        reports: vec![],
        stop_at: 2,
    };
    let m = runner.run_trial(&spec, &mut stop).unwrap();
    assert_eq!(stop.reports.len(), 2, "no reports after the stop");
    assert_eq!(stop.reports[0].step, 1000);
    assert!(m.step >= stop.reports[1].step && m.step < 100_000, "{m:?}");
    let log = std::fs::read_to_string(run_dir.join(LOG_FILE)).unwrap();
    assert!(log.contains("interrupted after update"), "{log}");
    let stopped_at = checkpoint::resolve(&run_dir).unwrap();
    assert!(!run_dir.join("summary.json").exists());

    // Resumed, it continues from that checkpoint, then evaluates.
    let resumed = TrialSpec {
        resume: true,
        steps: m.step + 2000,
        objective: Objective::EvalGreedy,
        ..spec
    };
    let cmd = runner.command(&resumed, Some(&stopped_at));
    assert!(format!("{cmd:?}").contains("--resume"));
    let mut go = StopAfter {
        reports: vec![],
        stop_at: usize::MAX,
    };
    let m2 = runner.run_trial(&resumed, &mut go).unwrap();
    assert!(
        go.reports[0].step > m.step,
        "{:?} after {m:?}",
        go.reports[0]
    );
    assert!(m2.step >= m.step + 2000);
    assert!(m2.eval_greedy_success.is_some() && m2.eval_greedy_len.is_some());
    assert!(run_dir.join("eval-greedy/summary.json").is_file());
}

#[test]
fn crashing_children_are_failed_trials_with_their_stderr_and_the_study_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let (file, base) = tiny_base(dir.path());
    // Seed 0 panics, seed 1 is killed as the OOM killer would, seed 2 trains.
    let fake = dir.path().join("fake-learner");
    std::fs::write(
        &fake,
        format!(
            "#!/bin/sh\ncase \" $* \" in\n\
             *\" --seed 1 \"*) echo 'memory allocation of 1073741824 bytes failed' >&2; kill -9 $$ ;;\n\
             *\" --seed 2 \"*) exec '{}' \"$@\" ;;\n\
             esac\n\
             echo \"thread 'main' panicked at learner/src/train/mod.rs:1:1:\" >&2\n\
             echo 'simulated bug' >&2\n\
             exit 101\n",
            learner().display()
        ),
    )
    .unwrap();
    let mut perms = std::fs::metadata(&fake).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perms, 0o755);
    std::fs::set_permissions(&fake, perms).unwrap();
    let runner = ProcessRunner::new(fake, file, base);
    let config = StudyConfig::from_toml_str(
        "[study]\nname = \"crash\"\ntrials = 3\nparallel = 2\nsteps_per_trial = 2000\n[space]\n\"ppo.lr\" = { choice = [3e-4] }",
    )
    .unwrap();
    let out = dir.path().join("study");
    let mut study = Study::open(&out, config).unwrap();
    let p = study.run(&runner).unwrap();
    assert_eq!(
        (p.failed, p.completed),
        (2, 1),
        "{:?}",
        study.state().trials
    );
    let error = |i: usize| study.state().trials[i].error.clone().unwrap();
    assert!(error(0).contains("exit status: 101"), "{}", error(0));
    assert!(error(0).contains("simulated bug"), "{}", error(0));
    assert!(error(1).contains("signal: 9"), "{}", error(1));
    assert!(error(1).contains("memory allocation"), "{}", error(1));
    let done = &study.state().trials[2];
    assert!(done.score.is_some() && done.last.as_ref().unwrap().step >= 2000);
}

fn pbt_file(dir: &Path) -> PathBuf {
    let path = dir.join("pbt.toml");
    std::fs::write(
        &path,
        r#"
[study]
name = "tiny-pbt"
base_config = "tiny.toml"
sampler = "random"
parallel = 2
steps_per_trial = 4000
objective = "train_success"
[study.scheduler]
kind = "pbt"
interval_steps = 2000
[space]
"ppo.lr" = { log_uniform = [1e-4, 3e-3] }
"ppo.clip" = { choice = [0.1, 0.2, 0.3] }
"#,
    )
    .unwrap();
    path
}

fn first_row(run_dir: &Path) -> MetricsRow {
    csv::Reader::from_path(run_dir.join("metrics.csv"))
        .unwrap()
        .deserialize()
        .next()
        .unwrap()
        .unwrap()
}

#[test]
fn pbt_runs_end_to_end_with_either_runner() {
    for runner in [RunnerKind::Process, RunnerKind::Thread] {
        let dir = tempfile::tempdir().unwrap();
        tiny_base(dir.path());
        let out = dir.path().join("out");
        let args = TuneArgs {
            command: None,
            study: Some(pbt_file(dir.path())),
            out: Some(out.clone()),
            parallel: Some(1),
            resume: false,
            eval_episodes: 5,
            quiet: true,
            runner,
            learner_exe: Some(learner()),
        };
        let state = tune::run(&args).unwrap();
        let pbt = state.pbt.as_ref().unwrap();
        assert_eq!(pbt.rounds_done, 2, "{runner:?}");
        assert_eq!(
            pbt.lineage.len(),
            1,
            "{runner:?}: 2 members, one copies the other"
        );
        let e = &pbt.lineage[0];
        for t in &state.trials {
            assert_eq!(t.status.name(), "completed", "{runner:?}: {t:?}");
            assert!(t.last.as_ref().unwrap().step >= 4000);
        }
        // The copier's second round continued the source's run: its counters
        // (updates, env steps) go on from the source's first round.
        let summary = |run: &Path| -> Summary {
            serde_json::from_str(&std::fs::read_to_string(run.join("summary.json")).unwrap())
                .unwrap()
        };
        let source = summary(&out.join(buridan_study::lineage::round_dir(e.source, 0)));
        assert_eq!(source.env_steps, e.step);
        let copier = out.join(buridan_study::lineage::round_dir(e.trial, 1));
        let row = first_row(&copier);
        assert_eq!(row.update, source.updates + 1, "{runner:?}");
        assert!(row.env_steps > e.step);
        assert!(summary(&copier).env_steps >= 4000);
        let cfg = TrainConfig::from_toml_file(&copier.join("config.toml")).unwrap();
        assert_eq!(
            Some(cfg.algorithm.ppo().unwrap().lr),
            e.overrides["ppo.lr"].as_float()
        );
        assert_eq!(
            (runner == RunnerKind::Process),
            copier.join(LOG_FILE).is_file()
        );
        for f in ["pbt.csv", "pbt-schedule.csv", "best-config.toml"] {
            assert!(out.join(f).is_file(), "{runner:?}: {f}");
        }
    }
}
