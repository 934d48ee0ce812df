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
//! Outputs in `out`: `metrics.csv` (one row per update), `config.toml`,
//! `checkpoints/update-NNNNNN/` every `checkpoint_every` updates,
//! `checkpoints/final/` at the end, `summary.json`. A checkpoint directory
//! holds `spec.json` + `model.safetensors` (loadable with
//! [`buridan_policy::Policy::load`]) plus `optimizer.safetensors`,
//! `trainer.json` and `config.toml` for `resume`.

pub mod config;
pub mod exchange;
pub mod metrics;
pub mod rollout;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use buridan_actor::Collector;
use buridan_env::{EnvConfig, Map, ObsKind, VecEnv};
use buridan_policy::{Fragment, Inference, ModelSpec, Policy, Weights};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::algo::impala::{Impala, ImpalaSettings};
use crate::algo::optim::Adam;
use crate::algo::ppo::{Ppo, PpoSettings};
use crate::algo::vtrace::VTraceParams;
use crate::algo::UpdateStats;

pub use config::{Algo, ImpalaConfig, PpoConfig, TrainConfig};
pub use exchange::{Exchange, InProcess, Shared};
pub use metrics::{EpisodeWindow, MetricsRow, MetricsWriter, Summary, METRICS_COLUMNS};

/// Live progress of a training run (the CLI shows a progress bar).
pub trait Progress {
    /// Training starts; `total_steps` is the env-step budget, `env_steps`
    /// the steps already done (resume).
    fn on_start(&mut self, _cfg: &TrainConfig, _total_steps: u64, _env_steps: u64) {}
    /// One learner update finished.
    fn on_update(&mut self, _row: &MetricsRow) {}
    /// A checkpoint was written.
    fn on_checkpoint(&mut self, _dir: &Path) {}
    /// Training finished.
    fn on_finish(&mut self, _summary: &Summary) {}
}

/// A [`Progress`] that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoProgress;

impl Progress for NoProgress {}

/// Counters saved with a checkpoint (`trainer.json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainerState {
    /// Learner updates (= policy version).
    pub updates: u64,
    /// Env steps sampled.
    pub env_steps: u64,
    /// Agent steps sampled.
    pub agent_steps: u64,
    /// Episodes finished.
    pub episodes: u64,
    /// Wall seconds spent so far.
    pub wall_seconds: f64,
    /// Adam steps taken.
    pub adam_steps: u64,
    /// PPO KL coefficients per weight set.
    pub kl_coeffs: Vec<f64>,
    /// Fragments dropped as stale.
    pub stale_fragments: u64,
    /// The last episodes (the metrics window), so a resumed run reports
    /// from its first update on.
    #[serde(default)]
    pub recent_episodes: Vec<buridan_env::EpisodeStats>,
}

/// File of the trainer counters inside a checkpoint.
pub const TRAINER_FILE: &str = "trainer.json";
/// File of the optimiser moments inside a checkpoint.
pub const OPTIMIZER_FILE: &str = "optimizer.safetensors";

enum Learner {
    Ppo(Ppo),
    Impala(Impala),
}

impl Learner {
    fn adam(&self) -> &Adam {
        match self {
            Learner::Ppo(p) => &p.adam,
            Learner::Impala(i) => &i.adam,
        }
    }
    fn adam_mut(&mut self) -> &mut Adam {
        match self {
            Learner::Ppo(p) => &mut p.adam,
            Learner::Impala(i) => &mut i.adam,
        }
    }
    fn kl_coeffs(&self) -> Vec<f64> {
        match self {
            Learner::Ppo(p) => p.kl_coeffs.clone(),
            Learner::Impala(_) => Vec::new(),
        }
    }
}

/// The env configuration of a training config.
pub fn env_config(cfg: &TrainConfig, seed: u64) -> EnvConfig {
    EnvConfig {
        agents: cfg.agents,
        t_max: cfg.t_max,
        starts: cfg.starts,
        seed,
        sensor_range: cfg.sensor_range,
        ..EnvConfig::default()
    }
}

