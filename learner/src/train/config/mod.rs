//! Training configuration: every hyperparameter of SPEC §4, with the
//! dissertation's comparison settings as defaults, loadable from TOML.

use std::path::Path;

use buridan_env::replay::ReplayConfig;
use buridan_env::{ObsFeatures, Rules, Starts};
use buridan_imitate::{ImitationConfig, Teacher};
use buridan_policy::{ActMode, LstmSpec, Mode, ModelSpec, ValueHead};
use serde::{Deserialize, Serialize};

use super::stop::{Finalists, GreedyCheck, StopRule};
use crate::algo::impala::ImpalaSettings;
use crate::algo::ppo::PpoSettings;
use crate::algo::vtrace::VTraceParams;
use crate::train::gate::Staleness;

mod algo;
mod error;
mod file;
mod layouts;
mod model;
mod run;
mod task;
#[cfg(test)]
mod tests;
mod validate;

pub use algo::{Algo, Algorithm, ImpalaConfig, PpoConfig};
pub use error::ConfigError;
pub use layouts::WeightedMap;
pub use model::ModelConfig;
pub use run::RunConfig;
pub use task::{Task, TaskKeysError};

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
/// let ppo = cfg.algorithm.ppo().unwrap();
/// assert_eq!((ppo.clip, ppo.epochs), (0.1, 12));
/// cfg.validate().unwrap();
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "file::TrainFile", into = "file::TrainFile")]
pub struct TrainConfig {
    /// PPO or IMPALA with its settings ([`Algorithm`]): TOML `algo`
    /// (`"ppo"` or `"impala"`) and that algorithm's table, `[ppo]` or
    /// `[impala]`. The other algorithm's table is refused unless it holds
    /// only its defaults (as configs saved before 2026-12 do).
    pub algorithm: Algorithm,
    /// CTE, CTDE or DTE.
    pub mode: Mode,
    /// What the run trains on ([`Task`]): one grid map (TOML `map`, by
    /// default `rm-2.1`), several layouts with weights (`maps`), or an AGV
    /// plant (`plant`); a file sets at most one of the three keys.
    pub task: Task,
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
    /// How the run is carried out ([`RunConfig`]): its seed and budget,
    /// the actors, checkpoints and when it stops, TOML top-level keys.
    pub run: RunConfig,
    /// Rollouts through the PIBT collision shield, as a shielded policy is
    /// deployed (`buridan_mapf::shield::rollout`; CS-PIBT): the policy acts under
    /// wall masks, so asking for a neighbour's cell is legal, and the env
    /// executes the shield's conflict-free joint move. Grid runs only; off
    /// by default.
    pub shield_rollouts: bool,
    /// Replay of failed training episodes, TOML `[replay]`
    /// ([`buridan_env::replay`], prioritized level replay in its simplest
    /// form): with probability `share` a reset plays a failed episode again
    /// (at most `tries` times, until it succeeds) instead of a fresh one.
    /// The training success and return count fresh episodes only; remote
    /// actors get the settings with their join reply. Grid runs only; off
    /// by default (`share = 0`).
    pub replay: ReplayConfig,
    /// Execution delays while training, as deployed robots lag: the
    /// probability in [0, 1) that an agent fails to carry out its move in
    /// a step ([`buridan_env::EnvConfig::delay`]; 0, the default: none,
    /// and the key is left out of a written config). Grid runs only;
    /// remote actors get it with the env settings.
    pub delay: f32,
    /// Discount γ (0.99).
    pub gamma: f32,
    /// The network: layer sizes and the LSTM, TOML top-level keys
    /// ([`ModelConfig`]).
    pub model: ModelConfig,
    /// Imitate a planner before learning from rewards, TOML `[imitation]`
    /// (DAgger, `buridan_imitate`): a fresh run's policy is first fitted
    /// to the planner's actions on the states it visits, then trained by
    /// `algo` for `steps` env steps (0: imitation only). Off by default.
    pub imitation: Option<ImitationConfig>,
    /// Imitate a planner after learning from rewards, TOML `[polish]`: the
    /// trained policy's own rollouts (greedy by default) get the planner's
    /// next steps as labels, DAgger on the states deterministic execution
    /// reaches, before the final checkpoint. With `expert_first = false`
    /// every round follows the policy; with `teacher = "shield"` the
    /// policy's own preferences through `shield-lanes=16` label the states
    /// instead of a planner. Off by default.
    pub polish: Option<ImitationConfig>,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            algorithm: Algorithm::default(),
            mode: Mode::Ctde,
            task: Task::default(),
            agents: 4,
            starts: Starts::Random,
            rules: Rules::Thesis,
            t_max: Rules::Thesis.default_t_max(),
            sensor_range: 2,
            features: ObsFeatures::default(),
            shaping: 0.0,
            run: RunConfig::default(),
            shield_rollouts: false,
            replay: ReplayConfig::default(),
            delay: 0.0,
            gamma: 0.99,
            model: ModelConfig::default(),
            imitation: None,
            polish: None,
        }
    }
}

