//! `learner tune` and `learner study` end to end, in process, on tiny budgets.

use std::path::{Path, PathBuf};

mod common;

use common::tiny_config;

use buridan_cli::study::{self, StudyArgs, StudyCommand};
use buridan_cli::tune::{self, TuneArgs};

fn tune_file(dir: &Path, trials: u64) -> PathBuf {
    let path = dir.join("tune.toml");
    std::fs::write(
        &path,
        format!(
            r#"
[study]
name = "tiny"
base_config = "tiny.toml"
sampler = "random"
trials = {trials}
steps_per_trial = 2000
objective = "train_success"
[space]
"ppo.lr" = {{ choice = [3e-4, 1e-3] }}
"ppo.clip" = {{ uniform = [0.05, 0.3] }}
"#
        ),
    )
    .unwrap();
    path
}

fn tune_args(file: PathBuf, out: PathBuf, resume: bool) -> TuneArgs {
    TuneArgs {
        command: None,
        study: Some(file),
        out: Some(out),
        parallel: Some(1),
        resume,
        eval_episodes: 5,
        quiet: true,
        runner: tune::RunnerKind::Thread,
        learner_exe: None,
    }
}

#[test]
fn a_tiny_tune_writes_its_outputs_and_resumes_without_rerunning_trials() {
    let dir = tempfile::tempdir().unwrap();
    tiny_config(dir.path());
    let out = dir.path().join("tune-out");
    let state = tune::run(&tune_args(tune_file(dir.path(), 2), out.clone(), false)).unwrap();
    assert_eq!(state.trials.len(), 2);
    for t in &state.trials {
        assert_eq!(t.status.name(), "completed", "{t:?}");
        assert!(t.score.is_some() && t.last.as_ref().unwrap().step >= 2000);
        assert!(out.join(&t.run_dir).join("summary.json").is_file());
        assert!(out.join(&t.run_dir).join("metrics.csv").is_file());
    }
    for f in [
        "trials.csv",
        "trials.json",
        "best.toml",
        "best-config.toml",
        "objective.png",
        "params.png",
        "study.toml",
        "base.toml",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let csv = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.lines().next().unwrap().contains("ppo.lr"), "{csv}");
    // The merged best config is a complete config with the best overrides.
    let best =
        buridan_learner::train::TrainConfig::from_toml_file(&out.join("best-config.toml")).unwrap();
    let b = state.best().unwrap();
    let best_ppo = best.algorithm.ppo().unwrap();
    assert_eq!(Some(best_ppo.lr), b.overrides["ppo.lr"].as_float());
    assert_eq!((best.task.grid_map(), best_ppo.epochs), (Some("rm-1.1"), 2));

    // Without --resume, the directory is refused.
    let e = tune::run(&tune_args(tune_file(dir.path(), 2), out.clone(), false)).unwrap_err();
    assert!(format!("{e:#}").contains("--resume"), "{e:#}");
    // With --resume and one more trial: only the new one runs.
    let again = tune::run(&tune_args(tune_file(dir.path(), 3), out.clone(), true)).unwrap();
    assert_eq!(again.trials.len(), 3);
    for (old, new) in state.trials.iter().zip(&again.trials) {
        assert_eq!(
            (new.starts, new.seconds),
            (old.starts, old.seconds),
            "trial {} reran",
            old.id
        );
    }
    assert_eq!(again.trials[2].starts, 1);
}

