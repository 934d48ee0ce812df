//! The crates' typed errors as Python exceptions, with the same messages.
//!
//! Every exception derives from `buridan.BuridanError`; the message is the
//! Rust error's `Display` (a malformed map names `file:line: problem`), and
//! the exception's `__cause__` chain is not needed because the messages
//! already carry their causes.

use pyo3::exceptions::PyException;
use pyo3::prelude::*;

pyo3::create_exception!(
    buridan,
    BuridanError,
    PyException,
    "Base class of every error raised by the buridan package."
);
pyo3::create_exception!(
    buridan,
    MapError,
    BuridanError,
    "A map or scenario could not be loaded: unreadable file, malformed text (`file:line: problem`; attributes `file`, `line`, `problem`) or an unknown reference model id."
);
pyo3::create_exception!(
    buridan,
    EnvError,
    BuridanError,
    "The environment was configured or driven incorrectly: bad agent counts, actions outside 0..5, wrong action shapes, stepping a finished episode."
);
pyo3::create_exception!(
    buridan,
    PlannerError,
    BuridanError,
    "A planner name is unknown, or the planner cannot plan under the env's rule set."
);
pyo3::create_exception!(
    buridan,
    SolveError,
    BuridanError,
    "A planner did not solve the instance: time, memory or node limit, no solution, or a bad instance."
);
pyo3::create_exception!(
    buridan,
    PolicyError,
    BuridanError,
    "A policy checkpoint could not be loaded, built or run."
);

/// `MapError`, with `file`, `line` and `problem` attributes for parse errors
/// and `path` for unreadable files.
pub fn map_err(py: Python<'_>, e: buridan_env::MapError) -> PyErr {
    let err = MapError::new_err(e.to_string());
    let value = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail in practice;
    // if it did, the message still says everything.
    let _ = match &e {
        buridan_env::MapError::Parse {
            file,
            line,
            problem,
        } => value
            .setattr("file", file)
            .and_then(|_| value.setattr("line", *line))
            .and_then(|_| value.setattr("problem", problem)),
        buridan_env::MapError::Io { path, .. } => value.setattr("path", path.clone()),
        buridan_env::MapError::UnknownMap { name, .. } => value.setattr("name", name),
        buridan_env::MapError::Spec(e) => value.setattr("name", &e.spec),
    };
    err
}

/// `EnvError` with the env's message.
pub fn env_err(e: buridan_env::EnvError) -> PyErr {
    EnvError::new_err(e.to_string())
}

/// `PlannerError` with the lookup's message.
pub fn planner_err(e: buridan_mapf::PlannerLookupError) -> PyErr {
    PlannerError::new_err(e.to_string())
}

/// `SolveError` with the planner's message.
pub fn solve_err(e: buridan_mapf::SolveError) -> PyErr {
    SolveError::new_err(e.to_string())
}

/// `PolicyError` with the policy crate's message.
pub fn policy_err(e: buridan_policy::PolicyError) -> PyErr {
    PolicyError::new_err(e.to_string())
}

/// Registers the exception classes on the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("BuridanError", py.get_type::<BuridanError>())?;
    m.add("MapError", py.get_type::<MapError>())?;
    m.add("EnvError", py.get_type::<EnvError>())?;
    m.add("PlannerError", py.get_type::<PlannerError>())?;
    m.add("SolveError", py.get_type::<SolveError>())?;
    m.add("PolicyError", py.get_type::<PolicyError>())?;
    Ok(())
}
