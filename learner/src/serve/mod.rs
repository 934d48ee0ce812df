//! `learner serve`: the learner as a gRPC server that actor processes join.
//!
//! ```text
//! actor process ──Join──────────────▶ LearnerService ─▶ Hub (run info, sessions)
//!               ◀─WatchParameters──── Hub::publish ◀── learner loop (Run::learn)
//!               ──SubmitFragment───▶ checks ─▶ bounded queue ─▶ RemoteExchange
//! ```
//!
//! The learner loop is the same [`Run::learn`] as in embedded training; only
//! its [`crate::train::Exchange`] differs. One tokio worker thread serves
//! gRPC, the calling thread learns.
//!
//! Rules for fragments (each outcome is counted in
//! `buridan_fragments_total{outcome}` and logged):
//! - malformed (shapes, NaN/Inf, ranges), wrong run, unknown session,
//!   a policy version newer than the learner's → gRPC error, `invalid`;
//! - a sequence number already seen in the session → `ALREADY_EXISTS`,
//!   `duplicate` (a fragment is never used twice);
//! - PPO: a fragment collected with an older version → refused, `stale`;
//!   one of the current version after its train batch is full → refused,
//!   `surplus`; the reply tells the actor to wait for the next version;
//! - IMPALA: older than `impala.max_policy_lag` versions → refused, `stale`;
//! - otherwise queued (`accepted`); the handler waits while the queue is
//!   full, so actors slow down rather than the learner's memory growing.
//!
//! Hardening:
//! - a well-formed fragment the run's env cannot have produced (a reward
//!   outside [`buridan_env::EnvConfig::step_reward_range`], episode
//!   statistics that contradict the fragment or the rules, a logit not
//!   finite where the mask allows the action) → `INVALID_ARGUMENT` naming
//!   the field, `invalid`, and `buridan_implausible_fragments_total{field}`
//!   ([`plausible`]);
//! - a request whose bytes do not decode → `INVALID_ARGUMENT`, counted in
//!   `buridan_undecodable_messages_total` ([`buridan_proto::codec`]);
//! - observations packed as 2-bit codes or LZ4 (`obs_encoding`, both
//!   offered in the join reply) must decode to exactly the size the
//!   fragment's shape asks for, within the run's largest fragment and
//!   `--max-message-bytes`; a corrupt or oversized buffer →
//!   `INVALID_ARGUMENT` naming the field, `invalid`
//!   ([`buridan_proto::obs_encoding`]);
//! - sessions without a parameter stream expire when idle, and their number
//!   is capped: a join beyond the cap gets `RESOURCE_EXHAUSTED`
//!   ([`sessions`]).

pub mod hub;
pub mod plausible;
pub mod service;
pub mod sessions;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::MapSource;
use buridan_proto::codec::UNDECODABLE_METADATA;
use buridan_proto::convert::{
    env_to_message, map_to_message, model_spec_to_message, replay_to_message,
};
use buridan_proto::v1;
use buridan_proto::v1::learner_server::LearnerServer;
use buridan_serving::{with_tls, BearerToken, ServerError};
use rand::Rng;
use tokio::io::DuplexStream;
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Server;

use crate::train::{env_config, Progress, Run, Summary, TrainConfig, TrainError};
pub use hub::{Hub, RemoteExchange, RunInfo};
pub use plausible::{Implausible, Plausibility};
pub use sessions::{
    LimitsError, SessionLimits, DEFAULT_IDLE_TIMEOUT, DEFAULT_MAX_SESSIONS, MAX_IDLE_TIMEOUT,
    MAX_SESSIONS_LIMIT,
};

impl From<TrainError> for ServeError {
    fn from(e: TrainError) -> Self {
        ServeError::Train(Box::new(e))
    }
}

