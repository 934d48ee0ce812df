//! `VecEnv`: a batch of grid envs with auto-reset whose buffers NumPy sees
//! without copies.

use buridan_env::{BatchedEnv, Cell, EnvError, GridEnv, ObsKind, VecEnv};
use numpy::ndarray::{ArrayView, IxDyn};
use numpy::{Element, IntoPyArray, PyArray1, PyArray3, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;

use super::args::{config, read_actions};
use super::map::{map_arg, PyMap};
use crate::errors::{env_err, EnvError as PyEnvError};
use crate::to_py;

/// `num_envs` grid envs stepped as one batch with auto-reset; env `e` plays
/// episodes `e, e + N, e + 2N, …`.
///
/// `obs`, `final_obs`, `masks`, `rewards`, `terminated` and `truncated` are
/// read-only NumPy views of the batch's own buffers: no copy is made, and
/// every `step` overwrites them in place (copy what you keep).
#[pyclass(name = "VecEnv", module = "buridan._buridan")]
pub struct PyVecEnv {
    venv: VecEnv,
    actions: Vec<u8>,
}

/// A read-only NumPy view of the buffer `data` picks from `owner`'s batch,
/// in the shape `shape` gives.
///
/// # Safety
/// `data` must pick a buffer that the `VecEnv` never reallocates while
/// `owner` is alive (its step buffers are sized once).
unsafe fn view<'py, T: Element, const D: usize>(
    owner: &Bound<'py, PyVecEnv>,
    data: fn(&VecEnv) -> &[T],
    shape: fn(&PyVecEnv) -> [usize; D],
) -> Bound<'py, PyArrayDyn<T>> {
    let this = owner.borrow();
    let v = ArrayView::from_shape(IxDyn(&shape(&this)), data(&this.venv))
        .expect("shape matches the buffer");
    // SAFETY: the caller guarantees `data` stays valid while `owner` lives;
    // the array keeps `owner` alive as its base object.
    let arr = unsafe { PyArrayDyn::borrow_from_array(&v, owner.clone().into_any()) };
    arr.readwrite().make_nonwriteable();
    arr
}

