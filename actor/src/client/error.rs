//! Why an actor stopped, could not connect, or could not set up a session.

use std::path::PathBuf;
use std::time::Duration;

use buridan_env::{EnvError, MapError};
use buridan_policy::PolicyError;
use buridan_proto::convert::ConvertError;
use tonic::Status;

use crate::collector::CollectError;
use crate::remote_env::RemoteEnvError;

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
    /// The model spec or the policy is inconsistent.
    #[error(transparent)]
    Policy(#[from] PolicyError),
    /// A field is missing or out of range (the run spec's fields among
    /// them).
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
