//! The `buridan.v1.FleetControl` service: Open, Step and Close over the
//! session table, controllers run on tokio's blocking threads.

use std::sync::Arc;
use std::time::Instant;

use buridan_env::error::error_chain;
use buridan_env::generate::GeneratedMap;
use buridan_env::{Map, REFERENCE_MODELS};
use buridan_eval::by_name::Controller as ControllerSpec;
use buridan_eval::fleet::{FleetError, FleetOptions, FleetSession};
use buridan_mapf::Limits;
use buridan_proto::control_convert::{
    answer_to_message, open_from_message, report_from_message, FleetAnswer, FleetMapSource,
    FleetOpen,
};
use buridan_proto::v1;
use buridan_proto::v1::fleet_control_server::FleetControl;
use tonic::{Code, Request, Response, Status};

use crate::metrics as m;
use crate::sessions::{lock, Ended, Fleet, SessionError, Sessions};
use crate::ServeConfig;

/// The fleet control service (see the [crate docs](crate)).
pub struct ControlService {
    cfg: ServeConfig,
    sessions: Arc<Sessions>,
}

impl ControlService {
    /// The service for `cfg` (checked by [`ServeConfig::check`] first).
    pub fn new(cfg: ServeConfig) -> Result<Self, crate::ServeError> {
        cfg.check()?;
        m::describe();
        let sessions = Arc::new(Sessions::new(
            cfg.max_sessions,
            cfg.idle_timeout,
            cfg.wait_alarm,
        ));
        Ok(Self { cfg, sessions })
    }

    /// The settings served.
    pub fn config(&self) -> &ServeConfig {
        &self.cfg
    }

    /// The session table (for the expiry sweep and for tests).
    pub fn sessions(&self) -> Arc<Sessions> {
        self.sessions.clone()
    }

    /// Opens a session: checks the request, then builds the map and the
    /// controller (a planner plans) on a blocking thread.
    async fn open_session(&self, req: v1::FleetOpenRequest) -> Result<v1::FleetOpenReply, Status> {
        let open = open_from_message(req).map_err(|e| Status::invalid_argument(e.to_string()))?;
        let agents = open.positions.len();
        if agents > self.cfg.max_robots {
            return Err(Status::resource_exhausted(format!(
                "{agents} robots, more than the server's limit of {} per session (--max-robots)",
                self.cfg.max_robots
            )));
        }
        let spec: ControllerSpec = open.controller.parse().map_err(|e| {
            Status::invalid_argument(format!("controller '{}': {e}", open.controller))
        })?;
        if !self.cfg.allow_checkpoint_dirs {
            if let Some(p) = spec
                .policies()
                .into_iter()
                .find(|p| !p.checkpoint.to_string_lossy().starts_with("model:"))
            {
                return Err(Status::invalid_argument(format!(
                    "controller '{}': checkpoint '{}' is a directory on the server; this server \
                     serves bundled models only (checkpoint:model:NAME) unless started with \
                     --allow-checkpoint-dirs",
                    open.controller,
                    p.checkpoint.display()
                )));
            }
        }
        let admission = self
            .sessions
            .admit()
            .map_err(|e| Status::resource_exhausted(e.to_string()))?;
        let limits = Limits::with_time(self.cfg.plan_time);
        let k = self.cfg.wait_alarm;
        let controller = spec.to_string();
        let reports_overrides = shielded(&spec);
        let (fleet, map) = tokio::task::spawn_blocking(move || build(open, &spec, limits, k))
            .await
            .map_err(|e| Status::internal(format!("opening the session failed: {e}")))??;
        let id = self.sessions.insert(admission, fleet, agents);
        tracing::info!(session = id, agents, %controller, map = %map.name, "session opened");
        Ok(v1::FleetOpenReply {
            session: id,
            agents: agents as u32,
            controller,
            height: map.grid.height() as u32,
            width: map.grid.width() as u32,
            map_name: map.name.clone(),
            reports_overrides,
            idle_timeout_ms: self.cfg.idle_timeout.as_millis() as u64,
        })
    }

    /// One control cycle of a session, the controller on a blocking thread.
    async fn step_session(&self, req: v1::FleetStepRequest) -> Result<v1::FleetStepReply, Status> {
        let started = Instant::now();
        let id = req.session;
        let (fleet, agents) = self.sessions.get(id).map_err(not_found)?;
        let (positions, goals) = report_from_message(&req.positions, &req.goals, agents)
            .map_err(|e| Status::invalid_argument(e.to_string()))?;
        let waiting = self.sessions.waiting_gauge();
        let task = tokio::task::spawn_blocking(move || {
            let mut f = lock(&fleet);
            if let Some(why) = f.ended {
                return Err(not_found(SessionError::Ended { id, why }));
            }
            let answer = match f.session.step(&positions, &goals) {
                Ok(moves) => FleetAnswer {
                    moves: moves.to_vec(),
                    overridden: f.session.overridden().map(<[bool]>::to_vec),
                    note: None,
                    step: 0,
                },
                Err(FleetError::GaveUp(why)) => FleetAnswer {
                    moves: vec![0; agents],
                    overridden: None,
                    note: Some(FleetError::GaveUp(why).to_string()),
                    step: 0,
                },
                Err(FleetError::Env(e)) => return Err(Status::invalid_argument(e.to_string())),
                Err(e @ FleetError::Controller(_)) => {
                    return Err(Status::internal(error_chain(&e)))
                }
            };
            // The report was accepted: the robots stand where it says.
            let (delta, passed) = f.waits.report(&positions, &goals);
            if delta != 0 {
                waiting.increment(delta as f64);
            }
            if passed > 0 {
                ::metrics::counter!(m::LONG_WAITS).increment(passed);
            }
            f.steps += 1;
            Ok(FleetAnswer {
                step: f.steps,
                ..answer
            })
        });
        let answer = match task.await {
            Ok(answer) => answer?,
            Err(e) => {
                // A controller that panicked may have left its state
                // half-changed: the session ends.
                let _ = self.sessions.end(id, Ended::Failed);
                tracing::error!(session = id, "the controller failed: {e}");
                return Err(Status::internal(format!(
                    "the controller failed ({e}); session {id} is closed: Open a new one"
                )));
            }
        };
        self.sessions.touch(id);
        if let Some(flags) = &answer.overridden {
            let n = flags.iter().filter(|&&o| o).count();
            if n > 0 {
                ::metrics::counter!(m::OVERRIDDEN).increment(n as u64);
            }
        }
        if let Some(note) = &answer.note {
            tracing::debug!(session = id, "{note}");
        }
        ::metrics::counter!(m::STEPS).increment(1);
        ::metrics::histogram!(m::STEP_SECONDS).record(started.elapsed().as_secs_f64());
        Ok(answer_to_message(&answer))
    }
}

