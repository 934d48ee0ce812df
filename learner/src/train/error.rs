//! What can end a training run, as data: each failure keeps its cause as
//! `source`, so a caller matches on the variant and a report prints the
//! whole chain (`{:#}` with anyhow, or walking `Error::source`).

use std::path::PathBuf;

use buridan_actor::CollectError;
use buridan_env::{EnvError, MapError};
use buridan_policy::PolicyError;

use crate::algo::AlgoError;
use crate::train::config::ConfigError;
use crate::train::metrics::MetricsError;

/// Why a run failed or stopped before its step budget.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The configuration is unusable.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The map cannot be loaded.
    #[error(transparent)]
    Map(#[from] MapError),
    /// The envs cannot be built.
    #[error("cannot build the envs")]
    Env(#[from] EnvError),
    /// The policy cannot be built, saved or restored.
    #[error("policy")]
    Policy(#[from] PolicyError),
    /// The run's `device` cannot be opened (a GPU in a default build, or
    /// none with that ordinal).
    #[error("cannot train on the device the run names")]
    Device(#[source] PolicyError),
    /// A checkpoint to resume from does not fit this run.
    #[error("cannot resume from {}", dir.display())]
    Resume {
        /// The checkpoint.
        dir: PathBuf,
        /// Why.
        source: PolicyError,
    },
    /// Imitating the planner failed.
    #[error("imitation")]
    Imitation(#[source] Box<buridan_imitate::ImitationError>),
    /// The held-out greedy check of `[stop.greedy]` could not play its
    /// episodes.
    #[error("the greedy check on held-out episodes failed")]
    GreedyCheck {
        /// Why.
        source: CollectError,
    },
    /// A learner update failed.
    #[error("learner update")]
    Update(#[from] AlgoError),
    /// A file or directory of the run cannot be read or written.
    #[error("{action} {}", path.display())]
    Io {
        /// What was being done ("cannot write", "cannot create", …).
        action: &'static str,
        /// The path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A checkpoint's trainer state is unreadable.
    #[error("{} is not a trainer state", path.display())]
    TrainerState {
        /// The file.
        path: PathBuf,
        /// What the JSON parser says.
        source: serde_json::Error,
    },
    /// The optimiser state of a checkpoint cannot be saved or restored.
    #[error("optimiser state {}", path.display())]
    Optimizer {
        /// The file.
        path: PathBuf,
        /// What candle says.
        source: candle_core::Error,
    },
    /// `metrics.csv` cannot be written.
    #[error(transparent)]
    Metrics(#[from] MetricsError),
    /// The TensorBoard event file cannot be written.
    #[error(transparent)]
    Events(#[from] crate::train::tensorboard::EventsError),
    /// The actors or the transport to them failed.
    #[error(transparent)]
    Exchange(#[from] ExchangeError),
    /// The run was interrupted; its state is in a checkpoint.
    #[error(transparent)]
    Interrupted(#[from] Interrupted),
    /// Interrupted, and the checkpoint on the way out failed too.
    #[error("interrupted after update {updates}, and the checkpoint failed")]
    InterruptedWithoutCheckpoint {
        /// Updates done.
        updates: u64,
        /// Why the checkpoint failed.
        source: Box<TrainError>,
    },
}

impl TrainError {
    /// An I/O failure on `path`.
    pub fn io(action: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        TrainError::Io {
            action,
            path: path.into(),
            source,
        }
    }
}

/// Why the learner lost its actors (in-process threads or gRPC sessions).
#[derive(Debug, thiserror::Error)]
pub enum ExchangeError {
    /// An in-process actor failed; `source` says why.
    #[error("actor {actor} failed")]
    Actor {
        /// The actor's id.
        actor: u32,
        /// Its own error.
        source: CollectError,
    },
    /// An in-process actor panicked.
    #[error("actor {actor} panicked")]
    ActorPanicked {
        /// The actor's id.
        actor: u32,
    },
    /// An embedded run needs at least one actor.
    #[error("at least one actor is needed")]
    NoActors,
    /// The OS refused a thread.
    #[error("cannot start an actor thread")]
    Spawn(#[source] std::io::Error),
    /// The fragment queue closed under the learner (the server stopped).
    #[error("the fragment queue closed")]
    QueueClosed,
}

/// The run was interrupted (`Run::interrupt_on`); its last state is in the
/// named checkpoint.
#[derive(Debug, thiserror::Error)]
#[error("interrupted after update {updates}; resume with --resume {}", checkpoint.display())]
pub struct Interrupted {
    /// Updates done.
    pub updates: u64,
    /// The checkpoint written on the way out.
    pub checkpoint: PathBuf,
}
