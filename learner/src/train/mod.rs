//! The trainer: in-process actors feeding a learner over a bounded queue.
//!
//! ```text
//! actor i: VecEnv ──obs/masks──▶ Inference ──actions──▶ VecEnv   (× fragment_len)
//!          └──────────── Fragment (T × rows) ───────────┐
//!                                                       ▼
//! learner: mpsc::sync_channel ─▶ train batch ─▶ PPO / IMPALA update
//!          └──▶ Shared::publish(Weights{version}) ──▶ actors reload between fragments
//! ```
//!
//! PPO is on-policy: the learner opens a gate for exactly one train batch
//! of fragments with the current version, the actors collect them and
//! wait; after the update the new weights are published and the gate
//! reopened. IMPALA actors run freely with the latest weights; fragments
//! older than `max_policy_lag` versions are dropped and counted.
//!
//! Outputs in `out`: `metrics.csv` (one row per update), `config.toml`,
//! `checkpoints/update-NNNNNN/` every `checkpoint_every` updates,
//! `checkpoints/final/` at the end, `summary.json`. A checkpoint directory
//! holds `spec.json` + `model.safetensors` (loadable with
//! [`buridan_policy::Policy::load`]) plus `optimizer.safetensors`,
//! `trainer.json` and `config.toml` for `resume`.

pub mod actor;
pub mod config;
pub mod metrics;
pub mod rollout;

use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use buridan_env::{EnvConfig, Map, ObsKind, VecEnv};
use buridan_policy::{Fragment, Inference, Mode, Policy};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::algo::impala::{Impala, ImpalaSettings};
use crate::algo::optim::Adam;
use crate::algo::ppo::{Ppo, PpoSettings};
use crate::algo::vtrace::VTraceParams;
use crate::algo::UpdateStats;

pub use actor::{Actor, Shared};
pub use config::{Algo, ImpalaConfig, PpoConfig, TrainConfig};
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

