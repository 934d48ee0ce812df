//! `buridan._buridan`: the native module of the `buridan` Python package.
//!
//! The Python-facing API lives in `python/buridan/` (PettingZoo, Gymnasium
//! and RLlib adapters over these classes); this crate binds the Rust crates:
//!
//! - [`env`]: `Map`, `GridEnv`, `VecEnv` (`buridan-env`);
//! - [`planners`]: `plan`, `Plan`, `evaluate`, `EvalReport` (`buridan-mapf`,
//!   `buridan-eval`);
//! - [`policy`]: `Policy`, trained checkpoints for inference (`buridan-policy`);
//! - [`errors`]: the crates' typed errors as Python exceptions.

use pyo3::prelude::*;

pub mod env;
pub mod errors;
pub mod planners;
pub mod policy;

/// A serialisable value as Python data (through JSON: the same field names
/// as the CLI's JSON output).
pub fn to_py<T: serde::Serialize + ?Sized>(py: Python<'_>, value: &T) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(value)
        .map_err(|e| errors::BuridanError::new_err(format!("cannot serialise: {e}")))?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

#[pymodule]
fn _buridan(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<env::PyMap>()?;
    m.add_class::<env::PyGridEnv>()?;
    m.add_class::<env::PyVecEnv>()?;
    m.add_class::<planners::PyPlan>()?;
    m.add_class::<planners::PyEvalReport>()?;
    m.add_class::<policy::PyPolicy>()?;
    m.add_function(wrap_pyfunction!(env::reference_models, m)?)?;
    m.add_function(wrap_pyfunction!(planners::planner_names, m)?)?;
    m.add_function(wrap_pyfunction!(planners::plan, m)?)?;
    m.add_function(wrap_pyfunction!(planners::evaluate, m)?)?;
    m.add("NUM_ACTIONS", buridan_env::NUM_ACTIONS)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
