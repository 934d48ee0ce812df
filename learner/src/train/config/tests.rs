use super::*;
use crate::algo::schedule::Schedule;

/// The default config with one field changed, validated.
fn with(change: impl Fn(&mut TrainConfig)) -> Result<(), ConfigError> {
    let mut cfg = TrainConfig::default();
    change(&mut cfg);
    cfg.validate()
}

fn plant_run(change: impl Fn(&mut TrainConfig)) -> Result<(), ConfigError> {
    with(|c| {
        c.task = Task::Plant("dissertation".into());
        change(c)
    })
}

#[test]
fn a_plant_run_refuses_imitation_and_grid_options() {
    plant_run(|_| {}).unwrap();
    plant_run(|c| c.mode = Mode::Cte).unwrap();
    let err = plant_run(|c| c.imitation = Some(ImitationConfig::default()));
    assert!(
        matches!(err, Err(ConfigError::PlantWithImitation { .. })),
        "{err:?}"
    );
    assert!(err
        .unwrap_err()
        .to_string()
        .contains("DAgger imitates grid planners"));
    let err = plant_run(|c| c.polish = Some(ImitationConfig::default()));
    let msg = err.unwrap_err().to_string();
    assert!(
        msg.contains("[polish] cannot be used with a plant"),
        "{msg}"
    );
    let err = plant_run(|c| c.delay = 0.1);
    assert!(
        matches!(err, Err(ConfigError::GridOnlyOption { what: "delay" })),
        "{err:?}"
    );
    let err = plant_run(|c| c.shaping = 0.05);
    assert!(
        matches!(err, Err(ConfigError::GridOnlyOption { what: "shaping" })),
        "{err:?}"
    );
    let err = plant_run(|c| c.features = TrainConfig::recipe().features);
    assert!(
        matches!(err, Err(ConfigError::GridOnlyOption { what: "features" })),
        "{err:?}"
    );
    let err = plant_run(|c| c.shield_rollouts = true);
    assert!(
        matches!(
            err,
            Err(ConfigError::GridOnlyOption {
                what: "shield_rollouts"
            })
        ),
        "{err:?}"
    );
    let err = plant_run(|c| c.replay.share = 0.5);
    assert!(
        matches!(err, Err(ConfigError::GridOnlyOption { what: "replay" })),
        "{err:?}"
    );
    let err = plant_run(|c| c.t_max = 0);
    assert!(matches!(err, Err(ConfigError::Invalid(_))), "{err:?}");
}

#[test]
fn failure_replay_is_written_only_when_on_and_its_ranges_are_checked() {
    let mut cfg = TrainConfig::default();
    assert!(!cfg.to_toml().contains("[replay]"));
    cfg.replay.share = 0.5;
    let text = cfg.to_toml();
    assert!(text.contains("[replay]\nshare = 0.5"), "{text}");
    let back: TrainConfig = toml::from_str(&text).unwrap();
    assert_eq!(back, cfg);
    back.validate().unwrap();
    for bad in [
        ReplayConfig {
            share: 1.5,
            ..ReplayConfig::default()
        },
        ReplayConfig {
            share: f64::NAN,
            ..ReplayConfig::default()
        },
        ReplayConfig {
            share: 0.5,
            tries: 0,
            capacity: 8,
        },
        ReplayConfig {
            share: 0.5,
            tries: 2,
            capacity: 0,
        },
    ] {
        let cfg = TrainConfig {
            replay: bad,
            ..TrainConfig::default()
        };
        let err = cfg.validate().unwrap_err().to_string();
        assert!(err.contains("replay."), "{bad:?}: {err}");
    }
}

