//! Where a run trains: one map, a weighted mixture of layouts, or an AGV
//! plant, and how each loads.

use std::sync::Arc;

use buridan_env::generate::GeneratedMap;
use buridan_env::{Map, WeightedLayout};
use buridan_plant::{Plant, PlantConfig, PlantEnv};
use serde::{Deserialize, Serialize};

use super::{ConfigError, TrainConfig};

/// One training layout and its weight: `maps = [{ name = "rm-2.2", weight
/// = 1.0 }, …]` in TOML, `--maps rm-2.2:1,rm-3.1:1` on the command line.
///
/// ```
/// use buridan_learner::train::WeightedMap;
/// let maps = WeightedMap::parse_list("rm-2.2:3, rm-3.1").unwrap();
/// assert_eq!(maps[0], WeightedMap { name: "rm-2.2".into(), weight: 3.0 });
/// assert_eq!(maps[1].weight, 1.0);
/// assert_eq!(WeightedMap::label(&maps), "rm-2.2:3+rm-3.1:1");
/// assert!(WeightedMap::parse_list("rm-2.2:x").is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeightedMap {
    /// Reference model id or MovingAI `.map` path.
    pub name: String,
    /// Relative frequency of its episodes (default 1).
    #[serde(default = "unit_weight")]
    pub weight: f64,
}

fn unit_weight() -> f64 {
    1.0
}

impl WeightedMap {
    /// Parses `NAME[:WEIGHT],…` (weight 1 if left out). A generated map's
    /// spec with a seed range (`maze/19x19/seed=0..100`) stands for one
    /// layout per seed, sharing its weight equally.
    ///
    /// ```
    /// use buridan_learner::train::WeightedMap;
    /// let maps = WeightedMap::parse_list("rm-2.2:2,maze/19x19/seed=0..4").unwrap();
    /// assert_eq!(maps.len(), 5);
    /// assert_eq!(maps[4], WeightedMap { name: "maze/19x19/seed=3".into(), weight: 0.25 });
    /// assert!(WeightedMap::parse_list("maze/19x19/seed=4..0").is_err());
    /// ```
    pub fn parse_list(text: &str) -> Result<Vec<WeightedMap>, ConfigError> {
        let entries: Vec<WeightedMap> = text
            .split(',')
            .map(|entry| {
                let entry = entry.trim();
                let bad = || ConfigError::BadMapsEntry {
                    entry: entry.to_string(),
                };
                let (name, weight) = match entry.rsplit_once(':') {
                    Some((name, w)) => (name, w.trim().parse::<f64>().map_err(|_| bad())?),
                    None => (entry, 1.0),
                };
                let name = name.trim();
                if name.is_empty() {
                    return Err(bad());
                }
                Ok(WeightedMap {
                    name: name.to_string(),
                    weight,
                })
            })
            .collect::<Result<_, _>>()?;
        let mut maps = Vec::with_capacity(entries.len());
        for entry in entries {
            if !GeneratedMap::is_spec(&entry.name) || !entry.name.contains("..") {
                maps.push(entry);
                continue;
            }
            let seeds = GeneratedMap::expand(&entry.name)
                .map_err(|source| ConfigError::BadMapSpec { source })?;
            let weight = entry.weight / seeds.len() as f64;
            maps.extend(seeds.iter().map(|spec| WeightedMap {
                name: spec.to_string(),
                weight,
            }));
        }
        Ok(maps)
    }

    /// A short name of a list: `NAME:WEIGHT` joined by `+`. Generated
    /// maps of consecutive seeds that share their settings and weight (what
    /// a seed range expands to, [`WeightedMap::parse_list`]) fold back into
    /// the range with the weight they share.
    ///
    /// ```
    /// use buridan_learner::train::WeightedMap;
    /// let maps = WeightedMap::parse_list("maze/19x19/seed=0..100,rm-2.2:2").unwrap();
    /// assert_eq!(WeightedMap::label(&maps), "maze/19x19/seed=0..100:1+rm-2.2:2");
    /// let maps = WeightedMap::parse_list("maze/19x19/seed=3,maze/19x19/seed=5").unwrap();
    /// assert_eq!(WeightedMap::label(&maps), "maze/19x19/seed=3:1+maze/19x19/seed=5:1");
    /// ```
    pub fn label(maps: &[WeightedMap]) -> String {
        let mut parts: Vec<String> = Vec::new();
        let mut i = 0;
        while i < maps.len() {
            let (weight, first) = (maps[i].weight, generated(&maps[i]));
            let run = first.map_or(1, |first| {
                maps[i..]
                    .iter()
                    .zip(first.seed..)
                    .take_while(|(m, seed)| {
                        m.weight == weight
                            && generated(m)
                                == Some(GeneratedMap {
                                    seed: *seed,
                                    ..first
                                })
                    })
                    .count()
            });
            match first {
                // A spec prints its seed last: `…/seed=A` becomes `…/seed=A..B`.
                Some(first) if run > 1 => {
                    // The weights of a range's seeds sum back to the range's
                    // weight, up to float rounding.
                    let weight = (weight * run as f64 * 1e9).round() / 1e9;
                    parts.push(format!("{first}..{}:{weight}", first.seed + run as u64));
                }
                _ => parts.push(format!("{}:{weight}", maps[i].name)),
            }
            i += run;
        }
        parts.join("+")
    }
}

/// The generated map `map` names, if it names one.
fn generated(map: &WeightedMap) -> Option<GeneratedMap> {
    if !GeneratedMap::is_spec(&map.name) {
        return None;
    }
    map.name.parse().ok()
}

