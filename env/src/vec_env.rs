//! Many env instances stepped as one batch, with auto-reset.
//!
//! Buffers are flat and owned by the [`VecEnv`]; after every [`VecEnv::step`]
//! they hold, per env `e` and agent `i` (row `e·n + i` for local observations,
//! row `e` for central ones):
//!
//! - `obs`: the observation to act on next — after an episode ended, the first
//!   observation of the next episode (auto-reset);
//! - `final_obs`: for envs whose episode ended in this step, the observation
//!   of the last state (to bootstrap values on truncation); other rows stale;
//! - `masks`, `rewards` (per agent), `terminated` and `truncated` (per env).
//!
//! Env `e` plays episodes `e, e + N, e + 2N, …` (N envs), so every episode is
//! reproducible from (map, agents, seed, episode index). Over several
//! layouts ([`VecEnv::with_layouts`]) each env is a [`LayoutMixture`] and
//! the episode index also decides the layout.
//!
//! ```
//! use buridan_env::{EnvConfig, Map, ObsKind, VecEnv};
//! let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
//! let mut venv = VecEnv::new(map, EnvConfig::default(), 8, ObsKind::Local, 1).unwrap();
//! let actions = vec![0u8; 8 * 4];
//! for _ in 0..100 {
//!     venv.step(&actions).unwrap();
//! }
//! let episodes = venv.drain_episodes();
//! assert_eq!(episodes.len(), 8); // all truncated at T_max = 100
//! assert!(episodes.iter().all(|e| !e.success && e.length == 100));
//! ```

use std::sync::Arc;

use rayon::prelude::*;

use crate::api::BatchedEnv;
use crate::buffers::StepBuffers;
use crate::config::EnvConfig;
use crate::error::EnvError;
use crate::map::Map;
use crate::mixture::{LayoutMixture, WeightedLayout};
use crate::obs::ObsKind;
use crate::replay::{FailureReplay, ReplayConfig};
use crate::stats::EpisodeStats;
use crate::world::{GridEnv, NUM_ACTIONS};

/// One env of a [`VecEnv`]: a [`GridEnv`] (one map), or a
/// [`LayoutMixture`] that moves to another layout at its resets. The batch
/// loop is generic over it, so the single-map batch compiles to the same
/// code as before mixtures existed.
pub trait EnvSlot: Send {
    /// The env of the current episode.
    fn env(&self) -> &GridEnv;
    /// The env of the current episode, to step it.
    fn env_mut(&mut self) -> &mut GridEnv;
    /// Starts episode `episode` (its starts and goals, and its layout in a
    /// mixture, follow from the index).
    fn reset_to(&mut self, episode: u64) -> Result<(), EnvError>;
    /// Starts the slot's next episode (`episode + stride`).
    fn reset_next(&mut self, stride: u64) -> Result<(), EnvError> {
        self.reset_to(self.env().episode() + stride)
    }
    /// Statistics of the current episode.
    fn stats(&self) -> EpisodeStats {
        self.env().stats()
    }
}

impl EnvSlot for GridEnv {
    #[inline]
    fn env(&self) -> &GridEnv {
        self
    }
    #[inline]
    fn env_mut(&mut self) -> &mut GridEnv {
        self
    }
    fn reset_to(&mut self, episode: u64) -> Result<(), EnvError> {
        GridEnv::reset_to(self, episode)
    }
}

/// A batch of environments with flat observation, mask and reward buffers;
/// each env one map ([`VecEnv::new`]) or a mixture of layouts
/// ([`VecEnv::with_layouts`]).
pub struct VecEnv<S: EnvSlot = GridEnv> {
    envs: Vec<S>,
    kind: ObsKind,
    agents: usize,
    obs_dim: usize,
    mask_dim: usize,
    buffers: StepBuffers,
    finished: Vec<Option<EpisodeStats>>,
    pool: Option<rayon::ThreadPool>,
}

impl VecEnv {
    /// `num_envs` copies of the env, observations of `kind`, stepped on
    /// `threads` threads (1 = on the caller's thread).
    pub fn new(
        map: Arc<Map>,
        cfg: EnvConfig,
        num_envs: usize,
        kind: ObsKind,
        threads: usize,
    ) -> Result<Self, EnvError> {
        let envs = slots(num_envs, |e| {
            GridEnv::with_episode(map.clone(), cfg.clone(), e)
        })?;
        Self::from_slots(envs, cfg.agents, kind, threads)
    }