impl TrainConfig {
    /// The default recipe: what `learner train --map LAYOUT` runs without a
    /// config. PPO-CTDE with the dissertation's 64-cell LSTM, in three
    /// phases:
    ///
    /// 1. **Imitation**: DAgger on the planners' next steps (4 rounds of
    ///    20k env steps labelled by LaCAM, then OD-A\*, 10 ms per call).
    /// 2. **PPO** with the comparison settings (lr 1e-3, 12 epochs, clip
    ///    0.05, entropy 0.001, batch = minibatch = 4000), the path and
    ///    intent features and potential-based shaping 0.05; the update on
    ///    the run's share of the cores (all of them alone, one each for two
    ///    runs of a study: [`crate::train::cores`]). It runs until the
    ///    greedy policy solves 99 % of 200 held-out episodes and of the
    ///    1,000 final ones (checked every 20k env steps, `[stop.greedy]`)
    ///    or the training success has stayed
    ///    at 99 % or more for 100k env steps (`[stop]`), at most 1M env
    ///    steps, and keeps the checked weights that solved the most
    ///    held-out episodes, the imitated ones among them (`keep_best`): of
    ///    the 4 best checks, the one whose weights solve the most of 1,000
    ///    further held-out episodes (`[stop.greedy.finalists]`).
    /// 3. **Polish** by the deployment shield (`[polish]`,
    ///    [`Teacher::Shield`](buridan_imitate::Teacher::Shield)): 4 DAgger
    ///    rounds of the kept policy's greedy rollouts labelled with the
    ///    joint move `shield-lanes=16` makes of its preferences (β 0.05,
    ///    10 epochs, half of the windows without an override fitted). The
    ///    polished weights are kept only if they solve more of the 1,000
    ///    final held-out episodes than the kept finalist, raw and through
    ///    `shield-lanes=16` counted together
    ///    ([`super::stop::GreedyProbe::judge_polish`]).
    ///
    /// Chosen by measurement: the book's recipe chapter and
    /// `docs/results/recipe-stop/RESULTS.md` give its figures per
    /// layout (10 seeds each) and the feed-forward IMPALA recipe it
    /// replaced, kept as `learner/configs/recipe-impala-feedforward.toml`.
    ///
    /// ```
    /// use buridan_learner::train::{Algo, TrainConfig};
    /// use buridan_imitate::Teacher;
    /// let r = TrainConfig::recipe();
    /// assert_eq!(r.algorithm.algo(), Algo::Ppo);
    /// assert!(r.model.lstm && r.features.path && r.features.intent && r.shaping > 0.0);
    /// let imitation = r.imitation.as_ref().unwrap();
    /// assert_eq!((imitation.rounds, imitation.expert.as_slice()), (4, &["lacam".to_string(), "od-astar".into()][..]));
    /// assert_eq!(r.run.stop.map(|s| (s.success, s.hold)), Some((0.99, 100_000)));
    /// let greedy = r.run.stop.and_then(|s| s.greedy).unwrap();
    /// assert_eq!((greedy.success, greedy.episodes, greedy.every), (0.99, 200, 20_000));
    /// assert!(greedy.keep_best);
    /// assert_eq!(greedy.finalists.map(|f| (f.count, f.episodes)), Some((4, 1000)));
    /// assert_eq!(r.algorithm.ppo().unwrap().update_threads, 0, "the run's share of the cores");
    /// let polish = r.polish.as_ref().unwrap();
    /// assert_eq!((polish.teacher, polish.rounds, polish.epochs), (Teacher::Shield, 4, 10));
    /// assert_eq!((polish.beta, polish.agreeing_share, polish.expert_first), (0.05, 0.5, false));
    /// r.validate().unwrap();
    /// ```
    pub fn recipe() -> Self {
        Self {
            algorithm: Algorithm::Ppo(PpoConfig::default()),
            features: ObsFeatures {
                path: true,
                intent: true,
                ..ObsFeatures::default()
            },
            shaping: 0.05,
            run: RunConfig {
                steps: 1_000_000,
                stop: Some(StopRule {
                    success: 0.99,
                    hold: 100_000,
                    greedy: Some(GreedyCheck {
                        success: 0.99,
                        episodes: 200,
                        every: 20_000,
                        keep_best: true,
                        finalists: Some(Finalists {
                            count: 4,
                            episodes: 1000,
                        }),
                    }),
                }),
                ..RunConfig::default()
            },
            model: ModelConfig {
                lstm: true,
                ..ModelConfig::default()
            },
            imitation: Some(ImitationConfig {
                expert: vec!["lacam".into(), "od-astar".into()],
                expert_time: 0.01,
                rounds: 4,
                ..ImitationConfig::default()
            }),
            polish: Some(ImitationConfig {
                teacher: Teacher::Shield,
                expert_first: false,
                rounds: 4,
                beta: 0.05,
                epochs: 10,
                agreeing_share: 0.5,
                ..ImitationConfig::default()
            }),
            ..Self::default()
        }
    }