#[test]
fn bad_study_files_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    tiny_config(dir.path());
    let cases = [
        ("[study]\nname = \"x\"\ntrials = 0\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }", "trials"),
        ("[study]\nname = \"x\"\nbase_config = \"tiny.toml\"\ntrials = 1\nsteps_per_trial = 1\n[space]\n\"ppo.nope\" = { int = [1, 2] }", "ppo.nope"),
        ("[study]\nname = \"x\"\nbase_config = \"missing.toml\"\ntrials = 1\nsteps_per_trial = 1\n[space]\n\"ppo.lr\" = { uniform = [0.1, 0.2] }", "missing.toml"),
        ("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\n\"ppo.lr\" = { uniform = [0.3, 0.2] }", "ppo.lr"),
    ];
    for (i, (text, needle)) in cases.into_iter().enumerate() {
        let file = dir.path().join(format!("bad-{i}.toml"));
        std::fs::write(&file, text).unwrap();
        let e = tune::run(&tune_args(
            file.clone(),
            dir.path().join(format!("o{i}")),
            false,
        ))
        .unwrap_err();
        let msg = format!("{e:#}");
        assert!(msg.contains(&file.display().to_string()), "{msg}");
        assert!(msg.contains(needle), "{needle}: {msg}");
    }
    // Same for experiment files.
    let file = dir.path().join("bad-experiment.toml");
    std::fs::write(
        &file,
        "[experiment]\nname = \"x\"\nlayouts = [\"rm-1.1\"]\nseeds = 2\nplanners = [\"dijkstra\"]",
    )
    .unwrap();
    let e = study::run(&StudyArgs {
        command: None,
        experiment: Some(file.clone()),
        out: Some(dir.path().join("x")),
        parallel: None,
        quiet: true,
    })
    .unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains(&file.display().to_string()) && msg.contains("dijkstra"),
        "{msg}"
    );
}

#[test]
fn a_directory_in_use_is_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    tiny_config(dir.path());
    let out = dir.path().join("busy");
    // Another `learner tune` or `learner study` holding the directory.
    let held = buridan_study::lock::DirLock::acquire(&out).unwrap();
    let tune_err = tune::run(&tune_args(tune_file(dir.path(), 1), out.clone(), false)).unwrap_err();
    let study_args = StudyArgs {
        out: Some(out.clone()),
        ..tiny_experiment(
            dir.path(),
            r#"
[experiment]
name = "x"
layouts = ["rm-1.1"]
seeds = 1
steps = 2000
[experiment.eval]
episodes = 5
[[method]]
name = "ppo"
config = "tiny.toml"
"#,
        )
    };
    let study_err = study::run(&study_args).unwrap_err();
    for e in [tune_err, study_err] {
        let msg = format!("{e:#}");
        assert!(
            msg.contains("in use") && msg.contains(&std::process::id().to_string()),
            "{msg}"
        );
    }
    // Nothing ran: no trial, no plan, no copies — only the lock file.
    let entries: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(entries, [buridan_study::lock::LOCK_FILE]);
    drop(held);
    // Free again: the study runs.
    study::run(&study_args).unwrap();
    assert!(out.join("plan.json").is_file());
}

/// A study of `experiment` (TOML) over the tiny PPO config, written into
/// `dir`: its arguments, one cell at a time, output in `dir/out`.
fn tiny_experiment(dir: &Path, experiment: &str) -> StudyArgs {
    tiny_config(dir);
    let file = dir.join("experiment.toml");
    std::fs::write(&file, experiment).unwrap();
    StudyArgs {
        command: None,
        experiment: Some(file),
        out: Some(dir.join("out")),
        parallel: Some(1),
        quiet: true,
    }
}

