//! The reference env server: the native AGV plant ([`PlantVecEnv`]) behind
//! the env API (`proto/buridan/v1/env.proto`), so that the path an external
//! simulator takes — `actor --env URL` → gRPC → a simulator — is exercised
//! end to end with a model whose every step is known. The `plant-server`
//! binary runs it as a process (`plant-server --plant ID --agents N --envs E
//! --listen ADDR`); [`EnvServer`] runs it on a thread of its own, for
//! tests and benchmarks.
//!
//! ```text
//! client ──Spec──▶ EnvSpec (envs, agents, obs kind/dim, 3 actions, T_max, "plant:ID")
//!        ──Reset(seed)──▶ new session: PlantVecEnv seeded `seed` ─▶ first obs, masks
//!        ──Step(session, actions)──▶ checks ─▶ PlantVecEnv::step ─▶ obs, masks, rewards,
//!                                     flags, final obs, finished episodes + KPIs
//! ```
//!
//! A session's episodes are exactly those of a local
//! `PlantVecEnv::new(plant, PlantConfig { seed, .. }, envs, kind)`.
//! Bad input gets a status that names the problem, and the server carries
//! on: a wrong number of actions or an action out of range →
//! `INVALID_ARGUMENT`; Step without a session (0) → `FAILED_PRECONDITION`;
//! an unknown session → `NOT_FOUND`; bytes that do not decode →
//! `INVALID_ARGUMENT` ([`buridan_proto::codec`]). At most
//! [`ServeConfig::max_sessions`] sessions live at once: a Reset beyond
//! evicts the least recently used one (an actor that crashed never steps
//! its session again; an evicted client gets `NOT_FOUND` and resets).
//!
//! ```no_run
//! use buridan_plant_server::{EnvServer, ServeConfig};
//! let cfg = ServeConfig::load("dissertation", 2, 8, None).unwrap();
//! let server = EnvServer::start(cfg, "127.0.0.1:50061".parse().unwrap()).unwrap();
//! println!("serving on {}", server.url());
//! server.stop().unwrap();
//! ```

#![warn(missing_docs)]

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, MutexGuard};

use buridan_env::{BatchedEnv, EnvError, ObsKind};
use buridan_plant::{Plant, PlantConfig, PlantError, PlantVecEnv, NUM_ACTIONS};
use buridan_proto::env_convert::{
    check_actions, ended, finished_episode, reset_reply, spec_to_message, step_reply, EnvSpec,
};
use buridan_proto::v1;
use buridan_proto::v1::environment_server::{Environment, EnvironmentServer};
use buridan_serving::{serve_with_grace, ServerError, ServerThread};
use tonic::{Request, Response, Status};

/// Sessions kept by default.
pub const DEFAULT_MAX_SESSIONS: usize = 64;

/// Largest message accepted or sent (a step of 1,024 envs of 8 AGVs is
/// well under 1 MB).
pub const MAX_MESSAGE_BYTES: usize = 16 * 1024 * 1024;

