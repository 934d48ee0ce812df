//! The stateless gRPC actor: join the learner, take its config and
//! weights, collect and submit fragments; on any connection loss, back
//! off and join again from scratch (nothing is kept across sessions).
//!
//! ```text
//! connect ─▶ Join ─▶ build envs + policy ─▶ WatchParameters (task) ─┐
//!   ▲                                                                ▼
//!   └── backoff ◀── error ── SubmitFragment ◀── collect ◀── load newest weights
//! ```
//!
//! A fragment whose submission fails is dropped, never resent: the learner
//! uses each fragment at most once and never in part.
//!
//! With [`ActorOptions::env`] (`actor --env URL`) the envs are a
//! [`RemoteEnv`] on an external env server instead of the join reply's
//! grid map: the actor reads the server's spec before joining (it joins
//! with the server's env count), checks it against the run's model
//! ([`check_env_spec`]), and when the server goes away mid-fragment it
//! drops the fragment, warns, and reopens a session on the server with
//! backoff while its learner session stays open.
mod error;
mod setup;
mod submit;

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::error::error_chain;
use buridan_env::EnvError;
use buridan_policy::Weights;
use buridan_proto::convert::weights_from_message;
use buridan_proto::v1;
use buridan_proto::v1::learner_client::LearnerClient;
use buridan_proto::v1::ObsEncoding;
use rand::Rng;
use tokio::sync::watch;
use tonic::metadata::MetadataValue;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;
use tonic::{Code, Request, Status};

pub use error::{ActorError, ConnectError, SetupError};
pub use setup::{build_collector, build_remote_collector, check_env_spec, run_spec};
pub use submit::obs_encoding_for;

use crate::collector::CollectError;
use crate::remote_env::RemoteEnvOptions;
use setup::{fetch_env_spec, open_remote, reconnect_env};
use submit::Submitter;

/// Makes a fresh channel to the learner (TCP, TLS or in-memory).
pub type Connector = Arc<
    dyn Fn() -> Pin<Box<dyn Future<Output = Result<Channel, ConnectError>> + Send>> + Send + Sync,
>;

/// A connector for a URL (`http://host:port`, or `https://…` with `tls_ca`).
///
/// ```
/// let c = buridan_actor::client::url_connector("http://127.0.0.1:50051", None).unwrap();
/// # let _ = c;
/// assert!(buridan_actor::client::url_connector("not a url", None).is_err());
/// ```
pub fn url_connector(url: &str, tls_ca: Option<&std::path::Path>) -> Result<Connector, ActorError> {
    let bad_url = || ActorError::Url {
        url: url.to_string(),
    };
    let uri: tonic::codegen::http::Uri = url.parse().map_err(|_| bad_url())?;
    if !matches!(uri.scheme_str(), Some("http" | "https")) || uri.authority().is_none() {
        return Err(bad_url());
    }
    let mut endpoint = Channel::from_shared(url.to_string())
        .map_err(|_| bad_url())?
        .connect_timeout(Duration::from_secs(5))
        .tcp_nodelay(true)
        // Fragments are megabytes: windows sized for them save round trips.
        .initial_stream_window_size(8 * 1024 * 1024)
        .initial_connection_window_size(16 * 1024 * 1024)
        .http2_keep_alive_interval(Duration::from_secs(10))
        .keep_alive_timeout(Duration::from_secs(20));
    if let Some(path) = tls_ca {
        let pem = std::fs::read(path).map_err(|source| ActorError::CaFile {
            path: path.to_path_buf(),
            source,
        })?;
        endpoint = endpoint
            .tls_config(
                tonic::transport::ClientTlsConfig::new()
                    .ca_certificate(tonic::transport::Certificate::from_pem(pem)),
            )
            .map_err(ActorError::Tls)?;
    }
    Ok(Arc::new(move || {
        let endpoint = endpoint.clone();
        Box::pin(async move {
            endpoint.connect().await.map_err(|e| ConnectError {
                target: endpoint.uri().to_string(),
                source: Box::new(e),
            })
        })
    }))
}