    /// Visit counts summed over all envs since creation (row-major cells).
    pub fn visits(&self) -> Vec<u64> {
        let mut totals = vec![0u64; self.envs[0].visits().len()];
        for env in &self.envs {
            for (t, &v) in totals.iter_mut().zip(env.visits()) {
                *t += v;
            }
        }
        totals
    }
}

impl VecEnv<LayoutMixture> {
    /// `num_envs` envs over several layouts: each draws the layout of every
    /// episode from `layouts`' weights ([`LayoutMixture`]). The layouts
    /// must give observations of one size for `kind` (any layouts for local
    /// observations; equally sized ones for central).
    pub fn with_layouts(
        layouts: &[WeightedLayout],
        cfg: EnvConfig,
        num_envs: usize,
        kind: ObsKind,
        threads: usize,
    ) -> Result<Self, EnvError> {
        let envs = slots(num_envs, |e| LayoutMixture::new(layouts, cfg.clone(), e))?;
        if let Some(first) = envs.first() {
            let dims: Vec<usize> = first
                .envs()
                .iter()
                .map(|env| obs_dims(env, kind).0)
                .collect();
            if dims.iter().any(|&d| d != dims[0]) {
                return Err(EnvError::InvalidConfig(format!(
                    "the layouts give {kind:?} observations of different sizes {dims:?}; \
                     one batch needs one size"
                )));
            }
        }
        Self::from_slots(envs, cfg.agents, kind, threads)
    }
}

/// `num_envs` slots, slot `e` made by `make(e)` (its first episode).
fn slots<S>(
    num_envs: usize,
    make: impl Fn(u64) -> Result<S, EnvError>,
) -> Result<Vec<S>, EnvError> {
    (0..num_envs as u64).map(make).collect()
}

/// Floats per observation row and bytes per mask row of `env` for `kind`.
fn obs_dims(env: &GridEnv, kind: ObsKind) -> (usize, usize) {
    match kind {
        ObsKind::Local => (env.local_obs_dim(), NUM_ACTIONS),
        ObsKind::Central => (env.central_obs_dim(), NUM_ACTIONS * env.agents()),
    }
}

