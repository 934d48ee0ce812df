//! Trained policies: `learner train` checkpoints loaded for inference
//! (`buridan_policy::checkpoint`, `buridan_policy::Inference`).

use std::path::PathBuf;

use buridan_env::NUM_ACTIONS;
use buridan_policy::{checkpoint, ActMode, Inference, LstmSpec, Mode, ModelSpec, Policy};
use numpy::ndarray::Array2;
use numpy::{
    Element, IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::env::{features_arg, rules_arg, PyGridEnv};
use crate::errors::{env_err, policy_err, PolicyError as PyPolicyError};
use crate::to_py;

/// A policy network (MLP or LSTM, masked categorical heads) for inference.
///
/// `Policy.load(path)` reads a `learner train` checkpoint: a checkpoint
/// directory (`spec.json` + `model.safetensors`) or a run directory (its
/// `checkpoints/final`, else its newest `checkpoints/update-*`).
/// `model.safetensors` is plain safetensors: PyTorch reads it too
/// (`safetensors.torch.load_file`).
#[pyclass(name = "Policy", module = "buridan._buridan")]
pub struct PyPolicy {
    inference: Inference,
    seed: u64,
    dir: Option<PathBuf>,
    actions: Vec<u8>,
    logp: Vec<f32>,
}

fn parse_mode(mode: &str) -> PyResult<Mode> {
    mode.parse::<Mode>()
        .map_err(|e| PyPolicyError::new_err(format!("invalid model spec: {e}")))
}

/// An array of `T`, NumPy's `dtype` (any other dtype or a sequence is
/// converted: float32 from any float, uint8 from any integer or bool).
fn typed_array<'py, T: Element>(
    obj: &Bound<'py, PyAny>,
    dtype: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, T>> {
    if let Ok(a) = obj.extract::<PyReadonlyArrayDyn<'py, T>>() {
        return Ok(a);
    }
    let np = obj.py().import("numpy")?;
    np.call_method1("ascontiguousarray", (obj, dtype))?
        .extract()
}

/// A float32 array (any float dtype or sequence is converted).
fn f32_array<'py>(obj: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArrayDyn<'py, f32>> {
    typed_array(obj, "float32")
}

/// A uint8 mask array (any integer/bool dtype or sequence is converted).
fn u8_array<'py>(obj: &Bound<'py, PyAny>) -> PyResult<PyReadonlyArrayDyn<'py, u8>> {
    typed_array(obj, "uint8")
}

/// `(actions, logp, logits)` of `Policy.act`.
type Acted<'py> = (
    Bound<'py, PyArray2<u8>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray2<f32>>,
);

impl PyPolicy {
    fn from_policy(policy: Policy, rows: usize, seed: u64, dir: Option<PathBuf>) -> Self {
        Self {
            inference: Inference::new(policy, rows, seed),
            seed,
            dir,
            actions: Vec::new(),
            logp: Vec::new(),
        }
    }

    fn spec(&self) -> &ModelSpec {
        self.inference.policy().spec()
    }

    /// Makes the inference batch `rows` rows (a fresh copy of the weights;
    /// a recurrent state starts over).
    fn ensure_rows(&mut self, rows: usize) -> PyResult<()> {
        if self.inference.rows() == rows {
            return Ok(());
        }
        let spec = self.spec().clone();
        let fresh = Policy::new(spec, 0).map_err(policy_err)?;
        fresh
            .copy_from(self.inference.policy())
            .map_err(policy_err)?;
        self.inference = Inference::new(fresh, rows, self.seed);
        Ok(())
    }

    fn run<'py>(
        &mut self,
        py: Python<'py>,
        obs: &[f32],
        masks: &[u8],
        rows: usize,
        greedy: bool,
    ) -> PyResult<Acted<'py>> {
        self.ensure_rows(rows)?;
        let heads = self.spec().heads;
        let w = self.spec().logits_dim();
        self.actions.resize(rows * heads, 0);
        self.logp.resize(rows, 0.0);
        let mode = if greedy {
            ActMode::Greedy
        } else {
            ActMode::Sample
        };
        let logits = self
            .inference
            .act(obs, masks, mode, &mut self.actions, &mut self.logp)
            .map_err(policy_err)?
            .to_vec();
        Ok((
            Array2::from_shape_vec((rows, heads), self.actions.clone())
                .expect("rows x heads")
                .into_pyarray(py),
            PyArray1::from_slice(py, &self.logp),
            Array2::from_shape_vec((rows, w), logits)
                .expect("rows x logits")
                .into_pyarray(py),
        ))
    }
}

