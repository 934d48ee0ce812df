//! The file form of a training configuration: [`TrainConfig`] as its TOML
//! has it, the task spread over the keys `map`, `maps` and `plant` (at most
//! one set), its algorithm as the key `algo` and that algorithm's table
//! (`[ppo]` or `[impala]`). `TrainConfig` (de)serialises through it, so the
//! format stays that of the flat struct it replaced: same keys, same order,
//! unknown keys refused.

use std::path::PathBuf;

use buridan_env::replay::ReplayConfig;
use buridan_env::{ObsFeatures, Rules, Starts};
use buridan_imitate::ImitationConfig;
use buridan_policy::{DeviceSpec, Mode};
use serde::{Deserialize, Serialize};

use super::{Algo, Algorithm};
use super::{
    ImpalaConfig, ModelConfig, PpoConfig, RunConfig, Task, TaskKeysError, TrainConfig, WeightedMap,
};
use crate::train::stop::StopRule;

/// Whether failure replay is off (then `[replay]` is left out of a saved config).
fn is_zero(n: &u8) -> bool {
    *n == 0
}

fn no_delay(delay: &f32) -> bool {
    *delay == 0.0
}

fn on_cpu(device: &DeviceSpec) -> bool {
    device.is_cpu()
}

fn replay_off(replay: &ReplayConfig) -> bool {
    *replay == ReplayConfig::default()
}

/// [`TrainConfig`] field by field, with its `task` as the three keys that
/// name it (documented on `TrainConfig` and [`Task`]) and its `algorithm`
/// as `algo` and a table per algorithm, at most the other's left at its
/// defaults (every config saved before the type wrote both).
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
    #[serde(skip_serializing_if = "no_delay")]
    delay: f32,
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
    #[serde(skip_serializing_if = "on_cpu")]
    device: DeviceSpec,
    #[serde(skip_serializing_if = "Option::is_none")]
    ppo: Option<PpoConfig>,
    #[serde(skip_serializing_if = "Option::is_none")]
    impala: Option<ImpalaConfig>,
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

/// Why a file's keys name no single configuration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(super) enum FileError {
    /// The task keys ([`TaskKeysError`]).
    #[error(transparent)]
    Task(#[from] TaskKeysError),
    /// The other algorithm's table, set away from its defaults.
    #[error("config sets [{table}] but algo = \"{algo}\": [{table}] holds {table}'s settings; set algo = \"{table}\" or drop the table")]
    OtherAlgorithm {
        /// The table: `ppo` or `impala`.
        table: Algo,
        /// The configured algorithm.
        algo: Algo,
    },
}

impl TrainFile {
    /// The algorithm `algo` with its table; the other algorithm's table
    /// may only hold its defaults.
    fn algorithm(
        algo: Algo,
        ppo: Option<PpoConfig>,
        impala: Option<ImpalaConfig>,
    ) -> Result<Algorithm, FileError> {
        let other = |table| FileError::OtherAlgorithm { table, algo };
        match algo {
            Algo::Ppo
                if impala
                    .as_ref()
                    .is_some_and(|i| *i != ImpalaConfig::default()) =>
            {
                Err(other(Algo::Impala))
            }
            Algo::Impala if ppo.as_ref().is_some_and(|p| *p != PpoConfig::default()) => {
                Err(other(Algo::Ppo))
            }
            Algo::Ppo => Ok(Algorithm::Ppo(ppo.unwrap_or_default())),
            Algo::Impala => Ok(Algorithm::Impala(impala.unwrap_or_default())),
        }
    }
}

/// Both conversions from one list of the fields the two forms share (every
/// field but the task's, the model's, the algorithm's and the run's). Each side is destructured whole,
/// so a field added to one form and not to this list fails to compile.
macro_rules! convert_through_shared_fields {
    ($($field:ident),* $(,)?) => {
        impl TryFrom<TrainFile> for TrainConfig {
            type Error = FileError;

            fn try_from(file: TrainFile) -> Result<Self, FileError> {
                let TrainFile { map, maps, plant, hidden, lstm, lstm_cells, max_seq_len, algo, ppo, impala, seed, steps, num_actors, envs_per_actor, actor_nice, fragment_len, checkpoint_every, stop_return, stop_len, stop, resume, device, $($field),* } = file;
                Ok(TrainConfig {
                    task: Task::from_keys(map, maps, plant)?,
                    algorithm: TrainFile::algorithm(algo, ppo, impala)?,
                    model: ModelConfig { hidden, lstm, lstm_cells, max_seq_len },
                    run: RunConfig { seed, steps, num_actors, envs_per_actor, actor_nice, fragment_len, checkpoint_every, stop_return, stop_len, stop, resume, device },
                    $($field),*
                })
            }
        }

        impl From<TrainConfig> for TrainFile {
            fn from(cfg: TrainConfig) -> Self {
                let TrainConfig { task, model, algorithm, run, $($field),* } = cfg;
                let (map, maps, plant) = task.into_keys();
                let algo = algorithm.algo();
                let (ppo, impala) = match algorithm {
                    Algorithm::Ppo(p) => (Some(p), None),
                    Algorithm::Impala(i) => (None, Some(i)),
                };
                let ModelConfig { hidden, lstm, lstm_cells, max_seq_len } = model;
                let RunConfig { seed, steps, num_actors, envs_per_actor, actor_nice, fragment_len, checkpoint_every, stop_return, stop_len, stop, resume, device } = run;
                TrainFile { map, maps, plant, hidden, lstm, lstm_cells, max_seq_len, algo, ppo, impala, seed, steps, num_actors, envs_per_actor, actor_nice, fragment_len, checkpoint_every, stop_return, stop_len, stop, resume, device, $($field),* }
            }
        }
    };
}

convert_through_shared_fields!(
    mode,
    agents,
    starts,
    rules,
    t_max,
    sensor_range,
    features,
    shaping,
    shield_rollouts,
    replay,
    delay,
    gamma,
    imitation,
    polish,
);