impl<S: EnvSlot> VecEnv<S> {
    /// The batch of `envs` (each with `n` agents), its buffers filled with
    /// the first observations.
    fn from_slots(envs: Vec<S>, n: usize, kind: ObsKind, threads: usize) -> Result<Self, EnvError> {
        if envs.is_empty() {
            return Err(EnvError::InvalidConfig(
                "a VecEnv needs at least one env".into(),
            ));
        }
        let num_envs = envs.len();
        let rows = num_envs * kind.rows_per_env(n);
        let (obs_dim, mask_dim) = obs_dims(envs[0].env(), kind);
        let pool = if threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .thread_name(|i| format!("vec-env-{i}"))
                    .build()
                    .map_err(|e| {
                        EnvError::InvalidConfig(format!("cannot start {threads} env threads: {e}"))
                    })?,
            )
        } else {
            None
        };
        let mut venv = Self {
            kind,
            agents: n,
            obs_dim,
            mask_dim,
            buffers: StepBuffers::new(num_envs, n, rows * obs_dim, rows * mask_dim),
            finished: vec![None; num_envs],
            envs,
            pool,
        };
        let rows = kind.rows_per_env(n);
        let per_env = venv
            .buffers
            .obs
            .chunks_mut(rows * obs_dim)
            .zip(venv.buffers.masks.chunks_mut(rows * mask_dim));
        for (slot, (obs, masks)) in venv.envs.iter().zip(per_env) {
            write_obs(slot.env(), kind, obs, masks)?;
        }
        Ok(venv)
    }

    /// Steps every env with `actions` (`num_envs · n` values, env-major).
    /// Invalid actions are rejected before any env moves.
    pub fn step(&mut self, actions: &[u8]) -> Result<(), EnvError> {
        let n = self.agents;
        EnvError::check_len("actions", self.envs.len() * n, actions.len())?;
        if let Some(k) = actions.iter().position(|&a| a as usize >= NUM_ACTIONS) {
            return Err(EnvError::InvalidAction {
                agent: k % n,
                action: actions[k],
            });
        }
        let rows = self.rows_per_env();
        let (o, m) = (rows * self.obs_dim, rows * self.mask_dim);
        let stride = self.envs.len() as u64;
        let kind = self.kind;
        let b = &mut self.buffers;
        let step_one =
            |(env, act, rew, obs, final_obs, mask, term, trunc, finished): SlotBuffers<'_, S>| {
                step_env(
                    env, kind, stride, act, rew, obs, final_obs, mask, term, trunc, finished,
                )
            };
        match &self.pool {
            Some(pool) => pool.install(|| {
                (
                    self.envs.par_iter_mut(),
                    actions.par_chunks(n),
                    b.rewards.par_chunks_mut(n),
                    b.obs.par_chunks_mut(o),
                    b.final_obs.par_chunks_mut(o),
                    b.masks.par_chunks_mut(m),
                    b.terminated.par_iter_mut(),
                    b.truncated.par_iter_mut(),
                    self.finished.par_iter_mut(),
                )
                    .into_par_iter()
                    .try_for_each(step_one)
            })?,
            // One thread: a plain loop on the caller's thread (a parallel
            // iterator here would run on rayon's global pool instead).
            None => {
                let per_env = self
                    .envs
                    .iter_mut()
                    .zip(actions.chunks(n))
                    .zip(b.rewards.chunks_mut(n))
                    .zip(b.obs.chunks_mut(o))
                    .zip(b.final_obs.chunks_mut(o))
                    .zip(b.masks.chunks_mut(m))
                    .zip(b.terminated.iter_mut())
                    .zip(b.truncated.iter_mut())
                    .zip(self.finished.iter_mut());
                for ((((((((env, act), rew), obs), final_obs), mask), term), trunc), finished) in
                    per_env
                {
                    step_one((env, act, rew, obs, final_obs, mask, term, trunc, finished))?;
                }
            }
        }
        b.episodes
            .extend(self.finished.iter_mut().filter_map(Option::take));
        Ok(())
    }

    /// Number of envs.
    pub fn num_envs(&self) -> usize {
        self.envs.len()
    }

    /// Agents per env.
    pub fn agents(&self) -> usize {
        self.agents
    }

    /// Floats per observation row.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Bytes per mask row (5 for local, 5n for central).
    pub fn mask_dim(&self) -> usize {
        self.mask_dim
    }

    /// The observation kind.
    pub fn kind(&self) -> ObsKind {
        self.kind
    }

    /// Current observations, one row per agent (local) or per env (central).
    pub fn obs(&self) -> &[f32] {
        &self.buffers.obs
    }

    /// Last observations of episodes that ended in the last step.
    pub fn final_obs(&self) -> &[f32] {
        &self.buffers.final_obs
    }

    /// Current action masks.
    pub fn masks(&self) -> &[u8] {
        &self.buffers.masks
    }

    /// Rewards of the last step, per agent, env-major.
    pub fn rewards(&self) -> &[f32] {
        &self.buffers.rewards
    }

    /// Per env: 1 if its episode terminated (success) in the last step.
    pub fn terminated(&self) -> &[u8] {
        &self.buffers.terminated
    }

    /// Per env: 1 if its episode was truncated in the last step.
    pub fn truncated(&self) -> &[u8] {
        &self.buffers.truncated
    }

    /// The envs, for inspection.
    pub fn envs(&self) -> &[S] {
        &self.envs
    }

    /// Takes the statistics of the episodes finished since the last call.
    pub fn drain_episodes(&mut self) -> Vec<EpisodeStats> {
        self.buffers.drain_episodes()
    }

    /// The same batch, each slot replaying its failed episodes
    /// ([`FailureReplay`]); the current episodes play on. Slot `e` draws
    /// its replays from a stream of its own env seed and index.
    ///
    /// ```
    /// use buridan_env::replay::ReplayConfig;
    /// use buridan_env::{EnvConfig, Map, ObsKind, VecEnv};
    /// let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
    /// let env = EnvConfig { t_max: 10, ..EnvConfig::default() };
    /// let venv = VecEnv::new(map, env, 2, ObsKind::Local, 1).unwrap();
    /// let replay = ReplayConfig { share: 1.0, ..ReplayConfig::default() };
    /// let mut venv = venv.with_failure_replay(replay).unwrap();
    /// for _ in 0..20 {
    ///     venv.step(&[0; 8]).unwrap();
    /// }
    /// // Standing still fails: the second episode of each slot is a replay.
    /// let eps = venv.drain_episodes();
    /// assert_eq!(eps.iter().map(|e| (e.episode, e.replay)).collect::<Vec<_>>(), [(0, 0), (1, 0), (0, 1), (1, 1)]);
    /// ```
    pub fn with_failure_replay(
        self,
        replay: ReplayConfig,
    ) -> Result<VecEnv<FailureReplay<S>>, EnvError> {
        let envs = self
            .envs
            .into_iter()
            .enumerate()
            .map(|(e, slot)| {
                let seed = slot.env().config().seed.wrapping_add(e as u64);
                FailureReplay::new(slot, replay, seed)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(VecEnv {
            envs,
            kind: self.kind,
            agents: self.agents,
            obs_dim: self.obs_dim,
            mask_dim: self.mask_dim,
            buffers: self.buffers,
            finished: self.finished,
            pool: self.pool,
        })
    }

    /// The batch as an actor drives it, boxed: replaying failed episodes
    /// if `replay` is on ([`Self::with_failure_replay`]), as it is
    /// otherwise.
    ///
    /// ```
    /// use buridan_env::replay::ReplayConfig;
    /// use buridan_env::{EnvConfig, Map, ObsKind, VecEnv};
    /// let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
    /// let env = EnvConfig { t_max: 10, ..EnvConfig::default() };
    /// let replayed = |replay| {
    ///     let venv = VecEnv::new(map.clone(), env.clone(), 2, ObsKind::Local, 1).unwrap();
    ///     let mut boxed = venv.boxed(replay).unwrap();
    ///     for _ in 0..20 {
    ///         boxed.step(&[0; 8]).unwrap();
    ///     }
    ///     boxed.drain_episodes().iter().filter(|e| e.replay > 0).count()
    /// };
    /// assert_eq!(replayed(ReplayConfig::default()), 0);
    /// assert_eq!(replayed(ReplayConfig { share: 1.0, ..ReplayConfig::default() }), 2);
    /// ```
    pub fn boxed(self, replay: ReplayConfig) -> Result<Box<dyn BatchedEnv + Send>, EnvError>
    where
        S: 'static,
    {
        Ok(if replay.enabled() {
            Box::new(self.with_failure_replay(replay)?)
        } else {
            Box::new(self)
        })
    }
}

/// One env's share of the batch buffers.
type SlotBuffers<'a, S> = (
    &'a mut S,
    &'a [u8],
    &'a mut [f32],
    &'a mut [f32],
    &'a mut [f32],
    &'a mut [u8],
    &'a mut u8,
    &'a mut u8,
    &'a mut Option<EpisodeStats>,
);