/// How an actor behaves.
#[derive(Debug, Clone)]
pub struct ActorOptions {
    /// Name reported to the learner (logs).
    pub name: String,
    /// Envs to run; `None`: the run's default.
    pub envs: Option<u32>,
    /// Shared token, if the learner requires one.
    pub token: Option<String>,
    /// Largest message sent or received.
    pub max_message_bytes: usize,
    /// First reconnect delay; doubles up to `backoff_max`.
    pub backoff_initial: Duration,
    /// Longest reconnect delay.
    pub backoff_max: Duration,
    /// Give up after this long without a session (`None`: never).
    pub give_up_after: Option<Duration>,
    /// URL of an external env server (`env.proto`, e.g. `plant-server`) to
    /// step instead of building envs from the join reply (`actor --env`).
    pub env: Option<String>,
    /// How to talk to the env server.
    pub env_options: RemoteEnvOptions,
    /// How to send observations when the learner accepts it
    /// (`actor --obs-encoding`); [`obs_encoding_for`] falls back to what
    /// the learner lists. Packing costs less CPU than moving the raw bytes
    /// through HTTP/2, and 2-bit codes less than LZ4
    /// (docs/results/transport/).
    pub obs_encoding: ObsEncoding,
}

impl Default for ActorOptions {
    fn default() -> Self {
        Self {
            name: "actor".into(),
            envs: None,
            token: None,
            max_message_bytes: 64 * 1024 * 1024,
            backoff_initial: Duration::from_millis(200),
            backoff_max: Duration::from_secs(5),
            give_up_after: None,
            env: None,
            env_options: RemoteEnvOptions::default(),
            obs_encoding: ObsEncoding::Codes,
        }
    }
}

/// What an actor did before it stopped.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ActorReport {
    /// Sessions opened (1 + reconnects).
    pub sessions: u64,
    /// Fragments the learner queued.
    pub accepted: u64,
    /// Fragments the learner refused as stale or surplus.
    pub refused: u64,
    /// Fragments lost with a failed connection.
    pub lost: u64,
    /// Env steps collected.
    pub env_steps: u64,
    /// Times the external env server failed mid-fragment and a new env
    /// session was opened (`--env` only).
    pub env_reconnects: u64,
}

/// Why a session ended.
enum SessionEnd {
    /// The learner says the run is over.
    Finished,
    /// The connection or the learner went away: join again.
    Lost(ActorError),
}

type Client = LearnerClient<InterceptedService<Channel, TokenInterceptor>>;

/// Adds the shared token to every call.
#[derive(Clone)]
pub struct TokenInterceptor {
    value: Option<MetadataValue<tonic::metadata::Ascii>>,
}

impl tonic::service::Interceptor for TokenInterceptor {
    fn call(&mut self, mut req: Request<()>) -> Result<Request<()>, Status> {
        if let Some(v) = &self.value {
            req.metadata_mut().insert("authorization", v.clone());
        }
        Ok(req)
    }
}

/// Runs an actor until the learner finishes the run (`Ok`), or until
/// `give_up_after` passes without a session or a session fails in a way
/// retrying cannot fix (`Err`).
pub async fn run(connect: Connector, opts: ActorOptions) -> Result<ActorReport, ActorError> {
    let interceptor = TokenInterceptor {
        value: match &opts.token {
            Some(t) => Some(
                format!("Bearer {t}")
                    .parse()
                    .map_err(|_| ActorError::Token)?,
            ),
            None => None,
        },
    };
    let mut report = ActorReport::default();
    let mut delay = opts.backoff_initial;
    let mut since_session = tokio::time::Instant::now();
    loop {
        let attempt = async {
            let channel = connect().await?;
            let client = LearnerClient::with_interceptor(channel, interceptor.clone())
                .max_decoding_message_size(opts.max_message_bytes)
                .max_encoding_message_size(opts.max_message_bytes);
            session(client, &opts, &mut report, &mut since_session, &mut delay).await
        };
        match attempt.await {
            Ok(SessionEnd::Finished) => {
                tracing::info!(?report, "the learner finished the run");
                return Ok(report);
            }
            Ok(SessionEnd::Lost(e)) | Err(e @ ActorError::Connect(_)) => {
                if let Some(limit) = opts.give_up_after {
                    if since_session.elapsed() > limit {
                        return Err(ActorError::GaveUp {
                            limit,
                            source: Box::new(e),
                        });
                    }
                }
                let jitter = rand::rng().random_range(0.8..1.2);
                let wait = delay.mul_f64(jitter);
                tracing::warn!("{}; reconnecting in {wait:.1?}", error_chain(&e));
                tokio::time::sleep(wait).await;
                delay = (delay * 2).min(opts.backoff_max);
            }
            Err(e) => return Err(e),
        }
    }
}