#[test]
fn a_tiny_study_aggregates_seeds_and_planners_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let args = tiny_experiment(
        dir.path(),
        r#"
[experiment]
name = "tiny"
layouts = ["rm-1.1"]
seeds = 2
steps = 2000
planners = ["cbs"]
[experiment.eval]
episodes = 4
starts = "random"
time_limit = 5.0
[[method]]
name = "ppo"
config = "tiny.toml"
"#,
    );
    let out = args.out.clone().unwrap();
    let first = study::run(&args).unwrap();
    assert_eq!(first.jobs_run, 3, "2 training cells + 1 planner evaluation");
    for f in [
        "table.md",
        "table.csv",
        "table.json",
        "cells.json",
        "cells.csv",
        "plan.json",
        "success.png",
        "timesteps.png",
        "learning-rm-1.1.png",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    // One layout, no agent sweep: no heatmaps.
    assert!(!out.join("heatmap.png").exists() && !out.join("heatmap-rm-1.1.png").exists());
    let csv = std::fs::read_to_string(out.join("table.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert!(
        lines[0].contains("success %_low") && lines[0].contains("success %_high"),
        "{csv}"
    );
    assert!(lines[0].contains("success % (IQM)_low"), "{csv}");
    assert_eq!(lines.len(), 4, "ppo sampled, ppo greedy, cbs: {csv}");
    assert!(lines[1].starts_with("rm-1.1,ppo,sampled,2,2/2,"), "{csv}");
    assert!(lines[2].starts_with("rm-1.1,ppo,greedy,2,2/2,"), "{csv}");
    assert!(lines[3].starts_with("rm-1.1,cbs,plan,2,1/1,"), "{csv}");
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(md.contains("| rm-1.1 | ppo | sampled | 2 | 2/2 |"), "{md}");
    let cells: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("cells.json")).unwrap()).unwrap();
    let cells = cells.as_array().unwrap();
    assert_eq!(cells.len(), 5);
    for c in cells {
        assert!(c["success_rate"].is_number(), "{c}");
        assert!(c["eval_command"]
            .as_str()
            .unwrap()
            .starts_with("learner eval --map rm-1.1"));
        if c["kind"] == "policy" {
            let cmd = c["train_command"].as_str().unwrap();
            assert!(
                cmd.starts_with("learner train --config") && cmd.contains("--steps 2000"),
                "{cmd}"
            );
            assert!(Path::new(c["run_dir"].as_str().unwrap())
                .join("summary.json")
                .is_file());
        }
    }
    let png = std::fs::read(out.join("success.png")).unwrap();
    assert_eq!(&png[..4], b"\x89PNG");

    // Everything is finished: a second invocation runs nothing.
    assert_eq!(study::run(&args).unwrap().jobs_run, 0);
    // `learner study report DIR` re-aggregates from the files.
    std::fs::remove_file(out.join("table.csv")).unwrap();
    let report = study::run(&StudyArgs {
        command: Some(StudyCommand::Report { dir: out.clone() }),
        experiment: None,
        out: None,
        parallel: None,
        quiet: true,
    })
    .unwrap();
    assert!(report.files.iter().any(|f| f.ends_with("table.csv")));
    assert_eq!(std::fs::read_to_string(out.join("table.csv")).unwrap(), csv);

    // Finished cells copied without checkpoints (as results are kept from
    // another machine) are skipped while their evaluations are complete...
    let run = out.join("runs/rm-1.1/ppo/seed-0");
    std::fs::remove_dir_all(run.join("checkpoints")).unwrap();
    assert_eq!(study::run(&args).unwrap().jobs_run, 0);
    // ...and trained again when one still needs the policy.
    let greedy = out.join("evals/rm-1.1/ppo/seed-0/greedy");
    assert!(greedy.is_dir(), "{}", greedy.display());
    std::fs::remove_dir_all(&greedy).unwrap();
    assert_eq!(study::run(&args).unwrap().jobs_run, 1);
    assert!(run.join("checkpoints").is_dir() && greedy.is_dir());
}

#[test]
fn a_tiny_generalization_study_reports_each_layout_and_the_mean() {
    let dir = tempfile::tempdir().unwrap();
    let args = tiny_experiment(
        dir.path(),
        r#"
[experiment]
name = "tiny-generalization"
layouts = ["rm-1.1:1,rm-1.2:1"]
seeds = 2
steps = 2000
[experiment.eval]
episodes = 4
starts = "random"
actions = ["sampled"]
layouts = ["rm-1.1", "rm-1.2", "rm-1.3"]
[[method]]
name = "ppo"
config = "tiny.toml"
set = ["starts=\"random\""]
"#,
    );
    let out = args.out.clone().unwrap();
    assert_eq!(study::run(&args).unwrap().jobs_run, 2);
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("runs/rm-1.1_1+rm-1.2_1/ppo/seed-1/summary.json"))
            .unwrap(),
    )
    .unwrap();
    assert_eq!(summary["maps"], serde_json::json!(["rm-1.1", "rm-1.2"]));
    let mut csv = csv::Reader::from_path(out.join("table.csv")).unwrap();
    let header: Vec<String> = csv.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(header[..3], ["layout", "trained on", "method"]);
    let rows: Vec<csv::StringRecord> = csv.records().map(Result::unwrap).collect();
    let layouts: Vec<&str> = rows.iter().map(|r| &r[0]).collect();
    assert_eq!(layouts, ["rm-1.1", "rm-1.2", "rm-1.3", "mean"]);
    assert!(
        rows.iter().all(|r| &r[1] == "rm-1.1:1,rm-1.2:1"),
        "{rows:?}"
    );
    // The mean row is the mean over layouts of each seed's success.
    let cells: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("cells.json")).unwrap()).unwrap();
    let rates: Vec<f64> = cells
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["success_rate"].as_f64().unwrap())
        .collect();
    assert_eq!(rates.len(), 2 * 3);
    let mean = 100.0 * rates.iter().sum::<f64>() / 6.0;
    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("table.json")).unwrap()).unwrap();
    let text = table.to_string();
    assert!(text.contains("\"mean\""), "{text}");
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    let mean_row = md.lines().find(|l| l.starts_with("| mean |")).unwrap();
    assert!(mean_row.contains("| 2/2 |"), "{mean_row}");
    assert!(
        mean_row.contains(&format!("{mean:.1}")),
        "{mean:.1} in {mean_row}"
    );
    assert!(out.join("success.png").is_file());
    // Layouts side by side: the success heatmap.
    assert!(out.join("heatmap.png").is_file());
}

