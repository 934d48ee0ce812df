//! The file form of a training configuration: [`TrainConfig`] as its TOML
//! has it, the task spread over the keys `map`, `maps` and `plant` (at most
//! one set). `TrainConfig` (de)serialises through it, so the format stays
//! that of the flat struct it replaced: same keys, same order, unknown keys
//! refused.

use std::path::PathBuf;

use buridan_env::replay::ReplayConfig;
use buridan_env::{ObsFeatures, Rules, Starts};
use buridan_imitate::ImitationConfig;
use buridan_policy::Mode;
use serde::{Deserialize, Serialize};

use super::Algo;
use super::{ImpalaConfig, ModelConfig, PpoConfig, Task, TaskKeysError, TrainConfig, WeightedMap};
use crate::train::stop::StopRule;

/// Whether failure replay is off (then `[replay]` is left out of a saved config).
fn is_zero(n: &u8) -> bool {
    *n == 0
}

fn replay_off(replay: &ReplayConfig) -> bool {
    *replay == ReplayConfig::default()
}

/// [`TrainConfig`] field by field, with its `task` as the three keys that
/// name it (documented on `TrainConfig` and [`Task`]).
#[derive(Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(super) struct TrainFile {
    algo: Algo,
    mode: Mode,
    #[serde(skip_serializing_if = "Option::is_none")]
    map: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    maps: Option<Vec<WeightedMap>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    plant: Option<String>,
    agents: usize,
    starts: Starts,
    rules: Rules,
    t_max: u32,
    sensor_range: usize,
    features: ObsFeatures,
    shaping: f32,
    seed: u64,
    steps: u64,
    num_actors: usize,
    envs_per_actor: usize,
    #[serde(skip_serializing_if = "is_zero")]
    actor_nice: u8,
    fragment_len: usize,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    shield_rollouts: bool,
    #[serde(skip_serializing_if = "replay_off")]
    replay: ReplayConfig,
    gamma: f32,
    hidden: Vec<usize>,
    lstm: bool,
    lstm_cells: usize,
    max_seq_len: usize,
    checkpoint_every: u64,
    stop_return: Option<f64>,
    stop_len: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    stop: Option<StopRule>,
    resume: Option<PathBuf>,
    ppo: PpoConfig,
    impala: ImpalaConfig,
    #[serde(skip_serializing_if = "Option::is_none")]
    imitation: Option<ImitationConfig>,
    #[serde(skip_serializing_if = "Option::is_none")]
    polish: Option<ImitationConfig>,
}

impl Default for TrainFile {
    /// The default config's settings; no task key (a file without one
    /// trains on [`Task::default`]).
    fn default() -> Self {
        Self {
            map: None,
            ..TrainConfig::default().into()
        }
    }
}

/// Both conversions from one list of the fields the two forms share (every
/// field but the task and the model's). Each side is destructured whole,
/// so a field added to one form and not to this list fails to compile.
macro_rules! convert_through_shared_fields {
    ($($field:ident),* $(,)?) => {
        impl TryFrom<TrainFile> for TrainConfig {
            type Error = TaskKeysError;

            fn try_from(file: TrainFile) -> Result<Self, TaskKeysError> {
                let TrainFile { map, maps, plant, hidden, lstm, lstm_cells, max_seq_len, $($field),* } = file;
                Ok(TrainConfig {
                    task: Task::from_keys(map, maps, plant)?,
                    model: ModelConfig { hidden, lstm, lstm_cells, max_seq_len },
                    $($field),*
                })
            }
        }

        impl From<TrainConfig> for TrainFile {
            fn from(cfg: TrainConfig) -> Self {
                let TrainConfig { task, model, $($field),* } = cfg;
                let (map, maps, plant) = task.into_keys();
                let ModelConfig { hidden, lstm, lstm_cells, max_seq_len } = model;
                TrainFile { map, maps, plant, hidden, lstm, lstm_cells, max_seq_len, $($field),* }
            }
        }
    };
}

convert_through_shared_fields!(
    algo,
    mode,
    agents,
    starts,
    rules,
    t_max,
    sensor_range,
    features,
    shaping,
    seed,
    steps,
    num_actors,
    envs_per_actor,
    actor_nice,
    fragment_len,
    shield_rollouts,
    replay,
    gamma,
    checkpoint_every,
    stop_return,
    stop_len,
    stop,
    resume,
    ppo,
    impala,
    imitation,
    polish,
);