fn save_checkpoint(
    dir: &Path,
    policy: &Policy,
    learner: &Learner,
    state: &TrainerState,
    cfg: &TrainConfig,
) -> Result<()> {
    policy
        .save(dir)
        .with_context(|| format!("cannot save checkpoint {}", dir.display()))?;
    learner.adam().save(&dir.join(OPTIMIZER_FILE))?;
    std::fs::write(
        dir.join(TRAINER_FILE),
        serde_json::to_string_pretty(state).expect("serialises"),
    )?;
    std::fs::write(dir.join("config.toml"), cfg.to_toml())?;
    Ok(())
}

/// Trains a policy as configured, writing metrics, checkpoints and the
/// summary into `out` (created if needed), reporting to `progress`: the
/// embedded default, with `cfg.num_actors` actor threads in this process.
///
/// Env steps are vectorised env steps (one step of one env instance = 1,
/// whatever the agent count). Call
/// [`buridan_policy::threads::pin_threads`] at the start of `main` to fix
/// candle's thread count (1 is fastest for these small networks).
pub fn train(cfg: &TrainConfig, out: &Path, progress: &mut dyn Progress) -> Result<Summary> {
    let run = Run::prepare(cfg, out)?;
    let mut collectors = Vec::with_capacity(cfg.num_actors);
    for i in 0..cfg.num_actors {
        let venv = VecEnv::new(
            run.map.clone(),
            env_config(cfg, run.actor_seed(i as u64)),
            cfg.envs_per_actor,
            cfg.mode.obs_kind(),
            1,
        )?;
        let actor_policy = Policy::new(run.spec.clone(), cfg.seed)?;
        actor_policy.copy_from(&run.policy)?;
        let rows = venv.obs().len() / venv.obs_dim();
        collectors.push(Collector {
            id: i as u32,
            inference: Inference::new(
                actor_policy,
                rows,
                cfg.seed ^ (0xA5A5_0000 + i as u64) ^ run.state.updates.wrapping_mul(7919),
            ),
            venv,
            fragment_len: cfg.fragment_len,
            version: run.state.updates,
        });
    }
    let mut exchange = InProcess::spawn(collectors, cfg.queue_capacity(), cfg.algo == Algo::Ppo)?;
    run.learn(&mut exchange, progress)
}

/// A training run between preparation and its end: config, policy,
/// optimiser and counters (fresh, or restored from `cfg.resume`).
pub struct Run {
    cfg: TrainConfig,
    out: PathBuf,
    map: Arc<Map>,
    spec: ModelSpec,
    policy: Policy,
    learner: Learner,
    state: TrainerState,
    window: EpisodeWindow,
    wall_offset: f64,
    t_start: Instant,
    interrupt: Option<Arc<AtomicBool>>,
}

/// The run was interrupted (`Run::interrupt_on`); its last state is in the
/// named checkpoint.
#[derive(Debug, thiserror::Error)]
#[error("interrupted after update {updates}; resume with --resume {}", checkpoint.display())]
pub struct Interrupted {
    /// Updates done.
    pub updates: u64,
    /// The checkpoint written on the way out.
    pub checkpoint: PathBuf,
}