#[pymethods]
impl PyVecEnv {
    #[new]
    #[pyo3(signature = (map, agents=4, num_envs=1, *, starts="random", seed=0, t_max=None, rules="thesis", sensor_range=2, features=Vec::new(), obs="local", threads=1))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        map: &Bound<'_, PyAny>,
        agents: usize,
        num_envs: usize,
        starts: &str,
        seed: u64,
        t_max: Option<u32>,
        rules: &str,
        sensor_range: usize,
        features: Vec<String>,
        obs: &str,
        threads: usize,
    ) -> PyResult<Self> {
        let map = map_arg(map)?;
        let cfg = config(
            agents,
            starts,
            seed,
            t_max,
            rules,
            sensor_range,
            &features,
            false,
        )?;
        let kind = match obs {
            "local" => ObsKind::Local,
            "central" => ObsKind::Central,
            other => {
                return Err(PyEnvError::new_err(format!(
                    "invalid configuration: unknown observation kind '{other}' (expected 'local' or 'central')"
                )))
            }
        };
        if threads == 0 {
            return Err(env_err(EnvError::InvalidConfig(
                "threads must be at least 1".into(),
            )));
        }
        let venv = VecEnv::new(map, cfg, num_envs, kind, threads).map_err(env_err)?;
        Ok(Self {
            venv,
            actions: Vec::with_capacity(num_envs * agents),
        })
    }

    /// Steps every env with `actions` (`(num_envs, agents)` or flat, any
    /// integer dtype; uint8 is read in place). The views are updated in place.
    fn step(&mut self, actions: &Bound<'_, PyAny>) -> PyResult<()> {
        read_actions(
            actions,
            Some(self.venv.num_envs()),
            self.venv.agents(),
            &mut self.actions,
        )?;
        self.venv.step(&self.actions).map_err(env_err)
    }

    /// Observations to act on, `(num_envs, rows_per_env, obs_dim)` float32
    /// (a read-only view; after an episode ended, the next one's first).
    #[getter]
    fn obs<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<f32>> {
        // SAFETY: VecEnv sizes its buffers once, at construction.
        unsafe { view(slf, VecEnv::obs, |this| this.row_shape(this.venv.obs_dim())) }
    }

    /// Last observations of the episodes that ended in the last step (rows
    /// of other envs are stale), same shape as `obs`.
    #[getter]
    fn final_obs<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<f32>> {
        // SAFETY: as in `obs`.
        unsafe {
            view(slf, VecEnv::final_obs, |this| {
                this.row_shape(this.venv.obs_dim())
            })
        }
    }

    /// Action masks, `(num_envs, rows_per_env, mask_dim)` uint8 (read-only view).
    #[getter]
    fn masks<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<u8>> {
        // SAFETY: as in `obs`.
        unsafe {
            view(slf, VecEnv::masks, |this| {
                this.row_shape(this.venv.mask_dim())
            })
        }
    }

    /// Rewards of the last step, `(num_envs, agents)` float32 (read-only view).
    #[getter]
    fn rewards<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<f32>> {
        // SAFETY: as in `obs`.
        unsafe {
            view(slf, VecEnv::rewards, |this| {
                [this.venv.num_envs(), this.venv.agents()]
            })
        }
    }

    /// Per env, 1 if the last step ended the episode with every agent home
    /// (`(num_envs,)` uint8 read-only view).
    #[getter]
    fn terminated<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<u8>> {
        // SAFETY: as in `obs`.
        unsafe { view(slf, VecEnv::terminated, |this| [this.venv.num_envs()]) }
    }

    /// Per env, 1 if the last step ended the episode at `T_max`
    /// (`(num_envs,)` uint8 read-only view).
    #[getter]
    fn truncated<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<u8>> {
        // SAFETY: as in `obs`.
        unsafe { view(slf, VecEnv::truncated, |this| [this.venv.num_envs()]) }
    }

    /// Statistics of the episodes finished since the last call, as dicts.
    fn drain_episodes(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_py(py, &self.venv.drain_episodes())
    }

    /// Agents' cells, `(num_envs, agents, 2)` int64 (a copy).
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<i64>> {
        self.cells_of(py, GridEnv::positions)
    }

    /// Agents' goals, `(num_envs, agents, 2)` int64 (a copy).
    fn goals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<i64>> {
        self.cells_of(py, GridEnv::goals)
    }

    /// The episode index each env is playing, `(num_envs,)` uint64.
    fn episodes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u64>> {
        let v: Vec<u64> = self.venv.envs().iter().map(GridEnv::episode).collect();
        v.into_pyarray(py)
    }

    /// Number of envs.
    #[getter]
    fn num_envs(&self) -> usize {
        self.venv.num_envs()
    }

    /// Agents per env.
    #[getter]
    fn agents(&self) -> usize {
        self.venv.agents()
    }

    /// Floats per observation row.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.venv.obs_dim()
    }

    /// Mask bytes per row (5 local, 5n central).
    #[getter]
    fn mask_dim(&self) -> usize {
        self.venv.mask_dim()
    }

    /// Rows per env: agents (local observations) or 1 (central).
    #[getter]
    fn rows_per_env(&self) -> usize {
        self.venv.rows_per_env()
    }

    /// `"local"` or `"central"`.
    #[getter]
    fn kind(&self) -> &'static str {
        match self.venv.kind() {
            ObsKind::Local => "local",
            ObsKind::Central => "central",
        }
    }

    /// Truncation step count.
    #[getter]
    fn t_max(&self) -> u32 {
        self.venv.envs()[0].config().t_max
    }

    /// The map.
    #[getter]
    fn map(&self) -> PyMap {
        PyMap {
            map: self.venv.envs()[0].map().clone(),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "VecEnv('{}', agents={}, num_envs={}, obs={})",
            self.venv.envs()[0].map().name,
            self.venv.agents(),
            self.venv.num_envs(),
            self.kind()
        )
    }
}

impl PyVecEnv {
    /// The shape of a per-row buffer `width` wide: `(num_envs,
    /// rows_per_env, width)`.
    fn row_shape(&self, width: usize) -> [usize; 3] {
        [self.venv.num_envs(), self.venv.rows_per_env(), width]
    }

    fn cells_of<'py>(
        &self,
        py: Python<'py>,
        f: impl Fn(&GridEnv) -> Vec<Cell>,
    ) -> Bound<'py, PyArray3<i64>> {
        let (e, n) = (self.venv.num_envs(), self.venv.agents());
        let mut out = Vec::with_capacity(e * n * 2);
        for env in self.venv.envs() {
            for c in f(env) {
                out.push(c.row as i64);
                out.push(c.col as i64);
            }
        }
        numpy::ndarray::Array3::from_shape_vec((e, n, 2), out)
            .expect("envs x agents x 2")
            .into_pyarray(py)
    }
}