/// Steps one env, records its episode end, auto-resets it and writes its
/// observations.
#[allow(clippy::too_many_arguments)]
fn step_env<S: EnvSlot>(
    slot: &mut S,
    kind: ObsKind,
    stride: u64,
    actions: &[u8],
    rewards: &mut [f32],
    obs: &mut [f32],
    final_obs: &mut [f32],
    mask: &mut [u8],
    terminated: &mut u8,
    truncated: &mut u8,
    finished: &mut Option<EpisodeStats>,
) -> Result<(), EnvError> {
    let out = slot.env_mut().step(actions, rewards)?;
    *terminated = u8::from(out.terminated);
    *truncated = u8::from(out.truncated);
    if out.done() {
        write_obs(slot.env(), kind, final_obs, mask)?;
        *finished = Some(slot.stats());
        slot.reset_next(stride)?;
    }
    write_obs(slot.env(), kind, obs, mask)
}

fn write_obs(
    env: &GridEnv,
    kind: ObsKind,
    obs: &mut [f32],
    masks: &mut [u8],
) -> Result<(), EnvError> {
    match kind {
        ObsKind::Local => {
            let d = env.local_obs_dim();
            for i in 0..env.agents() {
                env.write_local_obs(i, &mut obs[i * d..(i + 1) * d])?;
                env.write_action_mask(i, &mut masks[i * NUM_ACTIONS..(i + 1) * NUM_ACTIONS])?;
            }
            Ok(())
        }
        ObsKind::Central => {
            env.write_central_obs(obs)?;
            env.write_joint_mask(masks)
        }
    }
}

impl<S: EnvSlot> BatchedEnv for VecEnv<S> {
    fn num_envs(&self) -> usize {
        VecEnv::num_envs(self)
    }
    fn agents(&self) -> usize {
        VecEnv::agents(self)
    }
    fn kind(&self) -> ObsKind {
        VecEnv::kind(self)
    }
    fn obs_dim(&self) -> usize {
        VecEnv::obs_dim(self)
    }
    fn step(&mut self, actions: &[u8]) -> Result<(), EnvError> {
        VecEnv::step(self, actions)
    }
    crate::batched_env_buffers!(buffers);
    fn grid_env(&self, e: usize) -> Option<&GridEnv> {
        self.envs.get(e).map(EnvSlot::env)
    }
}
