//! Evaluation on the AGV plant (`learner eval --plant`): a controller —
//! the segment-reservation or random baseline, or a policy trained with
//! `learner train --plant` — plays seeded plant episodes, and the
//! [`Kpis`] of each become a CSV row and a summary.
//!
//! Episodes are seeded as the grid evaluation's are: episode `e` of seed
//! `S` is the plant env's episode `e` with env seed `S` (start offsets and
//! arrivals follow from `(plant, agents, S, e)`), the same episode a
//! training actor with env seed `S` plays as its `e`-th. The random
//! controller's draws in episode `e` depend only on `(S, e)`; a sampling
//! policy draws from one stream seeded by `S` over the episodes in order.
//! Episodes run one after the other.
//!
//! This module loads the plant and runs the evaluation loop; `controller`
//! holds what acts (the baselines and a trained [`PlantPolicy`]), `report`
//! the per-episode records, the summary and the files written.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_eval::plant::{evaluate_plant, load_plant, PlantController, PlantEvalSpec};
//! use buridan_policy::ActMode;
//! let plant = Arc::new(load_plant("dissertation", Some(200)).unwrap());
//! let spec = PlantEvalSpec { agents: 2, episodes: 2, seed: 42 };
//! let mut controller = PlantController::by_name("reservation", &plant, 2, 42, ActMode::Greedy).unwrap();
//! let report = evaluate_plant(&plant, &spec, &mut controller, &|_| {}).unwrap();
//! assert_eq!(report.records.len(), 2);
//! assert_eq!((report.summary.t_max, report.summary.collisions_mean), (200, 0.0));
//! ```

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use buridan_env::{EnvError, NUM_ACTIONS};
use buridan_plant::{Plant, PlantConfig, PlantEnv, PlantError};
use buridan_policy::PolicyError;
use serde::Serialize;

use crate::plant_figures::{Timeline, TrackUsage};
use crate::policy::PolicyLoadError;

mod controller;
mod report;
#[cfg(test)]
mod tests;

pub use controller::{PlantController, PlantPolicy};
pub use report::{
    mean_std, summary_line, write_plant_report, PlantEpisodeRecord, PlantEvalReport,
    PlantEvalSummary,
};

use report::summarize;

