//! `Map`, `GridEnv` (one env, the core of the PettingZoo `ParallelEnv`)
//! and `VecEnv` (a batch with auto-reset whose buffers NumPy sees without
//! copies).

use std::sync::Arc;

use buridan_env::{
    BatchedEnv, Cell, EnvConfig, EnvError, GridEnv, Map, MapSource, ObsFeatures, ObsKind, Rules,
    Starts, VecEnv, NUM_ACTIONS, REFERENCE_MODELS,
};
use numpy::ndarray::{Array2, ArrayView, IxDyn};
use numpy::{
    Element, IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayDyn, PyArrayMethods,
    PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

use crate::errors::{env_err, map_err, EnvError as PyEnvError};
use crate::to_py;

/// A grid layout: walls, free cells and (for reference models and maps with
/// a `.scen` beside them) fixed starts and goals.
///
/// `Map("rm-2.1")` loads a bundled reference model, `Map("path/to.map")` a
/// MovingAI `.map` file (and the `.scen` of the same stem beside it);
/// `Map.from_text(...)` parses text. Malformed text raises `MapError` whose
/// message names the file and line (`file:line: problem`).
#[pyclass(name = "Map", module = "buridan._buridan", frozen)]
pub struct PyMap {
    pub map: Arc<Map>,
}

#[pymethods]
impl PyMap {
    /// Loads a reference model id (`"rm-2.1"`) or a MovingAI `.map` path.
    #[new]
    fn new(py: Python<'_>, id_or_path: &Bound<'_, PyAny>) -> PyResult<Self> {
        let name = path_like(id_or_path)?;
        Ok(Self {
            map: Arc::new(Map::load(&name).map_err(|e| map_err(py, e))?),
        })
    }

    /// Parses MovingAI `.map` text (and optionally `.scen` text); errors name
    /// the map as `<name>.map` / `<name>.scen` with the line.
    #[staticmethod]
    #[pyo3(signature = (map_text, scen_text=None, name="text"))]
    fn from_text(
        py: Python<'_>,
        map_text: String,
        scen_text: Option<String>,
        name: &str,
    ) -> PyResult<Self> {
        let source = MapSource {
            name: name.to_string(),
            map_text,
            scen_text,
        };
        Ok(Self {
            map: Arc::new(source.parse().map_err(|e| map_err(py, e))?),
        })
    }

    /// The map's name (reference model id or file stem).
    #[getter]
    fn name(&self) -> &str {
        &self.map.name
    }

    /// Rows of the grid.
    #[getter]
    fn height(&self) -> usize {
        self.map.grid.height()
    }

    /// Columns of the grid.
    #[getter]
    fn width(&self) -> usize {
        self.map.grid.width()
    }

    /// Walls as a `(height, width)` bool array (a copy).
    #[getter]
    fn walls<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<bool>> {
        let g = &self.map.grid;
        Array2::from_shape_vec((g.height(), g.width()), g.walls().to_vec())
            .expect("walls are height x width")
            .into_pyarray(py)
    }

    /// Free cells as `(row, col)` tuples, row-major.
    #[getter]
    fn free_cells(&self) -> Vec<(usize, usize)> {
        cells(self.map.grid.free_cells())
    }

    /// The fixed scenario as `(starts, goals)` lists of `(row, col)`, or `None`.
    #[getter]
    fn scenario(&self) -> Option<(Cells, Cells)> {
        self.map
            .scenario
            .as_ref()
            .map(|s| (cells(&s.starts), cells(&s.goals)))
    }

    /// Shortest-path distances (steps) from every cell to `(row, col)` on
    /// the static layout, `(height, width)` uint16; 65535 = unreachable.
    fn distances_to<'py>(
        &self,
        py: Python<'py>,
        row: usize,
        col: usize,
    ) -> PyResult<Bound<'py, PyArray2<u16>>> {
        let g = &self.map.grid;
        let target = Cell::new(row, col);
        if !g.contains(target) {
            return Err(PyValueError::new_err(format!(
                "({row}, {col}) is outside the {}x{} grid",
                g.height(),
                g.width()
            )));
        }
        Ok(
            Array2::from_shape_vec((g.height(), g.width()), g.distances_to(target).to_vec())
                .expect("one distance per cell")
                .into_pyarray(py),
        )
    }

    fn __repr__(&self) -> String {
        format!(
            "Map('{}', {}x{}, {} free cells{})",
            self.map.name,
            self.map.grid.height(),
            self.map.grid.width(),
            self.map.grid.free_cells().len(),
            match &self.map.scenario {
                Some(s) => format!(", fixed scenario of {} agents", s.starts.len()),
                None => String::new(),
            }
        )
    }
}

