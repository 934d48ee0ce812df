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

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use buridan_env::{EnvError, ObsKind, NUM_ACTIONS};
use buridan_plant::controllers::{RandomController, ReservationController};
use buridan_plant::{Kpis, Plant, PlantConfig, PlantEnv, PlantError};
use buridan_policy::{checkpoint, ActMode, Inference, Mode, PolicyError};
use serde::Serialize;

use crate::output::{io, OutputError};
use crate::plant_figures::{write_timeline, write_track_usage, Timeline, TrackUsage};
use crate::policy::{load_for_agents, observe_step, reset_recurrent_state, PolicyLoadError};

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

/// A trained policy driving all AGVs, loaded from a checkpoint of
/// `learner train --plant`.
pub struct PlantPolicy {
    inference: Inference,
    mode: Mode,
    act_mode: ActMode,
    obs: Vec<f32>,
    masks: Vec<u8>,
    actions: Vec<u8>,
    logp: Vec<f32>,
    trained_on: String,
}

impl PlantPolicy {
    /// Loads the policy at `path` (a checkpoint or a run directory) for
    /// `agents` AGVs on `plant`, acting greedily or by sampling (`seed`).
    /// The checkpoint's `config.toml` must name a plant, and the policy's
    /// input must be the plant observation's size.
    pub fn load(
        path: &Path,
        plant: &Arc<Plant>,
        agents: usize,
        act_mode: ActMode,
        seed: u64,
    ) -> Result<Self, PlantEvalError> {
        let dir = checkpoint::resolve(path).map_err(|source| PolicyLoadError::Checkpoint {
            dir: path.to_path_buf(),
            source,
        })?;
        let trained_on = trained_plant(&dir)?;
        let (dir, policy, rows) = load_for_agents(&dir, agents)?;
        let spec = policy.spec().clone();
        let env = PlantEnv::new(
            plant.clone(),
            eval_config(&PlantEvalSpec {
                agents,
                episodes: 1,
                seed,
            }),
        )?;
        let (got, kind) = match spec.mode.obs_kind() {
            ObsKind::Local => (env.local_obs_dim(), "local"),
            ObsKind::Central => (env.central_obs_dim(), "central"),
        };
        if got != spec.obs_dim {
            return Err(PlantEvalError::ObsSize {
                dir,
                expected: spec.obs_dim,
                got,
                kind,
                agents,
            });
        }
        Ok(Self {
            mode: spec.mode,
            act_mode,
            obs: vec![0.0; rows * spec.obs_dim],
            masks: vec![0; agents * NUM_ACTIONS],
            actions: vec![0; agents],
            logp: vec![0.0; rows],
            inference: Inference::new(policy, rows, seed),
            trained_on,
        })
    }

    /// The plant the policy was trained on, as its run named it
    /// (`plant:ID`).
    pub fn trained_on(&self) -> &str {
        &self.trained_on
    }

    fn begin_episode(&mut self) {
        reset_recurrent_state(&mut self.inference);
    }

    fn act(&mut self, env: &PlantEnv, out: &mut [u8]) -> Result<(), PlantEvalError> {
        let n = env.agents();
        if self.mode == Mode::Cte {
            env.write_central_obs(&mut self.obs)?;
        } else {
            let d = env.local_obs_dim();
            for i in 0..n {
                env.write_local_obs(i, &mut self.obs[i * d..(i + 1) * d])?;
            }
        }
        for i in 0..n {
            env.write_mask(i, &mut self.masks[i * NUM_ACTIONS..(i + 1) * NUM_ACTIONS])?;
        }
        self.inference.act(
            &self.obs,
            &self.masks,
            self.act_mode,
            &mut self.actions,
            &mut self.logp,
        )?;
        out.copy_from_slice(&self.actions);
        Ok(())
    }

    fn after_step(&mut self, rewards: &[f32]) {
        observe_step(&mut self.inference, self.mode, &self.actions, rewards);
    }
}

