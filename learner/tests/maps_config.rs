//! Multi-layout configurations: `maps` in TOML, the typed errors of every
//! bad list, and what a run over several layouts records.

use buridan_env::{EnvError, MapError, Starts};
use buridan_learner::train::{
    train, ConfigError, NoProgress, Run, RunConfig, Task, TrainConfig, TrainError, WeightedMap,
};
use buridan_policy::{Mode, Policy};

fn with_maps(list: &str) -> TrainConfig {
    TrainConfig {
        task: Task::Mixture(WeightedMap::parse_list(list).unwrap()),
        ..TrainConfig::default()
    }
}

#[test]
fn maps_read_from_toml_and_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mix.toml");
    std::fs::write(
        &file,
        r#"
algo = "impala"
maps = [{ name = "rm-2.2", weight = 1.0 }, { name = "rm-3.1", weight = 3.0 }, { name = "rm-2.1" }]
"#,
    )
    .unwrap();
    let cfg = TrainConfig::from_toml_file(&file).unwrap();
    assert_eq!(cfg.layout_names(), ["rm-2.2", "rm-3.1", "rm-2.1"]);
    assert_eq!(cfg.layouts()[1].weight, 3.0);
    assert_eq!(cfg.layouts()[2].weight, 1.0, "weight defaults to 1");
    assert_eq!(cfg.map_label(), "rm-2.2:1+rm-3.1:3+rm-2.1:1");
    // The written config (config.toml of a run) reads back the same.
    std::fs::write(&file, cfg.to_toml()).unwrap();
    assert_eq!(TrainConfig::from_toml_file(&file).unwrap(), cfg);
    // A single-map config keeps its one map.
    assert_eq!(TrainConfig::default().layout_names(), ["rm-2.1"]);
    assert!(TrainConfig::default().load_maps().unwrap().is_none());
}

#[test]
fn every_bad_maps_list_has_its_own_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("both.toml");
    std::fs::write(&file, "map = \"rm-2.1\"\nmaps = [{ name = \"rm-2.2\" }]\n").unwrap();
    let err = TrainConfig::from_toml_file(&file).unwrap_err();
    assert!(matches!(err, ConfigError::MapAndMaps { .. }), "{err}");

    let empty = TrainConfig {
        task: Task::Mixture(Vec::new()),
        ..TrainConfig::default()
    };
    assert!(matches!(empty.validate(), Err(ConfigError::NoMaps)));

    for weight in ["0", "-2", "NaN", "inf"] {
        let err = with_maps(&format!("rm-2.1,rm-2.2:{weight}"))
            .validate()
            .unwrap_err();
        match &err {
            ConfigError::BadWeight { map, .. } => assert_eq!(map, "rm-2.2"),
            other => panic!("weight {weight}: {other}"),
        }
        assert!(err.to_string().contains("positive and finite"), "{err}");
    }

    assert!(matches!(
        with_maps("rm-2.1,rm-2.1").validate(),
        Err(ConfigError::DuplicateMap { map }) if map == "rm-2.1"
    ));

    let cte = TrainConfig {
        mode: Mode::Cte,
        ..with_maps("rm-2.2,rm-3.1")
    };
    let err = cte.validate().unwrap_err();
    assert!(matches!(err, ConfigError::CentralOnSeveralMaps));
    assert!(
        err.to_string().contains("depends on the layout"),
        "says why: {err}"
    );
    // CTDE and DTE are fine, and so is CTE on one listed map.
    for mode in [Mode::Ctde, Mode::Dte] {
        TrainConfig {
            mode,
            ..with_maps("rm-2.2,rm-3.1")
        }
        .validate()
        .unwrap();
    }
    TrainConfig {
        mode: Mode::Cte,
        ..with_maps("rm-2.2")
    }
    .validate()
    .unwrap();

    match with_maps("rm-2.1,rm-9.9").load_maps() {
        Err(ConfigError::UnknownMap { map, source }) => {
            assert_eq!(map, "rm-9.9");
            assert!(matches!(source, MapError::UnknownMap { .. }), "{source}");
        }
        other => panic!("{other:?}"),
    }

    // rm-1.1 has room for 2·n distinct cells only up to a few agents.
    let crowded = TrainConfig {
        agents: 8,
        ..with_maps("rm-2.1,rm-1.1")
    };
    match crowded.load_maps() {
        Err(ConfigError::AgentsDoNotFit {
            map,
            agents,
            source,
        }) => {
            assert_eq!((map.as_str(), agents), ("rm-1.1", 8));
            assert!(matches!(source, EnvError::TooFewFreeCells { .. }));
        }
        other => panic!("{other:?}"),
    }
    // Fixed starts need a scenario with enough agents on every layout.
    let fixed = TrainConfig {
        agents: 5,
        starts: Starts::Fixed,
        ..with_maps("rm-2.1b,rm-2.1")
    };
    assert!(matches!(
        fixed.load_maps(),
        Err(ConfigError::AgentsDoNotFit { map, source: EnvError::NotEnoughFixedAgents { .. }, .. }) if map == "rm-2.1"
    ));

    for entry in ["rm-2.1:", ":2", "rm-2.1:two", "rm-2.1,,rm-2.2"] {
        assert!(
            matches!(
                WeightedMap::parse_list(entry),
                Err(ConfigError::BadMapsEntry { .. })
            ),
            "{entry}"
        );
    }

    // The run refuses them too, before creating anything but its directory.
    let out = dir.path().join("run");
    let err = Run::prepare(&cte, &out).err().unwrap();
    assert!(matches!(
        err,
        TrainError::Config(ConfigError::CentralOnSeveralMaps)
    ));
}