#[test]
fn an_agent_sweep_writes_scalability_figures() {
    let dir = tempfile::tempdir().unwrap();
    let args = tiny_experiment(
        dir.path(),
        r#"
[experiment]
name = "sweep"
layouts = ["rm-2.1"]
seeds = 1
steps = 2000
planners = ["cbs"]
[experiment.eval]
episodes = 3
actions = ["greedy", "bss@backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:"]
agents = [2, 3]
time_limit = 5.0
[[method]]
name = "ppo"
config = "tiny.toml"
"#,
    );
    let out = args.out.clone().unwrap();
    let outcome = study::run(&args).unwrap();
    assert!(outcome.failures.is_empty(), "{:?}", outcome.failures);
    // The composed action: a backstop over the sampled shield with goal
    // settling and one-way lanes, in its own folder, its command as
    // `learner eval` takes it.
    let bss = out.join("evals/rm-2.1/ppo/seed-0/bss/agents-3");
    let command = std::fs::read_to_string(bss.join("command.txt")).unwrap();
    assert!(
        command.contains("--controller 'backstop:shield[patience=16,settle,lanes]:checkpoint:")
            && command.contains("--sample --time-limit 1 "),
        "{command}"
    );
    assert!(bss.join("summary.json").is_file());
    for f in [
        "scalability-rm-2.1.png",
        "heatmap-rm-2.1.png",
        "timesteps.png",
    ] {
        let png = std::fs::read(out.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(&png[..4], b"\x89PNG", "{f}");
    }
    // CBS solves these small instances: its timesteps are in the box plot's data.
    let cells: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("cells.json")).unwrap()).unwrap();
    let cbs_solved = cells
        .as_array()
        .unwrap()
        .iter()
        .any(|c| c["method"] == "cbs" && c["success_rate"].as_f64().unwrap() > 0.0);
    assert!(cbs_solved, "{cells}");
}

#[test]
fn the_shipped_study_and_experiment_files_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../learner/studies");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if name.starts_with("tune-") || name.starts_with("pbt-") {
            let (config, base) =
                tune::load_study_file(&path).unwrap_or_else(|e| panic!("{name}: {e:#}"));
            assert!(config.trials > 0 && base.run.steps > 0, "{name}");
            seen += 1;
        } else if name.ends_with(".toml") {
            let x = buridan_cli::experiment::Experiment::from_file(&path)
                .unwrap_or_else(|e| panic!("{name}: {e:#}"));
            assert!(x.eval.episodes >= 100, "{name}: at least 100 episodes");
            if x.methods.is_empty() {
                // Planners only: deterministic, one evaluation each.
                use buridan_cli::experiment::Evaluated;
                assert!(!x.planners.is_empty(), "{name}");
                assert!(
                    x.evals.iter().all(|e| e.evaluated == Evaluated::Planner),
                    "{name}"
                );
                seen += 1;
                continue;
            }
            assert!(x.seeds.len() >= 10, "{name}: at least 10 seeds");
            // Sampled and greedy always (the dissertation's and ours),
            // shielded where a study adds it.
            let named = |name: &str| x.eval.actions.iter().any(|a| a.name() == name);
            assert!(
                named("sampled") && named("greedy") && x.eval.episodes >= 100,
                "{name}"
            );
            seen += 1;
        }
    }
    assert!(seen >= 10, "{seen} files");
}
