//! Training configuration: every hyperparameter of SPEC §4, with the
//! dissertation's comparison settings as defaults, loadable from TOML.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use buridan_env::replay::ReplayConfig;
use buridan_env::{EnvError, Map, MapError, ObsFeatures, Rules, Starts, WeightedLayout};
use buridan_imitate::ImitationConfig;
use buridan_plant::{Plant, PlantConfig, PlantEnv, PlantError};
use buridan_policy::{ActMode, LstmSpec, Mode, ModelSpec, ValueHead};
use serde::{Deserialize, Serialize};

use super::stop::{GreedyCheck, StopRule};
use crate::algo::impala::ImpalaSettings;
use crate::algo::ppo::PpoSettings;
use crate::algo::schedule::Schedule;
use crate::algo::vtrace::VTraceParams;
use crate::train::gate::Staleness;

/// Why a configuration cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("cannot read config {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not a valid configuration (syntax, unknown key, type).
    #[error("invalid config {}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// What the TOML parser says.
        source: toml::de::Error,
    },
    /// A value is out of its range.
    #[error("invalid configuration: {0}")]
    Invalid(&'static str),
    /// The `[replay]` settings are out of range.
    #[error(transparent)]
    Replay(EnvError),
    /// A hyperparameter is not a number in its range (NaN, infinite, or
    /// e.g. a negative learning rate).
    #[error("invalid configuration: {key} = {value} must be {range}")]
    OutOfRange {
        /// The key, as in the file (`ppo.lr`).
        key: &'static str,
        /// Its value.
        value: f64,
        /// What it must be ("finite and positive", ...).
        range: &'static str,
    },
    /// The `[imitation]` or `[polish]` section is out of range.
    #[error("invalid configuration: [{section}]")]
    Imitation {
        /// `imitation` or `polish`.
        section: &'static str,
        /// What is wrong in it.
        #[source]
        source: Box<buridan_imitate::ImitationError>,
    },
    /// A file sets both `map` and `maps`.
    #[error("config {} sets both map and maps: use one (maps lists several layouts with weights)", path.display())]
    MapAndMaps {
        /// The file.
        path: PathBuf,
    },
    /// `maps` is an empty list.
    #[error("invalid configuration: maps is empty: name at least one layout (or use map)")]
    NoMaps,
    /// An entry of a `--maps` list is not `NAME` or `NAME:WEIGHT`.
    #[error("invalid maps entry '{entry}': expected NAME or NAME:WEIGHT, e.g. rm-2.2:1,rm-3.1:2")]
    BadMapsEntry {
        /// The entry.
        entry: String,
    },
    /// A layout's weight is not a positive finite number.
    #[error("invalid configuration: map '{map}' has weight {weight}: weights must be positive and finite")]
    BadWeight {
        /// The layout.
        map: String,
        /// Its weight.
        weight: f64,
    },
    /// A layout is listed twice.
    #[error("invalid configuration: map '{map}' is listed twice in maps")]
    DuplicateMap {
        /// The layout.
        map: String,
    },
    /// CTE with several layouts.
    #[error(
        "invalid configuration: cte cannot train on several layouts: its central observation \
         is 1 + 2·agents planes of the map's height × width cells, so its size (the network's \
         input) depends on the layout; use ctde or dte, whose local observations have one size on every layout"
    )]
    CentralOnSeveralMaps,
    /// A layout cannot be loaded.
    #[error("invalid configuration: map '{map}' cannot be loaded")]
    UnknownMap {
        /// The layout as named.
        map: String,
        /// Why.
        source: MapError,
    },
    /// A file sets `plant` together with `map` or `maps`.
    #[error("config {} sets plant together with map or maps: a run trains on a plant or on grid layouts, not both", path.display())]
    PlantAndMap {
        /// The file.
        path: PathBuf,
    },
    /// `plant` and `maps` are both set.
    #[error("invalid configuration: plant and maps are both set: a run trains on one AGV plant or on grid layouts, not both")]
    PlantAndMaps,
    /// A plant run with an `[imitation]` or `[polish]` section.
    #[error("invalid configuration: [{section}] cannot be used with a plant: DAgger imitates grid planners, and the AGV plant has none")]
    PlantWithImitation {
        /// `imitation` or `polish`.
        section: &'static str,
    },
    /// A plant run with a grid-only option.
    #[error("invalid configuration: {what} applies to grid layouts only, not to the AGV plant (leave it out with plant)")]
    GridOnlyOption {
        /// The option (`features`, `shaping`, `shield_rollouts`, `replay`).
        what: &'static str,
    },
    /// The plant cannot be loaded.
    #[error("invalid configuration: plant '{plant}' cannot be loaded")]
    UnknownPlant {
        /// The plant as named.
        plant: String,
        /// Why.
        source: Box<PlantError>,
    },
    /// A layout cannot hold the configured agents.
    #[error("invalid configuration: {agents} agents do not fit map '{map}'")]
    AgentsDoNotFit {
        /// The layout.
        map: String,
        /// Agents configured.
        agents: usize,
        /// What the env says (too few free cells, too small a scenario).
        source: EnvError,
    },
}

/// The plant `name` (a bundled id or a file) as its file has it.
fn load_plant_file(name: &str) -> Result<Plant, ConfigError> {
    Plant::load(name).map_err(|source| ConfigError::UnknownPlant {
        plant: name.to_string(),
        source: Box::new(source),
    })
}