/// The plant `name` (a bundled id or a file) as its file has it.
fn load_plant_file(name: &str) -> Result<Plant, ConfigError> {
    Plant::load(name).map_err(|source| ConfigError::UnknownPlant {
        plant: name.to_string(),
        source: Box::new(source),
    })
}

impl TrainConfig {
    /// Sets `t_max` to the plant file's `episode.t_max` (1,000 steps for
    /// the bundled plants) if this is a plant run; a grid run is left as it
    /// is. [`Self::from_toml_file`] and `learner train` call it when no
    /// `t_max` is given.
    ///
    /// ```
    /// use buridan_learner::train::TrainConfig;
    /// use buridan_learner::train::Task;
    /// let mut cfg = TrainConfig { task: Task::Plant("dissertation".into()), ..TrainConfig::default() };
    /// assert_eq!(cfg.t_max, 100); // the grid default, until...
    /// cfg.use_plant_t_max().unwrap();
    /// assert_eq!(cfg.t_max, 1000);
    /// ```
    pub fn use_plant_t_max(&mut self) -> Result<(), ConfigError> {
        if let Some(name) = self.task.plant() {
            self.t_max = load_plant_file(name)?.episode.t_max;
            self.load_plant()?;
        }
        Ok(())
    }

    /// Loads the plant of a plant run as the run uses it: its
    /// `episode.t_max` replaced by `t_max`, checked to have starts for
    /// `agents` AGVs. `None` for a grid run.
    ///
    /// ```
    /// use buridan_learner::train::{ConfigError, Task, TrainConfig};
    /// let mut cfg = TrainConfig { task: Task::Plant("dissertation".into()), t_max: 50, agents: 2, ..TrainConfig::default() };
    /// assert_eq!(cfg.load_plant().unwrap().unwrap().episode.t_max, 50);
    /// cfg.task = Task::Plant("no-such-plant".into());
    /// assert!(matches!(cfg.load_plant(), Err(ConfigError::UnknownPlant { .. })));
    /// ```
    pub fn load_plant(&self) -> Result<Option<Plant>, ConfigError> {
        let Some(name) = self.task.plant() else {
            return Ok(None);
        };
        let mut plant = load_plant_file(name)?;
        plant.episode.t_max = self.t_max;
        PlantEnv::new(
            std::sync::Arc::new(plant.clone()),
            self.plant_config(self.run.seed),
        )
        .map_err(|source| ConfigError::AgentsDoNotFit {
            map: self.map_label(),
            agents: self.agents,
            source,
        })?;
        Ok(Some(plant))
    }

    /// The plant env configuration of a plant run with env seed `seed`:
    /// `agents` AGVs, normalised observations, and
    /// [`buridan_env::NUM_ACTIONS`] (5) mask slots per AGV, the width of
    /// the policy's heads (the plant masks the two slots beyond its hold,
    /// forward and backward).
    pub fn plant_config(&self, seed: u64) -> PlantConfig {
        PlantConfig {
            agents: self.agents,
            seed,
            normalize: true,
            action_slots: buridan_env::NUM_ACTIONS,
        }
    }

    /// The training layouts: `maps`, or `map` with weight 1; none for a
    /// plant run ([`Task::layouts`](super::Task::layouts)).
    pub fn layouts(&self) -> Vec<WeightedMap> {
        self.task.layouts()
    }

    /// The training layouts' names, in order (a plant run: its
    /// [`Self::map_label`], `plant:ID`).
    pub fn layout_names(&self) -> Vec<String> {
        if self.task.is_plant() {
            return vec![self.map_label()];
        }
        self.layouts().into_iter().map(|m| m.name).collect()
    }

    /// What the run trains on, in one word: `map`, the
    /// [`WeightedMap::label`] of `maps`, or `plant:ID` for a plant
    /// ([`Task::map_label`](super::Task::map_label)).
    ///
    /// ```
    /// use buridan_learner::train::{Task, TrainConfig};
    /// let cfg = TrainConfig { task: Task::Plant("dissertation".into()), ..TrainConfig::default() };
    /// assert_eq!(cfg.map_label(), "plant:dissertation");
    /// ```
    pub fn map_label(&self) -> String {
        self.task.map_label()
    }

    /// Loads the layouts of `maps` with their weights, checking that each
    /// exists and holds the configured agents (one episode of each is
    /// drawn). `None` for a single-map config.
    ///
    /// ```
    /// use buridan_learner::train::{ConfigError, Task, TrainConfig, WeightedMap};
    /// let mut cfg = TrainConfig { task: Task::Mixture(WeightedMap::parse_list("rm-2.2,rm-3.1").unwrap()), ..TrainConfig::default() };
    /// assert_eq!(cfg.load_maps().unwrap().unwrap().len(), 2);
    /// cfg.agents = 200; // 400 distinct cells: more than rm-2.2 has
    /// assert!(matches!(cfg.load_maps(), Err(ConfigError::AgentsDoNotFit { .. })));
    /// ```
    pub fn load_maps(&self) -> Result<Option<Vec<WeightedLayout>>, ConfigError> {
        let Some(maps) = self.task.maps() else {
            return Ok(None);
        };
        self.validate()?;
        maps.iter()
            .map(|m| {
                let map = Map::load(&m.name).map_err(|source| ConfigError::UnknownMap {
                    map: m.name.clone(),
                    source,
                })?;
                buridan_env::episode_instance(&map, self.agents, self.starts, self.run.seed, 0)
                    .map_err(|source| ConfigError::AgentsDoNotFit {
                        map: m.name.clone(),
                        agents: self.agents,
                        source,
                    })?;
                Ok((Arc::new(map), m.weight))
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Some)
    }
}