/// Why `learner serve` could not serve its run.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The run itself failed (boxed: a run's errors are large, serve's
    /// own small).
    #[error(transparent)]
    Train(Box<TrainError>),
    /// The gRPC server could not start (runtime, address, TLS).
    #[error(transparent)]
    Server(#[from] ServerError),
    /// An empty token would accept everyone.
    #[error("an empty --token would accept everyone; leave it out instead")]
    EmptyToken,
    /// The session limits are zero or absurd.
    #[error(transparent)]
    SessionLimits(#[from] LimitsError),
    /// The run trains on several layouts, which remote actors cannot run yet.
    #[error("this run trains on several layouts ({0}); remote actors receive one map, so train it embedded with `learner train`")]
    SeveralLayouts(String),
}
pub use service::LearnerService;

/// Largest message accepted by default (a fragment of 64 envs × 4 agents ×
/// 50 steps of 129 floats is about 7 MB).
pub const DEFAULT_MAX_MESSAGE_BYTES: usize = 64 * 1024 * 1024;

/// HTTP/2 flow-control window per stream (bytes).
pub const FLOW_WINDOW: u32 = 8 * 1024 * 1024;

/// Server settings beyond the run's config.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// If set, every call must carry `authorization: Bearer <token>`.
    pub token: Option<String>,
    /// PEM certificate and key: serve TLS (rustls) instead of plain HTTP/2.
    pub tls: Option<(PathBuf, PathBuf)>,
    /// Largest message accepted; larger ones get `OUT_OF_RANGE`.
    pub max_message_bytes: usize,
    /// Largest `--envs` an actor may ask for.
    pub max_envs: u32,
    /// Fragments the learner queue holds (0: as embedded training,
    /// [`TrainConfig::queue_capacity`], at least 2).
    pub queue_capacity: usize,
    /// How long to keep serving after the last update, so actors hear
    /// that the run is finished.
    pub linger: Duration,
    /// Once set, the learner checkpoints and stops without telling actors
    /// the run is over (they reconnect to the restarted learner).
    pub interrupt: Option<Arc<AtomicBool>>,
    /// How long a session without a parameter stream may stay idle, and how
    /// many sessions may be open ([`sessions`]); checked by
    /// [`SessionLimits::check`].
    pub sessions: SessionLimits,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self {
            token: None,
            tls: None,
            max_message_bytes: DEFAULT_MAX_MESSAGE_BYTES,
            max_envs: 256,
            queue_capacity: 0,
            linger: Duration::from_millis(500),
            interrupt: None,
            sessions: SessionLimits::default(),
        }
    }
}

/// Where the server takes its connections from.
pub enum Listener {
    /// A TCP address.
    Tcp(SocketAddr),
    /// In-memory connections (tests): each item is the server's end of a
    /// `tokio::io::duplex` pair.
    InMemory(mpsc::Receiver<DuplexStream>),
}