/// The plant of checkpoint `dir`'s run (`plant:ID`), from its
/// `config.toml`; an error naming the grid layouts if it has none.
fn trained_plant(dir: &Path) -> Result<String, PlantEvalError> {
    let path = dir.join(checkpoint::CONFIG_FILE);
    let bad = |message: String| PlantEvalError::RunConfig {
        path: path.clone(),
        message,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| bad(e.message().to_string()))?;
    if let Some(plant) = table.get("plant").and_then(toml::Value::as_str) {
        return Ok(format!("plant:{plant}"));
    }
    let trained_on = match (table.get("maps"), table.get("map")) {
        (Some(maps), _) => maps
            .as_array()
            .map(|list| {
                list.iter()
                    .filter_map(|m| m.get("name").and_then(toml::Value::as_str))
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .unwrap_or_default(),
        (None, Some(map)) => map.as_str().unwrap_or_default().to_string(),
        (None, None) => "rm-2.1".to_string(),
    };
    Err(PlantEvalError::NotAPlantPolicy {
        dir: dir.to_path_buf(),
        trained_on,
    })
}

/// A controller of all AGVs of a plant episode.
pub enum PlantController {
    /// The segment-reservation baseline ([`ReservationController`]).
    Reservation(ReservationController),
    /// Uniform choice among legal actions ([`RandomController`]), its
    /// stream drawn per episode from the evaluation seed.
    Random {
        /// The evaluation seed.
        seed: u64,
        /// This episode's controller.
        controller: Box<RandomController>,
    },
    /// A trained policy.
    Policy(Box<PlantPolicy>),
}

impl PlantController {
    /// Resolves `reservation`, `random` or `checkpoint:DIR` for episodes of
    /// `plant` with `agents` AGVs and evaluation seed `seed`; a checkpoint
    /// acts by `act_mode` (greedy or sampled).
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_eval::plant::{load_plant, PlantController};
    /// use buridan_policy::ActMode;
    /// let plant = Arc::new(load_plant("dissertation", None).unwrap());
    /// let c = PlantController::by_name("random", &plant, 2, 0, ActMode::Greedy).unwrap();
    /// assert_eq!(c.name(), "random");
    /// let err = PlantController::by_name("cbs", &plant, 2, 0, ActMode::Greedy).err().unwrap();
    /// assert!(err.to_string().contains("expected reservation, random or checkpoint:DIR"));
    /// ```
    pub fn by_name(
        name: &str,
        plant: &Arc<Plant>,
        agents: usize,
        seed: u64,
        act_mode: ActMode,
    ) -> Result<Self, PlantEvalError> {
        match name {
            "reservation" => Ok(Self::Reservation(ReservationController::new(agents))),
            "random" => Ok(Self::Random {
                seed,
                controller: Box::new(RandomController::for_episode(seed, 0)),
            }),
            _ => match name.strip_prefix("checkpoint:") {
                Some(dir) if !dir.is_empty() => Ok(Self::Policy(Box::new(PlantPolicy::load(
                    Path::new(dir),
                    plant,
                    agents,
                    act_mode,
                    seed,
                )?))),
                _ => Err(PlantEvalError::UnknownController {
                    name: name.to_string(),
                }),
            },
        }
    }

    /// The name in summaries: `reservation`, `random`, or
    /// `ctde-policy` (`cte-policy`, `dte-policy`).
    pub fn name(&self) -> String {
        match self {
            Self::Reservation(_) => "reservation".into(),
            Self::Random { .. } => "random".into(),
            Self::Policy(p) => format!("{:?}-policy", p.mode).to_lowercase(),
        }
    }

    /// Prepares for episode `episode` (fresh grants, stream or state).
    pub fn begin_episode(&mut self, episode: u64) {
        match self {
            Self::Reservation(r) => r.reset(),
            Self::Random { seed, controller } => {
                **controller = RandomController::for_episode(*seed, episode)
            }
            Self::Policy(p) => p.begin_episode(),
        }
    }

    /// Writes one action per AGV of `env` into `out`.
    pub fn act(&mut self, env: &PlantEnv, out: &mut [u8]) -> Result<(), PlantEvalError> {
        match self {
            Self::Reservation(r) => r.actions(env, out)?,
            Self::Random { controller, .. } => controller.actions(env, out)?,
            Self::Policy(p) => p.act(env, out)?,
        }
        Ok(())
    }

    /// Tells the controller the rewards of the step it chose (a recurrent
    /// policy sees them next step).
    pub fn after_step(&mut self, rewards: &[f32]) {
        if let Self::Policy(p) = self {
            p.after_step(rewards);
        }
    }
}

/// One evaluated plant episode: a row of `episodes.csv`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlantEpisodeRecord {
    /// Episode index.
    pub episode: u64,
    /// Steps taken (T_max: plant episodes only truncate).
    pub steps: u32,
    /// Finished products delivered to the sink.
    pub deliveries: u32,
    /// Deliveries per simulated hour.
    pub throughput_per_hour: f64,
    /// Collisions (drives into an oncoming AGV).
    pub collisions: u32,
    /// Moves cut short by another AGV (collisions included).
    pub blocked_moves: u32,
    /// Deadlocks: cycles of mutually waiting AGVs that lasted long enough.
    pub deadlocks: u32,
    /// Steps with a deadlock in progress.
    pub deadlock_steps: u32,
    /// Unit utilisation averaged over the units.
    pub utilisation: f64,
    /// Each unit's utilisation (A, B), space-separated.
    #[serde(serialize_with = "space_separated")]
    pub unit_utilisation: Vec<f64>,
    /// Mean seconds from a product's creation to its delivery (empty
    /// without deliveries).
    pub lead_time: Option<f64>,
    /// Episode reward summed over AGVs.
    pub reward: f32,
    /// Episode reward per AGV (the sum over AGVs divided by their number).
    pub reward_per_agent: f64,
    /// Time spent in the controller, milliseconds.
    pub compute_ms: f64,
}

fn space_separated<S: serde::Serializer>(values: &[f64], s: S) -> Result<S::Ok, S::Error> {
    let text = values
        .iter()
        .map(|v| format!("{v:.4}"))
        .collect::<Vec<_>>()
        .join(" ");
    s.serialize_str(&text)
}

impl PlantEpisodeRecord {
    /// The row of an episode with `agents` AGVs that ended with `kpis`.
    pub fn new(kpis: &Kpis, agents: usize, compute_ms: f64) -> Self {
        let units = &kpis.unit_utilisation;
        Self {
            episode: kpis.episode,
            steps: kpis.steps,
            deliveries: kpis.deliveries,
            throughput_per_hour: kpis.throughput_per_hour,
            collisions: kpis.collisions,
            blocked_moves: kpis.blocked_moves,
            deadlocks: kpis.deadlock_events,
            deadlock_steps: kpis.deadlock_steps,
            utilisation: if units.is_empty() {
                0.0
            } else {
                units.iter().sum::<f64>() / units.len() as f64
            },
            unit_utilisation: units.clone(),
            lead_time: kpis.mean_lead_time,
            reward: kpis.reward,
            reward_per_agent: f64::from(kpis.reward) / agents.max(1) as f64,
            compute_ms,
        }
    }
}

/// Aggregate of a plant evaluation: the JSON summary. Every `_mean` is
/// over episodes; its `_std` is the sample standard deviation (0 for one
/// episode).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlantEvalSummary {
    /// Controller name.
    pub controller: String,
    /// `plant:ID`.
    pub plant: String,
    /// What a trained policy was trained on (`plant:ID`), else empty.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trained_on: Option<String>,
    /// AGVs per episode.
    pub agents: usize,
    /// Episodes evaluated.
    pub episodes: usize,
    /// Seed of the episode generator.
    pub seed: u64,
    /// Steps per episode.
    pub t_max: u32,
    /// Simulated seconds per episode.
    pub episode_seconds: f64,
    /// Deliveries per episode.
    pub deliveries_mean: f64,
    /// Their standard deviation.
    pub deliveries_std: f64,
    /// Deliveries per simulated hour.
    pub throughput_per_hour_mean: f64,
    /// Their standard deviation.
    pub throughput_per_hour_std: f64,
    /// Collisions per episode.
    pub collisions_mean: f64,
    /// Their standard deviation.
    pub collisions_std: f64,
    /// Deadlocks per episode.
    pub deadlocks_mean: f64,
    /// Their standard deviation.
    pub deadlocks_std: f64,
    /// Steps with a deadlock in progress per episode.
    pub deadlock_steps_mean: f64,
    /// Moves cut short per episode.
    pub blocked_moves_mean: f64,
    /// Episode reward per AGV (sum over the episode), averaged.
    pub reward_per_agent_mean: f64,
    /// Its standard deviation.
    pub reward_per_agent_std: f64,
    /// Unit utilisation (mean over units), averaged.
    pub utilisation_mean: f64,
    /// Its standard deviation.
    pub utilisation_std: f64,
    /// Each unit's utilisation (A, B), averaged over episodes.
    pub unit_utilisation_mean: Vec<f64>,
    /// Mean lead time in seconds over the episodes with deliveries (none
    /// if no episode delivered).
    pub lead_time_mean: Option<f64>,
    /// Its standard deviation over those episodes.
    pub lead_time_std: Option<f64>,
    /// Episodes that delivered at least once.
    pub episodes_with_deliveries: usize,
    /// Controller time per episode, milliseconds.
    pub compute_ms_mean: f64,
    /// Wall time of the whole evaluation, seconds.
    pub wall_seconds: f64,
}