/// The bundled reference models as `(id, description)` pairs.
#[pyfunction]
pub fn reference_models() -> Vec<(&'static str, &'static str)> {
    REFERENCE_MODELS
        .iter()
        .map(|m| (m.id, m.description))
        .collect()
}

/// Cells as `(row, col)` tuples.
pub type Cells = Vec<(usize, usize)>;

/// `cells` as `(row, col)` tuples.
pub fn cells(cells: &[Cell]) -> Cells {
    cells.iter().map(|c| (c.row, c.col)).collect()
}

/// A `str` or `os.PathLike` argument as text.
fn path_like(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(s) = obj.extract::<String>() {
        return Ok(s);
    }
    match obj.extract::<std::path::PathBuf>() {
        Ok(p) => Ok(p.to_string_lossy().into_owned()),
        Err(_) => Err(PyTypeError::new_err(format!(
            "expected a map id, a path or a buridan.Map, got {}",
            obj.get_type().name()?
        ))),
    }
}

/// A map argument: a `Map`, a reference model id or a path.
pub fn map_arg(obj: &Bound<'_, PyAny>) -> PyResult<Arc<Map>> {
    if let Ok(m) = obj.extract::<PyRef<'_, PyMap>>() {
        return Ok(m.map.clone());
    }
    let name = path_like(obj)?;
    Map::load(&name)
        .map(Arc::new)
        .map_err(|e| map_err(obj.py(), e))
}

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
    let got: usize = shape.iter().product();
    if got != expected {
        return Err(env_err(EnvError::WrongLength {
            what: "actions",
            expected,
            got,
        }));
    }
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

// ------------------------------------------------------------------ GridEnv

/// One grid environment (SPEC §2 "thesis" rules by default, or POGEMA's
/// "pogema" rules): the engine of `buridan.ParallelEnv`.
///
/// Episodes are a pure function of (map, agents, seed, episode index):
/// `reset(e)` starts episode `e`. Actions: 0 stay, 1 up, 2 right, 3 down,
/// 4 left.
#[pyclass(name = "GridEnv", module = "buridan._buridan")]
pub struct PyGridEnv {
    env: GridEnv,
    rewards: Vec<f32>,
    actions: Vec<u8>,
}

