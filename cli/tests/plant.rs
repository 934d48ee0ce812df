//! `learner train --plant` and `learner eval --plant` end to end, in
//! process (and the binary once, for an unknown plant).

mod common;

use std::path::{Path, PathBuf};

use buridan_cli::eval::{self, EvalArgs};
use buridan_cli::train::{self, TrainArgs};
use buridan_eval::plant::PlantEvalSummary;

/// `learner eval --plant dissertation --agents AGENTS --controller
/// CONTROLLER --episodes EPISODES --seed 42 --json --out OUT EXTRA…`.
fn plant_eval(
    controller: &str,
    agents: &str,
    episodes: usize,
    out: &Path,
    extra: &[&str],
) -> EvalArgs {
    let out = out.display().to_string();
    let episodes = episodes.to_string();
    let mut flags = vec![
        "--plant",
        "dissertation",
        "--agents",
        agents,
        "--controller",
        controller,
        "--episodes",
        &episodes,
        "--seed",
        "42",
        "--json",
        "--out",
        &out,
    ];
    flags.extend_from_slice(extra);
    common::eval_args(&flags)
}

fn run_plant(args: &EvalArgs) -> anyhow::Result<PlantEvalSummary> {
    eval::run_plant(args, args.plant.as_deref().expect("--plant"))
}

/// `learner train --plant dissertation --agents 2 --algo ppo --mode ctde`,
/// 1,200 env steps with 200-step episodes (`--set t_max=200`).
fn plant_train_args(out: PathBuf) -> TrainArgs {
    TrainArgs {
        map: None,
        plant: Some("dissertation".into()),
        overrides: vec![
            "ppo.train_batch=400".into(),
            "ppo.minibatch=400".into(),
            "ppo.epochs=2".into(),
            "envs_per_actor=2".into(),
            "t_max=200".into(),
            "checkpoint_every=1".into(),
            "lstm=false".into(),
        ],
        steps: Some(1200),
        starts: None,
        ..common::train_args(out)
    }
}

#[test]
fn train_on_the_plant_then_evaluate_its_checkpoint() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let args = plant_train_args(out.clone());
    let cfg = train::resolve_config(&args).unwrap();
    assert_eq!((cfg.t_max, cfg.shaping), (200, 0.0));
    assert!(
        cfg.features.is_none(),
        "the recipe's grid features are left out"
    );
    let mut recipe = args.clone();
    recipe.no_imitation = false;
    let resolved = train::resolve_config(&recipe).unwrap();
    assert!(
        resolved.imitation.is_none(),
        "the recipe's imitation (of grid planners) is left out"
    );
    assert!(
        resolved.polish.is_none(),
        "the recipe's polish (by a grid shield) is left out"
    );
    // Without `t_max`: the plant file's T_max, whatever --rules says.
    let mut plain = args.clone();
    plain.overrides.retain(|o| !o.starts_with("t_max"));
    plain.rules = Some(buridan_env::Rules::Pogema);
    assert_eq!(train::resolve_config(&plain).unwrap().t_max, 1000);
    let summary = train::run(&args).unwrap();
    assert_eq!(summary.env_steps, 1200);
    assert_eq!(summary.map, "plant:dissertation");
    // 2 envs × 600 steps: 6 episodes of 200 steps, none a success.
    assert_eq!((summary.episodes, summary.success_rate), (6, 0.0));
    assert!(summary.episode_return_mean.is_finite());
    assert!(summary.time_to_target.is_empty());
    let metrics = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_eq!(metrics.lines().count(), 4, "{metrics}"); // header + 3 updates
    for file in ["summary.json", "config.toml", "learning_curve.png"] {
        assert!(out.join(file).is_file(), "missing {file}");
    }
    for ckpt in ["update-000001", "final"] {
        assert!(
            out.join("checkpoints")
                .join(ckpt)
                .join("model.safetensors")
                .is_file(),
            "missing checkpoint {ckpt}"
        );
    }

    // The trained policy drives the plant: greedy, then sampled.
    let eval_out = dir.path().join("eval");
    let controller = format!("checkpoint:{}", out.display());
    let s = run_plant(&plant_eval(
        &controller,
        "2",
        2,
        &eval_out,
        &["--t-max", "150"],
    ))
    .unwrap();
    assert_eq!(
        (s.controller.as_str(), s.episodes, s.t_max),
        ("ctde-policy", 2, 150)
    );
    assert_eq!(s.trained_on.as_deref(), Some("plant:dissertation"));
    assert!(s.reward_per_agent_mean.is_finite());
    let csv = std::fs::read_to_string(eval_out.join("episodes.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    let sampled = run_plant(&plant_eval(
        &controller,
        "2",
        1,
        &eval_out,
        &["--t-max", "50", "--sample"],
    ));
    assert_eq!(sampled.unwrap().t_max, 50);

    // A grid checkpoint is not a plant policy.
    let grid = dir.path().join("grid");
    let spec = buridan_policy::ModelSpec::new(buridan_policy::Mode::Ctde, 2, 75);
    buridan_policy::Policy::new(spec, 0)
        .unwrap()
        .save(&grid)
        .unwrap();
    std::fs::write(grid.join("config.toml"), "map = \"rm-1.1\"\nagents = 2\n").unwrap();
    let err = run_plant(&plant_eval(
        &format!("checkpoint:{}", grid.display()),
        "2",
        1,
        &eval_out,
        &[],
    ))
    .unwrap_err();
    let text = format!("{err:#}");
    assert!(
        text.contains("trained on the grid layout(s) rm-1.1, not on an AGV plant"),
        "{text}"
    );
}

