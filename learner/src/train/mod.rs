//! The trainer: a [`Run`] (policy, optimiser, counters) fed by an
//! [`Exchange`] — actor threads in this process ([`train`]) or actor
//! processes over gRPC (`crate::serve`).
//!
//! ```text
//! actor i: VecEnv ──obs/masks──▶ Inference ──actions──▶ VecEnv   (× fragment_len)
//!          └──────────── Fragment (T × rows) ───────────┐
//!                                                       ▼
//! learner: Exchange::next_fragment ─▶ train batch ─▶ PPO / IMPALA update
//!          └──▶ Exchange::publish(Weights{version}) ──▶ actors reload between fragments
//! ```
//!
//! PPO is on-policy: each publish asks for exactly one train batch of
//! experience with the new version; actors collect it and wait. Fragments
//! of an older version that still arrive are dropped and counted
//! (`stale_fragments`). IMPALA actors run freely with the latest weights;
//! fragments more than `max_policy_lag` versions old are dropped and
//! counted.
//!
//! Outputs in `out`: `metrics.csv` (one row per update), the same scalars
//! as TensorBoard events (`events.out.tfevents.*`), `config.toml`,
//! `summary.json`, and checkpoints laid out as
//! [`buridan_policy::checkpoint`] describes.

pub mod config;
pub mod cores;
pub mod error;
pub mod exchange;
mod export;
pub mod gate;
mod learner;
pub mod metrics;
mod phases;
pub mod rollout;
mod state;
pub mod stop;
pub mod target;
pub mod tensorboard;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use buridan_actor::Collector;
use buridan_env::{seed, BatchedEnv, EnvConfig, Map, Shaping, VecEnv, WeightedLayout};
use buridan_mapf::shield::rollout::RolloutShield;
use buridan_plant::{Plant, PlantEnv, PlantVecEnv};
use buridan_policy::checkpoint::{self, CONFIG_FILE, OPTIMIZER_FILE, TRAINER_FILE};
use buridan_policy::{Fragment, Inference, ModelSpec, Policy, Weights};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::algo::UpdateStats;
use export::{count_consumed, export_metrics};
use learner::Learner;
use phases::{imitate, Phase};
use state::{read_trainer_state, restore_layout_windows};

pub use config::{
    Algo, Algorithm, ConfigError, ImpalaConfig, ModelConfig, PpoConfig, RunConfig, Task,
    TaskKeysError, TrainConfig, WeightedMap,
};
pub use error::{ExchangeError, Interrupted, TrainError};
pub use exchange::{Exchange, InProcess, Shared, Ticket};
pub use metrics::{EpisodeWindow, LayoutWindows, MetricsError, MetricsRow, MetricsWriter, Summary};
pub use phases::{IMITATION_FILE, POLISH_FILE};
pub use state::{LayoutRecord, TrainerState};
pub use stop::{StopReason, StopRule, GREEDY_FILE};

/// The run's metrics file inside its output directory.
pub const METRICS_FILE: &str = "metrics.csv";
/// The run's summary inside its output directory.
pub const SUMMARY_FILE: &str = "summary.json";

/// Live progress of a training run (the CLI shows a progress bar).
pub trait Progress {
    /// Training starts; `total_steps` is the env-step budget, `env_steps`
    /// the steps already done (resume).
    fn on_start(&mut self, _cfg: &TrainConfig, _total_steps: u64, _env_steps: u64) {}
    /// One learner update finished.
    fn on_update(&mut self, _row: &MetricsRow) {}
    /// The exchange after an update: actors, queue, fragment outcomes.
    fn on_exchange(&mut self, _status: &ExchangeStatus) {}
    /// A checkpoint was written.
    fn on_checkpoint(&mut self, _dir: &Path) {}
    /// The updates ended (`reason`); the choice of the kept weights and a
    /// `[polish]`, where configured, follow before [`Progress::on_finish`].
    fn on_stopped(&mut self, _reason: StopReason) {}
    /// Training finished.
    fn on_finish(&mut self, _summary: &Summary) {}
}

