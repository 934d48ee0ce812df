//! Search budgets ([`Limits`]), solver errors ([`SolveError`]) and the
//! instance checks every solver runs first.

use std::time::{Duration, Instant};

use buridan_env::{Cell, Grid};

use crate::planner::Stats;
use crate::Problem;

/// How much a solver may spend. Checked regularly (the clock every 256
/// expansions and every 4096 generated joint moves or low-level nodes), so a
/// solver overshoots a limit by milliseconds at most.
///
/// ```
/// use std::time::Duration;
/// use buridan_mapf::Limits;
/// let l = Limits::default();
/// assert_eq!(l.time, Duration::from_secs(60));
/// assert_eq!(l.memory_bytes, 2 << 30);
/// let quick = Limits::with_time(Duration::from_millis(200));
/// assert_eq!(quick.memory_bytes, l.memory_bytes);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Limits {
    /// CPU-time budget of the solving thread (SPEC §5: 60 s of CPU time).
    pub time: Duration,
    /// Memory budget in bytes, estimated from the stored nodes (MA-A*: the
    /// allocated capacities of its tables; CBS: constraint-tree nodes and
    /// paths plus the current low-level search).
    pub memory_bytes: usize,
    /// Optional cap on expanded (high-level, for CBS) nodes.
    pub max_nodes: Option<u64>,
    /// Optional cap on the makespan: no plan longer than this is searched
    /// (bounds CBS's low level so that unsolvable instances end).
    pub max_makespan: Option<usize>,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            time: Duration::from_secs(60),
            memory_bytes: 2 << 30,
            max_nodes: None,
            max_makespan: None,
        }
    }
}

impl Limits {
    /// Default limits with another time budget.
    ///
    /// ```
    /// let l = buridan_mapf::Limits::with_time(std::time::Duration::from_secs(10));
    /// assert_eq!(l.time.as_secs(), 10);
    /// ```
    pub fn with_time(time: Duration) -> Self {
        Self {
            time,
            ..Self::default()
        }
    }
}

/// A start/goal instance the solvers refuse before searching.
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{Cbs, InstanceError, Limits, Planner, SolveError, Problem};
/// let grid = Grid::from_rows(&[".@."]).unwrap();
/// let err = Cbs::default().solve(Problem::new(&grid, &[Cell::new(0, 1)], &[Cell::new(0, 0)]), &Limits::default()).unwrap_err();
/// assert!(matches!(err, SolveError::Instance(InstanceError::BadCell { agent: 0, which: "start", .. })));
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum InstanceError {
    /// Different numbers of starts and goals.
    #[error("{starts} starts but {goals} goals")]
    LengthMismatch {
        /// Number of starts.
        starts: usize,
        /// Number of goals.
        goals: usize,
    },
    /// A start or goal is a wall or outside the grid.
    #[error("agent {agent}: {which} {cell} is a wall or outside the grid")]
    BadCell {
        /// The agent.
        agent: usize,
        /// `"start"` or `"goal"`.
        which: &'static str,
        /// The cell.
        cell: Cell,
    },
    /// Two agents share a start or a goal.
    #[error("agents {first} and {second} share the {which} {cell}")]
    SharedCell {
        /// Lower agent index.
        first: usize,
        /// Higher agent index.
        second: usize,
        /// `"start"` or `"goal"`.
        which: &'static str,
        /// The cell.
        cell: Cell,
    },
    /// The grid is too large for the solvers' 32-bit cell indices.
    #[error("grid of {cells} cells is too large")]
    GridTooLarge {
        /// Number of cells.
        cells: usize,
    },
}