#[test]
fn a_run_over_two_layouts_records_them() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = TrainConfig {
        t_max: 15,
        run: RunConfig {
            steps: 1500,
            envs_per_actor: 6,
            checkpoint_every: 0,
            ..RunConfig::default()
        },
        algorithm: buridan_learner::train::Algorithm::Ppo(buridan_learner::train::PpoConfig {
            train_batch: 750,
            minibatch: 750,
            epochs: 1,
            ..Default::default()
        }),
        ..with_maps("rm-2.2:1,rm-3.1:2")
    };
    let summary = train(&cfg, dir.path(), &mut NoProgress).unwrap();
    assert_eq!(summary.map, "rm-2.2:1+rm-3.1:2");
    assert_eq!(summary.maps, ["rm-2.2", "rm-3.1"]);
    // 1500 env steps of 15-step episodes: 100 episodes, drawn 1 : 2.
    let (a, b) = (
        summary.episodes_by_map["rm-2.2"],
        summary.episodes_by_map["rm-3.1"],
    );
    assert_eq!(a + b, summary.episodes);
    assert!(a >= 15 && b > a, "{a} : {b}");
    for map in ["rm-2.2", "rm-3.1"] {
        assert!((0.0..=1.0).contains(&summary.success_by_map[map]));
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap())
            .unwrap();
    assert!(json["success_by_map"]["rm-3.1"].is_number(), "{json}");
    let policy = Policy::load(&summary.final_checkpoint).unwrap();
    assert_eq!(policy.spec().maps, ["rm-2.2", "rm-3.1"]);

    // Resumed on other layouts: the weights fit, the record follows the run.
    let resumed = TrainConfig {
        algorithm: cfg.algorithm.clone(),
        t_max: 15,
        run: RunConfig {
            steps: 2250,
            resume: Some(summary.final_checkpoint.clone()),
            ..cfg.run.clone()
        },
        ..with_maps("rm-2.1")
    };
    let again = train(&resumed, dir.path(), &mut NoProgress).unwrap();
    assert_eq!(again.updates, summary.updates + 1);
    let policy = Policy::load(&again.final_checkpoint).unwrap();
    assert_eq!(policy.spec().maps, ["rm-2.1"]);
}