/// Whether failure replay is off (then `[replay]` is left out of a saved config).
fn is_zero(n: &u8) -> bool {
    *n == 0
}

fn replay_off(replay: &ReplayConfig) -> bool {
    *replay == ReplayConfig::default()
}

fn ensure(ok: bool, why: &'static str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Invalid(why))
    }
}

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
    /// Parses `NAME[:WEIGHT],…` (weight 1 if left out).
    pub fn parse_list(text: &str) -> Result<Vec<WeightedMap>, ConfigError> {
        text.split(',')
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
            .collect()
    }

    /// A short name of a list: `NAME:WEIGHT` joined by `+`.
    pub fn label(maps: &[WeightedMap]) -> String {
        maps.iter()
            .map(|m| format!("{}:{}", m.name, m.weight))
            .collect::<Vec<_>>()
            .join("+")
    }
}

/// The learning algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Algo {
    /// Proximal policy optimisation, synchronous (on-policy).
    Ppo,
    /// IMPALA with V-trace, asynchronous actors.
    Impala,
}

impl std::str::FromStr for Algo {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "ppo" => Ok(Algo::Ppo),
            "impala" => Ok(Algo::Impala),
            other => Err(format!(
                "unknown algorithm '{other}': expected ppo or impala"
            )),
        }
    }
}

impl std::fmt::Display for Algo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Algo::Ppo => "ppo",
            Algo::Impala => "impala",
        })
    }
}

/// PPO hyperparameters (defaults: the dissertation's comparison config and
/// RLlib's defaults for the rest).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PpoConfig {
    /// Learning rate (1e-3).
    pub lr: f64,
    /// Passes over each train batch, RLlib `num_epochs` (12).
    pub epochs: usize,
    /// Surrogate clip ε (0.05).
    pub clip: f32,
    /// Entropy coefficient (0.001).
    pub entropy_coeff: f32,
    /// Train batch in env steps (4000).
    pub train_batch: usize,
    /// Minibatch size in samples of one weight set (4000). As in RLlib's
    /// multi-agent PPO, each policy's share of the train batch (agent steps:
    /// 8000 for CTDE with 2 agents and `train_batch` 4000) is split into
    /// `ceil(samples / minibatch)` shuffled minibatches per epoch.
    pub minibatch: usize,
    /// GAE λ (0.95).
    pub lambda: f32,
    /// Value loss coefficient (RLlib 1.0).
    pub vf_coeff: f32,
    /// Clamp of the squared value error (RLlib `vf_clip_param` 10).
    pub vf_clip: f32,
    /// Initial KL coefficient (0.2; 0 disables the KL penalty).
    pub kl_coeff: f64,
    /// KL target (0.01).
    pub kl_target: f64,
    /// Global-norm gradient clip (RLlib default: none).
    pub grad_clip: Option<f64>,
    /// Share the hidden layers between policy and value (RLlib default false).
    pub vf_share_layers: bool,
    /// Standardise advantages over the train batch (RLlib: yes).
    pub standardize_advantages: bool,
    /// Learning rate over env steps, RLlib's `lr_schedule` (`[[0, 1e-3],
    /// [2_000_000, 1e-4]]`): replaces `lr` when set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lr_schedule: Option<Schedule>,
    /// Entropy coefficient over env steps, RLlib's
    /// `entropy_coeff_schedule`: replaces `entropy_coeff` when set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub entropy_schedule: Option<Schedule>,
    /// Threads that share each minibatch's gradient (0, the default: the
    /// run's share of the cores, [`super::cores::share`]). A resource
    /// setting, not a hyperparameter: the update is the same up to float
    /// rounding. While PPO updates, its actors wait for the new weights,
    /// so the cores they leave are free.
    pub update_threads: usize,
}

impl Default for PpoConfig {
    fn default() -> Self {
        Self {
            lr: 1e-3,
            epochs: 12,
            clip: 0.05,
            entropy_coeff: 0.001,
            train_batch: 4000,
            minibatch: 4000,
            lambda: 0.95,
            vf_coeff: 1.0,
            vf_clip: 10.0,
            kl_coeff: 0.2,
            kl_target: 0.01,
            grad_clip: None,
            vf_share_layers: false,
            standardize_advantages: true,
            lr_schedule: None,
            entropy_schedule: None,
            update_threads: 0,
        }
    }
}