/// Why a solver returned no plan.
///
/// ```
/// use std::time::Duration;
/// use buridan_mapf::SolveError;
/// let e = SolveError::TimeLimit { elapsed: Duration::from_millis(201), expanded: 1234 };
/// assert_eq!(e.to_string(), "time limit reached after 201ms of CPU time and 1234 expanded nodes");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SolveError {
    /// The time budget ran out.
    #[error("time limit reached after {elapsed:?} of CPU time and {expanded} expanded nodes")]
    TimeLimit {
        /// CPU time spent.
        elapsed: Duration,
        /// Nodes expanded (CBS: high-level nodes).
        expanded: u64,
    },
    /// The estimated memory use exceeded the budget.
    #[error("memory limit: about {estimated_bytes} bytes in use (limit {limit_bytes}) after {expanded} expanded nodes")]
    MemoryLimit {
        /// Estimated bytes held by the search.
        estimated_bytes: usize,
        /// The budget.
        limit_bytes: usize,
        /// Nodes expanded (CBS: high-level nodes).
        expanded: u64,
    },
    /// The node cap [`Limits::max_nodes`] was reached.
    #[error("node limit: {expanded} nodes expanded")]
    NodeLimit {
        /// Nodes expanded.
        expanded: u64,
    },
    /// The instance has no solution at all (proven: a goal is unreachable,
    /// or the whole joint state space was searched).
    #[error("the instance has no solution")]
    NoSolution,
    /// No solution with makespan at most [`Limits::max_makespan`] exists.
    #[error("no solution with makespan at most {max_makespan}")]
    NoSolutionWithin {
        /// The cap.
        max_makespan: usize,
    },
    /// An incomplete planner (PIBT) gave up after this many steps without
    /// bringing every agent to its goal; the instance may still be solvable.
    #[error("gave up after {steps} steps without reaching all goals (incomplete planner)")]
    StepLimit {
        /// Steps simulated.
        steps: usize,
    },
    /// An incomplete planner (prioritized planning) tried every priority
    /// order of the agents without a plan; the instance may still be solvable.
    #[error("every one of the {orders} priority orders failed (incomplete planner)")]
    OrdersExhausted {
        /// Distinct orders tried (`n!`).
        orders: u64,
    },
    /// The instance itself is malformed.
    #[error("invalid instance: {0}")]
    Instance(#[from] InstanceError),
}

/// Checks starts and goals: same number, inside the grid, not on walls,
/// pairwise distinct.
pub(crate) fn check_instance(
    grid: &Grid,
    starts: &[Cell],
    goals: &[Cell],
) -> Result<(), InstanceError> {
    check_cells(grid, starts, goals, true)
}

/// [`check_instance`] for the online solvers (lifelong PIBT, the shield),
/// whose goals may be shared: in lifelong MAPF as POGEMA poses it, goals
/// are not exclusive, and these solvers only steer by each agent's
/// distances to its own goal. Positions stay pairwise distinct.
pub(crate) fn check_online(
    grid: &Grid,
    positions: &[Cell],
    goals: &[Cell],
) -> Result<(), InstanceError> {
    check_cells(grid, positions, goals, false)
}

/// Same lengths, no cell on a wall, starts pairwise distinct and goals
/// too if `distinct_goals`.
fn check_cells(
    grid: &Grid,
    starts: &[Cell],
    goals: &[Cell],
    distinct_goals: bool,
) -> Result<(), InstanceError> {
    if starts.len() != goals.len() {
        return Err(InstanceError::LengthMismatch {
            starts: starts.len(),
            goals: goals.len(),
        });
    }
    let cells = grid.height() * grid.width();
    if cells >= u32::MAX as usize / 2 {
        return Err(InstanceError::GridTooLarge { cells });
    }
    for (which, list) in [("start", starts), ("goal", goals)] {
        for (agent, &cell) in list.iter().enumerate() {
            if grid.is_wall(cell) {
                return Err(InstanceError::BadCell { agent, which, cell });
            }
            if which == "goal" && !distinct_goals {
                continue;
            }
            if let Some(first) = list[..agent].iter().position(|&c| c == cell) {
                return Err(InstanceError::SharedCell {
                    first,
                    second: agent,
                    which,
                    cell,
                });
            }
        }
    }
    Ok(())
}

/// Whether every agent's goal is reachable from its start on the static grid.
pub(crate) fn goals_reachable(grid: &Grid, starts: &[Cell], goals: &[Cell]) -> bool {
    starts
        .iter()
        .zip(goals)
        .all(|(&s, &g)| grid.distances_to(g)[grid.index(s)] != buridan_env::map::UNREACHABLE)
}

/// The running budget of one solve call.
#[derive(Debug)]
pub(crate) struct Budget {
    start: Instant,
    /// CPU time of the solving thread at the start: SPEC §5 limits CPU time,
    /// which a loaded machine does not eat into.
    cpu_start: Option<cpu_time::ThreadTime>,
    limits: Limits,
    /// Expanded nodes (CBS: high level).
    pub expanded: u64,
    /// Generated nodes (CBS: high level).
    pub generated: u64,
    /// Low-level space-time A* expansions (CBS, prioritized planning).
    pub low_expanded: u64,
    /// Bytes the search holds for good (its nodes, tables and arenas),
    /// kept by [`Budget::hold`] and [`Budget::release`].
    held: usize,
}