/// The exchange between actors and learner after an update.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ExchangeStatus {
    /// Actors connected (threads in process, or gRPC actors).
    pub connected_actors: usize,
    /// Fragments waiting for the learner.
    pub queue_depth: usize,
    /// Fragments so far by outcome: the exchange's counts, and
    /// `stale_at_learner` (dropped by the learner as too old).
    pub fragments: Vec<(String, u64)>,
}

/// A [`Progress`] that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoProgress;

impl Progress for NoProgress {}

/// The env configuration of a training config.
pub fn env_config(cfg: &TrainConfig, seed: u64) -> EnvConfig {
    EnvConfig {
        agents: cfg.agents,
        t_max: cfg.t_max,
        rules: cfg.rules,
        starts: cfg.starts,
        seed,
        sensor_range: cfg.sensor_range,
        features: cfg.features,
        shaping: (cfg.shaping > 0.0).then_some(Shaping {
            coeff: cfg.shaping,
            gamma: cfg.gamma,
        }),
        delay: cfg.delay,
        ..EnvConfig::default()
    }
}

fn write_file(path: &Path, text: &str) -> Result<(), TrainError> {
    std::fs::write(path, text).map_err(|e| TrainError::io("cannot write", path, e))
}

/// The envs of an in-process actor: one map or a mixture of layouts,
/// chosen by the configuration at run time.
pub type ActorEnv = Box<dyn BatchedEnv + Send>;

/// Trains a policy as configured, writing metrics, checkpoints and the
/// summary into `out` (created if needed), reporting to `progress`: the
/// embedded default, with `cfg.num_actors` actor threads in this process.
///
/// Env steps are vectorised env steps (one step of one env instance = 1,
/// whatever the agent count). Call
/// [`buridan_policy::threads::pin_threads`] at the start of `main` to fix
/// candle's thread count (1 is fastest for these small networks).
pub fn train(
    cfg: &TrainConfig,
    out: &Path,
    progress: &mut dyn Progress,
) -> Result<Summary, TrainError> {
    let run = Run::prepare(cfg, out)?;
    let collectors = (0..cfg.run.num_actors as u32)
        .map(|i| run.collector(i))
        .collect::<Result<Vec<_>, _>>()?;
    let mut exchange = InProcess::spawn(
        collectors,
        cfg.queue_capacity(),
        cfg.staleness(),
        cfg.run.actor_nice,
    )?;
    run.learn(&mut exchange, progress)
}

/// A training run between preparation and its end: config, policy,
/// optimiser and counters (fresh, or restored from `cfg.resume`).
pub struct Run {
    cfg: TrainConfig,
    out: PathBuf,
    /// The training layouts with their weights (one for a single map; none
    /// for a plant run).
    layouts: Vec<WeightedLayout>,
    /// The AGV plant of a plant run (`cfg.task`), its T_max the run's.
    plant: Option<Arc<Plant>>,
    spec: ModelSpec,
    policy: Policy,
    learner: Learner,
    state: TrainerState,
    window: EpisodeWindow,
    layout_windows: LayoutWindows,
    wall_offset: f64,
    t_start: Instant,
    interrupt: Option<Arc<AtomicBool>>,
    /// The `[stop]` rule's progress (it starts afresh on resume).
    holding: Option<stop::Holding>,
    /// `[stop.greedy]`'s checks (they start afresh on resume).
    greedy: Option<stop::GreedyProbe>,
}

/// When [`Run::greedy_check`] plays a `[stop.greedy]` check.
#[derive(Debug, Clone, Copy)]
enum Check {
    /// When one is due (every `every` env steps).
    IfDue,
    /// Now, on the weights the run starts from: the next check still
    /// follows the first update.
    First,
    /// Now.
    Now,
}

