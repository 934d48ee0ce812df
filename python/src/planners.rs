//! The classical planners of `buridan-mapf` (`plan`, `Plan`) and the
//! evaluation harness of `buridan-eval` (`evaluate`).

use buridan_mapf::Problem;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::error::error_chain;
use buridan_env::{Cell, EnvError, Map, Rules, Starts};
use buridan_eval::by_name::{Act, Controller, ControllerFactory, ControllerNameError};
use buridan_eval::{evaluate as eval_run, EvalSpec};
use buridan_mapf::replay::plan_actions;
use buridan_mapf::{planner_for_rules, replay_with, validate_with, Limits, Plan, Stats};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::env::{cells, map_arg, rules_arg, starts_arg};
use crate::errors::{env_err, planner_err, solve_err, BuridanError, PlannerError, PolicyError};

/// The planner names `plan` and `evaluate` accept (several may be joined
/// by `+` into a portfolio tried in turn, e.g. `"lacam+od-astar"`).
pub const PLANNER_NAMES: [&str; 9] = [
    "ma-astar",
    "od-astar",
    "od-astar-soc",
    "cbs",
    "pibt",
    "lacam",
    "lacam-star",
    "lacam-star-makespan",
    "pp",
];

/// The planner names `plan` accepts.
#[pyfunction]
pub fn planner_names() -> Vec<&'static str> {
    PLANNER_NAMES.to_vec()
}

fn limits(
    time_limit: f64,
    memory_limit_mib: usize,
    max_nodes: Option<u64>,
    max_makespan: Option<usize>,
) -> PyResult<Limits> {
    if !(time_limit > 0.0 && time_limit.is_finite()) {
        return Err(PyValueError::new_err(
            "time_limit must be a positive number of seconds",
        ));
    }
    Ok(Limits {
        time: Duration::from_secs_f64(time_limit),
        memory_bytes: memory_limit_mib << 20,
        max_nodes,
        max_makespan,
    })
}

fn to_cells(v: &[(usize, usize)]) -> Vec<Cell> {
    v.iter().map(|&(r, c)| Cell::new(r, c)).collect()
}

/// A plan: one timed path per agent, from the starts to the goals, with the
/// planner's statistics.
#[pyclass(name = "Plan", module = "buridan._buridan", frozen)]
pub struct PyPlan {
    plan: Plan,
    stats: Stats,
    planner: String,
    map: Arc<Map>,
    starts: Vec<Cell>,
    goals: Vec<Cell>,
    rules: Rules,
}

#[pymethods]
impl PyPlan {
    /// Paths as lists of `(row, col)`, one per agent; `paths[i][t]` is agent
    /// `i`'s cell at time `t` (after its path ends it rests on its goal).
    #[getter]
    fn paths(&self) -> Vec<Vec<(usize, usize)>> {
        self.plan.paths.iter().map(|p| cells(p)).collect()
    }

    /// Steps until the last agent arrives for good.
    #[getter]
    fn makespan(&self) -> usize {
        self.plan.makespan()
    }

    /// Σ over agents of their final arrival times.
    #[getter]
    fn sum_of_costs(&self) -> usize {
        self.plan.sum_of_costs()
    }

    /// Number of agents.
    #[getter]
    fn agents(&self) -> usize {
        self.plan.agents()
    }

    /// The planner's name (`"cbs"`, `"lacam+od-astar"`, …).
    #[getter]
    fn planner(&self) -> &str {
        &self.planner
    }

    /// The starts planned from, `(row, col)` per agent.
    #[getter]
    fn starts(&self) -> Vec<(usize, usize)> {
        cells(&self.starts)
    }

    /// The goals planned to, `(row, col)` per agent.
    #[getter]
    fn goals(&self) -> Vec<(usize, usize)> {
        cells(&self.goals)
    }