/// Whether a policy through the shield chooses the moves (inside a
/// planner net, on the steps the net leaves to it).
fn shielded(c: &ControllerSpec) -> bool {
    match c {
        ControllerSpec::Shield(_) => true,
        ControllerSpec::Net(net) => shielded(&net.inner),
        _ => false,
    }
}

/// The map of an Open request: a bundled id, a generated spec or a map's
/// text — never a path on the server.
fn resolve_map(source: &FleetMapSource) -> Result<Map, Status> {
    let invalid = |e: &dyn std::error::Error| Status::invalid_argument(error_chain(e));
    match source {
        FleetMapSource::Id(id) if REFERENCE_MODELS.iter().any(|m| m.id == id) => {
            Map::load(id).map_err(|e| invalid(&e))
        }
        FleetMapSource::Id(id) if GeneratedMap::is_spec(id) => id
            .parse::<GeneratedMap>()
            .map(|g| g.map())
            .map_err(|e| invalid(&e)),
        FleetMapSource::Id(id) => Err(Status::invalid_argument(format!(
            "unknown map '{id}': a bundled id ({}) or a generated map's spec \
             (maze/19x19/seed=0); send a map file's text in map.text",
            REFERENCE_MODELS
                .iter()
                .map(|m| m.id)
                .collect::<Vec<_>>()
                .join(", ")
        ))),
        FleetMapSource::Text(src) => src.parse().map_err(|e| invalid(&e)),
    }
}

/// Builds a session's map and controller (a planner plans its first plan).
fn build(
    open: FleetOpen,
    spec: &ControllerSpec,
    limits: Limits,
    k: u32,
) -> Result<(Fleet, Arc<Map>), Status> {
    let map = Arc::new(resolve_map(&open.map)?);
    let options = FleetOptions::from(open.seed).within(limits);
    let options = if open.shared_goals {
        options.with_shared_goals()
    } else {
        options
    };
    let session = FleetSession::open(
        map.clone(),
        open.rules,
        spec,
        &open.positions,
        &open.goals,
        options,
    )
    .map_err(|e| Status::invalid_argument(error_chain(&e)))?;
    Ok((Fleet::new(session, k, &open.positions), map))
}

/// NOT_FOUND for a session that is not open; RESOURCE_EXHAUSTED for a
/// full table.
fn not_found(e: SessionError) -> Status {
    match e {
        SessionError::Full { .. } => Status::resource_exhausted(e.to_string()),
        _ => Status::not_found(e.to_string()),
    }
}

/// Counts and logs a refused call.
fn refused<T>(call: &'static str, result: Result<T, Status>) -> Result<Response<T>, Status> {
    result.map(Response::new).inspect_err(|status| {
        let code = status.code();
        ::metrics::counter!(m::REFUSED, "code" => code_name(code)).increment(1);
        if code == Code::Internal {
            tracing::error!(call, "{}", status.message());
        } else {
            tracing::warn!(call, ?code, "refused: {}", status.message());
        }
    })
}

/// A code's name as Prometheus labels carry it.
fn code_name(code: Code) -> &'static str {
    match code {
        Code::InvalidArgument => "invalid_argument",
        Code::NotFound => "not_found",
        Code::ResourceExhausted => "resource_exhausted",
        Code::Unauthenticated => "unauthenticated",
        Code::Internal => "internal",
        _ => "other",
    }
}

#[tonic::async_trait]
impl FleetControl for ControlService {
    async fn open(
        &self,
        request: Request<v1::FleetOpenRequest>,
    ) -> Result<Response<v1::FleetOpenReply>, Status> {
        refused("open", self.open_session(request.into_inner()).await)
    }

    async fn step(
        &self,
        request: Request<v1::FleetStepRequest>,
    ) -> Result<Response<v1::FleetStepReply>, Status> {
        refused("step", self.step_session(request.into_inner()).await)
    }

    async fn close(
        &self,
        request: Request<v1::FleetCloseRequest>,
    ) -> Result<Response<v1::FleetCloseReply>, Status> {
        let id = request.into_inner().session;
        let result = self.sessions.end(id, Ended::Closed).map(|fleet| {
            let steps = lock(&fleet).steps;
            tracing::info!(session = id, steps, "session closed");
            v1::FleetCloseReply { steps }
        });
        refused("close", result.map_err(not_found))
    }
}