/// Everything a plant evaluation produced.
#[derive(Debug, Clone)]
pub struct PlantEvalReport {
    /// The plant evaluated on.
    pub plant: Arc<Plant>,
    /// One record per episode, in episode order.
    pub records: Vec<PlantEpisodeRecord>,
    /// The aggregate.
    pub summary: PlantEvalSummary,
    /// What each AGV did in the first episode.
    pub timeline: Timeline,
    /// Segment use over all episodes.
    pub track: TrackUsage,
}

/// Mean and sample standard deviation (0 for fewer than two values; NaN
/// mean for none).
///
/// ```
/// let (m, s) = buridan_eval::plant::mean_std(&[1.0, 2.0, 3.0]);
/// assert_eq!((m, s), (2.0, 1.0));
/// assert_eq!(buridan_eval::plant::mean_std(&[4.0]), (4.0, 0.0));
/// ```
pub fn mean_std(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, var.sqrt())
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

/// The summary of `records`.
fn summarize(
    controller: &str,
    plant: &Plant,
    trained_on: Option<String>,
    spec: &PlantEvalSpec,
    records: &[PlantEpisodeRecord],
    wall_seconds: f64,
) -> PlantEvalSummary {
    let col = |f: fn(&PlantEpisodeRecord) -> f64| -> Vec<f64> { records.iter().map(f).collect() };
    let (deliveries_mean, deliveries_std) = mean_std(&col(|r| f64::from(r.deliveries)));
    let (throughput_per_hour_mean, throughput_per_hour_std) =
        mean_std(&col(|r| r.throughput_per_hour));
    let (collisions_mean, collisions_std) = mean_std(&col(|r| f64::from(r.collisions)));
    let (deadlocks_mean, deadlocks_std) = mean_std(&col(|r| f64::from(r.deadlocks)));
    let (reward_per_agent_mean, reward_per_agent_std) = mean_std(&col(|r| r.reward_per_agent));
    let (utilisation_mean, utilisation_std) = mean_std(&col(|r| r.utilisation));
    let lead: Vec<f64> = records.iter().filter_map(|r| r.lead_time).collect();
    let (lead_mean, lead_std) = mean_std(&lead);
    let units = records.first().map_or(0, |r| r.unit_utilisation.len());
    let unit_utilisation_mean = (0..units)
        .map(|u| {
            mean_std(
                &records
                    .iter()
                    .map(|r| r.unit_utilisation.get(u).copied().unwrap_or(0.0))
                    .collect::<Vec<_>>(),
            )
            .0
        })
        .collect();
    PlantEvalSummary {
        controller: controller.to_string(),
        plant: format!("plant:{}", plant.id),
        trained_on,
        agents: spec.agents,
        episodes: records.len(),
        seed: spec.seed,
        t_max: plant.episode.t_max,
        episode_seconds: f64::from(plant.episode.t_max) * plant.episode.step,
        deliveries_mean,
        deliveries_std,
        throughput_per_hour_mean,
        throughput_per_hour_std,
        collisions_mean,
        collisions_std,
        deadlocks_mean,
        deadlocks_std,
        deadlock_steps_mean: mean_std(&col(|r| f64::from(r.deadlock_steps))).0,
        blocked_moves_mean: mean_std(&col(|r| f64::from(r.blocked_moves))).0,
        reward_per_agent_mean,
        reward_per_agent_std,
        utilisation_mean,
        utilisation_std,
        unit_utilisation_mean,
        lead_time_mean: (!lead.is_empty()).then_some(lead_mean),
        lead_time_std: (!lead.is_empty()).then_some(lead_std),
        episodes_with_deliveries: lead.len(),
        compute_ms_mean: mean_std(&col(|r| r.compute_ms)).0,
        wall_seconds,
    }
}