#[test]
fn shield_rollouts_are_written_only_when_on() {
    let mut cfg = TrainConfig::default();
    assert!(
        !cfg.to_toml().contains("shield_rollouts"),
        "older runs' configs stay as they were"
    );
    cfg.shield_rollouts = true;
    let text = cfg.to_toml();
    assert!(text.contains("shield_rollouts = true"), "{text}");
    let back: TrainConfig = toml::from_str(&text).unwrap();
    assert_eq!(back, cfg);
}
#[test]
fn a_plant_file_takes_the_plant_t_max_unless_it_sets_one() {
    let dir = tempfile::tempdir().unwrap();
    let read = |text: &str| {
        let path = dir.path().join("run.toml");
        std::fs::write(&path, text).unwrap();
        TrainConfig::from_toml_file(&path)
    };
    let cfg = read("plant = \"dissertation\"\nagents = 2\n").unwrap();
    assert_eq!(
        (cfg.t_max, cfg.map_label()),
        (1000, "plant:dissertation".into())
    );
    assert_eq!(cfg.layout_names(), ["plant:dissertation"]);
    assert_eq!(cfg.model_spec(11).maps, ["plant:dissertation"]);
    let cfg = read("plant = \"dissertation\"\nt_max = 64\n").unwrap();
    assert_eq!(cfg.t_max, 64);
    assert_eq!(cfg.load_plant().unwrap().unwrap().episode.t_max, 64);
    // The config a run writes reads back as the same config.
    let again = read(&cfg.to_toml()).unwrap();
    assert_eq!(again, cfg);
    let err = read("plant = \"dissertation\"\nmap = \"rm-2.1\"\n").unwrap_err();
    assert!(matches!(err, ConfigError::PlantAndMap { .. }), "{err:?}");
    let err = read("plant = \"atlantis\"\n").unwrap_err();
    assert!(
        matches!(&err, ConfigError::UnknownPlant { plant, .. } if plant == "atlantis"),
        "{err:?}"
    );
    let chain = format!("{err}: {}", std::error::Error::source(&err).unwrap());
    assert!(chain.contains("unknown plant 'atlantis'"), "{chain}");
    // The dissertation's plant has starts for 4 AGVs.
    let err = read("plant = \"dissertation\"\nagents = 5\n").unwrap_err();
    assert!(
        matches!(err, ConfigError::AgentsDoNotFit { agents: 5, .. }),
        "{err:?}"
    );
}

/// `c`'s PPO settings.
fn ppo(c: &mut TrainConfig) -> &mut PpoConfig {
    c.algorithm.ppo_mut().expect("a PPO config")
}

/// `c` switched to IMPALA, its settings.
fn impala(c: &mut TrainConfig) -> &mut ImpalaConfig {
    c.algorithm.switch_to(Algo::Impala);
    c.algorithm.impala_mut().expect("an IMPALA config")
}

#[test]
fn hyperparameters_outside_their_range_are_refused_by_name() {
    type Change = fn(&mut TrainConfig);
    let bad: [(&str, &str, Change); 8] = [
        ("ppo.lr", "finite and positive", |c| ppo(c).lr = f64::NAN),
        ("ppo.lr", "finite and positive", |c| ppo(c).lr = 0.0),
        ("impala.lr", "finite and positive", |c| {
            impala(c).lr = f64::INFINITY
        }),
        ("ppo.entropy_coeff", "finite", |c| {
            ppo(c).entropy_coeff = f32::NAN
        }),
        ("impala.rho_bar", "finite and positive", |c| {
            impala(c).rho_bar = -1.0
        }),
        ("ppo.lambda", "in [0, 1]", |c| ppo(c).lambda = 1.5),
        ("ppo.grad_clip", "finite and positive", |c| {
            ppo(c).grad_clip = Some(f64::NAN)
        }),
        // A schedule's points stand in the range of the setting they replace.
        ("impala.lr_schedule", "finite and at least 0", |c| {
            impala(c).lr_schedule = Some(Schedule::new(vec![(0, 1e-3), (10, -1e-4)]).unwrap())
        }),
    ];
    for (key, range, change) in bad {
        match with(change) {
            Err(ConfigError::OutOfRange {
                key: k, range: r, ..
            }) => {
                assert_eq!((k, r), (key, range));
            }
            other => panic!("{key}: expected OutOfRange, got {other:?}"),
        }
    }
    // The legal edges stay legal.
    let edges: [Change; 8] = [
        |c| ppo(c).entropy_coeff = 0.0,
        // Negative: a penalty on entropy.
        |c| ppo(c).entropy_coeff = -0.05,
        |c| ppo(c).kl_coeff = 0.0,
        |c| ppo(c).lambda = 1.0,
        |c| impala(c).lambda = 0.0,
        |c| ppo(c).lr = 1e-8,
        // A learning rate decays to 0; an entropy penalty fades out.
        |c| ppo(c).lr_schedule = Some(Schedule::new(vec![(0, 1e-3), (10, 0.0)]).unwrap()),
        |c| ppo(c).entropy_schedule = Some(Schedule::new(vec![(0, -0.05), (10, 0.0)]).unwrap()),
    ];
    for (i, change) in edges.into_iter().enumerate() {
        assert!(with(change).is_ok(), "edge {i} refused");
    }
}

