//! The pretrained policies in `models/` reproduce their manifests: each
//! reference-layout model, loaded by name (`checkpoint:model:NAME`) and
//! evaluated as its manifest's `[evaluation] command` says (seed 42,
//! 100 episodes, 4 agents, through `shield-lanes=16`), scores the manifest's
//! success, median timesteps and mean sum of costs.

use std::sync::Arc;

use buridan_env::{Map, Rules};
use buridan_eval::by_name::controller_factory;
use buridan_eval::{evaluate, EvalSpec};
use buridan_policy::{checkpoint, ActMode};

/// A model's `manifest.toml`, as the test reads it: the evaluation's
/// episodes, seed and fleet size, and its figures.
struct Manifest {
    name: String,
    table: toml::Table,
    agents: usize,
    episodes: usize,
    seed: u64,
}

impl Manifest {
    /// Reads model `name`'s manifest (where `model:NAME` resolves) and
    /// checks that its `[evaluation] command` runs `controller`.
    fn read(name: &str, controller: &str) -> Self {
        let path = checkpoint::model_dir(name)
            .unwrap()
            .join(checkpoint::MANIFEST_FILE);
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let table: toml::Table = text
            .parse()
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let evaluation = &table["evaluation"];
        assert!(
            evaluation["command"]
                .as_str()
                .unwrap()
                .contains(&format!("--controller {controller} ")),
            "{name}: the manifest's command is not the one this test runs"
        );
        Self {
            name: name.to_string(),
            agents: table["training"]["agents"].as_integer().unwrap() as usize,
            episodes: evaluation["episodes"].as_integer().unwrap() as usize,
            seed: evaluation["episode_seed"].as_integer().unwrap() as u64,
            table,
        }
    }

    /// A `[training]` text value.
    fn training(&self, key: &str) -> &str {
        self.table["training"][key].as_str().unwrap()
    }

    /// An `[evaluation]` figure.
    fn figure(&self, key: &str) -> f64 {
        let v = &self.table["evaluation"][key];
        v.as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .unwrap_or_else(|| panic!("{}: [evaluation] {key}: {v}", self.name))
    }
}

fn reproduces(name: &str) {
    let controller = format!("shield-lanes=16:checkpoint:model:{name}");
    let m = Manifest::read(name, &controller);
    let map = Arc::new(Map::load(m.training("map")).unwrap());
    let spec = EvalSpec {
        agents: m.agents,
        episodes: m.episodes,
        seed: m.seed,
        rules: Rules::Thesis,
        ..EvalSpec::default()
    };
    let make = controller_factory(
        &controller,
        m.agents,
        spec.seed,
        Default::default(),
        ActMode::Greedy,
        Rules::Thesis,
    )
    .unwrap_or_else(|e| panic!("{controller}: {e}"));
    let s = evaluate(&map, &spec, &make, &|_| {}).unwrap().summary;
    assert_eq!(
        s.success_rate,
        m.figure("shield_lanes_success"),
        "{name}: success"
    );
    assert_eq!(
        s.timesteps_median,
        Some(m.figure("shield_lanes_timesteps_median")),
        "{name}: median timesteps"
    );
    let soc = s.sum_of_costs_mean.unwrap();
    let want = m.figure("shield_lanes_sum_of_costs_mean");
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
    let controller = format!("checkpoint:model:{name}");
    let m = Manifest::read(name, &controller);
    let plant = Arc::new(load_plant(m.training("plant"), None).unwrap());
    let spec = PlantEvalSpec {
        agents: m.agents,
        episodes: m.episodes,
        seed: m.seed,
    };
    let mut c = PlantController::by_name(&controller, &plant, m.agents, spec.seed, ActMode::Greedy)
        .unwrap();
    let s = evaluate_plant(&plant, &spec, &mut c, &|_| {})
        .unwrap()
        .summary;
    for (got, key) in [
        (s.deliveries_mean, "deliveries_mean"),
        (s.reward_per_agent_mean, "reward_per_agent_mean"),
        (s.collisions_mean, "collisions_mean"),
    ] {
        let want = m.figure(key);
        assert!(
            (got - want).abs() < 0.005,
            "{name}: {key} {got}, manifest {want}"
        );
    }
}