/// Why a plant evaluation cannot run.
#[derive(Debug, thiserror::Error)]
pub enum PlantEvalError {
    /// The plant cannot be loaded.
    #[error("loading plant '{plant}'")]
    Plant {
        /// The plant as named.
        plant: String,
        /// Why.
        source: Box<PlantError>,
    },
    /// The controller name is none of the plant's.
    #[error("unknown plant controller '{name}': expected reservation, random or checkpoint:DIR")]
    UnknownController {
        /// The name given.
        name: String,
    },
    /// The checkpoint is missing or unreadable, or controls another number
    /// of agents.
    #[error(transparent)]
    Checkpoint(#[from] PolicyLoadError),
    /// The checkpoint's run configuration cannot be read.
    #[error("cannot read the run configuration {} of the checkpoint: {message}", path.display())]
    RunConfig {
        /// The `config.toml`.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The checkpoint was trained on grid layouts.
    #[error("checkpoint {} was trained on the grid layout(s) {trained_on}, not on an AGV plant: its policy reads grid observations (evaluate it with --map, or give a checkpoint of `learner train --plant`)", dir.display())]
    NotAPlantPolicy {
        /// The checkpoint.
        dir: PathBuf,
        /// What its configuration trained on.
        trained_on: String,
    },
    /// The policy's input size is not the plant observation's.
    #[error("the policy in {} expects {expected} observation floats, but {kind} observations of the plant with {agents} AGVs have {got}", dir.display())]
    ObsSize {
        /// The checkpoint.
        dir: PathBuf,
        /// Floats the policy reads.
        expected: usize,
        /// Floats the plant writes.
        got: usize,
        /// `local` or `central`.
        kind: &'static str,
        /// AGVs asked for.
        agents: usize,
    },
    /// No episode to evaluate.
    #[error("a plant evaluation needs at least one episode")]
    NoEpisodes,
    /// The plant env refused the configuration or a step.
    #[error("plant env")]
    Env(#[from] EnvError),
    /// The policy failed to act.
    #[error("policy inference")]
    Policy(#[from] PolicyError),
}

/// Loads a bundled plant (`dissertation`, `hall`) or a plant file, with
/// its episode length set to `t_max` if given (else the file's T_max).
///
/// ```
/// let plant = buridan_eval::plant::load_plant("hall", None).unwrap();
/// assert_eq!(plant.episode.t_max, 1000);
/// let err = buridan_eval::plant::load_plant("nowhere", None).unwrap_err();
/// assert!(err.to_string().contains("'nowhere'"), "{err}");
/// ```
pub fn load_plant(name: &str, t_max: Option<u32>) -> Result<Plant, PlantEvalError> {
    let mut plant = Plant::load(name).map_err(|source| PlantEvalError::Plant {
        plant: name.to_string(),
        source: Box::new(source),
    })?;
    if let Some(t) = t_max {
        plant.episode.t_max = t;
    }
    Ok(plant)
}

/// What to evaluate on: agents, episodes `0..episodes`, the episode seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlantEvalSpec {
    /// AGVs per episode.
    pub agents: usize,
    /// Episodes `0..episodes` of the seeded generator.
    pub episodes: usize,
    /// Seed of the episode generator (start offsets, arrivals).
    pub seed: u64,
}

/// The env configuration of an evaluation: normalised observations (as
/// `learner train --plant` trains with) and five mask slots per AGV (the
/// policy heads' width; the baselines read only the first three).
pub fn eval_config(spec: &PlantEvalSpec) -> PlantConfig {
    PlantConfig {
        agents: spec.agents,
        seed: spec.seed,
        normalize: true,
        action_slots: NUM_ACTIONS,
    }
}

/// Plays episodes `0..spec.episodes` of `plant` with `controller`, calling
/// `on_episode` after each.
pub fn evaluate_plant(
    plant: &Arc<Plant>,
    spec: &PlantEvalSpec,
    controller: &mut PlantController,
    on_episode: &dyn Fn(&PlantEpisodeRecord),
) -> Result<PlantEvalReport, PlantEvalError> {
    if spec.episodes == 0 {
        return Err(PlantEvalError::NoEpisodes);
    }
    let started = Instant::now();
    let mut env = PlantEnv::new(plant.clone(), eval_config(spec))?;
    let n = spec.agents;
    let (mut actions, mut rewards) = (vec![0u8; n], vec![0f32; n]);
    let mut records = Vec::with_capacity(spec.episodes);
    // A new env is at episode 0, the one the timeline records.
    let (mut timeline, mut track) = (Timeline::new(&env), TrackUsage::new(plant));
    for e in 0..spec.episodes as u64 {
        env.reset_to(e);
        controller.begin_episode(e);
        let mut compute = 0.0;
        while !env.is_over() {
            let t = Instant::now();
            controller.act(&env, &mut actions)?;
            compute += t.elapsed().as_secs_f64();
            env.step(&actions, &mut rewards)?;
            controller.after_step(&rewards);
            track.record(&env);
            if e == 0 {
                timeline.record(&env);
            }
        }
        let record = PlantEpisodeRecord::new(&env.kpis(), n, 1e3 * compute);
        on_episode(&record);
        records.push(record);
    }
    let trained_on = match controller {
        PlantController::Policy(p) => Some(p.trained_on().to_string()),
        _ => None,
    };
    let summary = summarize(
        &controller.name(),
        plant,
        trained_on,
        spec,
        &records,
        started.elapsed().as_secs_f64(),
    );
    Ok(PlantEvalReport {
        plant: plant.clone(),
        records,
        summary,
        timeline,
        track,
    })
}
