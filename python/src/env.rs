//! `Map`, `GridEnv` (one env, the core of the PettingZoo `ParallelEnv`)
//! and `VecEnv` (a batch with auto-reset whose buffers NumPy sees without
//! copies).
mod args;
mod map;
mod vec;

use buridan_env::{GridEnv, NUM_ACTIONS};
use numpy::ndarray::Array2;
use numpy::{Element, IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

pub use args::{config, features_arg, read_actions, rules_arg, starts_arg};
pub use map::{cells, map_arg, reference_models, Cells, PyMap};
pub use vec::PyVecEnv;

use crate::errors::{env_err, EnvError as PyEnvError};
use crate::to_py;

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
        self.agent_rows(py, self.env.local_obs_dim(), |i, row| {
            self.env.write_local_obs(i, row)
        })
    }

    /// Action masks of all agents, `(agents, 5)` uint8, 1 = legal.
    fn masks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        self.agent_rows(py, NUM_ACTIONS, |i, row| self.env.write_action_mask(i, row))
    }

    /// The central (CTE) observation, flat float32: `(1 + 2n)` one-hot
    /// planes of `height x width`, followed, with recipe features, by every
    /// agent's local observation (layout in `env/src/obs.rs`).
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

    /// An `(agents, width)` array (a new one) whose row `i` is what
    /// `write(i, row)` writes.
    fn agent_rows<'py, T: Element + Copy + Default>(
        &self,
        py: Python<'py>,
        width: usize,
        write: impl Fn(usize, &mut [T]) -> Result<(), buridan_env::EnvError>,
    ) -> PyResult<Bound<'py, PyArray2<T>>> {
        let n = self.env.agents();
        let mut buf = vec![T::default(); n * width];
        for (i, row) in buf.chunks_mut(width).enumerate() {
            write(i, row).map_err(env_err)?;
        }
        Ok(Array2::from_shape_vec((n, width), buf)
            .expect("agents x width")
            .into_pyarray(py))
    }

    /// The wrapped env (for policies and planners).
    pub fn inner(&self) -> &GridEnv {
        &self.env
    }
}