    /// Search statistics: `expanded`, `generated`, `low_level_expanded`,
    /// `wall_seconds`.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("expanded", self.stats.expanded)?;
        d.set_item("generated", self.stats.generated)?;
        d.set_item("low_level_expanded", self.stats.low_level_expanded)?;
        d.set_item("wall_seconds", self.stats.wall_time.as_secs_f64())?;
        Ok(d)
    }

    /// The env actions that execute the plan, `(makespan, agents)` uint8
    /// (0 stay, 1 up, 2 right, 3 down, 4 left).
    fn actions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        let steps = plan_actions(&self.plan).map_err(|e| BuridanError::new_err(e.to_string()))?;
        let n = self.plan.agents();
        let flat: Vec<u8> = steps.iter().flatten().copied().collect();
        Ok(Array2::from_shape_vec((steps.len(), n), flat)
            .expect("steps x agents")
            .into_pyarray(py))
    }

    /// Checks the plan independently of the planner (vertex, swap and —
    /// under thesis rules — following conflicts, moves, starts and goals);
    /// raises `BuridanError` with the first problem.
    fn validate(&self) -> PyResult<()> {
        validate_with(
            &self.map.grid,
            &self.starts,
            &self.goals,
            &self.plan,
            buridan_mapf::ConflictModel::from(self.rules),
        )
        .map_err(|e| BuridanError::new_err(format!("invalid plan: {e}")))
    }

    /// Replays the plan step by step in a `GridEnv` under the plan's rule
    /// set; returns `steps`, `success`, `terminated_at`, `truncated`,
    /// `blocked_moves`, `exact` (success after exactly `makespan` steps)
    /// and `final_positions`.
    #[pyo3(signature = (t_max=None))]
    fn replay<'py>(&self, py: Python<'py>, t_max: Option<u32>) -> PyResult<Bound<'py, PyDict>> {
        let t_max = t_max.unwrap_or(self.rules.default_t_max());
        let r = replay_with(
            &self.map,
            &self.starts,
            &self.goals,
            &self.plan,
            t_max,
            self.rules,
        )
        .map_err(|e| BuridanError::new_err(e.to_string()))?;
        let d = PyDict::new(py);
        d.set_item("steps", r.steps)?;
        d.set_item("success", r.success)?;
        d.set_item("terminated_at", r.terminated_at)?;
        d.set_item("truncated", r.truncated)?;
        d.set_item("blocked_moves", r.blocked_moves)?;
        d.set_item("exact", r.is_exact(self.plan.makespan()))?;
        d.set_item("final_positions", cells(&r.final_positions))?;
        Ok(d)
    }

    fn __len__(&self) -> usize {
        self.plan.agents()
    }

    fn __repr__(&self) -> String {
        format!(
            "Plan(planner='{}', agents={}, makespan={}, sum_of_costs={})",
            self.planner,
            self.plan.agents(),
            self.plan.makespan(),
            self.plan.sum_of_costs()
        )
    }
}

/// Plans paths on `map` with the planner `planner`.
///
/// Starts and goals default to the map's fixed scenario (its first
/// `agents` agents); give both `starts` and `goals` as `(row, col)` lists
/// for any other instance. The planner plans for `rules` (`"thesis"`: plans
/// the sequential env executes exactly; `"pogema"`: simultaneous moves).
/// Raises `PlannerError` for unknown names and `SolveError` when no plan is
/// found within the limits. The GIL is released while planning.
#[pyfunction]
#[pyo3(signature = (map, planner="lacam", *, agents=None, starts=None, goals=None, rules="thesis", time_limit=60.0, memory_limit_mib=2048, max_nodes=None, max_makespan=None))]
#[allow(clippy::too_many_arguments)]
pub fn plan(
    py: Python<'_>,
    map: &Bound<'_, PyAny>,
    planner: &str,
    agents: Option<usize>,
    starts: Option<Vec<(usize, usize)>>,
    goals: Option<Vec<(usize, usize)>>,
    rules: &str,
    time_limit: f64,
    memory_limit_mib: usize,
    max_nodes: Option<u64>,
    max_makespan: Option<usize>,
) -> PyResult<PyPlan> {
    let map = map_arg(map)?;
    let rules = rules_arg(rules)?;
    let limits = limits(time_limit, memory_limit_mib, max_nodes, max_makespan)?;
    let solver = planner_for_rules(planner, rules).map_err(planner_err)?;
    let (mut s, mut g) = match (starts, goals) {
        (Some(s), Some(g)) => (to_cells(&s), to_cells(&g)),
        (None, None) => match &map.scenario {
            Some(scen) => (scen.starts.clone(), scen.goals.clone()),
            None => {
                return Err(env_err(EnvError::NotEnoughFixedAgents {
                    map: map.name.clone(),
                    available: 0,
                    requested: agents.unwrap_or(1),
                }))
            }
        },
        _ => {
            return Err(PyValueError::new_err(
                "give both starts and goals, or neither (the map's fixed scenario)",
            ))
        }
    };
    if let Some(n) = agents {
        if n == 0 || n > s.len() {
            return Err(env_err(EnvError::NotEnoughFixedAgents {
                map: map.name.clone(),
                available: s.len(),
                requested: n,
            }));
        }
        s.truncate(n);
        g.truncate(n);
    }
    let grid = &map.grid;
    let solved = py.detach(|| solver.solve(Problem::new(grid, &s, &g), &limits));
    let solution = solved.map_err(solve_err)?;
    Ok(PyPlan {
        plan: solution.plan,
        stats: solution.stats,
        planner: solver.name().to_string(),
        map: map.clone(),
        starts: s,
        goals: g,
        rules,
    })
}

// --------------------------------------------------------------- evaluation