#[test]
fn the_reservation_baseline_delivers_without_collisions_and_random_collides() {
    let dir = tempfile::tempdir().unwrap();
    let reservation = run_plant(&plant_eval("reservation", "4", 3, dir.path(), &[])).unwrap();
    let random = run_plant(&plant_eval("random", "4", 3, dir.path(), &[])).unwrap();
    assert_eq!((reservation.agents, reservation.t_max), (4, 1000));
    assert!(reservation.deliveries_mean > 0.0, "{reservation:?}");
    assert_eq!(reservation.collisions_mean, 0.0, "{reservation:?}");
    assert!(reservation.throughput_per_hour_mean > 0.0);
    assert!(reservation.lead_time_mean.is_some());
    assert!(
        random.collisions_mean > reservation.collisions_mean,
        "random {random:?}"
    );
    // The files of the last evaluation: one row per episode.
    let csv = std::fs::read_to_string(dir.path().join("episodes.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4, "{csv}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(json["controller"], "random");
}

#[test]
fn bad_plant_input_is_an_error_that_names_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = plant_eval("reservation", "2", 1, dir.path(), &[]);
    args.plant = Some("atlantis".into());
    let text = format!("{:#}", run_plant(&args).unwrap_err());
    assert!(text.contains("unknown plant 'atlantis'"), "{text}");
    let text = format!(
        "{:#}",
        run_plant(&plant_eval("cbs", "2", 1, dir.path(), &[])).unwrap_err()
    );
    assert!(text.contains("unknown plant controller 'cbs'"), "{text}");
    let text = format!(
        "{:#}",
        run_plant(&plant_eval("reservation", "2,3", 1, dir.path(), &[])).unwrap_err()
    );
    assert!(text.contains("one agent count"), "{text}");
    let text = format!(
        "{:#}",
        run_plant(&plant_eval("reservation", "7", 1, dir.path(), &[])).unwrap_err()
    );
    assert!(
        text.contains("starts for 1 to 4 AGVs, 7 requested"),
        "{text}"
    );

    // Training: an unknown plant (found when its T_max is looked up, or
    // when the run loads it), a plant with imitation.
    let mut train_args = plant_train_args(dir.path().join("t"));
    train_args.plant = Some("atlantis".into());
    let text = format!("{:#}", train::run(&train_args).unwrap_err());
    assert!(text.contains("unknown plant 'atlantis'"), "{text}");
    assert!(
        !dir.path().join("t").exists(),
        "no output for a run that cannot start"
    );
    train_args.overrides.retain(|o| !o.starts_with("t_max"));
    let text = format!("{:#}", train::resolve_config(&train_args).unwrap_err());
    assert!(text.contains("loading plant 'atlantis'"), "{text}");
    assert!(text.contains("unknown plant 'atlantis'"), "{text}");
    let mut train_args = plant_train_args(dir.path().join("t"));
    train_args.no_imitation = false;
    train_args.overrides.push("imitation.rounds=1".into());
    let text = format!("{:#}", train::resolve_config(&train_args).unwrap_err());
    assert!(
        text.contains("[imitation] cannot be used with a plant"),
        "{text}"
    );
    let mut train_args = plant_train_args(dir.path().join("t"));
    train_args
        .overrides
        .push("maps=[{name = \"rm-2.2\"}]".into());
    // `--set maps=…` names another task: it replaces the plant, as
    // `--set map=…` does (a file that sets both is refused).
    let cfg = train::resolve_config(&train_args).unwrap();
    assert_eq!(cfg.map_label(), "rm-2.2:1");

    // The binary: an error message and a failure code, no panic.
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_learner"))
        .args([
            "eval",
            "--plant",
            "atlantis",
            "--controller",
            "random",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("unknown plant 'atlantis'"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");

    // Grid-only flags are refused with --plant instead of being ignored;
    // their defaults are not (the plant runs above parse).
    for flag in [
        ["--rules", "pogema"],
        ["--starts", "fixed"],
        ["--jobs", "2"],
        ["--time-limit", "5"],
        ["--memory-limit", "64"],
    ] {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_learner"))
            .args(["eval", "--plant", "dissertation", "--controller", "random"])
            .args(flag)
            .arg("--out")
            .arg(dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{flag:?}: {stderr}");
        assert!(stderr.contains("cannot be used with"), "{flag:?}: {stderr}");
        assert!(stderr.contains(flag[0]), "{flag:?}: {stderr}");
    }
}