impl Run {
    /// Validates `cfg`, creates `out`, builds (or restores) the policy and
    /// the optimiser.
    pub fn prepare(cfg: &TrainConfig, out: &Path) -> Result<Run, TrainError> {
        cfg.validate()?;
        // Before anything is written: a device this binary or this machine
        // lacks, or a plant that does not load, stops here.
        let device = cfg.run.device.open().map_err(TrainError::Device)?;
        let plant = cfg.load_plant()?.map(Arc::new);
        buridan_policy::threads::tune_allocator();
        let t_start = Instant::now();
        std::fs::create_dir_all(out).map_err(|e| TrainError::io("cannot create", out, e))?;
        write_file(&out.join(CONFIG_FILE), &cfg.to_toml())?;
        let (layouts, obs_dim) = match &plant {
            Some(plant) => {
                let env = PlantEnv::new(plant.clone(), cfg.plant_config(cfg.run.seed))?;
                let obs_dim = match cfg.mode.obs_kind() {
                    buridan_env::ObsKind::Local => env.local_obs_dim(),
                    buridan_env::ObsKind::Central => env.central_obs_dim(),
                };
                (Vec::new(), obs_dim)
            }
            None => {
                let layouts = match (cfg.load_maps()?, cfg.task.grid_map()) {
                    (Some(layouts), _) => layouts,
                    (None, Some(map)) => vec![(Arc::new(Map::load(map)?), 1.0)],
                    (None, None) => unreachable!("a run without a plant has a map or a mixture"),
                };
                // One size on every layout: `load_maps` refuses central
                // observations over several layouts.
                let obs_dim = cfg
                    .mode
                    .obs_kind()
                    .obs_dim(&layouts[0].0, &env_config(cfg, cfg.run.seed));
                (layouts, obs_dim)
            }
        };
        let spec = cfg.model_spec(obs_dim);
        let (policy, mut state) = match &cfg.run.resume {
            None => {
                let policy = Policy::new_on(spec.clone(), cfg.run.seed, &device)?;
                if let Some(im) = &cfg.imitation {
                    imitate(cfg, im, Phase::Warmup, &layouts, &policy, out)?;
                }
                (policy, TrainerState::default())
            }
            Some(dir) => {
                let policy = Policy::load_expecting(dir, &spec, &device).map_err(|source| {
                    TrainError::Resume {
                        dir: dir.clone(),
                        source,
                    }
                })?;
                (policy, read_trainer_state(dir)?)
            }
        };
        // Plant episodes only truncate: no success, so no time to target.
        if plant.is_some() {
            state.time_to_target.clear();
        } else if state.time_to_target.is_empty() {
            state.time_to_target = target::targets();
        }
        let mut learner = Learner::new(cfg, &policy);
        if let Some(dir) = &cfg.run.resume {
            learner.restore(dir, &state)?;
        }
        tracing::info!(
            algo = %cfg.algorithm.algo(),
            mode = %cfg.mode,
            map = %cfg.map_label(),
            agents = cfg.agents,
            params = policy.num_params(),
            device = %cfg.run.device,
            candle_threads = buridan_policy::threads::candle_threads(),
            updates = state.updates,
            "training"
        );
        let greedy = (cfg.run.stop.and_then(|s| s.greedy))
            .map(|check| stop::GreedyProbe::new(check, out))
            .transpose()?;
        Ok(Run {
            cfg: cfg.clone(),
            out: out.to_path_buf(),
            layout_windows: restore_layout_windows(&cfg.layout_names(), &state.layouts),
            layouts,
            plant,
            spec,
            policy,
            learner,
            window: EpisodeWindow::restore(state.episodes, &state.recent_episodes),
            wall_offset: state.wall_seconds,
            state,
            t_start,
            interrupt: None,
            holding: cfg.run.stop.map(stop::Holding::new),
            greedy,
        })
    }