/// A `learner eval --controller` text as the [`Controller`] value, made
/// into controllers by the same code as the CLI; with `sample`, every
/// policy in it samples. A text that is none of the grammar's forms, or a
/// planner that cannot plan under the rules, raises `PlannerError`; a
/// checkpoint that does not load raises `PolicyError`, with the Rust
/// message.
fn controller_factory(
    name: &str,
    agents: usize,
    seed: u64,
    limits: Limits,
    sample: bool,
    rules: Rules,
) -> PyResult<ControllerFactory> {
    let raise = |e: ControllerNameError| match e {
        ControllerNameError::Checkpoint(_) => PolicyError::new_err(error_chain(&e)),
        _ => PlannerError::new_err(error_chain(&e)),
    };
    let mut controller: Controller = name
        .parse()
        .map_err(|e| raise(ControllerNameError::Parse(e)))?;
    if sample {
        controller = controller.with_act(Act::Sampled);
    }
    controller
        .factory(agents, seed, limits, rules)
        .map_err(raise)
}

/// What `evaluate` returns: the per-episode records, the summary (the same
/// fields as `learner eval --json`) and the visit counts per cell.
#[pyclass(name = "EvalReport", module = "buridan._buridan", frozen)]
pub struct PyEvalReport {
    summary_json: String,
    records_json: String,
    visits: Vec<u64>,
    shape: (usize, usize),
}

#[pymethods]
impl PyEvalReport {
    /// The aggregate as a dict: `controller`, `map`, `agents`, `episodes`,
    /// `success_rate`, `timesteps_median`, `sum_of_costs_mean`,
    /// `compute_ms_median`, `reward_mean`, deadlock statistics, … — the
    /// JSON summary of `learner eval`.
    #[getter]
    fn summary(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json_loads(py, &self.summary_json)
    }

    /// One dict per episode, in episode order (the CSV rows of `learner eval`).
    #[getter]
    fn records(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json_loads(py, &self.records_json)
    }

    /// Visit counts per cell over all episodes, `(height, width)` uint64.
    #[getter]
    fn visits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u64>> {
        Array2::from_shape_vec(self.shape, self.visits.clone())
            .expect("one count per cell")
            .into_pyarray(py)
    }

    /// The summary as the JSON text `learner eval --json` prints.
    fn summary_json(&self) -> &str {
        &self.summary_json
    }

    fn __repr__(&self) -> String {
        format!("EvalReport({})", self.summary_json)
    }
}

fn json_loads(py: Python<'_>, text: &str) -> PyResult<Py<PyAny>> {
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

/// Evaluates a controller on the seeded episodes `0..episodes` of `map`,
/// as `learner eval` does.
///
/// `controller` is a `learner eval --controller` text: a planner name
/// (`"cbs"`, `"lacam"`, `"lacam+od-astar"`, …), `"random"`,
/// `"checkpoint:DIR"` (a trained policy), `"shield[OPTIONS]:checkpoint:DIR"`
/// (through the PIBT collision shield; options `env`, `patience=K`,
/// `settle`, `ordered`, `evict`, `lanes`), `"sampled:CONTROLLER"`, or a planner net
/// around any of these (`"rescue[=PLANNER]:CONTROLLER"`, `"lookahead:…"`,
/// `"backstop:…"`, `"pace:…"`); `buridan_eval::by_name::Controller` has
/// the grammar's table. `delay` is the probability that a robot fails to
/// carry out its move in a step (`learner eval --delay`; 0: none). The
/// GIL is released while episodes run.
#[pyfunction]
#[pyo3(signature = (map, controller, *, agents=4, episodes=100, seed=42, starts="random", t_max=None, rules="thesis", time_limit=60.0, memory_limit_mib=2048, jobs=1, sample=false, delay=0.0))]
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    py: Python<'_>,
    map: &Bound<'_, PyAny>,
    controller: &str,
    agents: usize,
    episodes: usize,
    seed: u64,
    starts: &str,
    t_max: Option<u32>,
    rules: &str,
    time_limit: f64,
    memory_limit_mib: usize,
    jobs: usize,
    sample: bool,
    delay: f32,
) -> PyResult<PyEvalReport> {
    let map = map_arg(map)?;
    let rules = rules_arg(rules)?;
    let starts: Starts = starts_arg(starts)?;
    let limits = limits(time_limit, memory_limit_mib, None, None)?;
    let make = controller_factory(controller, agents, seed, limits, sample, rules)?;
    let spec = EvalSpec {
        agents,
        episodes,
        seed,
        starts,
        t_max: t_max.unwrap_or(rules.default_t_max()),
        jobs: jobs.max(1),
        rules,
        delay,
    };
    let report = py
        .detach(|| eval_run(&map, &spec, &*make, &|_| {}))
        .map_err(env_err)?;
    Ok(PyEvalReport {
        summary_json: serde_json::to_string(&report.summary).expect("summary serialises"),
        records_json: serde_json::to_string(&report.records).expect("records serialise"),
        visits: report.visits,
        shape: (map.grid.height(), map.grid.width()),
    })
}