/// Whether a status means "join again" rather than "this actor is broken".
/// `RESOURCE_EXHAUSTED` is the learner's session cap (`--max-sessions`):
/// full now, with room once another actor leaves or idles out.
fn retryable(status: &Status) -> bool {
    matches!(
        status.code(),
        Code::Unavailable
            | Code::ResourceExhausted
            | Code::NotFound
            | Code::Cancelled
            | Code::Unknown
            | Code::Aborted
            | Code::DeadlineExceeded
            | Code::Internal
    )
}

/// What a join led to.
enum Joined {
    /// A session of a running run (boxed: a join reply is large).
    Run(Box<v1::JoinReply>),
    /// No session: see why.
    Ended(SessionEnd),
}

/// One session: join, follow the weights, collect and submit fragments
/// until the run ends or the connection is lost.
async fn session(
    mut client: Client,
    opts: &ActorOptions,
    report: &mut ActorReport,
    since_session: &mut tokio::time::Instant,
    delay: &mut Duration,
) -> Result<SessionEnd, ActorError> {
    // An env server decides the batch: join with its env count.
    let env_spec = match &opts.env {
        None => None,
        Some(url) => match fetch_env_spec(url, opts).await {
            Ok(spec) => Some(spec),
            Err(e) if e.retryable() => return Ok(SessionEnd::Lost(ActorError::Setup(e.into()))),
            Err(e) => return Err(ActorError::Setup(e.into())),
        },
    };
    let envs = env_spec.as_ref().map(|s| s.num_envs as u32).or(opts.envs);
    let join = match join(&mut client, opts, envs).await? {
        Joined::Run(reply) => *reply,
        Joined::Ended(end) => return Ok(end),
    };
    report.sessions += 1;
    *since_session = tokio::time::Instant::now();
    *delay = opts.backoff_initial;
    let mut collector = match &opts.env {
        None => build_collector(&join)?,
        Some(url) => match open_remote(&join, url, opts, 0).await {
            Ok(c) => c,
            Err(e) if e.retryable() => return Ok(SessionEnd::Lost(ActorError::Setup(e))),
            Err(e) => return Err(ActorError::Setup(e)),
        },
    };
    tracing::info!(
        run = %join.run_id,
        session = join.session,
        actor = join.actor_id,
        envs = join.envs,
        env = opts.env.as_deref().unwrap_or("built in"),
        "joined"
    );
    let (mut latest, _watcher) = match watch_weights(&mut client, &join).await {
        Ok(watch) => watch,
        Err(end) => return Ok(end),
    };
    // Env sessions opened on the env server in this learner session.
    let mut env_attempt = 0u64;
    let (run, _) = run_spec(&join).map_err(ActorError::Setup)?;
    let mut submitter = Submitter::new(client, &join, run, opts.obs_encoding);
    // On-policy: after a full batch, wait for a version newer than this.
    let mut wait_after: Option<u64> = None;
    loop {
        let weights = match newest_weights(&mut latest, wait_after).await {
            Ok(w) => w,
            Err(end) => return Ok(end),
        };
        wait_after = None;
        collector.load(&weights).map_err(ActorError::Weights)?;
        let (back, fragment) = tokio::task::spawn_blocking(move || {
            let f = collector.collect();
            (collector, f)
        })
        .await
        .map_err(|_| ActorError::Panicked("collector"))?;
        collector = back;
        let fragment = match fragment {
            Ok(f) => f,
            Err(CollectError::Env(EnvError::Remote {
                retryable: true,
                target,
                message,
            })) => {
                // The simulator went away mid-fragment: drop the fragment
                // (never sent in part), keep the learner session, and open
                // a new env session once the server is back.
                report.env_reconnects += 1;
                tracing::warn!(env = %target, "the env server failed: {message}; reconnecting");
                let url = opts.env.as_deref().unwrap_or(&target);
                collector =
                    match reconnect_env(&join, url, opts, &mut env_attempt, &mut latest).await? {
                        Ok(c) => c,
                        Err(end) => return Ok(end),
                    };
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        report.env_steps += fragment.env_steps;
        if let Some(end) = submitter.submit(fragment, report, &mut wait_after).await? {
            return Ok(end);
        }
    }
}

/// Joins the run asking for `envs` envs (`None`: the run's default); a
/// finished run is an answer, not an error.
async fn join(
    client: &mut Client,
    opts: &ActorOptions,
    envs: Option<u32>,
) -> Result<Joined, ActorError> {
    let reply = client
        .join(v1::JoinRequest {
            api_version: v1::ApiVersion::V2 as u32,
            actor_name: opts.name.clone(),
            envs: envs.unwrap_or(0),
        })
        .await;
    match reply {
        Ok(r) if r.get_ref().run_finished => Ok(Joined::Ended(SessionEnd::Finished)),
        Ok(r) => Ok(Joined::Run(Box::new(r.into_inner()))),
        Err(source) if retryable(&source) => Ok(Joined::Ended(SessionEnd::Lost(ActorError::Rpc {
            call: "join",
            source,
        }))),
        Err(s) => Err(ActorError::Refused(s)),
    }
}

/// The newest weights, pushed by the learner, in a watch channel fed by a
/// task (aborted when the returned guard drops).
async fn watch_weights(
    client: &mut Client,
    join: &v1::JoinReply,
) -> Result<(watch::Receiver<Option<Update>>, AbortOnDrop), SessionEnd> {
    let mut stream = client
        .watch_parameters(v1::WatchRequest {
            run_id: join.run_id.clone(),
            session: join.session,
        })
        .await
        .map_err(|source| {
            SessionEnd::Lost(ActorError::Rpc {
                call: "watch parameters",
                source,
            })
        })?
        .into_inner();
    let (latest_tx, latest) = watch::channel::<Option<Update>>(None);
    let watcher = tokio::spawn(async move {
        loop {
            let update = match stream.message().await {
                Ok(Some(p)) if p.finished => Update::Finished,
                Ok(Some(p)) => match weights_from_message(p) {
                    Ok(w) => Update::Weights(Arc::new(w)),
                    Err(e) => Update::Lost(format!("bad weights: {e}")),
                },
                Ok(None) => Update::Lost("the stream ended".into()),
                Err(s) => Update::Lost(s.to_string()),
            };
            let last = !matches!(update, Update::Weights(_));
            if latest_tx.send(Some(update)).is_err() || last {
                return;
            }
        }
    });
    Ok((latest, AbortOnDrop(watcher)))
}

/// Waits for weights to collect with: the newest, or (on-policy, after a
/// full batch) the first newer than `wait_after`.
async fn newest_weights(
    latest: &mut watch::Receiver<Option<Update>>,
    wait_after: Option<u64>,
) -> Result<Arc<Weights>, SessionEnd> {
    loop {
        let current = latest.borrow_and_update().clone();
        match current {
            Some(Update::Finished) => return Err(SessionEnd::Finished),
            Some(Update::Lost(why)) => return Err(SessionEnd::Lost(ActorError::Stream(why))),
            Some(Update::Weights(w)) if wait_after.is_none_or(|v| w.version > v) => return Ok(w),
            _ => {
                if latest.changed().await.is_err() {
                    return Err(SessionEnd::Lost(ActorError::Stream("closed".into())));
                }
            }
        }
    }
}
#[derive(Clone)]
enum Update {
    Weights(Arc<Weights>),
    Finished,
    Lost(String),
}

struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}