    /// The collector of in-process actor `id`: its own envs and a copy of
    /// the current policy.
    pub fn collector(&self, id: u32) -> Result<Collector<ActorEnv>, TrainError> {
        let cfg = &self.cfg;
        let actor = u64::from(id);
        let seed = self.actor_seed(actor);
        let (envs, kind) = (cfg.run.envs_per_actor, cfg.mode.obs_kind());
        // One map keeps the plain batch; a mixture only when there is a choice.
        let venv: ActorEnv = match (&self.plant, self.layouts.as_slice()) {
            (Some(plant), _) => Box::new(PlantVecEnv::new(
                plant.clone(),
                cfg.plant_config(seed),
                envs,
                kind,
            )?),
            (None, [(map, _)]) => {
                VecEnv::new(map.clone(), env_config(cfg, seed), envs, kind, 1)?.boxed(cfg.replay)?
            }
            (None, layouts) => VecEnv::with_layouts(layouts, env_config(cfg, seed), envs, kind, 1)?
                .boxed(cfg.replay)?,
        };
        let policy = Policy::new(self.spec.clone(), cfg.run.seed)?;
        policy.copy_from(&self.policy)?;
        let rows = venv.rows();
        let sampling = seed::actor_sampling(cfg.run.seed, actor, self.state.updates);
        Ok(Collector {
            id,
            inference: Inference::new(policy, rows, sampling),
            behaviour: cfg.behaviour(),
            venv,
            fragment_len: cfg.run.fragment_len,
            version: self.state.updates,
            shield: cfg.shield_rollouts.then(|| RolloutShield::new(seed)),
        })
    }

    /// Stops the run (with a checkpoint, and without telling remote actors
    /// the run is over) once `flag` is set — Ctrl-C, SIGTERM, tests.
    pub fn interrupt_on(&mut self, flag: Arc<AtomicBool>) {
        self.interrupt = Some(flag);
    }

    fn interrupted(&self) -> bool {
        self.interrupt
            .as_ref()
            .is_some_and(|f| f.load(Ordering::SeqCst))
    }

    /// Checkpoints an interrupted run and says where.
    fn stop_interrupted(&mut self) -> TrainError {
        let dir = checkpoint::update_dir(&self.out, self.state.updates);
        match self.save_checkpoint(&dir) {
            Ok(()) => Interrupted {
                updates: self.state.updates,
                checkpoint: dir,
            }
            .into(),
            Err(e) => TrainError::InterruptedWithoutCheckpoint {
                updates: self.state.updates,
                source: Box::new(e),
            },
        }
    }

    /// Writes the policy, the optimiser, the counters and the config into `dir`.
    fn save_checkpoint(&mut self, dir: &Path) -> Result<(), TrainError> {
        self.state.wall_seconds = self.wall();
        self.policy.save(dir)?;
        let path = dir.join(OPTIMIZER_FILE);
        self.learner
            .optim()
            .adam
            .save(&path)
            .map_err(|source| TrainError::Optimizer { path, source })?;
        let state = serde_json::to_string_pretty(&self.state).expect("trainer state serialises");
        write_file(&dir.join(TRAINER_FILE), &state)?;
        write_file(&dir.join(CONFIG_FILE), &self.cfg.to_toml())
    }

    /// The run's configuration.
    pub fn config(&self) -> &TrainConfig {
        &self.cfg
    }

    /// The map the run trains on (the first of several layouts); `None`
    /// for a plant run.
    pub fn map(&self) -> Option<&Arc<Map>> {
        self.layouts.first().map(|(map, _)| map)
    }

    /// The layouts the run trains on, with their weights (empty for a
    /// plant run).
    pub fn layouts(&self) -> &[WeightedLayout] {
        &self.layouts
    }

    /// The AGV plant of a plant run (with the run's T_max), else `None`.
    pub fn plant(&self) -> Option<&Arc<Plant>> {
        self.plant.as_ref()
    }

    /// The model's shape.
    pub fn spec(&self) -> &ModelSpec {
        &self.spec
    }

    /// Counters so far (restored ones on resume).
    pub fn state(&self) -> &TrainerState {
        &self.state
    }

    /// The current weights, stamped with the current policy version.
    pub fn weights(&self) -> Result<Weights, TrainError> {
        Ok(self.policy.weights(self.state.updates)?)
    }

    /// Env seed of actor `k` ([`seed::actor_env`]).
    pub fn actor_seed(&self, k: u64) -> u64 {
        seed::actor_env(self.cfg.run.seed, k, self.state.updates)
    }

