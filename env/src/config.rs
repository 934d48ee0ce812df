//! Environment configuration and the seeded episode generator.

use rand::seq::index::sample;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::error::EnvError;
use crate::map::{Map, Scenario};
use crate::rules::Rules;

/// Where agents start and where their goals are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Starts {
    /// Drawn per episode from the seeded RNG: 2n distinct free cells.
    #[default]
    Random,
    /// The map's `.scen` scenario (the dissertation's "deterministic" setting).
    Fixed,
}

impl std::str::FromStr for Starts {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "random" => Ok(Starts::Random),
            "fixed" | "deterministic" => Ok(Starts::Fixed),
            other => Err(format!(
                "unknown starts '{other}': expected 'random' or 'fixed'"
            )),
        }
    }
}

/// Settings of one grid environment; `Default` is the dissertation's setup.
///
/// Deserialised with every field optional; a missing `t_max` is the rule
/// set's own ([`Rules::default_t_max`]: 100 for thesis, 128 for pogema), so
/// files written before rule sets existed load unchanged as thesis.
///
/// ```
/// use buridan_env::{EnvConfig, Rules};
/// let cfg: EnvConfig = serde_json::from_str(r#"{"rules": "pogema", "agents": 64}"#).unwrap();
/// assert_eq!((cfg.rules, cfg.t_max, cfg.agents), (Rules::Pogema, 128, 64));
/// let old: EnvConfig = serde_json::from_str(r#"{"agents": 4}"#).unwrap();
/// assert_eq!(old, EnvConfig::default());
/// ```
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "EnvConfigFile")]
pub struct EnvConfig {
    /// Number of agents.
    pub agents: usize,
    /// Truncation step count `T_max`.
    pub t_max: u32,
    /// The rule set that moves the agents (thesis by default).
    pub rules: Rules,
    /// Fixed or random starts and goals.
    pub starts: Starts,
    /// Seed of the episode generator.
    pub seed: u64,
    /// Sensor range `R` of the local window, `(2R+1)²` cells.
    pub sensor_range: usize,
    /// Lifelong mode: an agent that reaches its goal gets a new one.
    pub lifelong: bool,
    /// The deadlock detector's window `k`: steps without getting closer to
    /// its goal after which an agent off its goal counts as stuck (and, if
    /// it waits on agents that are stuck too, as deadlocked or livelocked;
    /// definitions in [`crate::monitor`]). Default
    /// [`crate::monitor::DEFAULT_WINDOW`] = 8.
    pub stall_window: u32,
    /// Extra local-observation features (the recipe's; none by default).
    pub features: crate::ObsFeatures,
    /// Potential-based reward shaping on the goal distance (off by default).
    pub shaping: Option<crate::Shaping>,
    /// Execution uncertainty: the probability (in [0, 1), 0 by default)
    /// that an agent fails to carry out its move in a step and stays where
    /// it is, each agent and step independently, drawn from a seeded
    /// stream of the episode ([`crate::seed::delays`]). Real robots lag:
    /// a move takes longer or a robot stalls; a controller sees the
    /// positions that resulted, not the ones it commanded. Waits are not
    /// delayed; a delayed move is not a blocked move.
    pub delay: f32,
}

impl Default for EnvConfig {
    fn default() -> Self {
        Self {
            agents: 4,
            t_max: Rules::Thesis.default_t_max(),
            rules: Rules::Thesis,
            starts: Starts::Random,
            seed: 0,
            sensor_range: 2,
            lifelong: false,
            stall_window: crate::monitor::DEFAULT_WINDOW,
            features: crate::ObsFeatures::default(),
            shaping: None,
            delay: 0.0,
        }
    }
}

/// [`EnvConfig`] as read from a file: the same fields, `t_max` optional so
/// that its default can follow `rules`.
#[derive(serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
struct EnvConfigFile {
    agents: usize,
    t_max: Option<u32>,
    rules: Rules,
    starts: Starts,
    seed: u64,
    sensor_range: usize,
    lifelong: bool,
    stall_window: u32,
    features: crate::ObsFeatures,
    shaping: Option<crate::Shaping>,
    delay: f32,
}

impl Default for EnvConfigFile {
    fn default() -> Self {
        let d = EnvConfig::default();
        Self {
            agents: d.agents,
            t_max: None,
            rules: d.rules,
            starts: d.starts,
            seed: d.seed,
            sensor_range: d.sensor_range,
            lifelong: d.lifelong,
            stall_window: d.stall_window,
            features: d.features,
            shaping: d.shaping,
            delay: d.delay,
        }
    }
}