impl Budget {
    pub fn new(limits: &Limits) -> Self {
        Self {
            start: Instant::now(),
            cpu_start: cpu_time::ThreadTime::try_now().ok(),
            limits: *limits,
            expanded: 0,
            generated: 0,
            low_expanded: 0,
            held: 0,
        }
    }

    /// The search now holds `bytes` more.
    pub fn hold(&mut self, bytes: usize) {
        self.held += bytes;
    }

    /// The search has freed `bytes`.
    pub fn release(&mut self, bytes: usize) {
        self.held = self.held.saturating_sub(bytes);
    }

    /// The checks a search runs before it starts — a well-formed instance
    /// ([`check_instance`]), every goal reachable on the static grid (else
    /// [`SolveError::NoSolution`]) — and the budget, started before the
    /// reachability check so that it counts against the time limit.
    pub fn start(problem: Problem<'_>, limits: &Limits) -> Result<Self, SolveError> {
        let (grid, starts, goals) = (problem.grid, problem.starts, problem.goals);
        check_instance(grid, starts, goals)?;
        let budget = Self::new(limits);
        if !goals_reachable(grid, starts, goals) {
            return Err(SolveError::NoSolution);
        }
        Ok(budget)
    }

    /// Wall-clock time since the start.
    pub fn elapsed(&self) -> Duration {
        self.start.elapsed()
    }

    /// The search effort so far, as a solve call reports it.
    pub fn stats(&self) -> Stats {
        Stats {
            expanded: self.expanded,
            generated: self.generated,
            low_level_expanded: self.low_expanded,
            wall_time: self.elapsed(),
        }
    }

    /// CPU time of this thread since the start (wall time where the platform
    /// has no thread CPU clock).
    pub fn cpu_elapsed(&self) -> Duration {
        match &self.cpu_start {
            Some(t) => t.elapsed(),
            None => self.start.elapsed(),
        }
    }

    /// Checks the time budget (CPU time of the solving thread) now.
    pub fn check_time(&self) -> Result<(), SolveError> {
        let elapsed = self.cpu_elapsed();
        if elapsed > self.limits.time {
            return Err(SolveError::TimeLimit {
                elapsed,
                expanded: self.expanded,
            });
        }
        Ok(())
    }

    /// Called once per expansion: node cap every time, the clock and the
    /// memory estimate every 256 expansions (the bytes held plus
    /// `transient`, what the caller holds beyond them, e.g. its open list).
    pub fn on_expand(&mut self, transient: impl FnOnce() -> usize) -> Result<(), SolveError> {
        self.expanded += 1;
        if let Some(cap) = self.limits.max_nodes {
            if self.expanded > cap {
                return Err(SolveError::NodeLimit {
                    expanded: self.expanded - 1,
                });
            }
        }
        if self.expanded & 255 == 0 {
            self.check(transient())?;
        }
        Ok(())
    }

    /// Counts a generated node; true every 4096th, when the caller runs
    /// [`Budget::check`].
    pub fn count_generated(&mut self) -> bool {
        self.generated += 1;
        self.generated & 4095 == 0
    }

    /// Checks the clock and the memory estimate (the bytes held plus
    /// `transient`) now.
    pub fn check(&self, transient: usize) -> Result<(), SolveError> {
        self.check_time()?;
        self.check_memory(transient)
    }

    /// The error of a search whose open list ran dry:
    /// [`SolveError::NoSolutionWithin`] where the makespan cap cut a node
    /// off (`capped`), [`SolveError::NoSolution`] otherwise.
    pub fn exhausted(&self, capped: bool) -> SolveError {
        match self.max_makespan() {
            Some(max_makespan) if capped => SolveError::NoSolutionWithin { max_makespan },
            _ => SolveError::NoSolution,
        }
    }

    /// Checks the memory estimate: the bytes held plus `transient`.
    pub fn check_memory(&self, transient: usize) -> Result<(), SolveError> {
        let bytes = self.held + transient;
        if bytes > self.limits.memory_bytes {
            return Err(SolveError::MemoryLimit {
                estimated_bytes: bytes,
                limit_bytes: self.limits.memory_bytes,
                expanded: self.expanded,
            });
        }
        Ok(())
    }

    pub fn max_makespan(&self) -> Option<usize> {
        self.limits.max_makespan
    }
}