/// IMPALA hyperparameters (defaults: the dissertation's comparison config
/// and RLlib's defaults for the rest).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImpalaConfig {
    /// Learning rate (1e-3).
    pub lr: f64,
    /// Train batch in env steps per gradient step (8000).
    pub train_batch: usize,
    /// Value loss coefficient (0.5).
    pub vf_coeff: f32,
    /// Entropy coefficient (0).
    pub entropy_coeff: f32,
    /// Global-norm gradient clip (RLlib 40).
    pub grad_clip: Option<f64>,
    /// V-trace ρ̄ (1).
    pub rho_bar: f32,
    /// V-trace c̄ (1).
    pub c_bar: f32,
    /// Policy-gradient ρ̄ (1).
    pub pg_rho_bar: f32,
    /// V-trace λ (1).
    pub lambda: f32,
    /// Fragments older than this many policy versions are dropped (counted
    /// in `stale_fragments`).
    pub max_policy_lag: u64,
    /// Fragments the actor→learner queue holds (0: one train batch).
    pub queue_capacity: usize,
    /// Probability that a rollout step takes the policy's most probable
    /// action instead of a sample (0: plain sampling). Rollouts then
    /// rehearse greedy execution, and V-trace corrects for the mixed
    /// behaviour ([`ActMode::GreedyMix`]).
    pub greedy_mix: f32,
    /// Learning rate over env steps, RLlib's `lr_schedule` (`[[0, 5e-4],
    /// [10_000_000, 5e-5]]`): replaces `lr` when set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lr_schedule: Option<Schedule>,
    /// Entropy coefficient over env steps, RLlib's
    /// `entropy_coeff_schedule`: replaces `entropy_coeff` when set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub entropy_schedule: Option<Schedule>,
    /// Threads that share the train batch's gradient (1, the default; 0:
    /// the run's share of the cores, [`super::cores::share`]). A resource
    /// setting, not a hyperparameter: the update is the same up to float
    /// rounding. Unlike PPO's, IMPALA's actors keep collecting while it
    /// updates, so on a machine with no core to spare a second thread
    /// takes the actors' (measured on 2 cores: MLP 71k against 85k env
    /// steps/s with one thread, LSTM unchanged; `docs/results/lstm/`).
    pub update_threads: usize,
}

impl Default for ImpalaConfig {
    fn default() -> Self {
        Self {
            lr: 1e-3,
            train_batch: 8000,
            vf_coeff: 0.5,
            entropy_coeff: 0.0,
            grad_clip: Some(40.0),
            rho_bar: 1.0,
            c_bar: 1.0,
            pg_rho_bar: 1.0,
            lambda: 1.0,
            max_policy_lag: 8,
            queue_capacity: 0,
            greedy_mix: 0.0,
            lr_schedule: None,
            entropy_schedule: None,
            update_threads: 1,
        }
    }
}