/// Serves the run `cfg` until it has trained `cfg.steps` env steps, then
/// writes the same outputs as [`crate::train::train`] into `out`. `ready`
/// (if any) receives the bound address once the server accepts calls.
pub fn serve(
    cfg: &TrainConfig,
    out: &Path,
    opts: &ServeOptions,
    listener: Listener,
    ready: Option<std::sync::mpsc::Sender<Option<SocketAddr>>>,
    progress: &mut dyn Progress,
) -> Result<Summary, ServeError> {
    // The join reply carries one map: refuse before preparing anything. A
    // plant run's join reply carries no map: its actors step an external
    // env (`actor --env URL`, e.g. `plant-server`).
    if cfg.task.maps().is_some_and(|m| m.len() > 1) {
        return Err(ServeError::SeveralLayouts(cfg.map_label()));
    }
    opts.sessions.check()?;
    let mut run = Run::prepare(cfg, out)?;
    if let Some(flag) = &opts.interrupt {
        run.interrupt_on(flag.clone());
    }
    let info = run_info(&run, opts)?;
    let capacity = if opts.queue_capacity > 0 {
        opts.queue_capacity
    } else {
        cfg.queue_capacity().max(2)
    };
    let plausibility = plausibility(&run, &info);
    let (hub, rx) = Hub::new(info, capacity, opts.sessions, plausibility);
    let wanted = cfg.on_policy().then_some(cfg.train_batch());
    hub.publish(&run.weights()?, wanted);

    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .thread_name("grpc")
        .enable_all()
        .build()
        .map_err(ServerError::Runtime)?;
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server = match listener {
        Listener::Tcp(addr) => {
            let bind_failed = |source| ServerError::Bind { addr, source };
            let tcp = runtime
                .block_on(tokio::net::TcpListener::bind(addr))
                .map_err(bind_failed)?;
            let bound = tcp.local_addr().map_err(bind_failed)?;
            tracing::info!(%bound, run_id = %hub.info.run_id, "learner serving");
            if let Some(r) = &ready {
                let _ = r.send(Some(bound));
            }
            // Replies are small: without TCP_NODELAY they wait for Nagle.
            let incoming = buridan_serving::nodelay(tcp);
            spawn_server(&runtime, hub.clone(), opts, incoming, stop_rx)?
        }
        Listener::InMemory(rx) => {
            if let Some(r) = &ready {
                let _ = r.send(None);
            }
            let incoming = ReceiverStream::new(rx);
            let incoming = tokio_stream::StreamExt::map(incoming, Ok::<_, std::io::Error>);
            spawn_server(&runtime, hub.clone(), opts, incoming, stop_rx)?
        }
    };
    runtime.spawn(hub.clone().expire_idle_sessions());
    let mut exchange = RemoteExchange::new(hub.clone(), rx, runtime.handle().clone());
    let result = run.learn(&mut exchange, progress);
    // Let the actors hear that the run is over, then stop serving.
    if result.is_ok() {
        std::thread::sleep(opts.linger);
    }
    let _ = stop_tx.send(());
    let served =
        runtime.block_on(async { tokio::time::timeout(Duration::from_secs(2), server).await });
    runtime.shutdown_timeout(Duration::from_secs(1));
    let c = &hub.counters;
    tracing::info!(
        accepted = c.accepted.load(std::sync::atomic::Ordering::Relaxed),
        stale = c.stale.load(std::sync::atomic::Ordering::Relaxed),
        surplus = c.surplus.load(std::sync::atomic::Ordering::Relaxed),
        invalid = c.invalid.load(std::sync::atomic::Ordering::Relaxed),
        duplicate = c.duplicate.load(std::sync::atomic::Ordering::Relaxed),
        "fragments"
    );
    let summary = result?;
    if let Ok(Ok(Err(e))) = served {
        tracing::warn!("gRPC server ended with an error: {e}");
    }
    Ok(summary)
}

/// What the run's env can produce, for the fragment checks: its rules on
/// its maps (any reachable goal distance is below a map's free cells; a
/// mixture's largest map bounds them all), or the plant's reward model.
fn plausibility(run: &Run, info: &RunInfo) -> Plausibility {
    let cfg = run.config();
    if run.plant().is_some() {
        return Plausibility::plant(
            buridan_plant::env::step_reward_range(),
            cfg.agents as u32,
            cfg.t_max,
            info.rows_per_env,
        );
    }
    let max_goal_distance = run
        .layouts()
        .iter()
        .map(|layout| layout.0.grid.free_cells().len().saturating_sub(1))
        .max()
        .unwrap_or(0);
    Plausibility::new(
        &env_config(cfg, 0),
        u32::try_from(max_goal_distance).unwrap_or(u32::MAX),
        info.rows_per_env,
        cfg.layouts().len() as u32,
    )
}

fn run_info(run: &Run, opts: &ServeOptions) -> Result<RunInfo, TrainError> {
    let cfg = run.config();
    let spec = run.spec();
    let (map, env, plant) = if run.plant().is_some() {
        let plant = v1::PlantSettings {
            name: cfg.map_label(),
            agents: cfg.agents as u32,
            t_max: cfg.t_max,
        };
        (None, None, Some(plant))
    } else {
        let map = MapSource::read(&cfg.layouts()[0].name)?;
        (
            Some(map_to_message(&map)),
            Some(env_to_message(&env_config(cfg, 0))),
            None,
        )
    };
    let name = run
        .map()
        .map_or_else(|| cfg.map_label(), |m| m.name.clone());
    let run_id = format!("{name}-{:016x}", rand::rng().random::<u64>());
    Ok(RunInfo {
        run_id,
        spec: v1::RunSpec {
            model: Some(model_spec_to_message(spec)),
            map,
            env,
            plant,
            fragment_len: cfg.run.fragment_len as u32,
            on_policy: cfg.on_policy(),
            // PPO's actors never lag; they get IMPALA's default, as before.
            max_policy_lag: cfg
                .algorithm
                .impala()
                .map_or(crate::train::ImpalaConfig::default().max_policy_lag, |i| {
                    i.max_policy_lag
                }),
            greedy_mix: cfg.behaviour().greedy_mix(),
            shield_rollouts: cfg.shield_rollouts,
            replay: replay_to_message(&cfg.replay),
            obs_encodings: vec![v1::ObsEncoding::Codes as i32, v1::ObsEncoding::Lz4 as i32],
        },
        envs_per_actor: cfg.run.envs_per_actor as u32,
        max_envs: opts.max_envs.max(cfg.run.envs_per_actor as u32),
        seed_base: run.actor_seed(0),
        obs_dim: spec.obs_dim as u32,
        heads: spec.heads as u32,
        actions_per_head: spec.actions as u32,
        rows_per_env: cfg.mode.obs_kind().rows_per_env(cfg.agents) as u32,
    })
}