#[pymethods]
impl PyPolicy {
    /// Loads a `learner train` checkpoint (a checkpoint or run directory);
    /// `seed` seeds sampled actions.
    #[staticmethod]
    #[pyo3(signature = (path, *, seed=0))]
    fn load(path: PathBuf, seed: u64) -> PyResult<Self> {
        let dir = checkpoint::resolve(&path).map_err(policy_err)?;
        let policy = Policy::load(&dir).map_err(policy_err)?;
        let rows = policy.spec().agents.max(1);
        Ok(Self::from_policy(policy, rows, seed, Some(dir)))
    }

    /// A freshly initialised policy (deterministic in `seed`), e.g. to save
    /// a tiny checkpoint for tests. `obs_dim=None` is the local observation
    /// of `sensor_range` (129 for 2) or, for `"cte"`, requires a value.
    #[staticmethod]
    #[pyo3(signature = (mode="ctde", agents=2, obs_dim=None, *, hidden=None, lstm_cells=None, sensor_range=2, features=Vec::new(), rules="thesis", seed=0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        mode: &str,
        agents: usize,
        obs_dim: Option<usize>,
        hidden: Option<Vec<usize>>,
        lstm_cells: Option<usize>,
        sensor_range: usize,
        features: Vec<String>,
        rules: &str,
        seed: u64,
    ) -> PyResult<Self> {
        let mode = parse_mode(mode)?;
        let features = features_arg(&features)?;
        let obs_dim = match (obs_dim, mode) {
            (Some(d), _) => d,
            (None, Mode::Cte) => {
                return Err(PyValueError::new_err(
                    "a CTE policy needs obs_dim (the central observation's size)",
                ))
            }
            (None, _) => {
                buridan_env::local_obs_dim(sensor_range) + features.extra_dim(sensor_range)
            }
        };
        let mut spec = ModelSpec::new(mode, agents, obs_dim);
        if let Some(h) = hidden {
            spec.hidden = h;
        }
        if let Some(cells) = lstm_cells {
            spec.lstm = Some(LstmSpec {
                cells,
                ..LstmSpec::default()
            });
        }
        spec.sensor_range = sensor_range;
        spec.features = features;
        spec.rules = rules_arg(rules)?;
        let policy = Policy::new(spec, seed).map_err(policy_err)?;
        Ok(Self::from_policy(policy, agents.max(1), seed, None))
    }

    /// Saves `spec.json` and `model.safetensors` into `dir` (the layout of a
    /// `learner train` checkpoint's policy).
    fn save(&self, dir: PathBuf) -> PyResult<()> {
        self.inference.policy().save(&dir).map_err(policy_err)
    }

    /// Chooses actions for a batch of observation rows.
    ///
    /// `obs` is `(rows, obs_dim)` float32, `masks` `(rows, heads·5)` (1 =
    /// legal). Returns `(actions, logp, logits)`: `(rows, heads)` uint8,
    /// the joint log-probability `(rows,)` and the raw logits `(rows,
    /// heads·5)`. `greedy=False` samples. A recurrent policy's state
    /// advances; call `observe` after the env step.
    #[pyo3(signature = (obs, masks, *, greedy=true))]
    fn act<'py>(
        &mut self,
        py: Python<'py>,
        obs: &Bound<'py, PyAny>,
        masks: &Bound<'py, PyAny>,
        greedy: bool,
    ) -> PyResult<Acted<'py>> {
        let obs = f32_array(obs)?;
        let masks = u8_array(masks)?;
        let d = self.spec().obs_dim;
        let rows = match obs.shape() {
            [r, dd] if *dd == d && *r > 0 => *r,
            [n] if *n % d == 0 && *n > 0 => *n / d,
            shape => {
                return Err(PyPolicyError::new_err(format!(
                    "observations: expected shape (rows >= 1, {d}), got {shape:?}"
                )))
            }
        };
        let obs = obs
            .as_slice()
            .map(<[f32]>::to_vec)
            .unwrap_or_else(|_| obs.as_array().iter().copied().collect());
        let masks = masks
            .as_slice()
            .map(<[u8]>::to_vec)
            .unwrap_or_else(|_| masks.as_array().iter().copied().collect());
        self.run(py, &obs, &masks, rows, greedy)
    }

    /// Chooses every agent's action in `env` (a `GridEnv` built with this
    /// policy's `env_kwargs()`): local observations for CTDE/DTE, the
    /// central one for CTE. Returns `(agents,)` uint8.
    #[pyo3(signature = (env, *, greedy=true))]
    fn act_env<'py>(
        &mut self,
        py: Python<'py>,
        env: PyRef<'py, PyGridEnv>,
        greedy: bool,
    ) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let env = env.inner();
        let spec = self.spec().clone();
        let n = env.agents();
        let (obs, masks, rows) = if spec.mode == Mode::Cte {
            let mut obs = vec![0.0; env.central_obs_dim()];
            let mut masks = vec![0u8; n * NUM_ACTIONS];
            env.write_central_obs(&mut obs).map_err(env_err)?;
            env.write_joint_mask(&mut masks).map_err(env_err)?;
            (obs, masks, 1)
        } else {
            let d = env.local_obs_dim();
            let mut obs = vec![0.0; n * d];
            let mut masks = vec![0u8; n * NUM_ACTIONS];
            for (i, (o, m)) in obs
                .chunks_mut(d)
                .zip(masks.chunks_mut(NUM_ACTIONS))
                .enumerate()
            {
                env.write_local_obs(i, o).map_err(env_err)?;
                env.write_action_mask(i, m).map_err(env_err)?;
            }
            (obs, masks, n)
        };
        if obs.len() != rows * spec.obs_dim {
            return Err(PyPolicyError::new_err(format!(
                "the env's observations have {} floats per row, the policy reads {}: build the env with policy.env_kwargs()",
                obs.len() / rows,
                spec.obs_dim
            )));
        }
        let (actions, _, _) = self.run(py, &obs, &masks, rows, greedy)?;
        actions.reshape([n])
    }

    /// For recurrent policies: after an env step, remembers the executed
    /// `actions (rows, heads)` and `rewards (rows,)` and resets the rows
    /// whose episode ended (`done (rows,)`). No-op for MLPs.
    fn observe(
        &mut self,
        actions: &Bound<'_, PyAny>,
        rewards: &Bound<'_, PyAny>,
        done: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let actions = u8_array(actions)?
            .as_array()
            .iter()
            .copied()
            .collect::<Vec<_>>();
        let rewards = f32_array(rewards)?
            .as_array()
            .iter()
            .copied()
            .collect::<Vec<_>>();
        let done = u8_array(done)?
            .as_array()
            .iter()
            .copied()
            .collect::<Vec<_>>();
        let (rows, heads) = (self.inference.rows(), self.spec().heads);
        if let Some(state) = self.inference.state_mut() {
            for (what, expected, got) in [
                ("actions", rows * heads, actions.len()),
                ("rewards", rows, rewards.len()),
                ("done", rows, done.len()),
            ] {
                if expected != got {
                    return Err(PyPolicyError::new_err(format!(
                        "{what}: expected {expected} values, got {got}"
                    )));
                }
            }
            state.observe(&actions, &rewards, &done);
        }
        Ok(())
    }

    /// Resets the recurrent state of every row (an episode start).
    fn reset_state(&mut self) {
        let rows = self.inference.rows();
        if let Some(state) = self.inference.state_mut() {
            for r in 0..rows {
                state.reset_row(r);
            }
        }
    }

    /// The model spec (`spec.json`) as a dict.
    #[getter]
    fn spec_dict(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_py(py, self.spec())
    }

    /// `"cte"`, `"ctde"` or `"dte"`.
    #[getter]
    fn mode(&self) -> String {
        self.spec().mode.to_string()
    }

    /// Agents the policy was trained with.
    #[getter]
    fn agents(&self) -> usize {
        self.spec().agents
    }

    /// Floats per observation row.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.spec().obs_dim
    }

    /// Categorical heads per row (agents for CTE, else 1).
    #[getter]
    fn heads(&self) -> usize {
        self.spec().heads
    }

    /// Whether the policy has an LSTM.
    #[getter]
    fn recurrent(&self) -> bool {
        self.spec().is_recurrent()
    }

    /// Number of trainable parameters.
    #[getter]
    fn num_params(&self) -> usize {
        self.inference.policy().num_params()
    }

    /// The checkpoint directory it was loaded from, if any.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.dir.clone()
    }

    /// The env settings the policy reads (`sensor_range`, `features`,
    /// `rules`), as keyword arguments for `GridEnv`/`VecEnv`/`ParallelEnv`.
    fn env_kwargs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let spec = self.spec();
        let d = pyo3::types::PyDict::new(py);
        d.set_item("sensor_range", spec.sensor_range)?;
        d.set_item("features", spec.features.names())?;
        d.set_item("rules", spec.rules.name())?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let s = self.spec();
        format!(
            "Policy(mode={}, agents={}, obs_dim={}, hidden={:?}, lstm={}, params={})",
            s.mode,
            s.agents,
            s.obs_dim,
            s.hidden,
            s.lstm.map_or("none".to_string(), |l| l.cells.to_string()),
            self.inference.policy().num_params()
        )
    }
}