/// Everything a training run needs.
///
/// Env steps are *vectorised* env steps: one step of one env instance
/// counts 1 whatever the number of agents (RLlib's default
/// `count_steps_by="env_steps"`); `train_batch`, `steps` and every reported
/// step count use this unit.
///
/// ```
/// use buridan_learner::train::TrainConfig;
/// let cfg: TrainConfig = toml::from_str(r#"
///     algo = "ppo"
///     mode = "ctde"
///     map = "rm-1.1"
///     agents = 2
///     starts = "fixed"
///     steps = 200000
///     [ppo]
///     clip = 0.1
/// "#).unwrap();
/// assert_eq!(cfg.ppo.clip, 0.1);
/// assert_eq!(cfg.ppo.epochs, 12);
/// cfg.validate().unwrap();
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// PPO or IMPALA.
    pub algo: Algo,
    /// CTE, CTDE or DTE.
    pub mode: Mode,
    /// Reference model id (`rm-2.1`) or a MovingAI `.map` path.
    pub map: String,
    /// Several layouts with weights, instead of `map`: each env draws the
    /// layout of every episode from them (a file sets one of `map` and
    /// `maps`; when `maps` is set, `map` is not used). CTDE and DTE only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub maps: Option<Vec<WeightedMap>>,
    /// Train on an AGV plant instead of a grid map: a bundled plant id
    /// (`dissertation`, `hall`) or a plant file path ([`Plant::load`]).
    /// Excludes `maps` (a file sets at most one of `map`, `maps` and
    /// `plant`), `[imitation]`, `features` and `shaping`; `starts`,
    /// `rules` and `sensor_range` do not apply. The run's label is
    /// `plant:ID` ([`TrainConfig::map_label`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plant: Option<String>,
    /// Agents per env.
    pub agents: usize,
    /// Fixed (`.scen`) or random starts and goals.
    pub starts: Starts,
    /// The rule set agents move by: `thesis` (sequential moves in index
    /// order, the dissertation's) or `pogema` (simultaneous moves,
    /// POGEMA's repair). Recorded in checkpoints.
    pub rules: Rules,
    /// Episode truncation `T_max` (in a file without it: the rule set's,
    /// 100 for thesis, 128 for pogema). With `plant`: the plant episode's
    /// length in steps, replacing the plant file's `episode.t_max`; a file
    /// (or `learner train --plant`) that leaves `t_max` out takes the plant
    /// file's ([`TrainConfig::use_plant_t_max`]).
    pub t_max: u32,
    /// Sensor range R of local observations.
    pub sensor_range: usize,
    /// Extra local-observation features, TOML `[features] path = true`
    /// (the recipe's; none by default: the dissertation's observation).
    pub features: ObsFeatures,
    /// Potential-based shaping on the goal distance: reward per step gained
    /// (0 = off, the dissertation's rewards). Uses `gamma`.
    pub shaping: f32,
    /// Seed of weights, sampling and the env episodes (actor `i` uses env seed `seed + i`).
    pub seed: u64,
    /// Env-step budget.
    pub steps: u64,
    /// Actor threads.
    pub num_actors: usize,
    /// Envs per actor (one VecEnv each).
    pub envs_per_actor: usize,
    /// Niceness of the embedded actor threads (0–19; 0: the learner's
    /// priority), as `actor --nice` sets it for an actor process. Measured
    /// on 2 cores it leaves an embedded IMPALA run's speed unchanged (0.99)
    /// while it speeds up an actor process beside the learner; the
    /// transport bench sets both alike (README, "Measured on this 2-core
    /// machine").
    #[serde(skip_serializing_if = "is_zero")]
    pub actor_nice: u8,
    /// Rollout fragment length T (50).
    pub fragment_len: usize,
    /// Rollouts through the PIBT collision shield, as a shielded policy is
    /// deployed (`buridan_actor::shield`; CS-PIBT): the policy acts under
    /// wall masks, so asking for a neighbour's cell is legal, and the env
    /// executes the shield's conflict-free joint move. Grid runs only; off
    /// by default.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub shield_rollouts: bool,
    /// Replay of failed training episodes, TOML `[replay]`
    /// ([`buridan_env::replay`], prioritized level replay in its simplest
    /// form): with probability `share` a reset plays a failed episode again
    /// (at most `tries` times, until it succeeds) instead of a fresh one.
    /// The training success and return count fresh episodes only; remote
    /// actors get the settings with their join reply. Grid runs only; off
    /// by default (`share = 0`).
    #[serde(skip_serializing_if = "replay_off")]
    pub replay: ReplayConfig,
    /// Discount γ (0.99).
    pub gamma: f32,
    /// Hidden layer sizes ([64, 64]).
    pub hidden: Vec<usize>,
    /// LSTM after the hidden layers (the comparison runs used one; off by
    /// default here because the feed-forward net trains several times faster).
    pub lstm: bool,
    /// LSTM cells (64).
    pub lstm_cells: usize,
    /// Truncated-BPTT length (RLlib `max_seq_len` 32).
    pub max_seq_len: usize,
    /// Save a checkpoint every this many updates (0: only the final one).
    pub checkpoint_every: u64,
    /// Stop early once the mean return of the last 100 episodes reaches this.
    pub stop_return: Option<f64>,
    /// …and (if set) their mean length is at most this.
    pub stop_len: Option<f64>,
    /// Stop once the policy has learned, TOML `[stop]`: the training
    /// success has held `success` for `hold` env steps, or (`[stop.greedy]`)
    /// the greedy policy solves a share of held-out episodes (`steps` stays
    /// the cap; [`super::stop`]). Off by default; the recipe sets it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stop: Option<StopRule>,
    /// Continue from this checkpoint directory (weights, optimiser, counters).
    pub resume: Option<PathBuf>,
    /// PPO settings.
    pub ppo: PpoConfig,
    /// IMPALA settings.
    pub impala: ImpalaConfig,
    /// Imitate a planner before learning from rewards, TOML `[imitation]`
    /// (DAgger, `buridan_imitate`): a fresh run's policy is first fitted
    /// to the planner's actions on the states it visits, then trained by
    /// `algo` for `steps` env steps (0: imitation only). Off by default.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub imitation: Option<ImitationConfig>,
    /// Imitate a planner after learning from rewards, TOML `[polish]`: the
    /// trained policy's own rollouts (greedy by default) get the planner's
    /// next steps as labels, DAgger on the states deterministic execution
    /// reaches, before the final checkpoint. With `expert_first = false`
    /// every round follows the policy. Off by default.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub polish: Option<ImitationConfig>,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            algo: Algo::Ppo,
            mode: Mode::Ctde,
            map: "rm-2.1".into(),
            maps: None,
            plant: None,
            agents: 4,
            starts: Starts::Random,
            rules: Rules::Thesis,
            t_max: Rules::Thesis.default_t_max(),
            sensor_range: 2,
            features: ObsFeatures::default(),
            shaping: 0.0,
            seed: 0,
            steps: 2_000_000,
            num_actors: 1,
            envs_per_actor: 16,
            actor_nice: 0,
            fragment_len: 50,
            shield_rollouts: false,
            replay: ReplayConfig::default(),
            gamma: 0.99,
            hidden: vec![64, 64],
            lstm: false,
            lstm_cells: 64,
            max_seq_len: 32,
            checkpoint_every: 50,
            stop_return: None,
            stop_len: None,
            stop: None,
            resume: None,
            ppo: PpoConfig::default(),
            impala: ImpalaConfig::default(),
            imitation: None,
            polish: None,
        }
    }
}

