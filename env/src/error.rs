//! Errors of map loading and of the environment, as data.

use std::path::PathBuf;

/// A map or scenario could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// The file could not be read at all.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file that failed.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// The file was read but its content is malformed.
    #[error("{file}:{line}: {problem}")]
    Parse {
        /// File name (or `<bundled rm-x>` for an embedded model).
        file: String,
        /// 1-based line number of the problem.
        line: usize,
        /// What is wrong, in words.
        problem: String,
    },
    /// Neither a bundled reference model id nor an existing file.
    #[error("unknown map '{name}': not a file and not a reference model id (known ids: {known}; a generated map is named by its spec, e.g. maze/19x19/seed=0)")]
    UnknownMap {
        /// What the user asked for.
        name: String,
        /// The bundled ids, comma separated.
        known: String,
    },
    /// A generated map's spec that does not parse
    /// ([`crate::generate::GeneratedMap`]).
    #[error(transparent)]
    Spec(#[from] crate::generate::SpecError),
}

/// The environment was configured or driven incorrectly.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EnvError {
    /// An action index outside `0..5`.
    #[error(
        "agent {agent}: action {action} is outside 0..5 (0 stay, 1 up, 2 right, 3 down, 4 left)"
    )]
    InvalidAction {
        /// The agent whose action is wrong.
        agent: usize,
        /// The value given.
        action: u8,
    },
    /// The number of actions (or of buffer elements) does not match.
    #[error("expected {expected} {what}, got {got}")]
    WrongLength {
        /// What was counted ("actions", "observation floats", ...).
        what: &'static str,
        /// The length required.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// Fewer free cells than distinct starts and goals (or lifelong goal draws) require.
    #[error("map '{map}' has {free} free cells, but {agents} agents need {needed} (2 per agent for distinct starts and goals; agents + 1 for lifelong goal draws)")]
    TooFewFreeCells {
        /// Map name.
        map: String,
        /// Free cells on the map.
        free: usize,
        /// Number of agents requested.
        agents: usize,
        /// Cells required: 2 × agents for distinct starts and goals,
        /// agents + 1 for lifelong goal draws.
        needed: usize,
    },
    /// Fixed starts were requested but the map has no (or too short a) scenario.
    #[error("map '{map}' has fixed starts for {available} agents, {requested} requested")]
    NotEnoughFixedAgents {
        /// Map name.
        map: String,
        /// Agents in the `.scen` file.
        available: usize,
        /// Agents requested.
        requested: usize,
    },
    /// A start, goal or reported position lies on a wall or outside the
    /// grid.
    #[error("agent {agent}: {which} ({row}, {col}) is {problem}")]
    BadCell {
        /// Agent index.
        agent: usize,
        /// "start", "goal" or "position".
        which: &'static str,
        /// Row of the cell.
        row: usize,
        /// Column of the cell.
        col: usize,
        /// "a wall" or "outside the grid".
        problem: &'static str,
    },
    /// Two agents share a start, a goal or a reported position.
    #[error("agents {first} and {second} share the {which} cell ({row}, {col})")]
    SharedCell {
        /// Lower agent index.
        first: usize,
        /// Higher agent index.
        second: usize,
        /// "start", "goal" or "position".
        which: &'static str,
        /// Row of the shared cell.
        row: usize,
        /// Column of the shared cell.
        col: usize,
    },
    /// A goal of an agent's sequence ([`crate::GridEnv::reset_with_sequences`])
    /// lies on a wall or outside the grid.
    #[error("agent {agent}: goal {index} of its sequence ({row}, {col}) is {problem}")]
    BadSequenceGoal {
        /// Agent index.
        agent: usize,
        /// 0-based index of the goal in the agent's sequence.
        index: usize,
        /// Row of the cell.
        row: usize,
        /// Column of the cell.
        col: usize,
        /// "a wall" or "outside the grid".
        problem: &'static str,
    },
    /// An agent's goal sequence is empty.
    #[error("agent {agent}: its goal sequence is empty (it needs at least one goal)")]
    EmptySequence {
        /// Agent index.
        agent: usize,
    },
    /// Goal sequences were given to an env that is not in lifelong mode.
    #[error("goal sequences need lifelong mode (lifelong = true): without it an agent keeps its first goal")]
    SequencesNeedLifelong,
    /// A reported position more than one cell from the agent's last one
    /// ([`crate::GridEnv::report`]).
    #[error("agent {agent} moved from {from} to {to}: more than one cell in a step")]
    Jump {
        /// The agent.
        agent: usize,
        /// Its last position.
        from: crate::map::Cell,
        /// The position reported.
        to: crate::map::Cell,
    },
    /// A configuration value is out of its range.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// `step` was called on a finished episode without `reset`.
    #[error("the episode is over: call reset before stepping again")]
    EpisodeOver,
    /// An env served by another process (a simulator behind the env API,
    /// `env.proto`) failed: it could not be reached, it refused the call,
    /// or its reply did not fit its spec.
    #[error("remote env at {target}: {message}")]
    Remote {
        /// Where the env is served (its URL).
        target: String,
        /// Whether trying again on a new connection and session may help
        /// (the simulator went away or restarted, the session was
        /// dropped), as opposed to a refusal retrying cannot fix.
        retryable: bool,
        /// What happened, with the simulator's own words.
        message: String,
    },
}

impl EnvError {
    /// `Ok` if `got` is `expected`, else [`EnvError::WrongLength`] of `what`.
    ///
    /// ```
    /// use buridan_env::EnvError;
    /// assert!(EnvError::check_len("actions", 4, 4).is_ok());
    /// let e = EnvError::check_len("actions", 4, 3).unwrap_err();
    /// assert_eq!(e.to_string(), "expected 4 actions, got 3");
    /// ```
    pub fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), EnvError> {
        if expected == got {
            Ok(())
        } else {
            Err(EnvError::WrongLength {
                what,
                expected,
                got,
            })
        }
    }
}

/// The message of `e` and all its causes on one line, `a: b: c` — how the
/// binaries print a typed error whose causes are its `source` chain, for
/// places that carry errors as text (trial reports, Python exceptions).
///
/// ```
/// use buridan_env::error::error_chain;
/// #[derive(Debug)]
/// struct Loading(std::io::Error);
/// impl std::fmt::Display for Loading {
///     fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
///         write!(f, "loading rm-9")
///     }
/// }
/// impl std::error::Error for Loading {
///     fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
///         Some(&self.0)
///     }
/// }
/// let e = Loading(std::io::Error::other("no such map"));
/// assert_eq!(error_chain(&e), "loading rm-9: no such map");
/// ```
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}
