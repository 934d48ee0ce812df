//! Training configuration: every hyperparameter of SPEC §4, with the
//! dissertation's comparison settings as defaults, loadable from TOML.

use std::path::{Path, PathBuf};

use buridan_env::{ObsFeatures, Starts};
use buridan_policy::{LstmSpec, Mode, ModelSpec, ValueHead};
use serde::{Deserialize, Serialize};

use crate::algo::impala::ImpalaSettings;
use crate::algo::ppo::PpoSettings;
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
}

fn ensure(ok: bool, why: &'static str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Invalid(why))
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
    /// Agents per env.
    pub agents: usize,
    /// Fixed (`.scen`) or random starts and goals.
    pub starts: Starts,
    /// Episode truncation `T_max`.
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
    /// Rollout fragment length T (50).
    pub fragment_len: usize,
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
    /// Continue from this checkpoint directory (weights, optimiser, counters).
    pub resume: Option<PathBuf>,
    /// PPO settings.
    pub ppo: PpoConfig,
    /// IMPALA settings.
    pub impala: ImpalaConfig,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            algo: Algo::Ppo,
            mode: Mode::Ctde,
            map: "rm-2.1".into(),
            agents: 4,
            starts: Starts::Random,
            t_max: 100,
            sensor_range: 2,
            features: ObsFeatures::default(),
            shaping: 0.0,
            seed: 0,
            steps: 2_000_000,
            num_actors: 1,
            envs_per_actor: 16,
            fragment_len: 50,
            gamma: 0.99,
            hidden: vec![64, 64],
            lstm: false,
            lstm_cells: 64,
            max_seq_len: 32,
            checkpoint_every: 50,
            stop_return: None,
            stop_len: None,
            resume: None,
            ppo: PpoConfig::default(),
            impala: ImpalaConfig::default(),
        }
    }
}

impl TrainConfig {
    /// Reads a TOML file.
    pub fn from_toml_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let cfg: Self = toml::from_str(&text).map_err(|source| ConfigError::Parse {
            path: path.to_path_buf(),
            source,
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The config as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("config serialises")
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
        ensure(self.lstm_cells >= 1, "lstm_cells must be positive")?;
        Ok(())
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
        }
    }
}