impl TrainConfig {
    /// The default recipe: what `learner train --map LAYOUT` runs without a
    /// config. PPO-CTDE with the dissertation's 64-cell LSTM, warm-started
    /// by imitation: DAgger on the planners' next steps (4 rounds of 20k env
    /// steps labelled by LaCAM, then OD-A\*, 10 ms per call), then PPO with
    /// the comparison settings (lr 1e-3, 12 epochs, clip 0.05, entropy
    /// 0.001, batch = minibatch = 4000), the path and intent features and
    /// potential-based shaping 0.05; one update thread, so two runs share
    /// two cores. PPO runs until the greedy policy solves 99 % of 200
    /// held-out episodes (checked every 20k env steps, `[stop.greedy]`) or
    /// the training success has stayed at 99 % or more for 200k env steps
    /// (`[stop]`), at most 1M env steps.
    ///
    /// Chosen by measurement: the book's recipe chapter and
    /// `docs/results/recipe-lstm-imitation*/RESULTS.md` give its figures per
    /// layout (10 seeds each) and the feed-forward IMPALA recipe it
    /// replaced, kept as `learner/configs/recipe-impala-feedforward.toml`.
    ///
    /// ```
    /// use buridan_learner::train::{Algo, TrainConfig};
    /// let r = TrainConfig::recipe();
    /// assert_eq!(r.algo, Algo::Ppo);
    /// assert!(r.lstm && r.features.path && r.features.intent && r.shaping > 0.0);
    /// let imitation = r.imitation.as_ref().unwrap();
    /// assert_eq!((imitation.rounds, imitation.expert.as_slice()), (4, &["lacam".to_string(), "od-astar".into()][..]));
    /// assert_eq!(r.stop.map(|s| (s.success, s.hold)), Some((0.99, 200_000)));
    /// let greedy = r.stop.and_then(|s| s.greedy).unwrap();
    /// assert_eq!((greedy.success, greedy.episodes, greedy.every), (0.99, 200, 20_000));
    /// r.validate().unwrap();
    /// ```
    pub fn recipe() -> Self {
        Self {
            algo: Algo::Ppo,
            features: ObsFeatures {
                path: true,
                intent: true,
                ..ObsFeatures::default()
            },
            shaping: 0.05,
            steps: 1_000_000,
            stop: Some(StopRule {
                success: 0.99,
                hold: 200_000,
                greedy: Some(GreedyCheck {
                    success: 0.99,
                    episodes: 200,
                    every: 20_000,
                }),
            }),
            lstm: true,
            ppo: PpoConfig {
                update_threads: 1,
                ..PpoConfig::default()
            },
            imitation: Some(ImitationConfig {
                expert: vec!["lacam".into(), "od-astar".into()],
                expert_time: 0.01,
                rounds: 4,
                ..ImitationConfig::default()
            }),
            ..Self::default()
        }
    }

