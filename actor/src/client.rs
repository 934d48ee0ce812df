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

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, bail, Context, Result};
use buridan_env::VecEnv;
use buridan_policy::{Inference, ModelSpec, Policy, Weights};
use buridan_proto::convert::{
    env_from_message, fragment_to_message, map_from_message, weights_from_message, WireTag,
};
use buridan_proto::v1;
use buridan_proto::v1::learner_client::LearnerClient;
use rand::Rng;
use tokio::sync::watch;
use tonic::metadata::MetadataValue;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;
use tonic::{Code, Request, Status};

use crate::Collector;

/// Makes a fresh channel to the learner (TCP, TLS or in-memory).
pub type Connector =
    Arc<dyn Fn() -> Pin<Box<dyn Future<Output = Result<Channel>> + Send>> + Send + Sync>;

/// A connector for a URL (`http://host:port`, or `https://…` with `tls_ca`).
///
/// ```
/// let c = buridan_actor::client::url_connector("http://127.0.0.1:50051", None).unwrap();
/// # let _ = c;
/// assert!(buridan_actor::client::url_connector("not a url", None).is_err());
/// ```
pub fn url_connector(url: &str, tls_ca: Option<&std::path::Path>) -> Result<Connector> {
    let uri: tonic::codegen::http::Uri = url
        .parse()
        .with_context(|| format!("invalid learner URL '{url}'"))?;
    if !matches!(uri.scheme_str(), Some("http" | "https")) || uri.authority().is_none() {
        bail!("invalid learner URL '{url}': expected http://HOST:PORT or https://HOST:PORT");
    }
    let mut endpoint = Channel::from_shared(url.to_string())
        .with_context(|| format!("invalid learner URL '{url}'"))?
        .connect_timeout(Duration::from_secs(5))
        .tcp_nodelay(true)
        // Fragments are megabytes: windows sized for them save round trips.
        .initial_stream_window_size(8 * 1024 * 1024)
        .initial_connection_window_size(16 * 1024 * 1024)
        .http2_keep_alive_interval(Duration::from_secs(10))
        .keep_alive_timeout(Duration::from_secs(20));
    if let Some(path) = tls_ca {
        let pem = std::fs::read(path)
            .with_context(|| format!("cannot read CA certificate {}", path.display()))?;
        endpoint = endpoint
            .tls_config(
                tonic::transport::ClientTlsConfig::new()
                    .ca_certificate(tonic::transport::Certificate::from_pem(pem)),
            )
            .context("invalid TLS configuration")?;
    }
    Ok(Arc::new(move || {
        let endpoint = endpoint.clone();
        Box::pin(async move {
            endpoint
                .connect()
                .await
                .with_context(|| format!("cannot connect to {}", endpoint.uri()))
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
}

/// Why a session ended.
enum SessionEnd {
    /// The learner says the run is over.
    Finished,
    /// The connection or the learner went away: join again.
    Lost(anyhow::Error),
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
pub async fn run(connect: Connector, opts: ActorOptions) -> Result<ActorReport> {
    let interceptor = TokenInterceptor {
        value: match &opts.token {
            Some(t) => Some(
                format!("Bearer {t}")
                    .parse()
                    .map_err(|_| anyhow!("the token must be printable ASCII"))?,
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
            Ok(SessionEnd::Lost(e)) | Err(e) => {
                if let Some(limit) = opts.give_up_after {
                    if since_session.elapsed() > limit {
                        return Err(
                            e.context(format!("no learner session for {:.0?}; giving up", limit))
                        );
                    }
                }
                let jitter = rand::rng().random_range(0.8..1.2);
                let wait = delay.mul_f64(jitter);
                tracing::warn!("{e:#}; reconnecting in {wait:.1?}");
                tokio::time::sleep(wait).await;
                delay = (delay * 2).min(opts.backoff_max);
            }
        }
    }
}

/// Whether a status means "join again" rather than "this actor is broken".
fn retryable(status: &Status) -> bool {
    matches!(
        status.code(),
        Code::Unavailable
            | Code::NotFound
            | Code::Cancelled
            | Code::Unknown
            | Code::Aborted
            | Code::DeadlineExceeded
            | Code::Internal
    )
}

async fn session(
    mut client: Client,
    opts: &ActorOptions,
    report: &mut ActorReport,
    since_session: &mut tokio::time::Instant,
    delay: &mut Duration,
) -> Result<SessionEnd> {
    let join = client
        .join(v1::JoinRequest {
            api_version: v1::ApiVersion::V1 as u32,
            actor_name: opts.name.clone(),
            envs: opts.envs.unwrap_or(0),
        })
        .await;
    let join = match join {
        Ok(r) => r.into_inner(),
        Err(s) if s.code() == Code::FailedPrecondition && s.message().contains("finished") => {
            return Ok(SessionEnd::Finished)
        }
        Err(s) if retryable(&s) => return Ok(SessionEnd::Lost(anyhow!("join: {s}"))),
        Err(s) => bail!("the learner refused this actor: {s}"),
    };
    report.sessions += 1;
    *since_session = tokio::time::Instant::now();
    *delay = opts.backoff_initial;
    let mut collector = build_collector(&join).context("cannot set up the run the learner sent")?;
    tracing::info!(
        run = %join.run_id,
        session = join.session,
        actor = join.actor_id,
        envs = join.envs,
        "joined"
    );

    // Weights arrive on their own stream; the newest waits in `latest`.
    let mut stream = client
        .watch_parameters(v1::WatchRequest {
            run_id: join.run_id.clone(),
            session: join.session,
        })
        .await
        .map_err(|s| anyhow!("watch parameters: {s}"))?
        .into_inner();
    let (latest_tx, mut latest) = watch::channel::<Option<Update>>(None);
    let watcher = tokio::spawn(async move {
        loop {
            match stream.message().await {
                Ok(Some(p)) if p.finished => {
                    let _ = latest_tx.send(Some(Update::Finished));
                    return;
                }
                Ok(Some(p)) => match weights_from_message(p) {
                    Ok(w) => {
                        if latest_tx.send(Some(Update::Weights(Arc::new(w)))).is_err() {
                            return;
                        }
                    }
                    Err(e) => {
                        let _ = latest_tx.send(Some(Update::Lost(format!("bad weights: {e}"))));
                        return;
                    }
                },
                Ok(None) => {
                    let _ = latest_tx.send(Some(Update::Lost("parameter stream ended".into())));
                    return;
                }
                Err(s) => {
                    let _ = latest_tx.send(Some(Update::Lost(format!("parameter stream: {s}"))));
                    return;
                }
            }
        }
    });
    let _abort_watcher = AbortOnDrop(watcher);

    let tag_base = WireTag {
        run_id: join.run_id.clone(),
        session: join.session,
        seq: 0,
    };
    // On-policy: after a full batch, wait for a version newer than this.
    let mut wait_after: Option<u64> = None;
    let mut seq = 0u64;
    // Off-policy runs keep one submission in flight while the next
    // fragment is collected (as the in-process queue lets actors do);
    // on-policy runs submit synchronously, since the reply may say "wait".
    let pipelined = !join.on_policy;
    let mut in_flight: Option<(u64, tokio::task::JoinHandle<SubmitResult>)> = None;
    loop {
        // Newest weights (waiting for the first, or for a newer version).
        let weights = loop {
            let current = latest.borrow_and_update().clone();
            match current {
                Some(Update::Finished) => return Ok(SessionEnd::Finished),
                Some(Update::Lost(why)) => return Ok(SessionEnd::Lost(anyhow!(why))),
                Some(Update::Weights(w)) if wait_after.is_none_or(|v| w.version > v) => break w,
                _ => {
                    if latest.changed().await.is_err() {
                        return Ok(SessionEnd::Lost(anyhow!("parameter stream closed")));
                    }
                }
            }
        };
        wait_after = None;
        collector.load(&weights)?;
        let (back, fragment) = tokio::task::spawn_blocking(move || {
            let f = collector.collect();
            (collector, f)
        })
        .await
        .context("the collector thread panicked")?;
        collector = back;
        let fragment = fragment?;
        let version = fragment.policy_version;
        report.env_steps += fragment.env_steps;
        seq += 1;
        let tag = WireTag {
            seq,
            ..tag_base.clone()
        };
        if let Some((v, previous)) = in_flight.take() {
            let result = previous.await.context("the submit task panicked")?;
            if let Some(end) = on_reply(result, v, report, &mut wait_after)? {
                return Ok(end);
            }
        }
        let message = fragment_to_message(fragment, &tag);
        if pipelined {
            let mut c = client.clone();
            let submit = tokio::spawn(async move { c.submit_fragment(message).await });
            in_flight = Some((version, submit));
        } else {
            let result = client.submit_fragment(message).await;
            if let Some(end) = on_reply(result, version, report, &mut wait_after)? {
                return Ok(end);
            }
        }
    }
}

type SubmitResult = Result<tonic::Response<v1::SubmitReply>, Status>;

/// Books a submission's outcome; `Some(end)` if the session is over.
fn on_reply(
    result: SubmitResult,
    version: u64,
    report: &mut ActorReport,
    wait_after: &mut Option<u64>,
) -> Result<Option<SessionEnd>> {
    match result {
        Ok(reply) => {
            let reply = reply.into_inner();
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
        Err(s) if s.code() == Code::FailedPrecondition && s.message().contains("finished") => {
            Ok(Some(SessionEnd::Finished))
        }
        Err(s) if retryable(&s) => {
            report.lost += 1;
            Ok(Some(SessionEnd::Lost(anyhow!("submit: {s}"))))
        }
        Err(s) => bail!("the learner refused a fragment: {s}"),
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

/// Envs and policy as the learner described them in a join reply.
pub fn build_collector(join: &v1::JoinReply) -> Result<Collector> {
    let spec: ModelSpec =
        serde_json::from_str(&join.model_spec_json).context("the model spec is not valid JSON")?;
    spec.validate()?;
    let map = map_from_message(
        join.map
            .clone()
            .ok_or_else(|| anyhow!("no map in the reply"))?,
    )
    .parse()?;
    let env = env_from_message(
        join.env
            .as_ref()
            .ok_or_else(|| anyhow!("no env settings in the reply"))?,
        join.seed,
    )?;
    let kind = spec.mode.obs_kind();
    let venv = VecEnv::new(Arc::new(map), env, join.envs as usize, kind, 1)?;
    if venv.obs_dim() != spec.obs_dim {
        bail!(
            "the env's observations have {} floats, the model expects {}",
            venv.obs_dim(),
            spec.obs_dim
        );
    }
    let rows = venv.obs().len() / venv.obs_dim();
    let policy = Policy::new(spec, join.seed)?;
    Ok(Collector {
        id: join.actor_id,
        inference: Inference::new(policy, rows, join.seed ^ 0xAC70),
        venv,
        fragment_len: join.fragment_len as usize,
        // Nothing loaded yet: the first weights always load.
        version: u64::MAX,
    })
}