/// Why the server could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The plant file cannot be loaded.
    #[error(transparent)]
    Plant(#[from] PlantError),
    /// The plant envs cannot be built as configured (too many AGVs for the
    /// plant's starts, no envs, a batch too large to serve).
    #[error("cannot serve the plant as configured")]
    Env(#[source] EnvError),
    /// The server could not start or failed (runtime, address,
    /// transport).
    #[error(transparent)]
    Server(#[from] ServerError),
}

/// What the server serves: a plant, the batch's shape, the session limit.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// The plant (its `episode.t_max` is the episodes' length).
    pub plant: Arc<Plant>,
    /// The spec's name: `plant:ID` as `learner train --plant ID` labels the run.
    pub name: String,
    /// AGVs per env.
    pub agents: usize,
    /// Envs per session.
    pub envs: usize,
    /// One observation row per AGV (CTDE) or per env (CTE).
    pub kind: ObsKind,
    /// Observations scaled to about [0, 1], as `learner train --plant`
    /// trains on them (raw physical units if false).
    pub normalize: bool,
    /// Sessions kept at once; a Reset beyond evicts the least recently used.
    pub max_sessions: usize,
}

impl ServeConfig {
    /// The plant `plant` (a bundled id or a plant file) with `agents` AGVs
    /// and `envs` envs per session, local normalised observations, its
    /// T_max replaced by `t_max` if given, [`DEFAULT_MAX_SESSIONS`].
    pub fn load(
        plant: &str,
        agents: usize,
        envs: usize,
        t_max: Option<u32>,
    ) -> Result<Self, PlantError> {
        let mut loaded = Plant::load(plant)?;
        if let Some(t) = t_max {
            loaded.episode.t_max = t;
        }
        Ok(Self {
            plant: Arc::new(loaded),
            name: format!("plant:{plant}"),
            agents,
            envs,
            kind: ObsKind::Local,
            normalize: true,
            max_sessions: DEFAULT_MAX_SESSIONS,
        })
    }

    /// The env configuration of a session seeded `seed`.
    fn plant_config(&self, seed: u64) -> PlantConfig {
        PlantConfig {
            agents: self.agents,
            seed,
            normalize: self.normalize,
            action_slots: NUM_ACTIONS,
        }
    }

    /// A session's batch: the envs a local `PlantVecEnv` with this seed has.
    fn batch(&self, seed: u64) -> Result<PlantVecEnv, EnvError> {
        PlantVecEnv::new(
            self.plant.clone(),
            self.plant_config(seed),
            self.envs,
            self.kind,
        )
    }
}

/// The sessions: id → (last use, batch).
#[derive(Default)]
struct Sessions {
    clock: u64,
    live: HashMap<u64, (u64, Arc<Mutex<PlantVecEnv>>)>,
}

/// The `buridan.v1.Environment` service over plant envs.
pub struct PlantEnvService {
    cfg: ServeConfig,
    spec: EnvSpec,
    sessions: Mutex<Sessions>,
}

/// A lock that survives a panicked holder (a panic in one call must not
/// take every later call down with it).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl PlantEnvService {
    /// The service for `cfg`; fails if its envs cannot be built or the
    /// batch is too large for the API.
    pub fn new(cfg: ServeConfig) -> Result<Self, ServeError> {
        if cfg.max_sessions == 0 {
            return Err(ServeError::Env(EnvError::InvalidConfig(
                "max_sessions must be at least 1".into(),
            )));
        }
        let probe = cfg.batch(0).map_err(ServeError::Env)?;
        let spec = EnvSpec::of(&probe, NUM_ACTIONS, cfg.plant.episode.t_max, &cfg.name);
        buridan_proto::env_convert::spec_from_message(&spec_to_message(&spec))
            .map_err(|e| ServeError::Env(EnvError::InvalidConfig(e.to_string())))?;
        Ok(Self {
            cfg,
            spec,
            sessions: Mutex::new(Sessions::default()),
        })
    }

    /// The spec every session has.
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// Sessions alive now.
    pub fn sessions(&self) -> usize {
        lock(&self.sessions).live.len()
    }

    /// Opens a session seeded `seed`, evicting the least recently used
    /// one at the limit.
    fn open(&self, seed: u64) -> Result<(u64, Arc<Mutex<PlantVecEnv>>), Status> {
        let venv = self.cfg.batch(seed).map_err(|e| {
            tracing::error!("cannot build a session's envs: {e}");
            Status::internal(format!("cannot build the plant envs: {e}"))
        })?;
        let venv = Arc::new(Mutex::new(venv));
        let mut s = lock(&self.sessions);
        if s.live.len() >= self.cfg.max_sessions {
            if let Some((&oldest, _)) = s.live.iter().min_by_key(|(_, (used, _))| *used) {
                s.live.remove(&oldest);
                tracing::warn!(
                    session = oldest,
                    max_sessions = self.cfg.max_sessions,
                    "session evicted (least recently used) to make room"
                );
            }
        }
        // Random ids, not a counter: after a restart a stale client's id
        // must get NOT_FOUND, not step a session another client just opened.
        let id = loop {
            let id = rand::random::<u64>();
            if id != 0 && !s.live.contains_key(&id) {
                break id;
            }
        };
        s.clock += 1;
        let now = s.clock;
        s.live.insert(id, (now, venv.clone()));
        Ok((id, venv))
    }

    /// The batch of session `id`, marked as used now.
    fn session(&self, id: u64) -> Result<Arc<Mutex<PlantVecEnv>>, Status> {
        if id == 0 {
            return Err(Status::failed_precondition(
                "step before reset: no session given (session 0); call Reset first for a session",
            ));
        }
        let mut s = lock(&self.sessions);
        s.clock += 1;
        let now = s.clock;
        match s.live.get_mut(&id) {
            Some((used, venv)) => {
                *used = now;
                Ok(venv.clone())
            }
            None => Err(Status::not_found(format!(
                "unknown session {id}: call Reset for a new one (sessions end when the server \
                 restarts, and the least recently used is evicted beyond {} sessions)",
                self.cfg.max_sessions
            ))),
        }
    }

    /// Checks the actions and steps the session's batch.
    fn step_session(&self, req: v1::StepRequest) -> Result<v1::StepReply, Status> {
        let batch = self.session(req.session)?;
        check_actions(&self.spec, &req.actions).map_err(|e| {
            Status::invalid_argument(format!(
                "{e} ({} envs x {} agents, env-major; actions 0 hold, 1 forward, 2 backward)",
                self.spec.num_envs, self.spec.agents
            ))
        })?;
        let mut venv = lock(&batch);
        venv.step(&req.actions).map_err(|e| {
            // The actions were checked: a refusal here is the server's bug.
            tracing::error!(
                session = req.session,
                "the plant refused a checked step: {e}"
            );
            Status::internal(format!("the plant refused the step: {e}"))
        })?;
        let stats = venv.drain_episodes();
        let kpis = venv.drain_kpis();
        let episodes = ended(venv.terminated(), venv.truncated())
            .zip(stats.iter().zip(&kpis))
            .map(|(env, (s, k))| finished_episode(env, s, k.named()))
            .collect::<Vec<_>>();
        if !episodes.is_empty() {
            tracing::debug!(
                session = req.session,
                episodes = episodes.len(),
                "episodes finished"
            );
        }
        Ok(step_reply(&*venv, episodes))
    }
}