    /// Reads a TOML file (which sets at most one of `map` and `maps`).
    pub fn from_toml_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let parse_error = |source| ConfigError::Parse {
            path: path.to_path_buf(),
            source,
        };
        let table: toml::Table = toml::from_str(&text).map_err(parse_error)?;
        if table.contains_key("map") && table.contains_key("maps") {
            return Err(ConfigError::MapAndMaps {
                path: path.to_path_buf(),
            });
        }
        if table.contains_key("plant") && (table.contains_key("map") || table.contains_key("maps"))
        {
            return Err(ConfigError::PlantAndMap {
                path: path.to_path_buf(),
            });
        }
        let t_max_given = table.contains_key("t_max");
        let mut cfg: Self = table.try_into().map_err(parse_error)?;
        if !t_max_given {
            cfg.t_max = cfg.rules.default_t_max();
            cfg.use_plant_t_max()?;
        }
        cfg.validate()?;
        Ok(cfg)
    }

    /// Sets `t_max` to the plant file's `episode.t_max` (1,000 steps for
    /// the bundled plants) if this is a plant run; a grid run is left as it
    /// is. [`Self::from_toml_file`] and `learner train` call it when no
    /// `t_max` is given.
    ///
    /// ```
    /// use buridan_learner::train::TrainConfig;
    /// let mut cfg = TrainConfig { plant: Some("dissertation".into()), ..TrainConfig::default() };
    /// assert_eq!(cfg.t_max, 100); // the grid default, until...
    /// cfg.use_plant_t_max().unwrap();
    /// assert_eq!(cfg.t_max, 1000);
    /// ```
    pub fn use_plant_t_max(&mut self) -> Result<(), ConfigError> {
        if let Some(name) = &self.plant {
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
    /// use buridan_learner::train::{ConfigError, TrainConfig};
    /// let mut cfg = TrainConfig { plant: Some("dissertation".into()), t_max: 50, agents: 2, ..TrainConfig::default() };
    /// assert_eq!(cfg.load_plant().unwrap().unwrap().episode.t_max, 50);
    /// cfg.plant = Some("no-such-plant".into());
    /// assert!(matches!(cfg.load_plant(), Err(ConfigError::UnknownPlant { .. })));
    /// ```
    pub fn load_plant(&self) -> Result<Option<Plant>, ConfigError> {
        let Some(name) = &self.plant else {
            return Ok(None);
        };
        let mut plant = load_plant_file(name)?;
        plant.episode.t_max = self.t_max;
        PlantEnv::new(
            std::sync::Arc::new(plant.clone()),
            self.plant_config(self.seed),
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

    /// The config as TOML (without the unused `map` when `maps` or `plant`
    /// is set, so that the text reads back with [`Self::from_toml_file`]).
    pub fn to_toml(&self) -> String {
        if self.maps.is_none() && self.plant.is_none() {
            return toml::to_string_pretty(self).expect("config serialises");
        }
        let mut table = toml::Table::try_from(self).expect("config serialises");
        table.remove("map");
        toml::to_string_pretty(&table).expect("config serialises")
    }

    /// The training layouts: `maps`, or `map` with weight 1.
    pub fn layouts(&self) -> Vec<WeightedMap> {
        match &self.maps {
            Some(maps) => maps.clone(),
            None => vec![WeightedMap {
                name: self.map.clone(),
                weight: 1.0,
            }],
        }
    }

    /// The training layouts' names, in order (a plant run: its
    /// [`Self::map_label`], `plant:ID`).
    pub fn layout_names(&self) -> Vec<String> {
        if self.plant.is_some() {
            return vec![self.map_label()];
        }
        self.layouts().into_iter().map(|m| m.name).collect()
    }

    /// What the run trains on, in one word: `map`, the
    /// [`WeightedMap::label`] of `maps`, or `plant:ID` for a plant.
    ///
    /// ```
    /// use buridan_learner::train::TrainConfig;
    /// let cfg = TrainConfig { plant: Some("dissertation".into()), ..TrainConfig::default() };
    /// assert_eq!(cfg.map_label(), "plant:dissertation");
    /// ```
    pub fn map_label(&self) -> String {
        if let Some(plant) = &self.plant {
            return format!("plant:{plant}");
        }
        match &self.maps {
            Some(maps) => WeightedMap::label(maps),
            None => self.map.clone(),
        }
    }

    /// Loads the layouts of `maps` with their weights, checking that each
    /// exists and holds the configured agents (one episode of each is
    /// drawn). `None` for a single-map config.
    ///
    /// ```
    /// use buridan_learner::train::{ConfigError, TrainConfig, WeightedMap};
    /// let mut cfg = TrainConfig { maps: Some(WeightedMap::parse_list("rm-2.2,rm-3.1").unwrap()), ..TrainConfig::default() };
    /// assert_eq!(cfg.load_maps().unwrap().unwrap().len(), 2);
    /// cfg.agents = 200; // 400 distinct cells: more than rm-2.2 has
    /// assert!(matches!(cfg.load_maps(), Err(ConfigError::AgentsDoNotFit { .. })));
    /// ```
    pub fn load_maps(&self) -> Result<Option<Vec<WeightedLayout>>, ConfigError> {
        let Some(maps) = &self.maps else {
            return Ok(None);
        };
        self.validate()?;
        maps.iter()
            .map(|m| {
                let map = Map::load(&m.name).map_err(|source| ConfigError::UnknownMap {
                    map: m.name.clone(),
                    source,
                })?;
                buridan_env::episode_instance(&map, self.agents, self.starts, self.seed, 0)
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

    /// Checks the `maps` list without loading maps.
    fn validate_maps(&self) -> Result<(), ConfigError> {
        let Some(maps) = &self.maps else {
            return Ok(());
        };
        if maps.is_empty() {
            return Err(ConfigError::NoMaps);
        }
        for (i, m) in maps.iter().enumerate() {
            if !(m.weight.is_finite() && m.weight > 0.0) {
                return Err(ConfigError::BadWeight {
                    map: m.name.clone(),
                    weight: m.weight,
                });
            }
            if maps[..i].iter().any(|o| o.name == m.name) {
                return Err(ConfigError::DuplicateMap {
                    map: m.name.clone(),
                });
            }
        }
        if maps.len() > 1 && self.mode == Mode::Cte {
            return Err(ConfigError::CentralOnSeveralMaps);
        }
        Ok(())
    }

    /// Checks that every real-valued hyperparameter is a finite number in
    /// its range: a NaN learning rate would otherwise train on, silently
    /// turning every weight into NaN.
    fn validate_hyperparameters(&self) -> Result<(), ConfigError> {
        let (p, i) = (&self.ppo, &self.impala);
        let positive = [
            ("ppo.lr", p.lr),
            ("ppo.clip", p.clip.into()),
            ("ppo.vf_clip", p.vf_clip.into()),
            ("ppo.kl_target", p.kl_target),
            ("ppo.grad_clip", p.grad_clip.unwrap_or(1.0)),
            ("impala.lr", i.lr),
            ("impala.grad_clip", i.grad_clip.unwrap_or(1.0)),
            ("impala.rho_bar", i.rho_bar.into()),
            ("impala.c_bar", i.c_bar.into()),
            ("impala.pg_rho_bar", i.pg_rho_bar.into()),
        ];
        let non_negative = [
            ("ppo.entropy_coeff", p.entropy_coeff.into()),
            ("ppo.vf_coeff", p.vf_coeff.into()),
            ("ppo.kl_coeff", p.kl_coeff),
            ("impala.vf_coeff", i.vf_coeff.into()),
            ("impala.entropy_coeff", i.entropy_coeff.into()),
        ];
        let unit = [
            ("ppo.lambda", p.lambda.into()),
            ("impala.lambda", i.lambda.into()),
        ];
        let in_range = |keys: &[(&'static str, f64)], range, ok: fn(f64) -> bool| match keys
            .iter()
            .find(|(_, value)| !ok(*value))
        {
            Some(&(key, value)) => Err(ConfigError::OutOfRange { key, value, range }),
            None => Ok(()),
        };
        in_range(&positive, "finite and positive", |v| {
            v.is_finite() && v > 0.0
        })?;
        in_range(&non_negative, "finite and at least 0", |v| {
            v.is_finite() && v >= 0.0
        })?;
        in_range(&unit, "in [0, 1]", |v| (0.0..=1.0).contains(&v))
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), ConfigError> {
        ensure(self.agents >= 1, "agents must be at least 1")?;
        ensure(
            self.shaping.is_finite() && self.shaping >= 0.0,
            "shaping must be finite and at least 0",
        )?;
        ensure(
            self.features.is_none() || self.mode != Mode::Cte,
            "observation features apply to local observations (CTDE, DTE), not CTE's central one",
        )?;
        ensure(self.num_actors >= 1, "num_actors must be at least 1")?;
        ensure(
            self.envs_per_actor >= 1,
            "envs_per_actor must be at least 1",
        )?;
        ensure(self.actor_nice <= 19, "actor_nice must be at most 19")?;
        ensure(self.fragment_len >= 1, "fragment_len must be at least 1")?;
        ensure(
            !self.hidden.is_empty() && !self.hidden.contains(&0),
            "hidden sizes must be positive",
        )?;
        ensure((0.0..=1.0).contains(&self.gamma), "gamma must be in [0, 1]")?;
        ensure(self.ppo.epochs >= 1, "ppo.epochs must be at least 1")?;
        ensure(
            self.ppo.train_batch >= 1 && self.ppo.minibatch >= 1,
            "ppo batch sizes must be positive",
        )?;
        ensure(
            self.impala.train_batch >= 1,
            "impala.train_batch must be positive",
        )?;
        ensure(
            (0.0..1.0).contains(&self.impala.greedy_mix),
            "impala.greedy_mix must be in [0, 1)",
        )?;
        ensure(
            self.impala.greedy_mix == 0.0 || self.algo == Algo::Impala,
            "impala.greedy_mix needs algo = \"impala\" (PPO's ratio assumes sampled rollouts)",
        )?;
        ensure(self.lstm_cells >= 1, "lstm_cells must be positive")?;
        self.replay.validate().map_err(ConfigError::Replay)?;
        if let Some(stop) = &self.stop {
            stop.validate().map_err(ConfigError::Invalid)?;
            ensure(
                stop.greedy.is_none() || (self.maps.is_none() && self.plant.is_none()),
                "stop.greedy needs one grid map (`map`): it plays held-out episodes of that map",
            )?;
        }
        self.validate_hyperparameters()?;
        for (section, im) in self.imitation_phases() {
            im.validate().map_err(|e| ConfigError::Imitation {
                section,
                source: Box::new(e),
            })?;
        }
        self.validate_plant()?;
        self.validate_maps()
    }

    /// The run's imitation phases with their TOML section names: `imitation`
    /// before learning from rewards, `polish` after.
    fn imitation_phases(&self) -> impl Iterator<Item = (&'static str, &ImitationConfig)> {
        [("imitation", &self.imitation), ("polish", &self.polish)]
            .into_iter()
            .filter_map(|(section, im)| im.as_ref().map(|im| (section, im)))
    }

    /// Checks that a plant run sets nothing that only a grid run has.
    fn validate_plant(&self) -> Result<(), ConfigError> {
        if self.plant.is_none() {
            return Ok(());
        }
        if self.maps.is_some() {
            return Err(ConfigError::PlantAndMaps);
        }
        if let Some((section, _)) = self.imitation_phases().next() {
            return Err(ConfigError::PlantWithImitation { section });
        }
        if !self.features.is_none() {
            return Err(ConfigError::GridOnlyOption { what: "features" });
        }
        if self.shaping != 0.0 {
            return Err(ConfigError::GridOnlyOption { what: "shaping" });
        }
        if self.shield_rollouts {
            return Err(ConfigError::GridOnlyOption {
                what: "shield_rollouts",
            });
        }
        if self.replay.enabled() {
            return Err(ConfigError::GridOnlyOption { what: "replay" });
        }
        ensure(self.t_max >= 1, "t_max must be at least 1")
    }

    /// How rollouts choose actions: samples, mixed with greedy steps when
    /// IMPALA's `greedy_mix` is set (PPO always samples: its clipped ratio
    /// assumes the behaviour is the policy itself).
    ///
    /// ```
    /// use buridan_learner::train::{Algo, TrainConfig};
    /// use buridan_policy::ActMode;
    /// let mut cfg = TrainConfig::default();
    /// assert_eq!(cfg.behaviour(), ActMode::Sample);
    /// cfg.algo = Algo::Impala;
    /// cfg.impala.greedy_mix = 0.5;
    /// assert_eq!(cfg.behaviour(), ActMode::GreedyMix(0.5));
    /// ```
    pub fn behaviour(&self) -> ActMode {
        match self.algo {
            Algo::Impala => ActMode::rollout(self.impala.greedy_mix),
            Algo::Ppo => ActMode::Sample,
        }
    }

    /// Whether the algorithm learns only from the newest policy's
    /// experience (PPO), so actors wait after each train batch.
    pub fn on_policy(&self) -> bool {
        self.algo == Algo::Ppo
    }

    /// How old experience may be: on-policy for PPO, `impala.max_policy_lag`
    /// versions for IMPALA.
    pub fn staleness(&self) -> Staleness {
        match self.algo {
            Algo::Ppo => Staleness::OnPolicy,
            Algo::Impala => Staleness::MaxLag(self.impala.max_policy_lag),
        }
    }

    /// Env steps per train batch of the configured algorithm.
    pub fn train_batch(&self) -> u64 {
        match self.algo {
            Algo::Ppo => self.ppo.train_batch as u64,
            Algo::Impala => self.impala.train_batch as u64,
        }
    }

    /// Env steps one fragment holds: `fragment_len · envs_per_actor`.
    pub fn fragment_env_steps(&self) -> usize {
        self.fragment_len * self.envs_per_actor
    }

    /// Fragments per train batch (rounded up).
    pub fn fragments_per_batch(&self) -> usize {
        (self.train_batch() as usize)
            .div_ceil(self.fragment_env_steps())
            .max(1)
    }

    /// Fragments the actor→learner queue holds: `impala.queue_capacity` if
    /// set (IMPALA), else one train batch.
    pub fn queue_capacity(&self) -> usize {
        match self.algo {
            Algo::Impala if self.impala.queue_capacity > 0 => self.impala.queue_capacity,
            _ => self.fragments_per_batch(),
        }
    }

    /// The network architecture for observations of `obs_dim` floats.
    pub fn model_spec(&self, obs_dim: usize) -> ModelSpec {
        let value = if self.lstm {
            ValueHead::Shared
        } else {
            match self.algo {
                Algo::Ppo if !self.ppo.vf_share_layers => ValueHead::Separate,
                _ => ValueHead::Shared,
            }
        };
        ModelSpec {
            hidden: self.hidden.clone(),
            value,
            lstm: self.lstm.then_some(LstmSpec {
                cells: self.lstm_cells,
                prev_action: true,
                prev_reward: true,
            }),
            features: self.features,
            sensor_range: self.sensor_range,
            maps: self.layout_names(),
            rules: self.rules,
            ..ModelSpec::new(self.mode, self.agents, obs_dim)
        }
    }
}

impl From<&TrainConfig> for PpoSettings {
    fn from(cfg: &TrainConfig) -> Self {
        let p = &cfg.ppo;
        Self {
            lr: p.lr,
            epochs: p.epochs,
            minibatch_size: p.minibatch,
            clip: p.clip,
            vf_coeff: p.vf_coeff,
            vf_clip: p.vf_clip,
            entropy_coeff: p.entropy_coeff,
            kl_coeff: p.kl_coeff,
            kl_target: p.kl_target,
            gamma: cfg.gamma,
            lambda: p.lambda,
            grad_clip: p.grad_clip,
            standardize_advantages: p.standardize_advantages,
            max_seq_len: cfg.max_seq_len,
            update_threads: super::cores::update_threads(p.update_threads),
        }
    }
}

impl From<&TrainConfig> for ImpalaSettings {
    fn from(cfg: &TrainConfig) -> Self {
        let i = &cfg.impala;
        Self {
            lr: i.lr,
            vf_coeff: i.vf_coeff,
            entropy_coeff: i.entropy_coeff,
            grad_clip: i.grad_clip,
            vtrace: VTraceParams {
                gamma: cfg.gamma,
                lambda: i.lambda,
                rho_bar: i.rho_bar,
                c_bar: i.c_bar,
                pg_rho_bar: i.pg_rho_bar,
            },
            max_seq_len: cfg.max_seq_len,
            update_threads: super::cores::update_threads(i.update_threads),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default config with one field changed, validated.
    fn with(change: impl Fn(&mut TrainConfig)) -> Result<(), ConfigError> {
        let mut cfg = TrainConfig::default();
        change(&mut cfg);
        cfg.validate()
    }

    fn plant_run(change: impl Fn(&mut TrainConfig)) -> Result<(), ConfigError> {
        with(|c| {
            c.plant = Some("dissertation".into());
            change(c)
        })
    }

    #[test]
    fn a_plant_run_refuses_maps_imitation_and_grid_options() {
        plant_run(|_| {}).unwrap();
        plant_run(|c| c.mode = Mode::Cte).unwrap();
        let err = plant_run(|c| c.maps = Some(WeightedMap::parse_list("rm-2.2").unwrap()));
        assert!(matches!(err, Err(ConfigError::PlantAndMaps)), "{err:?}");
        let msg = err.unwrap_err().to_string();
        assert!(msg.contains("plant and maps are both set"), "{msg}");
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

    #[test]
    fn hyperparameters_outside_their_range_are_refused_by_name() {
        type Change = fn(&mut TrainConfig);
        let bad: [(&str, &str, Change); 7] = [
            ("ppo.lr", "finite and positive", |c| c.ppo.lr = f64::NAN),
            ("ppo.lr", "finite and positive", |c| c.ppo.lr = 0.0),
            ("impala.lr", "finite and positive", |c| {
                c.impala.lr = f64::INFINITY
            }),
            ("ppo.entropy_coeff", "finite and at least 0", |c| {
                c.ppo.entropy_coeff = -0.01
            }),
            ("impala.rho_bar", "finite and positive", |c| {
                c.impala.rho_bar = -1.0
            }),
            ("ppo.lambda", "in [0, 1]", |c| c.ppo.lambda = 1.5),
            ("ppo.grad_clip", "finite and positive", |c| {
                c.ppo.grad_clip = Some(f64::NAN)
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
        let edges: [Change; 5] = [
            |c| c.ppo.entropy_coeff = 0.0,
            |c| c.ppo.kl_coeff = 0.0,
            |c| c.ppo.lambda = 1.0,
            |c| c.impala.lambda = 0.0,
            |c| c.ppo.lr = 1e-8,
        ];
        for (i, change) in edges.into_iter().enumerate() {
            assert!(with(change).is_ok(), "edge {i} refused");
        }
    }
}