    /// The learner loop: publish weights, gather a train batch from
    /// `exchange`, update, repeat until `cfg.steps` env steps; then the
    /// `[polish]` rounds if configured (with finalists, kept only if they
    /// solve more of the final held-out episodes, raw and shielded), the final checkpoint and
    /// `summary.json`. Always calls
    /// [`Exchange::finish`]; an actor's failure is returned with its cause.
    pub fn learn(
        mut self,
        exchange: &mut dyn Exchange,
        progress: &mut dyn Progress,
    ) -> Result<Summary, TrainError> {
        let result = self.learn_loop(exchange, progress);
        let finished = exchange.finish(result.is_ok());
        let reason = result?;
        finished?;
        progress.on_stopped(reason);
        let kept = self.keep_best()?;
        let kept_replay = kept.and_then(|(_, replay)| replay);
        let mut polish_replay = None;
        if let Some(polish) = &self.cfg.polish {
            // The kept finalist, for the judgement after the polish.
            let before = match kept_replay {
                Some(replay) => self.unpolished(replay)?,
                None => None,
            };
            let perfect = before
                .as_ref()
                .is_some_and(|b| b.kept.solved == b.kept.episodes && b.shielded == b.kept.episodes);
            if perfect {
                tracing::info!(
                    "the kept finalist solves every final held-out episode, raw and shielded: \
                     no polish can do better, none made"
                );
            } else {
                imitate(
                    &self.cfg,
                    polish,
                    Phase::Polish,
                    &self.layouts,
                    &self.policy,
                    &self.out,
                )?;
                if let Some(before) = before {
                    polish_replay = self.judge_polish(&before)?;
                }
            }
        }
        let final_dir = checkpoint::final_dir(&self.out);
        self.save_checkpoint(&final_dir)?;
        progress.on_checkpoint(&final_dir);
        tracing::info!(reason = %reason, env_steps = self.state.env_steps, "training stopped");
        let summary = Summary {
            kept_check: kept.map(|(check, _)| check),
            kept_replay,
            polish_replay,
            ..self.summary(final_dir, reason)
        };
        let json = serde_json::to_value(&summary).unwrap_or(serde_json::Value::Null);
        let json = serde_json::to_string_pretty(&json).expect("summary serialises");
        write_file(&self.out.join(SUMMARY_FILE), &json)?;
        progress.on_finish(&summary);
        Ok(summary)
    }

    fn wall(&self) -> f64 {
        self.wall_offset + self.t_start.elapsed().as_secs_f64()
    }

    /// Runs updates until the step budget, or until a stop rule holds
    /// (`[stop]`, `stop_return`); says which ended it.
    fn learn_loop(
        &mut self,
        exchange: &mut dyn Exchange,
        progress: &mut dyn Progress,
    ) -> Result<StopReason, TrainError> {
        let mut metrics = MetricsWriter::open(&self.out.join(METRICS_FILE))?;
        let mut events = tensorboard::EventWriter::create(&self.out)?;
        let shuffle_seed = seed::learner_shuffle(self.cfg.run.seed, self.state.updates);
        let mut rng = ChaCha8Rng::seed_from_u64(shuffle_seed);
        progress.on_start(&self.cfg, self.cfg.run.steps, self.state.env_steps);
        let mut since = (self.wall_offset, self.state.env_steps);
        let _learning = cores::Learning::start();
        let keeps_best = self.greedy.as_ref().is_some_and(|g| g.keeps_best());
        // A candidate to keep; its pass (confirmed) stops the run after one
        // train batch, whose episodes the weights it starts from play: a
        // run reports episodes of its own, and an update of a policy that
        // has learned can only lose what it knows.
        let started_learned = keeps_best
            && self.state.env_steps < self.cfg.run.steps
            && self.greedy_check(Check::First)?;
        self.publish(exchange)?;
        while self.state.env_steps < self.cfg.run.steps {
            let Some(batch) = self.gather_batch(exchange)? else {
                return Err(self.stop_interrupted());
            };
            self.learner
                .follow_schedules(&self.cfg, self.state.env_steps);
            self.learner.follow_cores(&self.cfg);
            let t_learn = Instant::now();
            let stats = self.learner.update(&self.policy, &batch, &mut rng)?;
            let learn_seconds = t_learn.elapsed().as_secs_f64();
            count_consumed(&batch);
            self.state.updates += 1;
            self.publish(exchange)?;
            let (row, learned) = self.record_update(&stats, learn_seconds, &mut since);
            metrics.write(&row)?;
            events.row(&row)?;
            export_metrics(&row, exchange);
            tracing::debug!(?row, "update");
            progress.on_update(&row);
            progress.on_exchange(&self.exchange_status(exchange));
            let every = self.cfg.run.checkpoint_every;
            if every > 0 && self.state.updates.is_multiple_of(every) {
                let dir = checkpoint::update_dir(&self.out, self.state.updates);
                self.save_checkpoint(&dir)?;
                progress.on_checkpoint(&dir);
            }
            if self.goal_reached() {
                return Ok(StopReason::ReturnGoal);
            }
            if learned {
                return Ok(StopReason::Learned);
            }
            if started_learned || self.greedy_check(Check::IfDue)? {
                return Ok(StopReason::Greedy);
            }
        }
        Ok(StopReason::Budget)
    }