impl Run {
    /// Validates `cfg`, creates `out`, builds (or restores) the policy and
    /// the optimiser.
    pub fn prepare(cfg: &TrainConfig, out: &Path) -> Result<Run> {
        cfg.validate()?;
        buridan_policy::threads::tune_allocator();
        let t_start = Instant::now();
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
        let config_path = out.join("config.toml");
        std::fs::write(&config_path, cfg.to_toml())
            .with_context(|| format!("cannot write {}", config_path.display()))?;
        let map = Arc::new(Map::load(&cfg.map)?);
        let obs_dim = match cfg.mode.obs_kind() {
            ObsKind::Local => buridan_env::local_obs_dim(cfg.sensor_range),
            ObsKind::Central => {
                buridan_env::central_obs_dim(map.grid.height(), map.grid.width(), cfg.agents)
            }
        };
        let spec = cfg.model_spec(obs_dim);
        let (policy, state) = match &cfg.resume {
            None => (
                Policy::new(spec.clone(), cfg.seed)?,
                TrainerState::default(),
            ),
            Some(dir) => {
                let policy = Policy::load_expecting(dir, &spec)
                    .with_context(|| format!("cannot resume from {}", dir.display()))?;
                let text = std::fs::read_to_string(dir.join(TRAINER_FILE))
                    .with_context(|| format!("{} lacks {TRAINER_FILE}", dir.display()))?;
                (policy, serde_json::from_str::<TrainerState>(&text)?)
            }
        };
        let mut learner = match cfg.algo {
            Algo::Ppo => Learner::Ppo(Ppo::new(
                &policy,
                PpoSettings {
                    lr: cfg.ppo.lr,
                    epochs: cfg.ppo.epochs,
                    minibatch_size: cfg.ppo.minibatch,
                    clip: cfg.ppo.clip,
                    vf_coeff: cfg.ppo.vf_coeff,
                    vf_clip: cfg.ppo.vf_clip,
                    entropy_coeff: cfg.ppo.entropy_coeff,
                    kl_coeff: cfg.ppo.kl_coeff,
                    kl_target: cfg.ppo.kl_target,
                    gamma: cfg.gamma,
                    lambda: cfg.ppo.lambda,
                    grad_clip: cfg.ppo.grad_clip,
                    standardize_advantages: cfg.ppo.standardize_advantages,
                    max_seq_len: cfg.max_seq_len,
                },
            )),
            Algo::Impala => Learner::Impala(Impala::new(
                &policy,
                ImpalaSettings {
                    lr: cfg.impala.lr,
                    vf_coeff: cfg.impala.vf_coeff,
                    entropy_coeff: cfg.impala.entropy_coeff,
                    grad_clip: cfg.impala.grad_clip,
                    vtrace: VTraceParams {
                        gamma: cfg.gamma,
                        lambda: cfg.impala.lambda,
                        rho_bar: cfg.impala.rho_bar,
                        c_bar: cfg.impala.c_bar,
                        pg_rho_bar: cfg.impala.pg_rho_bar,
                    },
                    max_seq_len: cfg.max_seq_len,
                },
            )),
        };
        if let Some(dir) = &cfg.resume {
            let path = dir.join(OPTIMIZER_FILE);
            if path.is_file() {
                learner.adam_mut().load(&path, state.adam_steps)?;
            } else {
                tracing::warn!(
                    "{} lacks {OPTIMIZER_FILE}: fresh optimiser state",
                    dir.display()
                );
            }
            if let Learner::Ppo(p) = &mut learner {
                if state.kl_coeffs.len() == p.kl_coeffs.len() {
                    p.kl_coeffs = state.kl_coeffs.clone();
                }
            }
        }
        tracing::info!(
            algo = %cfg.algo,
            mode = %cfg.mode,
            map = %cfg.map,
            agents = cfg.agents,
            params = policy.num_params(),
            candle_threads = buridan_policy::threads::candle_threads(),
            updates = state.updates,
            "training"
        );
        Ok(Run {
            cfg: cfg.clone(),
            out: out.to_path_buf(),
            map,
            spec,
            policy,
            learner,
            window: EpisodeWindow::restore(state.episodes, &state.recent_episodes),
            wall_offset: state.wall_seconds,
            state,
            t_start,
            interrupt: None,
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

    fn stop_interrupted(&mut self, ckpt_root: &Path) -> anyhow::Error {
        let dir = ckpt_root.join(format!("update-{:06}", self.state.updates));
        self.state.wall_seconds = self.wall();
        if let Err(e) = save_checkpoint(&dir, &self.policy, &self.learner, &self.state, &self.cfg) {
            return e.context("interrupted, and the checkpoint failed");
        }
        Interrupted {
            updates: self.state.updates,
            checkpoint: dir,
        }
        .into()
    }

    /// The run's configuration.
    pub fn config(&self) -> &TrainConfig {
        &self.cfg
    }

    /// The map the run trains on.
    pub fn map(&self) -> &Arc<Map> {
        &self.map
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
    pub fn weights(&self) -> Result<Weights> {
        Ok(self.policy.weights(self.state.updates)?)
    }

    /// Env seed of actor `k`; a resumed run shifts the seeds so it does not
    /// replay the episodes it has already seen.
    pub fn actor_seed(&self, k: u64) -> u64 {
        let base = self.cfg.seed.wrapping_add(k);
        if self.state.updates > 0 {
            base.wrapping_add(self.state.updates.wrapping_mul(0x9E37_79B9))
        } else {
            base
        }
    }

    /// The learner loop: publish weights, gather a train batch from
    /// `exchange`, update, repeat until `cfg.steps` env steps; then the
    /// final checkpoint and `summary.json`. Always calls
    /// [`Exchange::finish`].
    pub fn learn(
        mut self,
        exchange: &mut dyn Exchange,
        progress: &mut dyn Progress,
    ) -> Result<Summary> {
        let result = self.learn_loop(exchange, progress);
        let finished = exchange.finish(result.is_ok());
        let stopped_early = result?;
        finished?;
        let cfg = &self.cfg;
        let final_dir = self.out.join("checkpoints").join("final");
        self.state.wall_seconds = self.wall();
        save_checkpoint(&final_dir, &self.policy, &self.learner, &self.state, cfg)?;
        progress.on_checkpoint(&final_dir);
        let window = &self.window;
        let summary = Summary {
            algo: cfg.algo.to_string(),
            mode: cfg.mode.to_string(),
            map: cfg.map.clone(),
            agents: cfg.agents,
            starts: match cfg.starts {
                buridan_env::Starts::Fixed => "fixed".into(),
                buridan_env::Starts::Random => "random".into(),
            },
            env_steps: self.state.env_steps,
            agent_steps: self.state.agent_steps,
            updates: self.state.updates,
            wall_seconds: self.state.wall_seconds,
            steps_per_s: self.state.env_steps as f64 / self.state.wall_seconds.max(1e-9),
            episodes: window.total,
            episode_return_mean: window.return_mean(),
            success_rate: window.success_rate(),
            episode_len_mean: window.len_mean(),
            stale_fragments: self.state.stale_fragments,
            stopped_early,
            final_checkpoint: final_dir,
        };
        std::fs::write(
            self.out.join("summary.json"),
            serde_json::to_string_pretty(&summary_json(&summary)).expect("serialises"),
        )?;
        progress.on_finish(&summary);
        Ok(summary)
    }

    fn wall(&self) -> f64 {
        self.wall_offset + self.t_start.elapsed().as_secs_f64()
    }

    /// Runs updates until the step budget; `Ok(true)` if stopped early by
    /// the `stop_return` goal.
    fn learn_loop(
        &mut self,
        exchange: &mut dyn Exchange,
        progress: &mut dyn Progress,
    ) -> Result<bool> {
        let cfg = self.cfg.clone();
        let ckpt_root = self.out.join("checkpoints");
        let mut metrics = MetricsWriter::open(&self.out.join("metrics.csv"))?;
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x5EED ^ self.state.updates);
        let on_policy = cfg.algo == Algo::Ppo;
        let target_steps = match cfg.algo {
            Algo::Ppo => cfg.ppo.train_batch as u64,
            Algo::Impala => cfg.impala.train_batch as u64,
        };
        let wanted = on_policy.then_some(target_steps);
        progress.on_start(&cfg, cfg.steps, self.state.env_steps);
        let mut last_row_time = self.wall_offset;
        let mut last_row_steps = self.state.env_steps;
        exchange.publish(self.weights()?, wanted)?;
        while self.state.env_steps < cfg.steps {
            if self.interrupted() {
                return Err(self.stop_interrupted(&ckpt_root));
            }
            // Gather one train batch.
            let mut batch: Vec<Fragment> = Vec::with_capacity(cfg.fragments_per_batch());
            let mut batch_steps = 0u64;
            while batch_steps < target_steps {
                let Some(f) = exchange.next_fragment(Duration::from_millis(200))? else {
                    if self.interrupted() {
                        return Err(self.stop_interrupted(&ckpt_root));
                    }
                    continue;
                };
                let state = &mut self.state;
                state.env_steps += f.env_steps;
                state.agent_steps += f.env_steps * cfg.agents as u64;
                ::metrics::counter!("buridan_env_steps_total").increment(f.env_steps);
                self.window.extend(&f.episodes);
                let lag = state.updates.saturating_sub(f.policy_version);
                ::metrics::histogram!("buridan_policy_lag").record(lag as f64);
                let stale = match cfg.algo {
                    Algo::Ppo => lag > 0,
                    Algo::Impala => lag > cfg.impala.max_policy_lag,
                };
                if stale {
                    state.stale_fragments += 1;
                    ::metrics::counter!("buridan_fragments_total", "outcome" => "stale_at_learner")
                        .increment(1);
                    continue;
                }
                batch_steps += f.env_steps;
                batch.push(f);
            }
            let t_learn = Instant::now();
            let stats: UpdateStats = match &mut self.learner {
                Learner::Ppo(p) => p.update(&self.policy, &batch, &mut rng)?,
                Learner::Impala(i) => i.update(&self.policy, &batch)?,
            };
            let learn_seconds = t_learn.elapsed().as_secs_f64();
            self.state.updates += 1;
            exchange.publish(self.weights()?, wanted)?;
            let wall = self.wall();
            let state = &mut self.state;
            state.episodes = self.window.total;
            state.adam_steps = self.learner.adam().steps();
            state.kl_coeffs = self.learner.kl_coeffs();
            state.wall_seconds = wall;
            state.recent_episodes = self.window.recent();
            let row = MetricsRow {
                update: state.updates,
                env_steps: state.env_steps,
                agent_steps: state.agent_steps,
                wall_seconds: wall,
                steps_per_s: (state.env_steps - last_row_steps) as f64
                    / (wall - last_row_time).max(1e-9),
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
            };
            last_row_time = wall;
            last_row_steps = state.env_steps;
            metrics.write(&row)?;
            export_metrics(&row, exchange);
            tracing::debug!(?row, "update");
            progress.on_update(&row);
            if cfg.checkpoint_every > 0 && self.state.updates % cfg.checkpoint_every == 0 {
                let dir = ckpt_root.join(format!("update-{:06}", self.state.updates));
                save_checkpoint(&dir, &self.policy, &self.learner, &self.state, &cfg)?;
                progress.on_checkpoint(&dir);
            }
            if let Some(goal) = cfg.stop_return {
                let len_ok = cfg.stop_len.is_none_or(|l| self.window.len_mean() <= l);
                if self.window.len() >= metrics::EPISODE_WINDOW
                    && self.window.return_mean() >= goal
                    && len_ok
                {
                    return Ok(true);
                }
            }
        }
        Ok(false)
    }
}

/// Publishes one update's figures as Prometheus metrics (no-ops unless an
/// exporter is installed).
fn export_metrics(row: &MetricsRow, exchange: &dyn Exchange) {
    ::metrics::gauge!("buridan_policy_version").set(row.update as f64);
    ::metrics::gauge!("buridan_env_steps").set(row.env_steps as f64);
    ::metrics::gauge!("buridan_env_steps_per_second").set(row.steps_per_s);
    ::metrics::gauge!("buridan_queue_depth").set(exchange.queue_depth() as f64);
    ::metrics::gauge!("buridan_connected_actors").set(exchange.connected_actors() as f64);
    ::metrics::gauge!("buridan_episodes").set(row.episodes as f64);
    for (name, v) in [
        ("buridan_episode_return_mean", row.episode_return_mean),
        ("buridan_success_rate", row.success_rate),
        ("buridan_episode_length_mean", row.episode_len_mean),
    ] {
        if v.is_finite() {
            ::metrics::gauge!(name).set(v);
        }
    }
    for (term, v) in [
        ("total", row.total_loss),
        ("policy", row.policy_loss),
        ("value", row.vf_loss),
        ("entropy", row.entropy),
        ("kl", row.kl),
    ] {
        ::metrics::gauge!("buridan_loss", "term" => term).set(v);
    }
    ::metrics::gauge!("buridan_grad_norm").set(row.grad_norm);
    ::metrics::histogram!("buridan_learn_seconds").record(row.learn_seconds);
}
/// JSON of a summary with NaN (no episode yet) written as `null`.
fn summary_json(s: &Summary) -> serde_json::Value {
    serde_json::to_value(s).unwrap_or(serde_json::Value::Null)
}

/// The final checkpoint directory of a finished run in `out`.
pub fn final_checkpoint(out: &Path) -> PathBuf {
    out.join("checkpoints").join("final")
}
