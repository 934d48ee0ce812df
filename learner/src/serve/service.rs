//! The `buridan.v1.Learner` gRPC service: joins, parameter streams and
//! fragment submissions, each checked before it touches the run.

use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};

use buridan_proto::convert::fragment_from_message_within;
use buridan_proto::obs_encoding::DEFAULT_MAX_DECODED_BYTES;
use buridan_proto::v1;
use buridan_proto::v1::learner_server::Learner;
use tokio_stream::wrappers::WatchStream;
use tokio_stream::Stream;
use tonic::{Request, Response, Status};

use super::hub::{refusal_outcome, Hub, Outcome};

/// The service over a [`Hub`].
#[derive(Clone)]
pub struct LearnerService {
    hub: Arc<Hub>,
    /// Bound on the bytes a fragment's compressed observations decode to.
    max_decoded_bytes: usize,
}

impl LearnerService {
    /// A service for `hub`; compressed observations may decode to at most
    /// the run's largest fragment (see [`Self::max_decoded_bytes`]).
    pub fn new(hub: Arc<Hub>) -> Self {
        let max_decoded_bytes = fragment_obs_bytes(&hub.info).min(DEFAULT_MAX_DECODED_BYTES);
        Self {
            hub,
            max_decoded_bytes,
        }
    }

    /// Lets compressed observations decode to at most `limit` bytes (and
    /// never more than the largest fragment the run can produce), so that
    /// compression lets nothing larger in than a raw message of the size
    /// limit could carry.
    pub fn max_decoded_bytes(mut self, limit: usize) -> Self {
        self.max_decoded_bytes = fragment_obs_bytes(&self.hub.info).min(limit);
        self
    }

    fn check_run(&self, run_id: &str) -> Result<(), Status> {
        if run_id != self.hub.info.run_id {
            return Err(Status::not_found(format!(
                "unknown run '{run_id}': this learner runs '{}'; join again",
                self.hub.info.run_id
            )));
        }
        Ok(())
    }

    /// The reply to a fragment that arrives after the run ended.
    fn finished_reply(&self) -> Response<v1::SubmitReply> {
        Response::new(v1::SubmitReply {
            accepted: false,
            reason: "the run is finished".into(),
            learner_version: self.hub.version(),
            wait_for_next_version: false,
            run_finished: true,
        })
    }

    /// The status of a call naming a session that is not open: never
    /// opened, left (its last parameter stream closed) or expired.
    fn unknown_session(&self, id: u64) -> Status {
        Status::not_found(format!(
            "unknown session {id} (it left, or expired after {} s without a parameter stream or a fragment): join again",
            self.hub.session_limits().idle_timeout.as_secs_f64()
        ))
    }

    fn refuse(&self, outcome: Outcome, status: Status) -> Status {
        self.hub.counters.count(outcome);
        tracing::warn!(code = ?status.code(), message = status.message(), "fragment refused");
        status
    }
}

/// The API version this learner speaks; a join of any other is refused.
const API_VERSION: u32 = v1::ApiVersion::V2 as u32;

/// The refusal of a join that speaks API version `got`: names both
/// versions and the side to upgrade.
///
/// ```text
/// this actor speaks API v1, this learner speaks v2: upgrade the actor
/// ```
fn version_refusal(got: u32) -> Status {
    let message = match got {
        0 => format!(
            "this actor names no API version (api_version 0), this learner speaks v{API_VERSION}: upgrade the actor"
        ),
        v if v < API_VERSION => format!(
            "this actor speaks API v{v}, this learner speaks v{API_VERSION}: upgrade the actor"
        ),
        v => format!(
            "this actor speaks API v{v}, this learner speaks v{API_VERSION}: upgrade the learner, or run an actor that speaks v{API_VERSION}"
        ),
    };
    tracing::warn!(api_version = got, "join refused: {message}");
    Status::failed_precondition(message)
}

/// Bytes of observations in the largest fragment of the run: obs and at most
/// as many final observations (one per truncated step), plus last_obs, for
/// an actor with the most envs allowed.
fn fragment_obs_bytes(info: &super::RunInfo) -> usize {
    let rows = u64::from(info.max_envs) * u64::from(info.rows_per_env);
    let values = (2 * u64::from(info.spec.fragment_len) + 1)
        .saturating_mul(rows)
        .saturating_mul(u64::from(info.obs_dim));
    usize::try_from(values.saturating_mul(4)).unwrap_or(usize::MAX)
}

/// The learner's weights as a stream that tells the hub when it closes.
pub struct ParameterStream {
    inner: WatchStream<Arc<v1::Parameters>>,
    hub: Arc<Hub>,
    session: u64,
    done: bool,
}

impl Stream for ParameterStream {
    type Item = Result<v1::Parameters, Status>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        if self.done {
            return Poll::Ready(None);
        }
        match Pin::new(&mut self.inner).poll_next(cx) {
            Poll::Ready(Some(p)) => {
                if p.finished {
                    self.done = true;
                }
                Poll::Ready(Some(Ok(p.as_ref().clone())))
            }
            Poll::Ready(None) => Poll::Ready(None),
            Poll::Pending => Poll::Pending,
        }
    }
}

impl Drop for ParameterStream {
    fn drop(&mut self) {
        self.hub.close_watch(self.session);
    }
}

