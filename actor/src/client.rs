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

use std::future::Future;
use std::path::PathBuf;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::error::error_chain;
use buridan_env::{BatchedEnv, EnvError, MapError, VecEnv};
use buridan_policy::{ActMode, Inference, ModelSpec, Policy, PolicyError, Weights};
use buridan_proto::convert::{
    env_from_message, fragment_to_message_encoded, map_from_message, replay_from_message,
    weights_from_message, ConvertError, WireTag,
};
use buridan_proto::v1;
use buridan_proto::v1::learner_client::LearnerClient;
use buridan_proto::v1::ObsEncoding;
use rand::Rng;
use tokio::sync::watch;
use tonic::metadata::MetadataValue;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;
use tonic::{Code, Request, Status};

use crate::collector::{ActorEnv, CollectError, Collector};
use crate::remote_env::{RemoteEnv, RemoteEnvError, RemoteEnvOptions};
use crate::shield::RolloutShield;
use buridan_proto::env_convert::EnvSpec;

/// Why an actor stopped (or could not start).
#[derive(Debug, thiserror::Error)]
pub enum ActorError {
    /// The learner URL is not `http(s)://HOST:PORT`.
    #[error("invalid learner URL '{url}': expected http://HOST:PORT or https://HOST:PORT")]
    Url {
        /// The URL given.
        url: String,
    },
    /// The CA certificate cannot be read.
    #[error("cannot read CA certificate {}", path.display())]
    CaFile {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The TLS settings are invalid.
    #[error("invalid TLS configuration")]
    Tls(#[source] tonic::transport::Error),
    /// The token cannot travel in a header.
    #[error("the token must be printable ASCII")]
    Token,
    /// No connection to the learner.
    #[error(transparent)]
    Connect(#[from] ConnectError),
    /// The learner refused this actor for good (not a connection problem).
    #[error("the learner refused this actor")]
    Refused(#[source] Status),
    /// The learner refused a fragment for good (a bug on one side).
    #[error("the learner refused a fragment")]
    FragmentRefused(#[source] Status),
    /// The connection or the learner went away mid-session.
    #[error("{call}")]
    Rpc {
        /// The call that failed.
        call: &'static str,
        /// Its status.
        source: Status,
    },
    /// The parameter stream ended or sent weights that do not load.
    #[error("parameter stream: {0}")]
    Stream(String),
    /// The run the learner described cannot be set up here.
    #[error("cannot set up the run the learner sent")]
    Setup(#[from] SetupError),
    /// Collecting a fragment failed.
    #[error(transparent)]
    Collect(#[from] CollectError),
    /// Loading the learner's weights failed.
    #[error("cannot load the learner's weights")]
    Weights(#[source] PolicyError),
    /// A collector or submit task panicked.
    #[error("the {0} task panicked")]
    Panicked(&'static str),
    /// No session for longer than `give_up_after`.
    #[error("no learner session for {limit:.0?}; giving up")]
    GaveUp {
        /// The limit.
        limit: Duration,
        /// The last failure.
        source: Box<ActorError>,
    },
}

/// A channel to the learner could not be opened.
#[derive(Debug, thiserror::Error)]
#[error("cannot connect to {target}")]
pub struct ConnectError {
    /// Where to.
    pub target: String,
    /// Why not.
    pub source: Box<dyn std::error::Error + Send + Sync>,
}

/// What in a join reply does not describe a run this actor can run.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The model spec is not JSON of a [`ModelSpec`].
    #[error("the model spec is not valid JSON")]
    SpecJson(#[source] serde_json::Error),
    /// The model spec or the policy is inconsistent.
    #[error(transparent)]
    Policy(#[from] PolicyError),
    /// A field is missing or out of range.
    #[error(transparent)]
    Convert(#[from] ConvertError),
    /// The map does not parse.
    #[error(transparent)]
    Map(#[from] MapError),
    /// The envs cannot be built.
    #[error(transparent)]
    Env(#[from] EnvError),
    /// The reply lacks a part.
    #[error("no {0} in the reply")]
    Missing(&'static str),
    /// Env and model disagree.
    #[error("the env's observations have {env} floats, the model expects {model}")]
    ObsDim {
        /// The env's.
        env: usize,
        /// The model's.
        model: usize,
    },
    /// The run trains on a plant whose envs are external, and this actor
    /// has no env server.
    #[error("the run trains on {plant}, whose envs this actor cannot build: start it with --env URL of an env server for that plant (e.g. `plant-server --plant ID --agents {agents}`)")]
    NeedsEnv {
        /// The run's label, `plant:ID`.
        plant: String,
        /// AGVs per env.
        agents: u32,
    },
    /// The external env server cannot be used (boxed: the error is large).
    #[error(transparent)]
    Remote(Box<RemoteEnvError>),
    /// The external env server's spec does not fit the run.
    #[error("the env server '{name}' has {what} {env}, the run {run}")]
    EnvSpec {
        /// The server's spec name.
        name: String,
        /// What differs ("obs_dim", "agents", ...).
        what: &'static str,
        /// The server's value.
        env: String,
        /// The run's value.
        run: String,
    },
}

impl From<RemoteEnvError> for SetupError {
    fn from(e: RemoteEnvError) -> Self {
        SetupError::Remote(Box::new(e))
    }
}

impl SetupError {
    /// Whether joining (or reconnecting to the env server) again may help:
    /// only an env server that cannot be reached right now.
    pub fn retryable(&self) -> bool {
        matches!(self, SetupError::Remote(e) if e.retryable())
    }
}

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
    let mut submitter = Submitter::new(client, &join, opts.obs_encoding);
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
            api_version: v1::ApiVersion::V1 as u32,
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

type SubmitResult = Result<tonic::Response<v1::SubmitReply>, Status>;

/// The observation encoding to send with: the one wanted if the learner
/// lists it, else the cheaper packing it lists (codes, then LZ4), else raw
/// (every learner reads raw, including those from before the field).
/// Wanting raw always gets raw.
///
/// ```
/// use buridan_actor::client::obs_encoding_for;
/// use buridan_proto::v1::{JoinReply, ObsEncoding};
/// let old = JoinReply::default();
/// assert_eq!(obs_encoding_for(&old, ObsEncoding::Codes), ObsEncoding::Raw);
/// let lz4_only = JoinReply { obs_encodings: vec![ObsEncoding::Lz4 as i32], ..Default::default() };
/// assert_eq!(obs_encoding_for(&lz4_only, ObsEncoding::Codes), ObsEncoding::Lz4);
/// let both = JoinReply {
///     obs_encodings: vec![ObsEncoding::Codes as i32, ObsEncoding::Lz4 as i32],
///     ..Default::default()
/// };
/// assert_eq!(obs_encoding_for(&both, ObsEncoding::Lz4), ObsEncoding::Lz4);
/// assert_eq!(obs_encoding_for(&both, ObsEncoding::Codes), ObsEncoding::Codes);
/// assert_eq!(obs_encoding_for(&both, ObsEncoding::Raw), ObsEncoding::Raw);
/// ```
pub fn obs_encoding_for(join: &v1::JoinReply, wanted: ObsEncoding) -> ObsEncoding {
    if wanted == ObsEncoding::Raw {
        return ObsEncoding::Raw;
    }
    let listed = |e: ObsEncoding| join.obs_encodings.contains(&(e as i32));
    [wanted, ObsEncoding::Codes, ObsEncoding::Lz4]
        .into_iter()
        .find(|&e| listed(e))
        .unwrap_or(ObsEncoding::Raw)
}

/// Sends fragments, numbered per session. Off-policy runs keep one
/// submission in flight while the next fragment is collected (as the
/// in-process queue lets actors do), and encode it in that task too, beside
/// the collection; on-policy runs submit synchronously, since the reply may
/// say "wait".
struct Submitter {
    client: Client,
    tag: WireTag,
    pipelined: bool,
    encoding: ObsEncoding,
    in_flight: Option<(u64, tokio::task::JoinHandle<SubmitResult>)>,
}

impl Submitter {
    fn new(client: Client, join: &v1::JoinReply, wanted: ObsEncoding) -> Self {
        let encoding = obs_encoding_for(join, wanted);
        tracing::debug!(?encoding, "observation encoding");
        Self {
            client,
            tag: WireTag {
                run_id: join.run_id.clone(),
                session: join.session,
                seq: 0,
            },
            pipelined: !join.on_policy,
            encoding,
            in_flight: None,
        }
    }

    /// Submits `fragment` (after booking the previous one's reply, if
    /// pipelined); `Some(end)` if the session is over.
    async fn submit(
        &mut self,
        fragment: buridan_policy::Fragment,
        report: &mut ActorReport,
        wait_after: &mut Option<u64>,
    ) -> Result<Option<SessionEnd>, ActorError> {
        let version = fragment.policy_version;
        self.tag.seq += 1;
        if let Some((v, previous)) = self.in_flight.take() {
            let result = previous.await.map_err(|_| ActorError::Panicked("submit"))?;
            if let Some(end) = on_reply(result, v, report, wait_after)? {
                return Ok(Some(end));
            }
        }
        let (tag, encoding) = (self.tag.clone(), self.encoding);
        if self.pipelined {
            let mut c = self.client.clone();
            let submit = tokio::spawn(async move {
                let message = fragment_to_message_encoded(fragment, &tag, encoding);
                c.submit_fragment(message).await
            });
            self.in_flight = Some((version, submit));
            Ok(None)
        } else {
            let message = fragment_to_message_encoded(fragment, &tag, encoding);
            let result = self.client.submit_fragment(message).await;
            on_reply(result, version, report, wait_after)
        }
    }
}

/// Books a submission's outcome; `Some(end)` if the session is over.
fn on_reply(
    result: SubmitResult,
    version: u64,
    report: &mut ActorReport,
    wait_after: &mut Option<u64>,
) -> Result<Option<SessionEnd>, ActorError> {
    match result {
        Ok(reply) => {
            let reply = reply.into_inner();
            if reply.run_finished {
                return Ok(Some(SessionEnd::Finished));
            }
            if reply.accepted {
                report.accepted += 1;
            } else {
                report.refused += 1;
                tracing::debug!(reason = %reply.reason, "fragment refused");
            }
            if reply.wait_for_next_version {
                *wait_after = Some(reply.learner_version.max(version));
            }
            Ok(None)
        }
        Err(source) if retryable(&source) => {
            report.lost += 1;
            Ok(Some(SessionEnd::Lost(ActorError::Rpc {
                call: "submit",
                source,
            })))
        }
        Err(s) => Err(ActorError::FragmentRefused(s)),
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

/// The spec of the env server at `url` (a short connection of its own).
async fn fetch_env_spec(url: &str, opts: &ActorOptions) -> Result<EnvSpec, RemoteEnvError> {
    let (url, options) = (url.to_string(), opts.env_options.clone());
    tokio::task::spawn_blocking(move || RemoteEnv::fetch_spec(&url, &options))
        .await
        .unwrap_or_else(|_| {
            Err(RemoteEnvError::Runtime(std::io::Error::other(
                "the env client task panicked",
            )))
        })
}

/// A collector over a new session on the env server at `url`, the
/// `attempt`-th of this learner session (the blocking connect runs off the
/// async threads).
async fn open_remote(
    join: &v1::JoinReply,
    url: &str,
    opts: &ActorOptions,
    attempt: u64,
) -> Result<Collector<ActorEnv>, SetupError> {
    let (join, url, options) = (join.clone(), url.to_string(), opts.env_options.clone());
    tokio::task::spawn_blocking(move || build_remote_collector(&join, &url, &options, attempt))
        .await
        .unwrap_or_else(|_| {
            Err(SetupError::from(RemoteEnvError::Runtime(
                std::io::Error::other("the env client task panicked"),
            )))
        })
}

/// Opens env sessions on the env server at `url` with backoff until one
/// opens (`Ok(Ok(collector))`), the learner ends the session meanwhile
/// (`Ok(Err(end))`), or the server refuses for good (`Err`).
async fn reconnect_env(
    join: &v1::JoinReply,
    url: &str,
    opts: &ActorOptions,
    attempt: &mut u64,
    latest: &mut watch::Receiver<Option<Update>>,
) -> Result<Result<Collector<ActorEnv>, SessionEnd>, ActorError> {
    let mut delay = opts.backoff_initial;
    loop {
        let wait = delay.mul_f64(rand::rng().random_range(0.8..1.2));
        tokio::time::sleep(wait).await;
        match latest.borrow().clone() {
            Some(Update::Finished) => return Ok(Err(SessionEnd::Finished)),
            Some(Update::Lost(why)) => return Ok(Err(SessionEnd::Lost(ActorError::Stream(why)))),
            _ => {}
        }
        *attempt += 1;
        match open_remote(join, url, opts, *attempt).await {
            Ok(c) => {
                tracing::info!(env = url, attempt = *attempt, "env session reopened");
                return Ok(Ok(c));
            }
            Err(e) if e.retryable() => {
                tracing::warn!("{}; retrying", error_chain(&e));
                delay = (delay * 2).min(opts.backoff_max);
            }
            Err(e) => return Err(ActorError::Setup(e)),
        }
    }
}

/// Checks an env server's spec against the run the learner described:
/// observation kind and size, agents, actions (at most the policy heads'
/// width; fewer are masked out), envs (the count joined with) and T_max.
///
/// ```
/// use buridan_actor::client::check_env_spec;
/// use buridan_env::ObsKind;
/// use buridan_policy::{ModelSpec, Mode};
/// use buridan_proto::env_convert::EnvSpec;
/// use buridan_proto::v1;
/// let model = ModelSpec::new(Mode::Ctde, 2, 11);
/// let join = v1::JoinReply {
///     envs: 8,
///     plant: Some(v1::PlantSettings { name: "plant:dissertation".into(), agents: 2, t_max: 1000 }),
///     ..Default::default()
/// };
/// let mut env = EnvSpec { num_envs: 8, agents: 2, kind: ObsKind::Local, obs_dim: 11, num_actions: 3, t_max: 1000, name: "plant:dissertation".into() };
/// check_env_spec(&env, &model, &join).unwrap();
/// env.obs_dim = 16;
/// let err = check_env_spec(&env, &model, &join).unwrap_err();
/// assert_eq!(err.to_string(), "the env server 'plant:dissertation' has obs_dim 16, the run 11");
/// ```
pub fn check_env_spec(
    env: &EnvSpec,
    model: &ModelSpec,
    join: &v1::JoinReply,
) -> Result<(), SetupError> {
    let mismatch = |what, env_value: String, run: String| SetupError::EnvSpec {
        name: env.name.clone(),
        what,
        env: env_value,
        run,
    };
    let run_kind = model.mode.obs_kind();
    if env.kind != run_kind {
        return Err(mismatch(
            "observation rows",
            format!("{:?}", env.kind).to_lowercase(),
            format!("{:?} ({} policy)", run_kind, model.mode).to_lowercase(),
        ));
    }
    let run_t_max = match (&join.plant, &join.env) {
        (Some(p), _) => Some(p.t_max),
        (None, Some(e)) => Some(e.t_max),
        (None, None) => None,
    };
    for (what, got, want) in [
        ("obs_dim", env.obs_dim, Some(model.obs_dim)),
        ("agents", env.agents, Some(model.agents)),
        ("num_envs", env.num_envs, Some(join.envs as usize)),
        ("t_max", env.t_max as usize, run_t_max.map(|t| t as usize)),
    ] {
        if let Some(want) = want {
            if got != want {
                return Err(mismatch(what, got.to_string(), want.to_string()));
            }
        }
    }
    if env.num_actions > model.actions {
        return Err(mismatch(
            "num_actions",
            env.num_actions.to_string(),
            format!("at most {} (the policy heads' width)", model.actions),
        ));
    }
    if let Some(plant) = &join.plant {
        if env.name != plant.name {
            tracing::warn!(
                env = %env.name,
                run = %plant.name,
                "the env server's name differs from the run's plant (shapes match, so training goes on)"
            );
        }
    }
    Ok(())
}

/// Envs and policy as the learner described them in a join reply, with
/// the envs stepped on the env server at `url` (a new session seeded from
/// the join's seed and `attempt`, checked by [`check_env_spec`]). Blocks:
/// call it off async contexts.
pub fn build_remote_collector(
    join: &v1::JoinReply,
    url: &str,
    options: &RemoteEnvOptions,
    attempt: u64,
) -> Result<Collector<ActorEnv>, SetupError> {
    let spec = model_spec(join)?;
    let options = RemoteEnvOptions {
        mask_slots: Some(spec.actions),
        ..options.clone()
    };
    let seed = buridan_env::seed::remote_env_session(join.seed, attempt);
    let venv = RemoteEnv::connect(url, seed, &options)?;
    check_env_spec(venv.spec(), &spec, join)?;
    collector_over(join, spec, Box::new(venv))
}

fn model_spec(join: &v1::JoinReply) -> Result<ModelSpec, SetupError> {
    let spec: ModelSpec =
        serde_json::from_str(&join.model_spec_json).map_err(SetupError::SpecJson)?;
    spec.validate()?;
    Ok(spec)
}

/// The collector of a join reply over `venv`.
fn collector_over(
    join: &v1::JoinReply,
    spec: ModelSpec,
    venv: ActorEnv,
) -> Result<Collector<ActorEnv>, SetupError> {
    if venv.obs_dim() != spec.obs_dim {
        return Err(SetupError::ObsDim {
            env: venv.obs_dim(),
            model: spec.obs_dim,
        });
    }
    let rows = venv.rows();
    let policy = Policy::new(spec, join.seed)?;
    Ok(Collector {
        id: join.actor_id,
        inference: Inference::new(policy, rows, buridan_env::seed::session_sampling(join.seed)),
        behaviour: ActMode::rollout(join.greedy_mix),
        venv,
        fragment_len: join.fragment_len as usize,
        // Nothing loaded yet: the first weights always load.
        version: u64::MAX,
        shield: join
            .shield_rollouts
            .then(|| RolloutShield::new(buridan_env::seed::session_sampling(join.seed))),
    })
}

/// Envs and policy as the learner described them in a join reply: the
/// grid envs of its map (a plant run's envs are external: see
/// [`build_remote_collector`]).
pub fn build_collector(join: &v1::JoinReply) -> Result<Collector<ActorEnv>, SetupError> {
    if let Some(plant) = &join.plant {
        return Err(SetupError::NeedsEnv {
            plant: plant.name.clone(),
            agents: plant.agents,
        });
    }
    let spec = model_spec(join)?;
    let map = map_from_message(join.map.clone().ok_or(SetupError::Missing("map"))?).parse()?;
    let env = env_from_message(
        join.env
            .as_ref()
            .ok_or(SetupError::Missing("env settings"))?,
        join.seed,
    )?;
    let kind = spec.mode.obs_kind();
    let replay = join
        .replay
        .as_ref()
        .map(replay_from_message)
        .unwrap_or_default();
    let venv = VecEnv::new(Arc::new(map), env, join.envs as usize, kind, 1)?.boxed(replay)?;
    collector_over(join, spec, venv)
}