/// Reads `text` as a config file.
fn read_file(text: &str) -> Result<TrainConfig, ConfigError> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.toml");
    std::fs::write(&path, text).unwrap();
    TrainConfig::from_toml_file(&path)
}

#[test]
fn each_task_form_reads_from_its_key_and_writes_it_back() {
    let forms = [
        ("map = \"rm-1.1\"\n", Task::Grid("rm-1.1".into())),
        (
            "[[maps]]\nname = \"rm-2.2\"\nweight = 2.0\n\n[[maps]]\nname = \"rm-3.1\"\n",
            Task::Mixture(WeightedMap::parse_list("rm-2.2:2,rm-3.1").unwrap()),
        ),
        (
            "plant = \"dissertation\"\nagents = 2\n",
            Task::Plant("dissertation".into()),
        ),
    ];
    for (text, task) in forms {
        let cfg = read_file(text).unwrap();
        assert_eq!(cfg.task, task, "{text}");
        assert_eq!(toml::from_str::<TrainConfig>(text).unwrap().task, task);
        // The written config names the task by its one key, and reads back
        // the same, from a file and from text.
        let printed = cfg.to_toml();
        let keys: toml::Table = toml::from_str(&printed).unwrap();
        let set: Vec<_> = Task::KEYS
            .iter()
            .filter(|k| keys.contains_key(**k))
            .collect();
        assert_eq!(set.len(), 1, "{printed}");
        assert_eq!(read_file(&printed).unwrap(), cfg);
        assert_eq!(toml::from_str::<TrainConfig>(&printed).unwrap(), cfg);
        assert_eq!(read_file(&printed).unwrap().to_toml(), printed);
    }
}

#[test]
fn a_grid_config_writes_its_keys_as_the_flat_struct_did() {
    let text = TrainConfig::default().to_toml();
    assert!(
        text.starts_with("algo = \"ppo\"\nmode = \"ctde\"\nmap = \"rm-2.1\"\nagents = 4\n"),
        "{text}"
    );
    assert!(!text.contains("maps") && !text.contains("plant"), "{text}");
}