/// Writes `episodes.csv` (one row per episode), `summary.json`, the first
/// episode's timeline and the track's use ([`crate::plant_figures`]: CSV
/// and PNG) of a plant evaluation into `dir` (created if missing) and
/// returns their paths.
pub fn write_plant_report(
    dir: &Path,
    report: &PlantEvalReport,
) -> Result<Vec<PathBuf>, OutputError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let csv_path = dir.join("episodes.csv");
    let csv_error = |source| OutputError::Csv {
        path: csv_path.clone(),
        source,
    };
    let mut w = csv::Writer::from_path(&csv_path).map_err(csv_error)?;
    for r in &report.records {
        w.serialize(r).map_err(csv_error)?;
    }
    w.flush().map_err(io(&csv_path))?;
    let json_path = dir.join("summary.json");
    let json = serde_json::to_string_pretty(&report.summary).expect("summary serialises");
    std::fs::write(&json_path, json + "\n").map_err(io(&json_path))?;
    let s = &report.summary;
    let title = format!("{} on {}, {} AGVs", s.controller, s.plant, s.agents);
    let mut files = vec![csv_path, json_path];
    files.extend(write_timeline(
        dir,
        &format!("{title}, episode {}", report.timeline.episode),
        &report.timeline,
    )?);
    files.extend(write_track_usage(
        dir,
        &format!("{title}, {} episodes", s.episodes),
        &report.plant,
        &report.track,
    )?);
    Ok(files)
}