    /// The recipe's settings that depend on the mode, for a run whose
    /// mode is set: CTE's joint policy warms its critic up for 20k env
    /// steps ([`PpoConfig::critic_warmup`]) before the policy gradient
    /// starts. Without it PPO undoes most of what the imitation taught
    /// the joint policy (rm-2.1, 4 agents, 100k env steps, seeds 0 and 1:
    /// `docs/results/recipe-cte/RESULTS.md`).
    ///
    /// ```
    /// use buridan_learner::train::TrainConfig;
    /// use buridan_policy::Mode;
    /// let mut cte = TrainConfig { mode: Mode::Cte, ..TrainConfig::recipe() };
    /// cte.apply_recipe_mode();
    /// assert_eq!(cte.algorithm.ppo().unwrap().critic_warmup, 20_000);
    /// let mut ctde = TrainConfig::recipe();
    /// ctde.apply_recipe_mode();
    /// assert_eq!(ctde, TrainConfig::recipe());
    /// ```
    pub fn apply_recipe_mode(&mut self) {
        if let (Mode::Cte, Algorithm::Ppo(ppo)) = (self.mode, &mut self.algorithm) {
            ppo.critic_warmup = 20_000;
        }
    }

    /// Reads a TOML file (which sets at most one of `map`, `maps` and
    /// `plant`: [`Task`]).
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
        let [map, maps, plant] = Task::KEYS.map(|key| table.contains_key(key));
        Task::check_keys(map, maps, plant).map_err(|e| {
            let path = path.to_path_buf();
            match e {
                TaskKeysError::MapAndMaps => ConfigError::MapAndMaps { path },
                TaskKeysError::PlantAndMap => ConfigError::PlantAndMap { path },
            }
        })?;
        let t_max_given = table.contains_key("t_max");
        let mut cfg: Self = table.try_into().map_err(parse_error)?;
        if !t_max_given {
            cfg.t_max = cfg.rules.default_t_max();
            cfg.use_plant_t_max()?;
        }
        cfg.validate()?;
        Ok(cfg)
    }

    /// The config as TOML, its task as one of the keys `map`, `maps` and
    /// `plant`; it reads back with [`Self::from_toml_file`]. A grid run's
    /// keys come in field order; a mixture's or a plant's in key order, as
    /// the configs such runs wrote before [`Task`] read.
    ///
    /// ```
    /// use buridan_learner::train::{Task, TrainConfig};
    /// let cfg = TrainConfig { task: Task::Plant("hall".into()), ..TrainConfig::default() };
    /// let text = cfg.to_toml();
    /// assert!(text.contains("plant = \"hall\"") && !text.contains("map"), "{text}");
    /// assert_eq!(toml::from_str::<TrainConfig>(&text).unwrap(), cfg);
    /// ```
    pub fn to_toml(&self) -> String {
        if self.task.grid_map().is_some() {
            return toml::to_string_pretty(self).expect("config serialises");
        }
        let table = toml::Table::try_from(self).expect("config serialises");
        toml::to_string_pretty(&table).expect("config serialises")
    }

    /// How rollouts choose actions: samples, mixed with greedy steps when
    /// IMPALA's `greedy_mix` is set (PPO always samples: its clipped ratio
    /// assumes the behaviour is the policy itself).
    ///
    /// ```
    /// use buridan_learner::train::{Algorithm, ImpalaConfig, TrainConfig};
    /// use buridan_policy::ActMode;
    /// let mut cfg = TrainConfig::default();
    /// assert_eq!(cfg.behaviour(), ActMode::Sample);
    /// cfg.algorithm = Algorithm::Impala(ImpalaConfig { greedy_mix: 0.5, ..ImpalaConfig::default() });
    /// assert_eq!(cfg.behaviour(), ActMode::GreedyMix(0.5));
    /// ```
    pub fn behaviour(&self) -> ActMode {
        match &self.algorithm {
            Algorithm::Impala(i) => ActMode::rollout(i.greedy_mix),
            Algorithm::Ppo(_) => ActMode::Sample,
        }
    }

    /// Whether the algorithm learns only from the newest policy's
    /// experience (PPO), so actors wait after each train batch.
    pub fn on_policy(&self) -> bool {
        self.algorithm.algo() == Algo::Ppo
    }

    /// How old experience may be: on-policy for PPO, `impala.max_policy_lag`
    /// versions for IMPALA.
    pub fn staleness(&self) -> Staleness {
        match &self.algorithm {
            Algorithm::Ppo(_) => Staleness::OnPolicy,
            Algorithm::Impala(i) => Staleness::MaxLag(i.max_policy_lag),
        }
    }

    /// Env steps per train batch of the configured algorithm.
    pub fn train_batch(&self) -> u64 {
        self.algorithm.train_batch() as u64
    }

    /// Env steps one fragment holds: `fragment_len · envs_per_actor`.
    pub fn fragment_env_steps(&self) -> usize {
        self.run.fragment_len * self.run.envs_per_actor
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
        match &self.algorithm {
            Algorithm::Impala(i) if i.queue_capacity > 0 => i.queue_capacity,
            _ => self.fragments_per_batch(),
        }
    }

    /// The network architecture for observations of `obs_dim` floats.
    pub fn model_spec(&self, obs_dim: usize) -> ModelSpec {
        let value = if self.model.lstm {
            ValueHead::Shared
        } else {
            match &self.algorithm {
                Algorithm::Ppo(p) if !p.vf_share_layers => ValueHead::Separate,
                _ => ValueHead::Shared,
            }
        };
        ModelSpec {
            hidden: self.model.hidden.clone(),
            value,
            lstm: self.model.lstm.then_some(LstmSpec {
                cells: self.model.lstm_cells,
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

impl TrainConfig {
    /// The threads an update cuts its batch over for an `update_threads`
    /// setting: on the CPU the number itself, or the run's share of the
    /// cores for 0 ([`super::cores::update_threads`]); on a GPU one for 0,
    /// so that each update is one graph on the device.
    ///
    /// ```
    /// use buridan_learner::train::TrainConfig;
    /// let mut cfg = TrainConfig::default();
    /// assert_eq!(cfg.update_threads(3), 3);
    /// cfg.run.device = buridan_policy::DeviceSpec::Cuda(0);
    /// assert_eq!((cfg.update_threads(0), cfg.update_threads(3)), (1, 3));
    /// ```
    pub fn update_threads(&self, setting: usize) -> usize {
        match (setting, self.run.device) {
            (0, buridan_policy::DeviceSpec::Cuda(_)) => 1,
            (setting, _) => super::cores::update_threads(setting),
        }
    }

    /// PPO's update settings: `ppo` with the run's discount and sequence
    /// length.
    pub fn ppo_settings(&self, p: &PpoConfig) -> PpoSettings {
        PpoSettings {
            lr: p.lr,
            epochs: p.epochs,
            minibatch_size: p.minibatch,
            clip: p.clip,
            vf_coeff: p.vf_coeff,
            vf_clip: p.vf_clip,
            entropy_coeff: p.entropy_coeff,
            kl_coeff: p.kl_coeff,
            kl_target: p.kl_target,
            gamma: self.gamma,
            lambda: p.lambda,
            grad_clip: p.grad_clip,
            standardize_advantages: p.standardize_advantages,
            max_seq_len: self.model.max_seq_len,
            update_threads: self.update_threads(p.update_threads),
        }
    }

    /// IMPALA's update settings: `impala` with the run's discount and
    /// sequence length.
    pub fn impala_settings(&self, i: &ImpalaConfig) -> ImpalaSettings {
        ImpalaSettings {
            lr: i.lr,
            vf_coeff: i.vf_coeff,
            entropy_coeff: i.entropy_coeff,
            grad_clip: i.grad_clip,
            vtrace: VTraceParams {
                gamma: self.gamma,
                lambda: i.lambda,
                rho_bar: i.rho_bar,
                c_bar: i.c_bar,
                pg_rho_bar: i.pg_rho_bar,
            },
            max_seq_len: self.model.max_seq_len,
            update_threads: self.update_threads(i.update_threads),
        }
    }
}