    fn exchange_status(&self, exchange: &dyn Exchange) -> ExchangeStatus {
        let mut fragments: Vec<(String, u64)> = exchange
            .fragment_outcomes()
            .into_iter()
            .map(|(k, n)| (k.to_string(), n))
            .collect();
        fragments.push(("stale_at_learner".into(), self.state.stale_fragments));
        ExchangeStatus {
            connected_actors: exchange.connected_actors(),
            queue_depth: exchange.queue_depth(),
            fragments,
        }
    }

    /// Publishes the current weights; on-policy runs ask for one train batch.
    fn publish(&self, exchange: &mut dyn Exchange) -> Result<(), TrainError> {
        let wanted = self.cfg.on_policy().then_some(self.cfg.train_batch());
        Ok(exchange.publish(self.weights()?, wanted)?)
    }

    /// Fragments until one train batch of fresh experience is there;
    /// `None` if the run was interrupted meanwhile.
    fn gather_batch(
        &mut self,
        exchange: &mut dyn Exchange,
    ) -> Result<Option<Vec<Fragment>>, TrainError> {
        let target = self.cfg.train_batch();
        let staleness = self.cfg.staleness();
        let mut batch = Vec::with_capacity(self.cfg.fragments_per_batch());
        let mut batch_steps = 0u64;
        while batch_steps < target {
            if self.interrupted() {
                return Ok(None);
            }
            let Some(f) = exchange.next_fragment(Duration::from_millis(200))? else {
                continue;
            };
            self.state.env_steps += f.env_steps;
            self.state.agent_steps += f.env_steps * self.cfg.agents as u64;
            ::metrics::counter!("buridan_env_steps_total").increment(f.env_steps);
            self.window.extend(&f.episodes);
            self.layout_windows.extend(&f.episodes);
            let lag = self.state.updates.saturating_sub(f.policy_version);
            ::metrics::histogram!("buridan_policy_lag").record(lag as f64);
            if staleness.is_stale(f.policy_version, self.state.updates) {
                self.state.stale_fragments += 1;
                ::metrics::counter!("buridan_fragments_total", "outcome" => "stale_at_learner")
                    .increment(1);
                continue;
            }
            batch_steps += f.env_steps;
            batch.push(f);
        }
        Ok(Some(batch))
    }

