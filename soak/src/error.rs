//! Why a soak could not run, or failed.

use std::path::PathBuf;

use buridan_actor::client::ActorError;
use buridan_experiment::resolve::ResolveError;

/// Why a soak could not run, or what it found wrong.
#[derive(Debug, thiserror::Error)]
pub enum SoakError {
    /// A flag the soak cannot run with.
    #[error("{0}")]
    Flag(&'static str),
    /// `--out` holds an earlier soak (its CSV and run would be appended to).
    #[error("{} already holds a soak run; choose another --out", .0.display())]
    OutTaken(PathBuf),
    /// The learner's config and overrides do not resolve.
    #[error(transparent)]
    Config(#[from] ResolveError),
    /// No `actor` executable where it was looked for.
    #[error("no actor executable at {} (build it: cargo build --release -p buridan-actor, or pass --actor-exe)", .0.display())]
    NoActor(PathBuf),
    /// The learner ended before it listened.
    #[error("the learner ended with {status} before listening; see {}", .log.display())]
    LearnerEnded {
        /// How it ended.
        status: std::process::ExitStatus,
        /// Its log.
        log: PathBuf,
    },
    /// The learner did not listen in time.
    #[error("the learner did not listen within 300 s")]
    LearnerSilent,
    /// The misbehaving client could not start.
    #[error(transparent)]
    Misbehaver(#[from] ActorError),
    /// A file or a process could not be made, read or watched.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The error.
        source: std::io::Error,
    },
    /// `soak.csv` could not be written.
    #[error("soak.csv: {0}")]
    Csv(#[from] csv::Error),
    /// `soak.json` could not be written.
    #[error("writing soak.json: {0}")]
    Json(#[from] serde_json::Error),
    /// The soak ran, and a check failed.
    #[error("the soak failed: {} (see {})", .failures.join("; "), .out.display())]
    Failed {
        /// Every check that failed.
        failures: Vec<String>,
        /// The soak's output directory.
        out: PathBuf,
    },
}

impl SoakError {
    /// An I/O error while doing `what`.
    pub(crate) fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> Self {
        let what = what.into();
        move |source| Self::Io { what, source }
    }
}

/// Why `/metrics` could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ScrapeError {
    /// The connection or the read failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The reply has no HTTP header.
    #[error("no HTTP header in the metrics reply")]
    NoHeader,
    /// The endpoint answered something other than 200.
    #[error("metrics endpoint answered {0}")]
    Status(String),
}