#[pymethods]
impl PyGridEnv {
    #[new]
    #[pyo3(signature = (map, agents=4, *, starts="random", seed=0, t_max=None, rules="thesis", sensor_range=2, features=Vec::new(), lifelong=false, episode=0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        map: &Bound<'_, PyAny>,
        agents: usize,
        starts: &str,
        seed: u64,
        t_max: Option<u32>,
        rules: &str,
        sensor_range: usize,
        features: Vec<String>,
        lifelong: bool,
        episode: u64,
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
            lifelong,
        )?;
        let env = GridEnv::with_episode(map, cfg, episode).map_err(env_err)?;
        Ok(Self {
            env,
            rewards: vec![0.0; agents],
            actions: Vec::with_capacity(agents),
        })
    }

    /// Starts episode `episode` (starts and goals drawn from (seed, episode)).
    fn reset(&mut self, episode: u64) -> PyResult<()> {
        self.env.reset_to(episode).map_err(env_err)
    }

    /// Steps all agents; returns `(rewards, terminated, truncated,
    /// blocked_moves)` with `rewards` a float32 array of one value per agent.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyArray1<f32>>, bool, bool, u32)> {
        read_actions(actions, None, self.env.agents(), &mut self.actions)?;
        let out = self
            .env
            .step(&self.actions, &mut self.rewards)
            .map_err(env_err)?;
        Ok((
            PyArray1::from_slice(py, &self.rewards),
            out.terminated,
            out.truncated,
            out.blocked_moves,
        ))
    }

    /// Local observations of all agents, `(agents, obs_dim)` float32 (a new
    /// array; layout in `env/src/obs.rs`).
    fn obs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (n, d) = (self.env.agents(), self.env.local_obs_dim());
        let mut buf = vec![0.0f32; n * d];
        for (i, row) in buf.chunks_mut(d).enumerate() {
            self.env.write_local_obs(i, row).map_err(env_err)?;
        }
        Ok(Array2::from_shape_vec((n, d), buf)
            .expect("n x d")
            .into_pyarray(py))
    }

    /// Action masks of all agents, `(agents, 5)` uint8, 1 = legal.
    fn masks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        let n = self.env.agents();
        let mut buf = vec![0u8; n * NUM_ACTIONS];
        for (i, row) in buf.chunks_mut(NUM_ACTIONS).enumerate() {
            self.env.write_action_mask(i, row).map_err(env_err)?;
        }
        Ok(Array2::from_shape_vec((n, NUM_ACTIONS), buf)
            .expect("n x 5")
            .into_pyarray(py))
    }

    /// The central (CTE) observation, `(1 + 2n)` one-hot planes of
    /// `height x width`, flat float32.
    fn central_obs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let mut buf = vec![0.0f32; self.env.central_obs_dim()];
        self.env.write_central_obs(&mut buf).map_err(env_err)?;
        Ok(buf.into_pyarray(py))
    }

    /// The joint action mask (the agents' masks in order), `(5n,)` uint8.
    fn joint_mask<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let mut buf = vec![0u8; self.env.agents() * NUM_ACTIONS];
        self.env.write_joint_mask(&mut buf).map_err(env_err)?;
        Ok(buf.into_pyarray(py))
    }

    /// Agents' cells as `(row, col)` tuples.
    fn positions(&self) -> Vec<(usize, usize)> {
        cells(&self.env.positions())
    }

    /// Agents' goals as `(row, col)` tuples.
    fn goals(&self) -> Vec<(usize, usize)> {
        cells(&self.env.goals())
    }

    /// Whether agent `agent` stands on its goal.
    fn at_goal(&self, agent: usize) -> PyResult<bool> {
        self.check_agent(agent)?;
        Ok(self.env.at_goal(agent))
    }

    /// Statistics of the current episode (`reward`, `length`, `success`,
    /// `agents_at_goal`, `blocked_moves`, deadlock counts, …) as a dict.
    fn stats(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        to_py(py, &self.env.stats())
    }

    /// Sum over agents of POGEMA-style costs (arrival step, `T_max` if off goal).
    fn sum_of_costs(&self) -> u64 {
        self.env.sum_of_costs()
    }

    /// The largest POGEMA-style cost.
    fn makespan(&self) -> u32 {
        self.env.makespan()
    }

    /// Number of agents.
    #[getter]
    fn agents(&self) -> usize {
        self.env.agents()
    }

    /// Steps taken in this episode.
    #[getter]
    fn t(&self) -> u32 {
        self.env.t()
    }

    /// The episode index.
    #[getter]
    fn episode(&self) -> u64 {
        self.env.episode()
    }

    /// Whether the episode has ended (terminated or truncated).
    #[getter]
    fn is_over(&self) -> bool {
        self.env.is_over()
    }

    /// Floats per local observation.
    #[getter]
    fn obs_dim(&self) -> usize {
        self.env.local_obs_dim()
    }

    /// Truncation step count.
    #[getter]
    fn t_max(&self) -> u32 {
        self.env.config().t_max
    }

    /// The rule set: `"thesis"` or `"pogema"`.
    #[getter]
    fn rules(&self) -> &'static str {
        self.env.rules().name()
    }

    /// The seed of the episode generator.
    #[getter]
    fn seed(&self) -> u64 {
        self.env.config().seed
    }

    /// The map.
    #[getter]
    fn map(&self) -> PyMap {
        PyMap {
            map: self.env.map().clone(),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "GridEnv('{}', agents={}, rules={}, episode={}, t={})",
            self.env.map().name,
            self.env.agents(),
            self.env.rules().name(),
            self.env.episode(),
            self.env.t()
        )
    }
}