/// The line `learner eval --plant` prints: the KPIs with their standard
/// deviations.
pub fn summary_line(s: &PlantEvalSummary) -> String {
    let lead = s
        .lead_time_mean
        .map_or_else(|| "-".into(), |t| format!("{t:.0} s"));
    format!(
        "{} on {} with {} AGVs ({} episodes of {} steps, seed {}): deliveries {:.2} ± {:.2} ({:.1}/h), collisions {:.2} ± {:.2}, deadlocks {:.2} ± {:.2}, reward per AGV {:.2} ± {:.2}, utilisation {:.2}, lead time {lead}",
        s.controller,
        s.plant,
        s.agents,
        s.episodes,
        s.t_max,
        s.seed,
        s.deliveries_mean,
        s.deliveries_std,
        s.throughput_per_hour_mean,
        s.collisions_mean,
        s.collisions_std,
        s.deadlocks_mean,
        s.deadlocks_std,
        s.reward_per_agent_mean,
        s.reward_per_agent_std,
        s.utilisation_mean,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use buridan_policy::Policy;

    fn plant(t_max: u32) -> Arc<Plant> {
        Arc::new(load_plant("dissertation", Some(t_max)).unwrap())
    }

    fn run(name: &str, agents: usize, episodes: usize, t_max: u32) -> PlantEvalReport {
        let plant = plant(t_max);
        let spec = PlantEvalSpec {
            agents,
            episodes,
            seed: 42,
        };
        let mut c = PlantController::by_name(name, &plant, agents, 42, ActMode::Greedy).unwrap();
        evaluate_plant(&plant, &spec, &mut c, &|_| {}).unwrap()
    }

    #[test]
    fn the_summary_averages_the_episode_kpis() {
        let report = run("reservation", 3, 3, 400);
        let s = &report.summary;
        assert_eq!((s.episodes, s.t_max, s.agents), (3, 400, 3));
        let deliveries: Vec<f64> = report
            .records
            .iter()
            .map(|r| f64::from(r.deliveries))
            .collect();
        assert_eq!((s.deliveries_mean, s.deliveries_std), mean_std(&deliveries));
        for r in &report.records {
            assert_eq!(r.steps, 400);
            assert!((r.reward_per_agent - f64::from(r.reward) / 3.0).abs() < 1e-9);
        }
        let rpa: f64 = report
            .records
            .iter()
            .map(|r| r.reward_per_agent)
            .sum::<f64>()
            / 3.0;
        assert!((s.reward_per_agent_mean - rpa).abs() < 1e-9);
        assert!(s.deliveries_mean > 0.0, "{s:?}");
        assert_eq!(s.collisions_mean, 0.0);
        assert_eq!(
            s.episodes_with_deliveries,
            report.records.iter().filter(|r| r.deliveries > 0).count()
        );
    }

    #[test]
    fn episodes_are_the_seeded_envs_and_random_draws_depend_on_the_episode_only() {
        let a = run("random", 3, 3, 200);
        let b = run("random", 3, 3, 200);
        let timeless = |r: &PlantEpisodeRecord| PlantEpisodeRecord {
            compute_ms: 0.0,
            ..r.clone()
        };
        let rows = |r: &PlantEvalReport| r.records.iter().map(timeless).collect::<Vec<_>>();
        assert_eq!(rows(&a), rows(&b));
        // Episode 2 alone plays as it did third in a row.
        let plant = plant(200);
        let spec = PlantEvalSpec {
            agents: 3,
            episodes: 3,
            seed: 42,
        };
        let mut c = PlantController::by_name("random", &plant, 3, 42, ActMode::Greedy).unwrap();
        let mut env = PlantEnv::new(plant.clone(), eval_config(&spec)).unwrap();
        env.reset_to(2);
        c.begin_episode(2);
        let (mut actions, mut rewards) = (vec![0u8; 3], vec![0f32; 3]);
        while !env.is_over() {
            c.act(&env, &mut actions).unwrap();
            env.step(&actions, &mut rewards).unwrap();
        }
        assert_eq!(env.kpis().deliveries, a.records[2].deliveries);
        assert_eq!(env.kpis().reward, a.records[2].reward);
    }

    #[test]
    fn files_and_bad_input() {
        let report = run("reservation", 2, 2, 100);
        let dir = tempfile::tempdir().unwrap();
        let files = write_plant_report(dir.path(), &report).unwrap();
        assert_eq!(files.len(), 7);
        let csv = std::fs::read_to_string(dir.path().join("episodes.csv")).unwrap();
        assert_eq!(csv.lines().count(), 3, "{csv}");
        assert!(csv.starts_with("episode,steps,deliveries,"), "{csv}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&files[1]).unwrap()).unwrap();
        assert_eq!(json["plant"], "plant:dissertation");
        for key in [
            "deliveries_mean",
            "collisions_mean",
            "deadlocks_mean",
            "reward_per_agent_mean",
            "throughput_per_hour_mean",
            "utilisation_mean",
        ] {
            assert!(json[key].is_number(), "{key}: {json}");
        }
        let plant = plant(100);
        let spec = PlantEvalSpec {
            agents: 2,
            episodes: 0,
            seed: 0,
        };
        let mut c = PlantController::by_name("random", &plant, 2, 0, ActMode::Greedy).unwrap();
        assert!(matches!(
            evaluate_plant(&plant, &spec, &mut c, &|_| {}),
            Err(PlantEvalError::NoEpisodes)
        ));
        // More AGVs than the plant has starts: the env says so.
        let spec = PlantEvalSpec {
            agents: 9,
            episodes: 1,
            seed: 0,
        };
        let mut c = PlantController::by_name("reservation", &plant, 9, 0, ActMode::Greedy).unwrap();
        let err = evaluate_plant(&plant, &spec, &mut c, &|_| {}).unwrap_err();
        assert!(matches!(err, PlantEvalError::Env(_)), "{err:?}");
        let err = PlantController::by_name("checkpoint:", &plant, 2, 0, ActMode::Greedy)
            .err()
            .unwrap();
        assert!(matches!(err, PlantEvalError::UnknownController { .. }));
    }

    #[test]
    fn a_checkpoint_must_come_from_a_plant_run_of_the_right_size() {
        let plant = plant(100);
        let missing =
            PlantController::by_name("checkpoint:/no/such/dir", &plant, 2, 0, ActMode::Greedy)
                .err()
                .unwrap();
        assert!(
            matches!(missing, PlantEvalError::Checkpoint(_)),
            "{missing:?}"
        );
        // A grid policy (25 × 3 inputs) with a grid run's config.
        let dir = tempfile::tempdir().unwrap();
        let spec = buridan_policy::ModelSpec::new(Mode::Ctde, 2, 75);
        Policy::new(spec, 0).unwrap().save(dir.path()).unwrap();
        std::fs::write(
            dir.path().join("config.toml"),
            "map = \"rm-2.2\"\nagents = 2\n",
        )
        .unwrap();
        let err = PlantPolicy::load(dir.path(), &plant, 2, ActMode::Greedy, 0)
            .err()
            .unwrap();
        assert!(
            matches!(&err, PlantEvalError::NotAPlantPolicy { trained_on, .. } if trained_on == "rm-2.2"),
            "{err:?}"
        );
        assert!(err.to_string().contains("not on an AGV plant"), "{err}");
        // A config naming a plant but a policy of the wrong input size.
        std::fs::write(dir.path().join("config.toml"), "plant = \"dissertation\"\n").unwrap();
        let err = PlantPolicy::load(dir.path(), &plant, 2, ActMode::Greedy, 0)
            .err()
            .unwrap();
        assert!(
            matches!(
                err,
                PlantEvalError::ObsSize {
                    expected: 75,
                    got: 11,
                    ..
                }
            ),
            "{err:?}"
        );
        // The right size acts, legally.
        let spec = buridan_policy::ModelSpec::new(Mode::Ctde, 2, buridan_plant::LOCAL_OBS_DIM);
        Policy::new(spec, 0).unwrap().save(dir.path()).unwrap();
        let mut c = PlantController::by_name(
            &format!("checkpoint:{}", dir.path().display()),
            &plant,
            2,
            0,
            ActMode::Sample,
        )
        .unwrap();
        assert_eq!(c.name(), "ctde-policy");
        let spec = PlantEvalSpec {
            agents: 2,
            episodes: 1,
            seed: 0,
        };
        let report = evaluate_plant(&plant, &spec, &mut c, &|_| {}).unwrap();
        assert_eq!(
            report.summary.trained_on.as_deref(),
            Some("plant:dissertation")
        );
        assert_eq!(report.records[0].steps, 100);
    }
}
