use super::*;
use buridan_policy::{ActMode, Mode, Policy};

/// The evaluation of `episodes` episodes with `agents` AGVs, seed `seed`.
fn eval_spec(agents: usize, episodes: usize, seed: u64) -> PlantEvalSpec {
    PlantEvalSpec {
        agents,
        episodes,
        seed,
    }
}

/// Controller `name` for `spec`'s episodes on `plant`, acting greedily.
fn controller(name: &str, plant: &Arc<Plant>, spec: &PlantEvalSpec) -> PlantController {
    PlantController::by_name(name, plant, spec.agents, spec.seed, ActMode::Greedy).unwrap()
}

fn plant(t_max: u32) -> Arc<Plant> {
    Arc::new(load_plant("dissertation", Some(t_max)).unwrap())
}

fn run(name: &str, agents: usize, episodes: usize, t_max: u32) -> PlantEvalReport {
    let plant = plant(t_max);
    let spec = eval_spec(agents, episodes, 42);
    let mut c = controller(name, &plant, &spec);
    evaluate_plant(&plant, &spec, &mut c, &|_| {}).unwrap()
}

#[test]
fn the_summary_averages_the_episode_kpis() {
    let report = run("reservation", 3, 3, 400);
    let s = &report.summary;
    assert_eq!((s.episodes, s.t_max, s.agents), (3, 400, 3));
    let deliveries: Vec<f64> = report
        .records
        .iter()
        .map(|r| f64::from(r.deliveries))
        .collect();
    assert_eq!((s.deliveries_mean, s.deliveries_std), mean_std(&deliveries));
    for r in &report.records {
        assert_eq!(r.steps, 400);
        assert!((r.reward_per_agent - f64::from(r.reward) / 3.0).abs() < 1e-9);
    }
    let rpa: f64 = report
        .records
        .iter()
        .map(|r| r.reward_per_agent)
        .sum::<f64>()
        / 3.0;
    assert!((s.reward_per_agent_mean - rpa).abs() < 1e-9);
    assert!(s.deliveries_mean > 0.0, "{s:?}");
    assert_eq!(s.collisions_mean, 0.0);
    assert_eq!(
        s.episodes_with_deliveries,
        report.records.iter().filter(|r| r.deliveries > 0).count()
    );
}

#[test]
fn episodes_are_the_seeded_envs_and_random_draws_depend_on_the_episode_only() {
    let a = run("random", 3, 3, 200);
    let b = run("random", 3, 3, 200);
    let timeless = |r: &PlantEpisodeRecord| PlantEpisodeRecord {
        compute_ms: 0.0,
        ..r.clone()
    };
    let rows = |r: &PlantEvalReport| r.records.iter().map(timeless).collect::<Vec<_>>();
    assert_eq!(rows(&a), rows(&b));
    // Episode 2 alone plays as it did third in a row.
    let plant = plant(200);
    let spec = eval_spec(3, 3, 42);
    let mut c = controller("random", &plant, &spec);
    let mut env = PlantEnv::new(plant.clone(), eval_config(&spec)).unwrap();
    env.reset_to(2);
    c.begin_episode(2);
    let (mut actions, mut rewards) = (vec![0u8; 3], vec![0f32; 3]);
    while !env.is_over() {
        c.act(&env, &mut actions).unwrap();
        env.step(&actions, &mut rewards).unwrap();
    }
    assert_eq!(env.kpis().deliveries, a.records[2].deliveries);
    assert_eq!(env.kpis().reward, a.records[2].reward);
}

#[test]
fn files_and_bad_input() {
    let report = run("reservation", 2, 2, 100);
    let dir = tempfile::tempdir().unwrap();
    let files = write_plant_report(dir.path(), &report).unwrap();
    assert_eq!(files.len(), 7);
    let csv = std::fs::read_to_string(dir.path().join("episodes.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(csv.starts_with("episode,steps,deliveries,"), "{csv}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&files[1]).unwrap()).unwrap();
    assert_eq!(json["plant"], "plant:dissertation");
    for key in [
        "deliveries_mean",
        "collisions_mean",
        "deadlocks_mean",
        "reward_per_agent_mean",
        "throughput_per_hour_mean",
        "utilisation_mean",
    ] {
        assert!(json[key].is_number(), "{key}: {json}");
    }
    let plant = plant(100);
    let spec = eval_spec(2, 0, 0);
    let mut c = controller("random", &plant, &spec);
    assert!(matches!(
        evaluate_plant(&plant, &spec, &mut c, &|_| {}),
        Err(PlantEvalError::NoEpisodes)
    ));
    // More AGVs than the plant has starts: the env says so.
    let spec = eval_spec(9, 1, 0);
    let mut c = controller("reservation", &plant, &spec);
    let err = evaluate_plant(&plant, &spec, &mut c, &|_| {}).unwrap_err();
    assert!(matches!(err, PlantEvalError::Env(_)), "{err:?}");
    let err = PlantController::by_name("checkpoint:", &plant, 2, 0, ActMode::Greedy)
        .err()
        .unwrap();
    assert!(matches!(err, PlantEvalError::UnknownController { .. }));
}

#[test]
fn a_checkpoint_must_come_from_a_plant_run_of_the_right_size() {
    let plant = plant(100);
    let missing =
        PlantController::by_name("checkpoint:/no/such/dir", &plant, 2, 0, ActMode::Greedy)
            .err()
            .unwrap();
    assert!(
        matches!(missing, PlantEvalError::Checkpoint(_)),
        "{missing:?}"
    );
    // A grid policy (25 × 3 inputs) with a grid run's config.
    let dir = tempfile::tempdir().unwrap();
    let spec = buridan_policy::ModelSpec::new(Mode::Ctde, 2, 75);
    Policy::new(spec, 0).unwrap().save(dir.path()).unwrap();
    std::fs::write(
        dir.path().join("config.toml"),
        "map = \"rm-2.2\"\nagents = 2\n",
    )
    .unwrap();
    let err = PlantPolicy::load(dir.path(), &plant, 2, ActMode::Greedy, 0)
        .err()
        .unwrap();
    assert!(
        matches!(&err, PlantEvalError::NotAPlantPolicy { trained_on, .. } if trained_on == "rm-2.2"),
        "{err:?}"
    );
    assert!(err.to_string().contains("not on an AGV plant"), "{err}");
    // A config naming a plant but a policy of the wrong input size.
    std::fs::write(dir.path().join("config.toml"), "plant = \"dissertation\"\n").unwrap();
    let err = PlantPolicy::load(dir.path(), &plant, 2, ActMode::Greedy, 0)
        .err()
        .unwrap();
    assert!(
        matches!(
            err,
            PlantEvalError::ObsSize {
                expected: 75,
                got: 11,
                ..
            }
        ),
        "{err:?}"
    );
    // The right size acts, legally.
    let spec = buridan_policy::ModelSpec::new(Mode::Ctde, 2, buridan_plant::LOCAL_OBS_DIM);
    Policy::new(spec, 0).unwrap().save(dir.path()).unwrap();
    let mut c = PlantController::by_name(
        &format!("checkpoint:{}", dir.path().display()),
        &plant,
        2,
        0,
        ActMode::Sample,
    )
    .unwrap();
    assert_eq!(c.name(), "ctde-policy");
    let spec = eval_spec(2, 1, 0);
    let report = evaluate_plant(&plant, &spec, &mut c, &|_| {}).unwrap();
    assert_eq!(
        report.summary.trained_on.as_deref(),
        Some("plant:dissertation")
    );
    assert_eq!(report.records[0].steps, 100);
}