/// Counts every gRPC error status the server sends (whether from a
/// handler or from tonic itself, e.g. an oversized message) by code, and
/// requests that did not decode ([`buridan_proto::codec`] marks them) in
/// `buridan_undecodable_messages_total`; the mark is not sent on.
fn count_status(mut resp: http::Response<tonic::body::Body>) -> http::Response<tonic::body::Body> {
    if resp.headers_mut().remove(UNDECODABLE_METADATA).is_some() {
        ::metrics::counter!("buridan_undecodable_messages_total").increment(1);
        // The header carries the message percent-encoded; tonic decodes it.
        let status = tonic::Status::from_header_map(resp.headers());
        tracing::warn!(
            message = status.as_ref().map_or("", |s| s.message()),
            "undecodable request refused"
        );
    }
    if let Some(code) = resp
        .headers()
        .get("grpc-status")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<i32>().ok())
    {
        if code != 0 {
            let name = format!("{:?}", tonic::Code::from_i32(code));
            ::metrics::counter!("buridan_rpc_errors_total", "code" => name).increment(1);
        }
    }
    resp
}

/// Starts the gRPC server on `runtime` over `incoming` until `shutdown`.
fn spawn_server<I, IO, IE>(
    runtime: &tokio::runtime::Runtime,
    hub: Arc<Hub>,
    opts: &ServeOptions,
    incoming: I,
    shutdown: tokio::sync::oneshot::Receiver<()>,
) -> Result<tokio::task::JoinHandle<Result<(), tonic::transport::Error>>, ServeError>
where
    I: tokio_stream::Stream<Item = Result<IO, IE>> + Send + 'static,
    IO: tokio::io::AsyncRead
        + tokio::io::AsyncWrite
        + tonic::transport::server::Connected
        + Unpin
        + Send
        + 'static,
    IO::ConnectInfo: Clone + Send + Sync + 'static,
    IE: Into<Box<dyn std::error::Error + Send + Sync>> + Send + 'static,
{
    // Fragments are megabytes: windows sized for them save round trips.
    let builder = Server::builder()
        .initial_stream_window_size(Some(FLOW_WINDOW))
        .initial_connection_window_size(Some(2 * FLOW_WINDOW));
    let builder = with_tls(builder, opts.tls.as_ref()).map_err(ServerError::Tls)?;
    let service =
        LearnerServer::new(LearnerService::new(hub).max_decoded_bytes(opts.max_message_bytes))
            .max_decoding_message_size(opts.max_message_bytes)
            .max_encoding_message_size(opts.max_message_bytes);
    if opts.token.as_deref() == Some("") {
        return Err(ServeError::EmptyToken);
    }
    let check = BearerToken::new(
        opts.token.as_deref(),
        "this learner needs a token: pass --token (authorization: Bearer …)",
    );
    let (health_reporter, health) = tonic_health::server::health_reporter();
    runtime.block_on(health_reporter.set_serving::<LearnerServer<LearnerService>>());
    let layer: fn(http::Response<tonic::body::Body>) -> http::Response<tonic::body::Body> =
        count_status;
    let router = builder
        .layer(tower::util::MapResponseLayer::new(layer))
        .add_service(health)
        .add_service(InterceptedService::new(service, check));
    Ok(
        runtime.spawn(router.serve_with_incoming_shutdown(incoming, async {
            let _ = shutdown.await;
        })),
    )
}