#[tonic::async_trait]
impl Environment for PlantEnvService {
    async fn spec(
        &self,
        _request: Request<v1::SpecRequest>,
    ) -> Result<Response<v1::EnvSpec>, Status> {
        Ok(Response::new(spec_to_message(&self.spec)))
    }

    async fn reset(
        &self,
        request: Request<v1::ResetRequest>,
    ) -> Result<Response<v1::ResetReply>, Status> {
        let seed = request.into_inner().seed;
        let (session, batch) = self.open(seed)?;
        tracing::info!(session, seed, "session opened");
        let reply = reset_reply(session, &*lock(&batch));
        Ok(Response::new(reply))
    }

    async fn step(
        &self,
        request: Request<v1::StepRequest>,
    ) -> Result<Response<v1::StepReply>, Status> {
        let req = request.into_inner();
        let session = req.session;
        self.step_session(req)
            .map(Response::new)
            .inspect_err(|status| {
                if status.code() != tonic::Code::Internal {
                    tracing::warn!(session, code = ?status.code(), "step refused: {}", status.message());
                }
            })
    }
}

/// How long open connections get to wind down after the shutdown signal
/// before they are cut (a client whose runtime is idle between steps never
/// answers a graceful close).
pub const SHUTDOWN_GRACE: std::time::Duration = std::time::Duration::from_millis(500);

/// Serves `service` on `listener` until `shutdown` completes, then gives
/// open connections [`SHUTDOWN_GRACE`] to close before cutting them.
pub async fn serve(
    service: PlantEnvService,
    listener: tokio::net::TcpListener,
    shutdown: impl std::future::Future<Output = ()> + Send,
) -> Result<(), ServeError> {
    let router = tonic::transport::Server::builder().add_service(
        EnvironmentServer::new(service)
            .max_decoding_message_size(MAX_MESSAGE_BYTES)
            .max_encoding_message_size(MAX_MESSAGE_BYTES),
    );
    // Every step is a small request answered at once: no Nagle delay.
    let incoming = buridan_serving::nodelay(listener);
    serve_with_grace(
        |stopping| router.serve_with_incoming_shutdown(incoming, stopping.wait()),
        shutdown,
        SHUTDOWN_GRACE,
    )
    .await
    .map_err(|e| ServerError::Transport(e).into())
}

/// A server running on its own thread (one tokio worker), stopped by
/// [`EnvServer::stop`] or when dropped.
pub struct EnvServer(ServerThread<ServeError>);

impl EnvServer {
    /// Binds `addr` (port 0: any free port) and serves `cfg` on a thread.
    pub fn start(cfg: ServeConfig, addr: SocketAddr) -> Result<Self, ServeError> {
        let service = PlantEnvService::new(cfg)?;
        ServerThread::spawn("plant env server", addr, |listener, stop| {
            serve(service, listener, stop)
        })
        .map(Self)
    }

    /// The bound address.
    pub fn addr(&self) -> SocketAddr {
        self.0.addr()
    }

    /// `http://ADDR`, what `actor --env` takes.
    pub fn url(&self) -> String {
        self.0.url()
    }

    /// Stops serving (open connections are closed) and waits for the
    /// thread; the server's own error, if it failed.
    pub fn stop(self) -> Result<(), ServeError> {
        self.0.stop()
    }
}
