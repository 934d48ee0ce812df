//! The pretrained policies in `models/` reproduce their manifests: each
//! reference-layout model, loaded by name (`checkpoint:model:NAME`) and
//! evaluated as its manifest's `[evaluation] command` says (seed 42,
//! 100 episodes, 4 agents, through `shield-lanes=16`), scores the manifest's
//! success, median timesteps and mean sum of costs.

use std::path::PathBuf;
use std::sync::Arc;

use buridan_env::{Map, Rules};
use buridan_eval::by_name::controller_factory;
use buridan_eval::{evaluate, EvalSpec};
use buridan_policy::ActMode;

fn models_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../models")
}

/// `[evaluation]` and `[training]` of a model's manifest.
fn manifest(name: &str) -> toml::Table {
    let path = models_dir().join(name).join("manifest.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.parse()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn number(table: &toml::Table, section: &str, key: &str) -> f64 {
    let v = &table[section][key];
    v.as_float()
        .or_else(|| v.as_integer().map(|i| i as f64))
        .unwrap_or_else(|| panic!("[{section}] {key}: {v}"))
}

fn reproduces(name: &str) {
    let m = manifest(name);
    let training = m["training"].as_table().unwrap();
    let evaluation = m["evaluation"].as_table().unwrap();
    let map_name = training["map"].as_str().unwrap();
    let agents = training["agents"].as_integer().unwrap() as usize;
    assert!(
        evaluation["command"]
            .as_str()
            .unwrap()
            .contains(&format!("shield-lanes=16:checkpoint:model:{name}")),
        "{name}: the manifest's command is not the one this test runs"
    );
    let map = Arc::new(Map::load(map_name).unwrap());
    let spec = EvalSpec {
        agents,
        episodes: evaluation["episodes"].as_integer().unwrap() as usize,
        seed: evaluation["episode_seed"].as_integer().unwrap() as u64,
        rules: Rules::Thesis,
        ..EvalSpec::default()
    };
    let controller = format!("shield-lanes=16:checkpoint:model:{name}");
    let make = controller_factory(
        &controller,
        agents,
        spec.seed,
        Default::default(),
        ActMode::Greedy,
        Rules::Thesis,
    )
    .unwrap_or_else(|e| panic!("{controller}: {e}"));
    let s = evaluate(&map, &spec, &make, &|_| {}).unwrap().summary;
    assert_eq!(
        s.success_rate,
        number(&m, "evaluation", "shield_lanes_success"),
        "{name}: success"
    );
    assert_eq!(
        s.timesteps_median,
        Some(number(&m, "evaluation", "shield_lanes_timesteps_median")),
        "{name}: median timesteps"
    );
    let soc = s.sum_of_costs_mean.unwrap();
    let want = number(&m, "evaluation", "shield_lanes_sum_of_costs_mean");
    assert!(
        (soc - want).abs() < 0.005,
        "{name}: mean sum of costs {soc}, manifest {want}"
    );
}

#[test]
fn the_rm_2_1_model_reproduces_its_manifest() {
    reproduces("rm-2.1");
}

#[test]
fn the_rm_2_1b_model_reproduces_its_manifest() {
    reproduces("rm-2.1b");
}

#[test]
fn the_rm_2_2_model_reproduces_its_manifest() {
    reproduces("rm-2.2");
}

#[test]
fn the_rm_3_1_model_reproduces_its_manifest() {
    reproduces("rm-3.1");
}

#[test]
fn the_plant_model_reproduces_its_manifest() {
    use buridan_eval::plant::{evaluate_plant, load_plant, PlantController, PlantEvalSpec};
    let name = "plant-dissertation";
    let m = manifest(name);
    let training = m["training"].as_table().unwrap();
    let evaluation = m["evaluation"].as_table().unwrap();
    let agents = training["agents"].as_integer().unwrap() as usize;
    let controller = format!("checkpoint:model:{name}");
    assert!(
        evaluation["command"]
            .as_str()
            .unwrap()
            .contains(&format!("--controller {controller} ")),
        "{name}: the manifest's command is not the one this test runs"
    );
    let plant = Arc::new(load_plant(training["plant"].as_str().unwrap(), None).unwrap());
    let spec = PlantEvalSpec {
        agents,
        episodes: evaluation["episodes"].as_integer().unwrap() as usize,
        seed: evaluation["episode_seed"].as_integer().unwrap() as u64,
    };
    let mut c =
        PlantController::by_name(&controller, &plant, agents, spec.seed, ActMode::Greedy).unwrap();
    let s = evaluate_plant(&plant, &spec, &mut c, &|_| {})
        .unwrap()
        .summary;
    for (got, key) in [
        (s.deliveries_mean, "deliveries_mean"),
        (s.reward_per_agent_mean, "reward_per_agent_mean"),
        (s.collisions_mean, "collisions_mean"),
    ] {
        let want = number(&m, "evaluation", key);
        assert!(
            (got - want).abs() < 0.005,
            "{name}: {key} {got}, manifest {want}"
        );
    }
}