impl PyGridEnv {
    fn check_agent(&self, agent: usize) -> PyResult<()> {
        if agent >= self.env.agents() {
            return Err(PyEnvError::new_err(format!(
                "agent {agent} does not exist ({} agents)",
                self.env.agents()
            )));
        }
        Ok(())
    }

    /// The wrapped env (for policies and planners).
    pub fn inner(&self) -> &GridEnv {
        &self.env
    }
}

// ------------------------------------------------------------------- VecEnv

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

/// A read-only NumPy view of `data` (owned by `owner`) with `shape`.
///
/// # Safety
/// `data` must live in a buffer owned by `owner` that is never reallocated
/// while `owner` is alive (the `VecEnv`'s buffers are sized once).
unsafe fn view<'py, T: Element>(
    owner: &Bound<'py, PyVecEnv>,
    data: &[T],
    shape: &[usize],
) -> Bound<'py, PyArrayDyn<T>> {
    let v = ArrayView::from_shape(IxDyn(shape), data).expect("shape matches the buffer");
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
        let this = slf.borrow();
        let shape = this.row_shape(this.venv.obs_dim());
        // SAFETY: VecEnv sizes its buffers once, at construction.
        unsafe { view(slf, this.venv.obs(), &shape) }
    }

    /// Last observations of the episodes that ended in the last step (rows
    /// of other envs are stale), same shape as `obs`.
    #[getter]
    fn final_obs<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<f32>> {
        let this = slf.borrow();
        let shape = this.row_shape(this.venv.obs_dim());
        // SAFETY: as in `obs`.
        unsafe { view(slf, this.venv.final_obs(), &shape) }
    }

    /// Action masks, `(num_envs, rows_per_env, mask_dim)` uint8 (read-only view).
    #[getter]
    fn masks<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<u8>> {
        let this = slf.borrow();
        let shape = this.row_shape(this.venv.mask_dim());
        // SAFETY: as in `obs`.
        unsafe { view(slf, this.venv.masks(), &shape) }
    }

    /// Rewards of the last step, `(num_envs, agents)` float32 (read-only view).
    #[getter]
    fn rewards<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<f32>> {
        let this = slf.borrow();
        let shape = [this.venv.num_envs(), this.venv.agents()];
        // SAFETY: as in `obs`.
        unsafe { view(slf, this.venv.rewards(), &shape) }
    }

    /// Per env, 1 if the last step ended the episode with every agent home
    /// (`(num_envs,)` uint8 read-only view).
    #[getter]
    fn terminated<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<u8>> {
        let this = slf.borrow();
        let shape = [this.venv.num_envs()];
        // SAFETY: as in `obs`.
        unsafe { view(slf, this.venv.terminated(), &shape) }
    }

    /// Per env, 1 if the last step ended the episode at `T_max`
    /// (`(num_envs,)` uint8 read-only view).
    #[getter]
    fn truncated<'py>(slf: &Bound<'py, Self>) -> Bound<'py, PyArrayDyn<u8>> {
        let this = slf.borrow();
        let shape = [this.venv.num_envs()];
        // SAFETY: as in `obs`.
        unsafe { view(slf, this.venv.truncated(), &shape) }
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
