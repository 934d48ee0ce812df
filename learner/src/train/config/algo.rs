//! The algorithms a run may use and each one's own settings (SPEC §4).

use crate::algo::schedule::Schedule;
use serde::{Deserialize, Serialize};

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

/// The learning algorithm with its own settings: TOML `algo = "ppo"` with
/// a `[ppo]` table, or `algo = "impala"` with `[impala]`. A run carries the
/// settings of the algorithm it trains with and no other's.
///
/// ```
/// use buridan_learner::train::{Algo, Algorithm, PpoConfig};
/// let mut a = Algorithm::Ppo(PpoConfig { lr: 5e-4, ..PpoConfig::default() });
/// assert_eq!((a.algo(), a.train_batch()), (Algo::Ppo, 4000));
/// a.switch_to(Algo::Ppo); // the same algorithm keeps its settings
/// assert_eq!(a.ppo().map(|p| p.lr), Some(5e-4));
/// a.switch_to(Algo::Impala); // another starts from its defaults
/// assert_eq!((a.algo(), a.train_batch(), a.ppo()), (Algo::Impala, 8000, None));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub enum Algorithm {
    /// PPO ([`PpoConfig`]).
    Ppo(PpoConfig),
    /// IMPALA ([`ImpalaConfig`]).
    Impala(ImpalaConfig),
}

impl Default for Algorithm {
    /// PPO with the comparison settings.
    fn default() -> Self {
        Algorithm::Ppo(PpoConfig::default())
    }
}

impl Algorithm {
    /// `algo` with its default settings.
    pub fn of(algo: Algo) -> Self {
        match algo {
            Algo::Ppo => Algorithm::Ppo(PpoConfig::default()),
            Algo::Impala => Algorithm::Impala(ImpalaConfig::default()),
        }
    }

    /// Which algorithm.
    pub fn algo(&self) -> Algo {
        match self {
            Algorithm::Ppo(_) => Algo::Ppo,
            Algorithm::Impala(_) => Algo::Impala,
        }
    }

    /// Trains with `algo` from now on: the settings stay when it is the
    /// algorithm already, else they are `algo`'s defaults.
    pub fn switch_to(&mut self, algo: Algo) {
        if self.algo() != algo {
            *self = Self::of(algo);
        }
    }

    /// PPO's settings, if this is PPO.
    pub fn ppo(&self) -> Option<&PpoConfig> {
        match self {
            Algorithm::Ppo(p) => Some(p),
            Algorithm::Impala(_) => None,
        }
    }

    /// IMPALA's settings, if this is IMPALA.
    pub fn impala(&self) -> Option<&ImpalaConfig> {
        match self {
            Algorithm::Impala(i) => Some(i),
            Algorithm::Ppo(_) => None,
        }
    }

    /// PPO's settings to change, if this is PPO.
    pub fn ppo_mut(&mut self) -> Option<&mut PpoConfig> {
        match self {
            Algorithm::Ppo(p) => Some(p),
            Algorithm::Impala(_) => None,
        }
    }

    /// IMPALA's settings to change, if this is IMPALA.
    pub fn impala_mut(&mut self) -> Option<&mut ImpalaConfig> {
        match self {
            Algorithm::Impala(i) => Some(i),
            Algorithm::Ppo(_) => None,
        }
    }

    /// Env steps per train batch.
    pub fn train_batch(&self) -> usize {
        match self {
            Algorithm::Ppo(p) => p.train_batch,
            Algorithm::Impala(i) => i.train_batch,
        }
    }

    /// The `update_threads` setting (0: the run's share of the cores).
    pub fn update_threads(&self) -> usize {
        match self {
            Algorithm::Ppo(p) => p.update_threads,
            Algorithm::Impala(i) => i.update_threads,
        }
    }

    /// The learning-rate and entropy schedules, where set.
    pub fn schedules(&self) -> (Option<&Schedule>, Option<&Schedule>) {
        match self {
            Algorithm::Ppo(p) => (p.lr_schedule.as_ref(), p.entropy_schedule.as_ref()),
            Algorithm::Impala(i) => (i.lr_schedule.as_ref(), i.entropy_schedule.as_ref()),
        }
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
    /// Entropy coefficient (0.001): a bonus; negative, a penalty that
    /// drives the policy toward the deterministic one greedy execution runs.
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
    /// `entropy_coeff_schedule`: replaces `entropy_coeff` when set. Its
    /// points may be negative, as `entropy_coeff` may (`[[0, -0.05],
    /// [500_000, 0]]`: a penalty that fades out).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub entropy_schedule: Option<Schedule>,
    /// Threads that share each minibatch's gradient (0, the default: the
    /// run's share of the cores, [`super::cores::share`]). A resource
    /// setting, not a hyperparameter: the update is the same up to float
    /// rounding. While PPO updates, its actors wait for the new weights,
    /// so the cores they leave are free.
    pub update_threads: usize,
    /// Env steps of critic warm-up (0, the default: none): the first
    /// updates fit only the value head (and a separate value MLP) to the
    /// returns of the policy as it stands, every other weight frozen, so
    /// that the policy gradient starts from a critic that knows the
    /// imitated policy instead of rewriting it through a random one
    /// ([`crate::algo::ppo`], "Critic warm-up").
    #[serde(skip_serializing_if = "is_zero")]
    pub critic_warmup: u64,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
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
            critic_warmup: 0,
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
    /// Entropy coefficient (0): a bonus; negative, a penalty (as PPO's).
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
    /// `entropy_coeff_schedule`: replaces `entropy_coeff` when set. Its
    /// points may be negative, as `entropy_coeff` may (`[[0, -0.05],
    /// [500_000, 0]]`: a penalty that fades out).
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
