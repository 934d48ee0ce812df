//! Study files: what to search, how, and with which budgets.
//!
//! ```toml
//! [study]
//! name = "ppo-ctde-rm-2.1"
//! base_config = "learner/configs/ppo-ctde-rm-2.1.toml"  # for the runner
//! sampler = "tpe"              # grid | random | tpe
//! trials = 40
//! parallel = 2                 # trials at once (threads)
//! steps_per_trial = 2_000_000
//! wall_time = "4h"             # total, across resumes: s, m or h
//! objective = "train_success"  # | eval_sampled | eval_greedy
//! seed = 0
//!
//! [study.scheduler]
//! kind = "asha"                # none | asha | median | pbt
//! grace_steps = 250_000        # asha, median: no decision before
//! # reduction = 3              # asha: rungs at grace·3^k, the top third goes on
//! # min_trials = 3             # median: other trials needed before judging
//!
//! [space]
//! "ppo.lr" = { choice = [1e-4, 3e-4, 5e-4, 1e-3] }
//! "ppo.epochs" = { int = [5, 14] }
//! ```
//!
//! Population-based training replaces the trial loop: the population
//! trains in rounds, and `trials` may be left out (it is the population).
//!
//! ```toml
//! [study.scheduler]
//! kind = "pbt"
//! interval_steps = 250_000     # env steps per round
//! population = 4               # default: `parallel`
//! quantile = 0.25              # bottom quarter copies the top quarter
//! resample_probability = 0.25  # else floats ×0.8/×1.2, choices move to a neighbour
//! ```
//!
//! A PBT space must not vary the network's shape
//! ([`crate::scheduler::pbt::NETWORK_KEYS`], e.g. `hidden`): members copy
//! each other's checkpoints.

use std::path::Path;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::objective::Objective;
use crate::sampler::SamplerKind;
use crate::scheduler::SchedulerKind;
use crate::space::{SearchSpace, SpaceError};

/// A parsed study file.
///
/// ```
/// let cfg = buridan_study::StudyConfig::from_toml_str(r#"
///     [study]
///     name = "demo"
///     trials = 8
///     steps_per_trial = 1000
///     [space]
///     x = { uniform = [0, 1] }
/// "#).unwrap();
/// assert_eq!((cfg.parallel, cfg.sampler), (1, buridan_study::sampler::SamplerKind::Random));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyConfig {
    /// Name (used for the Kubernetes Job and report titles).
    pub name: String,
    /// A base run configuration the runner applies the overrides to (opaque here).
    pub base_config: Option<String>,
    /// The sampler.
    pub sampler: SamplerKind,
    /// Grid points per float range of a grid search.
    pub grid_points: usize,
    /// The early-stopping rule.
    pub scheduler: SchedulerKind,
    /// What is maximised.
    pub objective: Objective,
    /// Trials in total (PBT: the population).
    pub trials: u64,
    /// Trials at once.
    pub parallel: usize,
    /// Env-step budget per trial.
    pub steps_per_trial: u64,
    /// Total wall-time budget across sessions, `None` for unlimited.
    pub wall_time: Option<Duration>,
    /// Seed of the sampler; trial `i` trains with seed `seed + i`.
    pub seed: u64,
    /// The search space.
    pub space: SearchSpace,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StudySection {
    name: String,
    base_config: Option<String>,
    #[serde(default)]
    sampler: SamplerKind,
    #[serde(default = "five")]
    grid_points: usize,
    #[serde(default)]
    scheduler: SchedulerKind,
    #[serde(default)]
    objective: Objective,
    trials: Option<u64>,
    #[serde(default = "one")]
    parallel: usize,
    steps_per_trial: u64,
    wall_time: Option<toml::Value>,
    #[serde(default)]
    seed: u64,
}

fn five() -> usize {
    5
}

fn one() -> usize {
    1
}

/// A study file that cannot be used: where, and why.
///
/// ```
/// let e = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"").unwrap_err();
/// assert!(e.to_string().contains("[study]"));
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// Not TOML, or the file cannot be read.
    #[error("study file: {0}")]
    Read(String),
    /// The `[study]` table is missing or malformed.
    #[error("[study]: {0}")]
    Study(String),
    /// A field has an impossible value.
    #[error("[study] {field}: {problem}")]
    Invalid {
        /// The field.
        field: &'static str,
        /// Why.
        problem: String,
    },
    /// The `[space]` table is wrong.
    #[error("[space]: {0}")]
    Space(#[from] SpaceError),
    /// A PBT space varies a key that shapes the network, which a member
    /// cannot change while continuing from another member's checkpoint.
    #[error(
        "[space] `{key}` shapes the network, and PBT members continue from each other's checkpoints: fix it in the base configuration, or use another scheduler"
    )]
    NetworkKey {
        /// The key.
        key: String,
    },
}