    /// Books an update into the counters and returns its metrics row and
    /// whether the `[stop]` rule now holds; `since` holds the wall time and
    /// env steps of the previous row.
    fn record_update(
        &mut self,
        stats: &UpdateStats,
        learn_seconds: f64,
        since: &mut (f64, u64),
    ) -> (MetricsRow, bool) {
        let wall = self.wall();
        let (lr, entropy_coeff) = self.learner.rates();
        let state = &mut self.state;
        state.episodes = self.window.total;
        state.adam_steps = self.learner.optim().adam.steps();
        state.kl_coeffs = self.learner.kl_coeffs();
        state.wall_seconds = wall;
        state.recent_episodes = self.window.recent();
        if self.cfg.task.maps().is_some() {
            let lw = &self.layout_windows;
            state.layouts = (self.cfg.layout_names().into_iter())
                .zip(lw.totals().into_iter().zip(lw.recent()))
                .map(|(map, (episodes, recent))| LayoutRecord {
                    map,
                    episodes,
                    recent,
                })
                .collect();
        }
        let row = MetricsRow {
            update: state.updates,
            env_steps: state.env_steps,
            agent_steps: state.agent_steps,
            wall_seconds: wall,
            steps_per_s: (state.env_steps - since.1) as f64 / (wall - since.0).max(1e-9),
            episodes: self.window.total,
            episode_return_mean: self.window.return_mean(),
            success_rate: self.window.success_rate(),
            episode_len_mean: self.window.len_mean(),
            total_loss: stats.total_loss,
            policy_loss: stats.policy_loss,
            vf_loss: stats.vf_loss,
            entropy: stats.entropy,
            kl: stats.kl,
            kl_coeff: stats.kl_coeff,
            grad_norm: stats.grad_norm,
            mean_rho: stats.mean_rho,
            stale_fragments: state.stale_fragments,
            learn_seconds,
            lr,
            entropy_coeff,
        };
        *since = (wall, state.env_steps);
        let at = target::Mark {
            update: state.updates,
            env_steps: state.env_steps,
            wall_seconds: wall,
        };
        let full = self.window.len() >= metrics::EPISODE_WINDOW;
        for t in &mut state.time_to_target {
            if t.observe(row.success_rate, full, at) {
                tracing::info!(
                    success = t.success,
                    env_steps = at.env_steps,
                    wall_seconds = at.wall_seconds,
                    "training success first reached {:.0} % after {} env steps, {:.1} s",
                    100.0 * t.success,
                    at.env_steps,
                    at.wall_seconds
                );
            }
        }
        let learned =
            (self.holding.as_mut()).is_some_and(|h| h.observe(row.success_rate, full, at));
        (row, learned)
    }

    /// `[stop.greedy]`, when a check is due (or whenever `when` says):
    /// whether the greedy policy now solves its share of held-out episodes
    /// of the run's map.
    fn greedy_check(&mut self, when: Check) -> Result<bool, TrainError> {
        let at = target::Mark {
            update: self.state.updates,
            env_steps: self.state.env_steps,
            wall_seconds: self.wall(),
        };
        if self.greedy.is_none() {
            return Ok(false);
        }
        let Some(ground) = self.greedy_ground() else {
            return Ok(false);
        };
        let probe = self.greedy.as_mut().expect("checked above");
        match when {
            Check::IfDue if !probe.due(at.env_steps) => Ok(false),
            Check::IfDue | Check::Now => probe.run(&self.policy, &ground, at),
            Check::First => probe.run_first(&self.policy, &ground, at),
        }
    }

    /// Where `[stop.greedy]` plays: the run's (first) map under its rules,
    /// `None` for a run without a grid map.
    fn greedy_ground(&self) -> Option<stop::Ground> {
        let (map, _) = self.layouts.first()?;
        Some(stop::Ground {
            map: map.clone(),
            env: env_config(&self.cfg, self.cfg.run.seed),
            stepping_aside: self.cfg.polish.as_ref().is_some_and(|p| p.stepping_aside),
        })
    }

    /// `[stop.greedy] keep_best`: checks the last update's weights if no
    /// check has yet, then puts the best checked weights (with
    /// `finalists`: the best finalist's) into the policy; returns the check
    /// they passed and their final replay (`None` without `keep_best`).
    fn keep_best(
        &mut self,
    ) -> Result<Option<(stop::GreedyRecord, Option<stop::FinalRecord>)>, TrainError> {
        let updates = self.state.updates;
        match &self.greedy {
            Some(probe) if probe.keeps_best() => {
                if !probe.checked(updates) {
                    self.greedy_check(Check::Now)?;
                }
            }
            _ => return Ok(None),
        }
        let probe = self.greedy.as_ref().expect("checked above");
        let Some(ground) = self.greedy_ground() else {
            return Ok(None);
        };
        let kept = probe.restore_best(&self.policy, &ground)?;
        if let Some((k, _)) = kept.filter(|(k, _)| k.update != updates) {
            tracing::info!(
                update = k.update,
                env_steps = k.env_steps,
                solved = k.solved,
                episodes = k.episodes,
                "keeping the weights of update {} ({} of {} held-out episodes solved), not the last update's",
                k.update,
                k.solved,
                k.episodes
            );
        }
        Ok(kept)
    }