#[test]
fn a_config_carries_its_algorithms_table_and_refuses_the_others_settings() {
    // Configs saved before the type wrote both tables, the other at its
    // defaults (`models/*/config.toml`): they still read.
    let both = "algo = \"impala\"\n[ppo]\nlr = 0.001\n[impala]\nlr = 0.0005\n";
    let cfg = read_file(both).unwrap();
    assert_eq!(cfg.algorithm.impala().map(|i| i.lr), Some(5e-4));
    // Written back, a config holds its own algorithm's table only.
    let printed = cfg.to_toml();
    assert!(
        printed.contains("[impala]") && !printed.contains("[ppo]"),
        "{printed}"
    );
    assert_eq!(read_file(&printed).unwrap(), cfg);
    // The other algorithm's table away from its defaults is a mistake
    // (`--set impala.lr=…` on a PPO run): refused, naming both.
    let wrong = "algo = \"ppo\"\n[impala]\nlr = 0.0005\n";
    let err = read_file(wrong).unwrap_err();
    assert!(matches!(err, ConfigError::Parse { .. }), "{err:?}");
    let message = toml::from_str::<TrainConfig>(wrong)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("sets [impala] but algo = \"ppo\""),
        "{message}"
    );
    assert!(toml::from_str::<TrainConfig>("[ppo]\nepochs = 3\nalgo = \"impala\"").is_err());
    // Every shipped model's saved config still reads.
    let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models");
    let mut read = 0;
    for entry in std::fs::read_dir(&models).unwrap() {
        let path = entry.unwrap().path().join("config.toml");
        if path.exists() {
            TrainConfig::from_toml_file(&path)
                .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
            read += 1;
        }
    }
    assert!(read >= 5, "{read} model configs under {}", models.display());
    // Without its table an algorithm takes its defaults.
    let cfg = read_file("algo = \"impala\"\n").unwrap();
    assert_eq!(cfg.algorithm, Algorithm::Impala(ImpalaConfig::default()));
}

#[test]
fn training_delays_read_write_and_reach_the_env() {
    let cfg = read_file("delay = 0.1\n").unwrap();
    assert_eq!(cfg.delay, 0.1);
    assert_eq!(crate::train::env_config(&cfg, 3).delay, 0.1);
    assert!(cfg.to_toml().contains("delay = 0.1"), "{}", cfg.to_toml());
    assert!(!TrainConfig::default().to_toml().contains("delay"));
    for bad in [1.0, -0.5, f32::NAN] {
        let err = with(|c| c.delay = bad).unwrap_err().to_string();
        assert!(
            err.contains("delay must be a probability in [0, 1)"),
            "{err}"
        );
    }
}

#[test]
fn without_a_task_key_the_task_is_the_grid_map_rm_2_1() {
    assert_eq!(Task::default(), Task::Grid("rm-2.1".into()));
    assert_eq!(TrainConfig::default().task, Task::default());
    let cfg = read_file("agents = 2\n").unwrap();
    assert_eq!(cfg.task.grid_map(), Some("rm-2.1"));
    assert_eq!(cfg.layout_names(), ["rm-2.1"]);
    let cfg: TrainConfig = toml::from_str("").unwrap();
    assert_eq!(cfg, TrainConfig::default());
}

#[test]
fn two_task_keys_are_refused_naming_both() {
    let both = [
        (
            "map = \"rm-2.1\"\nmaps = [{ name = \"rm-2.2\" }]\n",
            "sets both map and maps",
        ),
        (
            "map = \"rm-2.1\"\nplant = \"dissertation\"\n",
            "sets plant together with map or maps",
        ),
        (
            "maps = [{ name = \"rm-2.2\" }]\nplant = \"dissertation\"\n",
            "sets plant together with map or maps",
        ),
    ];
    for (text, why) in both {
        // From a file: the typed error, naming the file.
        let err = read_file(text).unwrap_err();
        assert!(
            matches!(
                err,
                ConfigError::MapAndMaps { .. } | ConfigError::PlantAndMap { .. }
            ),
            "{err:?}"
        );
        let msg = err.to_string();
        assert!(msg.contains(why) && msg.contains("run.toml"), "{msg}");
        // From text (`toml::from_str`, a `--set` table): the same words.
        let msg = toml::from_str::<TrainConfig>(text).unwrap_err().to_string();
        assert!(msg.contains(why), "{msg}");
    }
}

#[test]
fn an_unknown_key_is_still_refused_and_the_task_keys_are_listed() {
    let msg = toml::from_str::<TrainConfig>("mapp = \"rm-2.1\"")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("unknown field `mapp`") && msg.contains("`map`, `maps`, `plant`"),
        "{msg}"
    );
}