/// The observation kind a mode consumes.
pub fn obs_kind(mode: Mode) -> ObsKind {
    match mode {
        Mode::Cte => ObsKind::Central,
        Mode::Ctde | Mode::Dte => ObsKind::Local,
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
/// summary into `out` (created if needed), reporting to `progress`.
///
/// Env steps are vectorised env steps (one step of one env instance = 1,
/// whatever the agent count). Call
/// [`buridan_policy::threads::pin_threads`] at the start of `main` to fix
/// candle's thread count (1 is fastest for these small networks).
pub fn train(cfg: &TrainConfig, out: &Path, progress: &mut dyn Progress) -> Result<Summary> {
    cfg.validate()?;
    buridan_policy::threads::tune_allocator();
    let t_start = Instant::now();
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    std::fs::write(out.join("config.toml"), cfg.to_toml())?;
    let map = Arc::new(Map::load(&cfg.map)?);
    let kind = obs_kind(cfg.mode);

    // Actor envs first: they tell the observation size.
    let mut venvs = Vec::with_capacity(cfg.num_actors);
    for i in 0..cfg.num_actors {
        let seed = cfg.seed.wrapping_add(i as u64);
        venvs.push(VecEnv::new(
            map.clone(),
            env_config(cfg, seed),
            cfg.envs_per_actor,
            kind,
            1,
        )?);
    }
    let spec = cfg.model_spec(venvs[0].obs_dim());
    let (policy, mut state) = match &cfg.resume {
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
    // A resumed run must not replay the same episodes: shift the env seeds.
    if state.updates > 0 {
        for (i, v) in venvs.iter_mut().enumerate() {
            let seed = cfg
                .seed
                .wrapping_add(i as u64)
                .wrapping_add(state.updates.wrapping_mul(0x9E37_79B9));
            *v = VecEnv::new(
                map.clone(),
                env_config(cfg, seed),
                cfg.envs_per_actor,
                kind,
                1,
            )?;
        }
    }
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
        "training"
    );

    let per_batch = cfg.fragments_per_batch();
    let on_policy = cfg.algo == Algo::Ppo;
    let shared = Arc::new(Shared::new(policy.weights(state.updates)?, !on_policy));
    let capacity = match cfg.algo {
        Algo::Ppo => per_batch,
        Algo::Impala if cfg.impala.queue_capacity > 0 => cfg.impala.queue_capacity,
        Algo::Impala => per_batch,
    };
    let (tx, rx) = sync_channel::<Fragment>(capacity);
    let mut handles = Vec::new();
    for (i, venv) in venvs.into_iter().enumerate() {
        let actor_policy = Policy::new(spec.clone(), cfg.seed)?;
        actor_policy.copy_from(&policy)?;
        let rows = venv.obs().len() / venv.obs_dim();
        let actor = Actor {
            id: i as u32,
            inference: Inference::new(
                actor_policy,
                rows,
                cfg.seed ^ (0xA5A5_0000 + i as u64) ^ state.updates.wrapping_mul(7919),
            ),
            venv,
            fragment_len: cfg.fragment_len,
            version: state.updates,
        };
        let (shared, tx) = (shared.clone(), tx.clone());
        handles.push(
            std::thread::Builder::new()
                .name(format!("actor-{i}"))
                .spawn(move || actor.run(shared, tx))
                .context("cannot start an actor thread")?,
        );
    }
    drop(tx);

    let mut metrics = MetricsWriter::open(&out.join("metrics.csv"))?;
    let ckpt_root = out.join("checkpoints");
    let mut window = EpisodeWindow::default();
    window.total = state.episodes;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x5EED ^ state.updates);
    let wall_offset = state.wall_seconds;
    progress.on_start(cfg, cfg.steps, state.env_steps);
    let mut last_row_time = wall_offset;
    let mut last_row_steps = state.env_steps;
    let mut stopped_early = false;
    let result: Result<()> = (|| {
        while state.env_steps < cfg.steps {
            if on_policy {
                shared.open(state.updates, per_batch);
            }
            // Gather one train batch.
            let mut batch: Vec<Fragment> = Vec::with_capacity(per_batch);
            let mut batch_steps = 0u64;
            let target_steps = match cfg.algo {
                Algo::Ppo => cfg.ppo.train_batch as u64,
                Algo::Impala => cfg.impala.train_batch as u64,
            };
            while batch_steps < target_steps {
                let f = match rx.recv_timeout(Duration::from_millis(200)) {
                    Ok(f) => f,
                    Err(RecvTimeoutError::Timeout) => {
                        if handles.iter().any(|h| h.is_finished()) {
                            bail!("an actor stopped unexpectedly");
                        }
                        continue;
                    }
                    Err(RecvTimeoutError::Disconnected) => bail!("all actors stopped"),
                };
                state.env_steps += f.env_steps;
                state.agent_steps += f.env_steps * cfg.agents as u64;
                window.extend(&f.episodes);
                let lag = state.updates.saturating_sub(f.policy_version);
                let stale = match cfg.algo {
                    Algo::Ppo => lag > 0,
                    Algo::Impala => lag > cfg.impala.max_policy_lag,
                };
                if stale {
                    state.stale_fragments += 1;
                    continue;
                }
                batch_steps += f.env_steps;
                batch.push(f);
            }
            let t_learn = Instant::now();
            let stats: UpdateStats = match &mut learner {
                Learner::Ppo(p) => p.update(&policy, &batch, &mut rng)?,
                Learner::Impala(i) => i.update(&policy, &batch)?,
            };
            let learn_seconds = t_learn.elapsed().as_secs_f64();
            state.updates += 1;
            shared.publish(policy.weights(state.updates)?);
            state.episodes = window.total;
            state.adam_steps = learner.adam().steps();
            state.kl_coeffs = learner.kl_coeffs();
            let wall = wall_offset + t_start.elapsed().as_secs_f64();
            state.wall_seconds = wall;
            let row = MetricsRow {
                update: state.updates,
                env_steps: state.env_steps,
                agent_steps: state.agent_steps,
                wall_seconds: wall,
                steps_per_s: (state.env_steps - last_row_steps) as f64
                    / (wall - last_row_time).max(1e-9),
                episodes: window.total,
                episode_return_mean: window.return_mean(),
                success_rate: window.success_rate(),
                episode_len_mean: window.len_mean(),
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
            tracing::debug!(?row, "update");
            progress.on_update(&row);
            if cfg.checkpoint_every > 0 && state.updates % cfg.checkpoint_every == 0 {
                let dir = ckpt_root.join(format!("update-{:06}", state.updates));
                save_checkpoint(&dir, &policy, &learner, &state, cfg)?;
                progress.on_checkpoint(&dir);
            }
            if let Some(goal) = cfg.stop_return {
                let len_ok = cfg.stop_len.is_none_or(|l| window.len_mean() <= l);
                if window.len() >= metrics::EPISODE_WINDOW && window.return_mean() >= goal && len_ok
                {
                    stopped_early = true;
                    break;
                }
            }
        }
        Ok(())
    })();
    // Shut the actors down whatever happened.
    shared.stop();
    drop(rx);
    let mut actor_error = None;
    for h in handles {
        match h.join() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => actor_error = Some(e),
            Err(_) => actor_error = Some(anyhow!("an actor thread panicked")),
        }
    }
    if let Err(e) = result {
        return Err(match actor_error {
            Some(a) => e.context(format!("actor error: {a:#}")),
            None => e,
        });
    }
    if let Some(a) = actor_error {
        return Err(a.context("actor failed"));
    }
    let final_dir = ckpt_root.join("final");
    state.wall_seconds = wall_offset + t_start.elapsed().as_secs_f64();
    save_checkpoint(&final_dir, &policy, &learner, &state, cfg)?;
    progress.on_checkpoint(&final_dir);
    let summary = Summary {
        algo: cfg.algo.to_string(),
        mode: cfg.mode.to_string(),
        map: cfg.map.clone(),
        agents: cfg.agents,
        starts: match cfg.starts {
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
        stopped_early,
        final_checkpoint: final_dir,
    };
    std::fs::write(
        out.join("summary.json"),
        serde_json::to_string_pretty(&summary_json(&summary)).expect("serialises"),
    )?;
    progress.on_finish(&summary);
    Ok(summary)
}

/// JSON of a summary with NaN (no episode yet) written as `null`.
fn summary_json(s: &Summary) -> serde_json::Value {
    serde_json::to_value(s).unwrap_or(serde_json::Value::Null)
}

/// The final checkpoint directory of a finished run in `out`.
pub fn final_checkpoint(out: &Path) -> PathBuf {
    out.join("checkpoints").join("final")
}