#[tonic::async_trait]
impl Learner for LearnerService {
    async fn join(
        &self,
        request: Request<v1::JoinRequest>,
    ) -> Result<Response<v1::JoinReply>, Status> {
        let req = request.into_inner();
        let info = &self.hub.info;
        if req.api_version != API_VERSION {
            return Err(version_refusal(req.api_version));
        }
        if self.hub.finished() {
            return Ok(Response::new(v1::JoinReply {
                run_finished: true,
                ..Default::default()
            }));
        }
        let envs = if req.envs == 0 {
            info.envs_per_actor
        } else {
            req.envs
        };
        if envs > info.max_envs {
            return Err(Status::invalid_argument(format!(
                "{envs} envs asked for; this learner allows at most {} per actor",
                info.max_envs
            )));
        }
        let name = if req.actor_name.is_empty() {
            "actor".to_string()
        } else {
            req.actor_name.chars().take(128).collect()
        };
        let (session, s) = self.hub.open_session(name.clone(), envs).map_err(|cap| {
            ::metrics::counter!("buridan_joins_refused_total", "reason" => "max_sessions")
                .increment(1);
            tracing::warn!(%name, open = cap.open, cap = cap.cap, "join refused: session cap");
            Status::resource_exhausted(cap.to_string())
        })?;
        tracing::info!(session, actor = s.actor_id, %name, envs, "actor joined");
        Ok(Response::new(v1::JoinReply {
            run_id: info.run_id.clone(),
            session,
            actor_id: s.actor_id,
            envs,
            seed: buridan_env::seed::session_env(info.seed_base, session),
            run: Some(info.spec.clone()),
            run_finished: false,
        }))
    }

    type WatchParametersStream = ParameterStream;

    async fn watch_parameters(
        &self,
        request: Request<v1::WatchRequest>,
    ) -> Result<Response<Self::WatchParametersStream>, Status> {
        let req = request.into_inner();
        self.check_run(&req.run_id)?;
        if !self.hub.open_watch(req.session) {
            return Err(self.unknown_session(req.session));
        }
        Ok(Response::new(ParameterStream {
            inner: WatchStream::new(self.hub.subscribe()),
            hub: self.hub.clone(),
            session: req.session,
            done: false,
        }))
    }

    async fn submit_fragment(
        &self,
        request: Request<v1::Fragment>,
    ) -> Result<Response<v1::SubmitReply>, Status> {
        let info = &self.hub.info;
        let message = request.into_inner();
        let (tag, mut f) =
            fragment_from_message_within(message, self.max_decoded_bytes).map_err(|e| {
                self.refuse(
                    Outcome::Invalid,
                    Status::invalid_argument(format!("malformed fragment: {e}")),
                )
            })?;
        self.check_run(&tag.run_id)
            .map_err(|s| self.refuse(Outcome::Invalid, s))?;
        if self.hub.finished() {
            return Ok(self.finished_reply());
        }
        let session = self
            .hub
            .session(tag.session)
            .ok_or_else(|| self.refuse(Outcome::Invalid, self.unknown_session(tag.session)))?;
        for (what, got, expected) in [
            ("obs_dim", f.obs_dim as u64, u64::from(info.obs_dim)),
            ("heads", f.heads as u64, u64::from(info.heads)),
            (
                "actions_per_head",
                f.actions_per_head as u64,
                u64::from(info.actions_per_head),
            ),
            (
                "rows_per_env",
                f.rows_per_env as u64,
                u64::from(info.rows_per_env),
            ),
            ("len", f.len as u64, u64::from(info.spec.fragment_len)),
            (
                "rows",
                f.rows as u64,
                u64::from(session.envs) * u64::from(info.rows_per_env),
            ),
        ] {
            if got != expected {
                return Err(self.refuse(
                    Outcome::Invalid,
                    Status::invalid_argument(format!(
                        "fragment {what} is {got}; this run expects {expected}"
                    )),
                ));
            }
        }
        let current = self.hub.version();
        if f.policy_version > current {
            return Err(self.refuse(
                Outcome::Invalid,
                Status::invalid_argument(format!(
                    "unknown policy version {}: the learner is at version {current}",
                    f.policy_version
                )),
            ));
        }
        if let Err(implausible) = self.hub.plausibility.check(&f) {
            ::metrics::counter!("buridan_implausible_fragments_total", "field" => implausible.field())
                .increment(1);
            return Err(self.refuse(
                Outcome::Invalid,
                Status::invalid_argument(implausible.to_string()),
            ));
        }
        match self.hub.claim_seq(tag.session, tag.seq) {
            None => return Err(self.refuse(Outcome::Invalid, self.unknown_session(tag.session))),
            Some(Err(last)) => {
                return Err(self.refuse(
                    Outcome::Duplicate,
                    Status::already_exists(format!(
                        "fragment {} of session {} already received (last was {last})",
                        tag.seq, tag.session
                    )),
                ))
            }
            Some(Ok(())) => {}
        }
        // Room first: from here to the reply nothing awaits, so a cancelled
        // handler never leaves steps admitted but not queued.
        let Some(slot) = self.hub.reserve().await else {
            return Ok(self.finished_reply());
        };
        let wait_for_next_version = match self.hub.admit(f.policy_version, f.env_steps) {
            Ok(wait) => wait,
            Err(refusal) => {
                self.hub.counters.count(refusal_outcome(&refusal));
                return Ok(Response::new(v1::SubmitReply {
                    accepted: false,
                    reason: refusal.to_string(),
                    learner_version: self.hub.version(),
                    wait_for_next_version: self.hub.info.spec.on_policy,
                    run_finished: false,
                }));
            }
        };
        f.actor = session.actor_id;
        slot.send(f);
        self.hub.counters.count(Outcome::Accepted);
        Ok(Response::new(v1::SubmitReply {
            accepted: true,
            reason: String::new(),
            learner_version: current,
            wait_for_next_version,
            run_finished: false,
        }))
    }
}
