//! The fleet controller service: a warehouse's fleet manager (any language)
//! reports, every control cycle, where each robot stands and where it must
//! go; the service answers with every robot's next move, chosen by any
//! controller of the project's grammar ([`buridan_eval::by_name`]) — a
//! planner (`pibt`, `lacam`: replanned when robots lag or goals change) or
//! a trained policy through the collision shield
//! (`shield-lanes=16:checkpoint:model:rm-2.1`). The API is
//! `proto/buridan/v1/control.proto` (`buridan.v1.FleetControl`); each
//! session is a closed-loop [`buridan_eval::fleet::FleetSession`].
//!
//! ```text
//! client ──Open(map, rules, controller, positions, goals, seed)──▶ session id, agents
//!        ──Step(session, positions, goals)──▶ report checked ─▶ controller (blocking thread)
//!                                            ─▶ moves, per robot: shield changed it?
//!        ──Close(session)──▶ steps answered
//! ```
//!
//! Bad input gets a status that names robot, cell and problem, and the
//! session keeps working: `INVALID_ARGUMENT` (a robot on a wall or off the
//! map, two on one cell, a jump of more than one cell, a goal on a wall, a
//! wrong number of robots, an unknown map or controller), `NOT_FOUND` (a
//! session never opened, closed, expired or dropped), `RESOURCE_EXHAUSTED`
//! ([`ServeConfig::max_sessions`], [`ServeConfig::max_robots`]),
//! `UNAUTHENTICATED` (a token required and not sent). Controllers run on
//! tokio's blocking threads, never on the reactor; planners plan within
//! [`ServeConfig::plan_time`]. Prometheus series: [`metrics`].
//!
//! ```no_run
//! use buridan_control::{ControlServer, ServeConfig};
//! let server = ControlServer::start(ServeConfig::default(), "127.0.0.1:50071".parse().unwrap()).unwrap();
//! println!("serving on {}", server.url());
//! server.stop();
//! ```

#![warn(missing_docs)]

use std::path::PathBuf;
use std::time::Duration;

pub mod metrics;
mod server;
mod service;
pub mod sessions;

pub use server::{serve, ControlServer};
pub use service::ControlService;

/// Sessions open at once by default.
pub const DEFAULT_MAX_SESSIONS: usize = 64;
/// Robots per session by default.
pub const DEFAULT_MAX_ROBOTS: usize = 1024;
/// How long a session may go without a call by default.
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(300);
/// A planner's time for one plan by default.
pub const DEFAULT_PLAN_TIME: Duration = Duration::from_secs(1);
/// Steps a robot may wait off its goal before the metrics count it.
pub const DEFAULT_WAIT_ALARM: u32 = 100;
/// Largest message accepted or sent: a map's text and 10⁵ robots fit.
pub const DEFAULT_MAX_MESSAGE_BYTES: usize = 16 * 1024 * 1024;
/// How long calls in flight get to finish after the shutdown signal.
pub const DEFAULT_GRACE: Duration = Duration::from_secs(5);

/// Why the service could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// A setting is out of range.
    #[error("invalid setting: {0}")]
    Config(String),
    /// The server could not start or failed (runtime, address, TLS,
    /// transport).
    #[error(transparent)]
    Server(#[from] buridan_serving::ServerError),
}

/// What the service allows and how it is reached.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// Sessions open at once; an Open beyond gets RESOURCE_EXHAUSTED.
    pub max_sessions: usize,
    /// Robots per session; an Open with more gets RESOURCE_EXHAUSTED.
    pub max_robots: usize,
    /// A session without a call for this long ends (NOT_FOUND after).
    pub idle_timeout: Duration,
    /// A planner's time for one plan (at Open and at each replan): a
    /// planner that finds none in time leaves the robots waiting a step.
    pub plan_time: Duration,
    /// Robots off their goal that have not moved for more than this many
    /// consecutive steps are counted ([`metrics::WAITING`]).
    pub wait_alarm: u32,
    /// Whether controllers may load checkpoints from directories on the
    /// server (`checkpoint:DIR`); otherwise only bundled models
    /// (`checkpoint:model:NAME`).
    pub allow_checkpoint_dirs: bool,
    /// If set, every call must carry `authorization: Bearer <token>`.
    pub token: Option<String>,
    /// PEM certificate and key: serve TLS instead of plain HTTP/2.
    pub tls: Option<(PathBuf, PathBuf)>,
    /// Largest message accepted or sent, bytes.
    pub max_message_bytes: usize,
    /// How long calls in flight get after the shutdown signal.
    pub grace: Duration,
}

impl Default for ServeConfig {
    fn default() -> Self {
        Self {
            max_sessions: DEFAULT_MAX_SESSIONS,
            max_robots: DEFAULT_MAX_ROBOTS,
            idle_timeout: DEFAULT_IDLE_TIMEOUT,
            plan_time: DEFAULT_PLAN_TIME,
            wait_alarm: DEFAULT_WAIT_ALARM,
            allow_checkpoint_dirs: false,
            token: None,
            tls: None,
            max_message_bytes: DEFAULT_MAX_MESSAGE_BYTES,
            grace: DEFAULT_GRACE,
        }
    }
}

impl ServeConfig {
    /// Refuses settings that cannot work: zero limits, an empty token.
    ///
    /// ```
    /// use buridan_control::ServeConfig;
    /// assert!(ServeConfig::default().check().is_ok());
    /// let empty = ServeConfig { token: Some(String::new()), ..ServeConfig::default() };
    /// assert!(empty.check().unwrap_err().to_string().contains("token"));
    /// ```
    pub fn check(&self) -> Result<(), ServeError> {
        let bad = |what: &str| Err(ServeError::Config(what.to_string()));
        if self.max_sessions == 0 {
            return bad("max_sessions must be at least 1");
        }
        if self.max_robots == 0 {
            return bad("max_robots must be at least 1");
        }
        if self.idle_timeout.is_zero() {
            return bad("the idle timeout must be positive");
        }
        if self.plan_time.is_zero() {
            return bad("the planning time must be positive");
        }
        if self.max_message_bytes < 1024 {
            return bad("max_message_bytes must be at least 1024");
        }
        if self.token.as_deref() == Some("") {
            return bad("an empty token would accept everyone; leave it out instead");
        }
        Ok(())
    }
}