impl StudyConfig {
    /// Reads and parses a study file.
    ///
    /// ```
    /// assert!(buridan_study::StudyConfig::from_file(std::path::Path::new("/nonexistent.toml")).is_err());
    /// ```
    pub fn from_file(path: &Path) -> Result<StudyConfig, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ConfigError::Read(format!("{}: {e}", path.display())))?;
        StudyConfig::from_toml_str(&text)
    }

    /// Parses a study file's text.
    ///
    /// ```
    /// let e = buridan_study::StudyConfig::from_toml_str(
    ///     "[study]\nname = \"x\"\ntrials = 0\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }",
    /// ).unwrap_err();
    /// assert!(matches!(e, buridan_study::config::ConfigError::Invalid { field: "trials", .. }));
    /// ```
    pub fn from_toml_str(text: &str) -> Result<StudyConfig, ConfigError> {
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| ConfigError::Read(e.message().to_string()))?;
        let study = table
            .remove("study")
            .ok_or_else(|| ConfigError::Study("missing table".into()))?;
        let s: StudySection = study
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError::Study(e.message().to_string()))?;
        let space = match table.remove("space") {
            Some(toml::Value::Table(t)) => SearchSpace::from_table(&t)?,
            _ => {
                return Err(ConfigError::Space(SpaceError {
                    key: String::new(),
                    problem: crate::space::Problem::Empty,
                }))
            }
        };
        if let Some(k) = table.keys().next() {
            return Err(ConfigError::Read(format!("unknown table `{k}`")));
        }
        let invalid = |field, problem: &str| ConfigError::Invalid {
            field,
            problem: problem.to_string(),
        };
        if s.parallel == 0 {
            return Err(invalid("parallel", "must be at least 1"));
        }
        let (trials, scheduler) = match s.scheduler {
            SchedulerKind::Pbt {
                interval_steps,
                population,
                quantile,
                resample_probability,
            } => {
                let population = population.unwrap_or(s.parallel);
                if population < 2 {
                    return Err(invalid(
                        "scheduler.population",
                        "PBT needs at least 2 members",
                    ));
                }
                if interval_steps == 0 {
                    return Err(invalid("scheduler.interval_steps", "must be at least 1"));
                }
                if !(quantile > 0.0 && quantile <= 0.5) {
                    return Err(invalid("scheduler.quantile", "must be in (0, 0.5]"));
                }
                if !(0.0..=1.0).contains(&resample_probability) {
                    return Err(invalid(
                        "scheduler.resample_probability",
                        "must be in [0, 1]",
                    ));
                }
                if s.trials.is_some_and(|t| t != population as u64) {
                    return Err(invalid(
                        "trials",
                        &format!("a PBT study's trials are its population ({population}); leave `trials` out"),
                    ));
                }
                if let Some(key) = crate::scheduler::pbt::network_key(&space) {
                    return Err(ConfigError::NetworkKey {
                        key: key.to_string(),
                    });
                }
                let scheduler = SchedulerKind::Pbt {
                    interval_steps,
                    population: Some(population),
                    quantile,
                    resample_probability,
                };
                (population as u64, scheduler)
            }
            other => match s.trials {
                None => return Err(ConfigError::Study("missing field `trials`".into())),
                Some(0) => return Err(invalid("trials", "must be at least 1")),
                Some(t) => (t, other),
            },
        };
        if s.steps_per_trial == 0 {
            return Err(invalid("steps_per_trial", "must be at least 1"));
        }
        if s.grid_points == 0 {
            return Err(invalid("grid_points", "must be at least 1"));
        }
        let wall_time = match s.wall_time {
            None => None,
            Some(v) => Some(parse_duration(&v).map_err(|p| invalid("wall_time", &p))?),
        };
        Ok(StudyConfig {
            name: s.name,
            base_config: s.base_config,
            sampler: s.sampler,
            grid_points: s.grid_points,
            scheduler,
            objective: s.objective,
            trials,
            parallel: s.parallel,
            steps_per_trial: s.steps_per_trial,
            wall_time,
            seed: s.seed,
            space,
        })
    }
}

/// A duration as seconds (an integer) or a number with unit `s`, `m` or `h`.
///
/// ```
/// use std::time::Duration;
/// let d = buridan_study::config::parse_duration(&toml::Value::String("1.5h".into())).unwrap();
/// assert_eq!(d, Duration::from_secs(5400));
/// assert!(buridan_study::config::parse_duration(&toml::Value::String("4 weeks".into())).is_err());
/// ```
pub fn parse_duration(v: &toml::Value) -> Result<Duration, String> {
    let secs = match v {
        toml::Value::Integer(s) if *s > 0 => *s as f64,
        toml::Value::String(s) => {
            let s = s.trim();
            // The unit is the last character, which may take several bytes
            // (`4ß` panicked here; found by study/tests/fuzz.rs).
            let (num, unit) = s.split_at(s.char_indices().next_back().map_or(0, |(i, _)| i));
            let scale = match unit {
                "s" => 1.0,
                "m" => 60.0,
                "h" => 3600.0,
                _ => return Err(format!("`{s}`: expected a number and s, m or h")),
            };
            let n: f64 = num
                .trim()
                .parse()
                .map_err(|_| format!("`{s}`: expected a number and s, m or h"))?;
            n * scale
        }
        _ => return Err("expected seconds or a string like \"4h\"".into()),
    };
    // A positive number of seconds can still round to no time at all
    // (`1e-320h`, found by study/tests/fuzz.rs).
    if !(1e-9..1e12).contains(&secs) {
        return Err("must be positive".into());
    }
    Ok(Duration::from_secs_f64(secs))
}