    /// The kept finalist (`replay`) as the polish is judged against it
    /// ([`stop::GreedyProbe::unpolished`]); `None` without greedy checks.
    fn unpolished(
        &self,
        replay: stop::FinalRecord,
    ) -> Result<Option<stop::Unpolished>, TrainError> {
        let (Some(probe), Some(ground)) = (&self.greedy, self.greedy_ground()) else {
            return Ok(None);
        };
        probe
            .unpolished(&self.policy, &ground, replay, self.state.updates)
            .map(Some)
    }

    /// Keeps the polished weights only if they solve more of the final
    /// held-out episodes, raw and shielded together, than the kept
    /// finalist (`before`), else puts its weights back
    /// ([`stop::GreedyProbe::judge_polish`]).
    fn judge_polish(
        &self,
        before: &stop::Unpolished,
    ) -> Result<Option<stop::PolishReplay>, TrainError> {
        let (Some(probe), Some(ground)) = (&self.greedy, self.greedy_ground()) else {
            return Ok(None);
        };
        probe.judge_polish(&self.policy, &ground, before).map(Some)
    }

    /// Whether the `stop_return` (and `stop_len`) goal holds over a full window.
    fn goal_reached(&self) -> bool {
        let Some(goal) = self.cfg.run.stop_return else {
            return false;
        };
        let len_ok = self
            .cfg
            .run
            .stop_len
            .is_none_or(|l| self.window.len_mean() <= l);
        self.window.len() >= metrics::EPISODE_WINDOW && self.window.return_mean() >= goal && len_ok
    }

    fn summary(&self, final_checkpoint: PathBuf, reason: StopReason) -> Summary {
        let (cfg, window, state) = (&self.cfg, &self.window, &self.state);
        let names = cfg.layout_names();
        let (mut success_by_map, mut episodes_by_map) = Default::default();
        if cfg.task.maps().is_some() {
            let lw = &self.layout_windows;
            success_by_map = names.iter().cloned().zip(lw.success_rates()).collect();
            episodes_by_map = names.iter().cloned().zip(lw.totals()).collect();
        }
        Summary {
            algo: cfg.algorithm.algo().to_string(),
            mode: cfg.mode.to_string(),
            map: cfg.map_label(),
            maps: names,
            success_by_map,
            episodes_by_map,
            agents: cfg.agents,
            starts: match cfg.starts {
                // Plant AGVs start at random offsets on their start tracks.
                _ if cfg.task.is_plant() => "random".into(),
                buridan_env::Starts::Fixed => "fixed".into(),
                buridan_env::Starts::Random => "random".into(),
            },
            env_steps: state.env_steps,
            agent_steps: state.agent_steps,
            updates: state.updates,
            wall_seconds: state.wall_seconds,
            steps_per_s: state.env_steps as f64 / state.wall_seconds.max(1e-9),
            episodes: window.total,
            episode_return_mean: window.return_mean(),
            success_rate: window.success_rate(),
            episode_len_mean: window.len_mean(),
            stale_fragments: state.stale_fragments,
            stopped_early: reason != StopReason::Budget,
            stop_reason: reason,
            time_to_target: state.time_to_target.clone(),
            greedy_check: self.greedy.as_ref().and_then(|g| g.last()),
            kept_check: None,
            kept_replay: None,
            polish_replay: None,
            final_checkpoint,
        }
    }
}

/// The final checkpoint directory of a finished run in `out`.
pub fn final_checkpoint(out: &Path) -> PathBuf {
    checkpoint::final_dir(out)
}
