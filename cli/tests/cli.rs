//! The `learner train` and `learner eval` commands end to end, in process.

mod common;

use std::path::{Path, PathBuf};

use buridan_cli::eval::{self, EvalArgs};
use buridan_cli::train;
use buridan_env::Starts;
use buridan_learner::train::Task;
use buridan_policy::Mode;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("buridan-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn eval_args(controller: String, out: PathBuf) -> EvalArgs {
    let out = out.display().to_string();
    common::eval_args(&[
        "--map",
        "rm-1.1",
        "--agents",
        "2",
        "--episodes",
        "3",
        "--controller",
        &controller,
        "--starts",
        "fixed",
        "--t-max",
        "100",
        "--time-limit",
        "10",
        "--memory-limit",
        "256",
        "--out",
        &out,
    ])
}

#[test]
fn train_writes_its_outputs_and_eval_loads_the_checkpoint() {
    let out = temp_dir("train");
    let summary = train::run(&common::train_args(out.clone())).unwrap();
    assert!(summary.env_steps >= 3000, "{}", summary.env_steps);
    for file in [
        "metrics.csv",
        "summary.json",
        "config.toml",
        "learning_curve.png",
        "success_curve.png",
    ] {
        assert!(out.join(file).is_file(), "missing {file}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for field in [
        "env_steps",
        "wall_seconds",
        "episode_return_mean",
        "success_rate",
    ] {
        assert!(json[field].is_number(), "summary.json lacks {field}");
    }
    let metrics = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert!(
        metrics.lines().count() >= 3,
        "header + one row per update (3 updates of 1000 steps)"
    );
    assert!(out.join("checkpoints/final/spec.json").is_file());
    let png = std::fs::read(out.join("learning_curve.png")).unwrap();
    assert_eq!(&png[..4], b"\x89PNG");

    // The same directory is refused without --resume, so no run is overwritten.
    let err = train::run(&common::train_args(out.clone())).unwrap_err();
    assert!(err.to_string().contains("--resume"), "{err}");
    // `--resume OUT` continues from OUT's newest checkpoint.
    let mut more = common::train_args(out.clone());
    (more.steps, more.resume) = (Some(4000), Some(out.clone()));
    let resumed = train::run(&more).unwrap();
    assert_eq!(resumed.updates, summary.updates + 1);
    assert!(resumed.env_steps >= 4000);
    // `--resume auto` starts fresh where there is no checkpoint yet.
    let fresh = temp_dir("train-auto");
    let mut auto = common::train_args(fresh.clone());
    auto.resume = Some("auto".into());
    assert_eq!(train::run(&auto).unwrap().updates, summary.updates);
    std::fs::remove_dir_all(fresh).ok();

    let eval_out = temp_dir("eval-ckpt");
    let summaries = eval::run(&eval_args(
        format!("checkpoint:{}", out.display()),
        eval_out.clone(),
    ))
    .unwrap();
    assert_eq!(summaries[0].episodes, 3);
    assert_eq!(summaries[0].controller, "ctde-policy");
    assert!(eval_out.join("episodes.csv").is_file() && eval_out.join("heatmap.png").is_file());
    // Greedy actions on the fixed scenario: every episode is identical.
    let csv = std::fs::read_to_string(eval_out.join("episodes.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert!(rows.windows(2).all(|w| w[0][1..4] == w[1][1..4]), "{csv}");
    // A CTDE policy runs with another agent count (the scalability sweep).
    let sweep_out = temp_dir("eval-sweep");
    let mut args = eval_args(format!("checkpoint:{}", out.display()), sweep_out.clone());
    (args.agents, args.starts) = (Some("2..3".into()), Starts::Random);
    let summaries = eval::run(&args).unwrap();
    assert_eq!(
        summaries.iter().map(|s| s.agents).collect::<Vec<_>>(),
        [2, 3]
    );
    assert!(sweep_out.join("sweep.csv").is_file() && sweep_out.join("sweep_success.png").is_file());
    for dir in [out, eval_out, sweep_out] {
        std::fs::remove_dir_all(dir).ok();
    }
}

#[test]
fn bad_controllers_and_checkpoints_are_reported() {
    let out = temp_dir("bad");
    let err = eval::run(&eval_args("dijkstra".into(), out.clone())).unwrap_err();
    assert!(
        err.to_string().contains("unknown controller 'dijkstra'"),
        "{err}"
    );
    let err = eval::run(&eval_args(
        format!("checkpoint:{}", out.display()),
        out.clone(),
    ))
    .unwrap_err();
    assert!(format!("{err:#}").contains("no checkpoint"), "{err:#}");
    let mut args = eval_args("cbs".into(), out.clone());
    args.agents = Some("0".into());
    assert!(eval::run(&args).is_err());
    args.agents = Some("2".into());
    args.map = Some("rm-7.7".into());
    let err = eval::run(&args).unwrap_err();
    assert!(
        format!("{err:#}").contains("unknown map 'rm-7.7'"),
        "{err:#}"
    );
    // A GPU asked of a default build: refused, naming the build script.
    if !buridan_policy::device::CUDA_BUILT {
        let mut args = eval_args("cbs".into(), out.clone());
        args.device = buridan_policy::DeviceSpec::Cuda(0);
        let err = format!("{:#}", eval::run(&args).unwrap_err());
        assert!(err.contains("--device cuda:0"), "{err}");
        assert!(err.contains("scripts/build-cuda.sh"), "{err}");
    }
}

#[test]
fn config_layers_defaults_file_flags_and_overrides() {
    let dir = temp_dir("config");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("run.toml");
    std::fs::write(
        &file,
        "map = \"rm-3.1\"\nagents = 6\n[ppo]\nlr = 0.0005\nepochs = 7\n",
    )
    .unwrap();
    let mut args = common::train_args(dir.join("out"));
    args.config = Some(file.clone());
    args.map = None;
    args.agents = None;
    args.overrides = vec!["ppo.epochs=9".into(), "hidden=[32, 32]".into()];
    let cfg = train::resolve_config(&args).unwrap();
    assert_eq!(
        (cfg.task.grid_map(), cfg.agents),
        (Some("rm-3.1"), 6),
        "file values stay where no flag overrides them"
    );
    let ppo = cfg.algorithm.ppo().unwrap();
    assert_eq!(ppo.lr, 5e-4);
    assert_eq!(ppo.epochs, 9, "--set beats the file");
    assert_eq!(cfg.model.hidden, [32, 32]);
    assert_eq!(cfg.run.steps, 3000, "flags beat defaults");
    args.overrides = vec!["ppo.no_such_key=1".into()];
    assert!(
        train::resolve_config(&args).is_err(),
        "unknown keys are rejected"
    );
    // `--set` names a task as the flags do: it replaces the file's.
    args.overrides = vec!["plant=dissertation".into(), "agents=2".into()];
    let cfg = train::resolve_config(&args).unwrap();
    assert_eq!(cfg.task, Task::Plant("dissertation".into()));
    assert_eq!(cfg.t_max, 1000, "a plant run takes its plant's T_max");
    args.overrides = vec!["maps=[{ name = \"rm-2.2\" }]".into()];
    let cfg = train::resolve_config(&args).unwrap();
    assert_eq!(cfg.map_label(), "rm-2.2:1");
    args.overrides = vec!["plant=dissertation".into(), "map=rm-2.2".into()];
    let cfg = train::resolve_config(&args).unwrap();
    assert_eq!(cfg.task, Task::Grid("rm-2.2".into()));
    std::fs::write(&file, "agents = \"many\"\n").unwrap();
    args.overrides.clear();
    assert!(format!("{:#}", train::resolve_config(&args).unwrap_err()).contains("run.toml"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn without_a_config_the_recipe_imitates_first_unless_told_not_to() {
    let mut args = common::train_args(temp_dir("recipe"));
    args.overrides.clear();
    args.no_imitation = false;
    let cfg = train::resolve_config(&args).unwrap();
    let recipe = buridan_learner::train::TrainConfig::recipe();
    assert!(cfg.model.lstm && cfg.imitation.is_some());
    assert_eq!(cfg.imitation, recipe.imitation);
    assert_eq!(cfg.polish, recipe.polish);
    assert!(cfg.polish.is_some());
    // The recipe stops once learned, unless told to use its whole budget.
    assert_eq!(cfg.run.stop, recipe.run.stop);
    assert!(cfg.run.stop.is_some());
    args.no_stop = true;
    assert!(train::resolve_config(&args).unwrap().run.stop.is_none());
    args.no_stop = false;
    // Over several layouts it keeps the training-success rule and leaves
    // out the greedy check, which plays one map's held-out episodes.
    let mut mixed = args.clone();
    (mixed.map, mixed.maps) = (None, Some("rm-2.2,rm-3.1".into()));
    let stop = train::resolve_config(&mixed).unwrap().run.stop.unwrap();
    assert_eq!(
        (stop.success, stop.hold, stop.greedy),
        (0.99, 100_000, None)
    );
    args.no_imitation = true;
    let cfg = train::resolve_config(&args).unwrap();
    assert!(cfg.model.lstm && cfg.imitation.is_none() && cfg.polish.is_none());
    // It also skips a config's imitation.
    let config =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../learner/configs/impala-ctde-rm-2.2.toml");
    args.config = Some(config);
    assert!(train::resolve_config(&args).unwrap().imitation.is_none());
    args.no_imitation = false;
    assert_eq!(
        train::resolve_config(&args)
            .unwrap()
            .imitation
            .unwrap()
            .rounds,
        4
    );
}

#[test]
fn a_policy_trained_on_two_layouts_evaluates_on_a_third() {
    let out = temp_dir("maps");
    let mut args = common::train_args(out.clone());
    args.map = None;
    args.maps = Some("rm-2.2:1,rm-3.1:1".into());
    (args.agents, args.starts) = (Some(4), Some(Starts::Random));
    args.overrides.push("t_max=20".into());
    let summary = train::run(&args).unwrap();
    assert_eq!(summary.maps, ["rm-2.2", "rm-3.1"]);
    // 3000 env steps of at most 20: 150 episodes or more, on both layouts.
    assert!(
        summary.episodes_by_map.values().all(|&n| n >= 30),
        "{summary:?}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(json["success_by_map"]["rm-2.2"].is_number(), "{json}");
    let spec = std::fs::read_to_string(out.join("checkpoints/final/spec.json")).unwrap();
    assert!(spec.contains("rm-3.1"), "{spec}");
    // The written config names the layouts and trains the same again.
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(
        config.contains("[[maps]]") && !config.contains("map ="),
        "{config}"
    );

    let eval_out = temp_dir("maps-eval");
    let mut eval = eval_args(format!("checkpoint:{}", out.display()), eval_out.clone());
    (eval.map, eval.agents, eval.starts) =
        (Some("rm-2.1".into()), Some("4".into()), Starts::Random);
    let summaries = eval::run(&eval).unwrap();
    assert_eq!(
        (summaries[0].episodes, summaries[0].map.as_str()),
        (3, "rm-2.1")
    );

    // CTE over several layouts is refused, and says why.
    let mut cte = common::train_args(temp_dir("maps-cte"));
    (cte.map, cte.maps, cte.mode) = (None, Some("rm-2.2,rm-3.1".into()), Some(Mode::Cte));
    let err = format!("{:#}", train::run(&cte).unwrap_err());
    assert!(err.contains("cte cannot train on several layouts"), "{err}");
    // `--map` replaces a config's maps.
    let mut one = common::train_args(temp_dir("maps-one"));
    one.config = Some(out.join("config.toml"));
    one.maps = None;
    let cfg = train::resolve_config(&one).unwrap();
    assert_eq!(cfg.task, Task::Grid("rm-1.1".into()));
    for dir in [out, eval_out] {
        std::fs::remove_dir_all(dir).ok();
    }
}