impl From<EnvConfigFile> for EnvConfig {
    fn from(f: EnvConfigFile) -> Self {
        Self {
            agents: f.agents,
            t_max: f.t_max.unwrap_or(f.rules.default_t_max()),
            rules: f.rules,
            starts: f.starts,
            seed: f.seed,
            sensor_range: f.sensor_range,
            lifelong: f.lifelong,
            stall_window: f.stall_window,
            features: f.features,
            shaping: f.shaping,
            delay: f.delay,
        }
    }
}

/// The largest deadlock-detector window [`EnvConfig::validate`] accepts
/// (steps; the monitor keeps two bytes of history per agent and step).
pub const MAX_STALL_WINDOW: u32 = 4096;

impl EnvConfig {
    /// The default configuration under `rules`, with that rule set's `T_max`.
    ///
    /// ```
    /// use buridan_env::{EnvConfig, Rules};
    /// let cfg = EnvConfig::for_rules(Rules::Pogema);
    /// assert_eq!((cfg.rules, cfg.t_max), (Rules::Pogema, 128));
    /// ```
    pub fn for_rules(rules: Rules) -> Self {
        Self {
            rules,
            t_max: rules.default_t_max(),
            ..Self::default()
        }
    }

    /// Checks ranges that do not depend on the map.
    pub fn validate(&self) -> Result<(), EnvError> {
        if self.agents == 0 || self.agents > u16::MAX as usize - 1 {
            return Err(EnvError::InvalidConfig(format!(
                "agents must be in 1..65534, got {}",
                self.agents
            )));
        }
        if self.t_max == 0 {
            return Err(EnvError::InvalidConfig("t_max must be at least 1".into()));
        }
        if self.sensor_range > 16 {
            return Err(EnvError::InvalidConfig(format!(
                "sensor_range must be at most 16, got {}",
                self.sensor_range
            )));
        }
        if self.stall_window == 0 {
            return Err(EnvError::InvalidConfig(
                "stall_window must be at least 1".into(),
            ));
        }
        // The deadlock monitor keeps `stall_window` steps of history per
        // agent: a window of billions (a nonsensical wire message, found by
        // proto/tests/fuzz.rs) asked for tens of gigabytes.
        if self.stall_window > MAX_STALL_WINDOW {
            return Err(EnvError::InvalidConfig(format!(
                "stall_window must be at most {MAX_STALL_WINDOW}, got {}",
                self.stall_window
            )));
        }
        if let Some(shaping) = &self.shaping {
            shaping.validate().map_err(EnvError::InvalidConfig)?;
        }
        if !(0.0..1.0).contains(&self.delay) {
            return Err(EnvError::InvalidConfig(format!(
                "delay must be a probability in [0, 1), got {}",
                self.delay
            )));
        }
        Ok(())
    }
}

/// The RNG of one episode: a pure function of `(seed, episode)`.
pub fn episode_rng(seed: u64, episode: u64) -> ChaCha8Rng {
    // Distinct streams of one ChaCha key keep episodes independent and stable
    // across platforms and rand versions.
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(episode);
    rng
}

/// The starts and goals of episode `episode`: the fixed scenario, or 2n
/// distinct free cells drawn from [`episode_rng`] (first n starts, next n
/// goals). Identical for every controller given the same arguments.
///
/// ```
/// use buridan_env::{episode_instance, Map, Starts};
/// let map = Map::load("rm-2.1").unwrap();
/// let a = episode_instance(&map, 4, Starts::Random, 42, 7).unwrap();
/// assert_eq!(a, episode_instance(&map, 4, Starts::Random, 42, 7).unwrap());
/// assert_ne!(a, episode_instance(&map, 4, Starts::Random, 42, 8).unwrap());
/// ```
pub fn episode_instance(
    map: &Map,
    agents: usize,
    starts: Starts,
    seed: u64,
    episode: u64,
) -> Result<Scenario, EnvError> {
    match starts {
        Starts::Fixed => {
            let available = map.scenario.as_ref().map_or(0, |s| s.starts.len());
            let scen = map
                .scenario
                .as_ref()
                .filter(|s| s.starts.len() >= agents)
                .ok_or(EnvError::NotEnoughFixedAgents {
                    map: map.name.clone(),
                    available,
                    requested: agents,
                })?;
            Ok(Scenario {
                starts: scen.starts[..agents].to_vec(),
                goals: scen.goals[..agents].to_vec(),
            })
        }
        Starts::Random => {
            let free = map.grid.free_cells();
            if free.len() < 2 * agents {
                return Err(EnvError::TooFewFreeCells {
                    map: map.name.clone(),
                    free: free.len(),
                    agents,
                    needed: 2 * agents,
                });
            }
            let mut rng = episode_rng(seed, episode);
            let picked = sample(&mut rng, free.len(), 2 * agents);
            let cells: Vec<_> = picked.iter().map(|i| free[i]).collect();
            Ok(Scenario {
                starts: cells[..agents].to_vec(),
                goals: cells[agents..].to_vec(),
            })
        }
    }
}
