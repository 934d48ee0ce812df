//! Keyword arguments of the env classes: the env configuration, and
//! action arrays checked with the env's messages.

use buridan_env::{EnvConfig, EnvError, ObsFeatures, Rules, Starts, NUM_ACTIONS};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

use crate::errors::{env_err, EnvError as PyEnvError};

/// Observation features by name (`ObsFeatures::NAMES`: `"path"`,
/// `"priority"`, `"pressure"`, `"intent"`, `"order"`).
pub fn features_arg(names: &[String]) -> PyResult<ObsFeatures> {
    ObsFeatures::from_names(names)
        .map_err(|e| PyEnvError::new_err(format!("invalid configuration: {e}")))
}

pub fn rules_arg(rules: &str) -> PyResult<Rules> {
    rules
        .parse::<Rules>()
        .map_err(|e| PyEnvError::new_err(format!("invalid configuration: {e}")))
}

pub fn starts_arg(starts: &str) -> PyResult<Starts> {
    starts
        .parse::<Starts>()
        .map_err(|e| PyEnvError::new_err(format!("invalid configuration: {e}")))
}

/// An env configuration from keyword arguments; `t_max=None` is the rule
/// set's own (100 thesis, 128 pogema).
#[allow(clippy::too_many_arguments)]
pub fn config(
    agents: usize,
    starts: &str,
    seed: u64,
    t_max: Option<u32>,
    rules: &str,
    sensor_range: usize,
    features: &[String],
    lifelong: bool,
) -> PyResult<EnvConfig> {
    let rules = rules_arg(rules)?;
    let cfg = EnvConfig {
        agents,
        starts: starts_arg(starts)?,
        seed,
        t_max: t_max.unwrap_or(rules.default_t_max()),
        rules,
        sensor_range,
        features: features_arg(features)?,
        lifelong,
        ..EnvConfig::default()
    };
    cfg.validate().map_err(env_err)?;
    Ok(cfg)
}

/// Reads an action array (any integer dtype, or a sequence) of `rows`
/// rows of `agents` actions each (`(rows, agents)`, or flat
/// `(rows·agents,)`; `(agents,)` when `rows` is `None`) into `out`, with
/// the env's messages for bad lengths and values.
pub fn read_actions(
    obj: &Bound<'_, PyAny>,
    rows: Option<usize>,
    agents: usize,
    out: &mut Vec<u8>,
) -> PyResult<()> {
    let py = obj.py();
    let expected = rows.unwrap_or(1) * agents;
    // Fast path: a uint8 array is read in place.
    if let Ok(arr) = obj.extract::<PyReadonlyArrayDyn<'_, u8>>() {
        check_shape(arr.shape(), rows, agents, expected)?;
        out.clear();
        match arr.as_slice() {
            Ok(s) => out.extend_from_slice(s),
            Err(_) => out.extend(arr.as_array().iter().copied()),
        }
        return check_values(out.iter().map(|&a| i64::from(a)), agents);
    }
    let np = py.import("numpy")?;
    let arr = np.call_method1("asarray", (obj,))?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "i" | "u" | "b") {
        return Err(PyTypeError::new_err(format!(
            "actions must be integers in 0..5, got an array of dtype {}",
            arr.getattr("dtype")?.str()?
        )));
    }
    let arr = arr.call_method1("astype", ("int64",))?;
    let arr: PyReadonlyArrayDyn<'_, i64> = arr.extract()?;
    check_shape(arr.shape(), rows, agents, expected)?;
    let view = arr.as_array();
    check_values(view.iter().copied(), agents)?;
    out.clear();
    out.extend(view.iter().map(|&a| a as u8));
    Ok(())
}

fn check_shape(
    shape: &[usize],
    rows: Option<usize>,
    agents: usize,
    expected: usize,
) -> PyResult<()> {
    EnvError::check_len("actions", expected, shape.iter().product()).map_err(env_err)?;
    let ok = match (rows, shape) {
        (_, [_]) => true,
        (Some(r), [a, b]) => *a == r && *b == agents,
        _ => false,
    };
    if !ok {
        let want = match rows {
            Some(r) => format!("({r}, {agents}) or ({expected},)"),
            None => format!("({agents},)"),
        };
        return Err(PyEnvError::new_err(format!(
            "expected actions of shape {want}, got shape {shape:?}"
        )));
    }
    Ok(())
}

fn check_values(values: impl Iterator<Item = i64>, agents: usize) -> PyResult<()> {
    for (k, a) in values.enumerate() {
        if !(0..NUM_ACTIONS as i64).contains(&a) {
            let agent = k % agents;
            // The env's own message; values beyond u8 in the same words.
            let msg = match u8::try_from(a) {
                Ok(action) => EnvError::InvalidAction { agent, action }.to_string(),
                Err(_) => format!(
                    "agent {agent}: action {a} is outside 0..5 (0 stay, 1 up, 2 right, 3 down, 4 left)"
                ),
            };
            return Err(PyEnvError::new_err(msg));
        }
    }
    Ok(())
}
