//! [`Problem`]: one classical MAPF instance, what every planner solves.

use buridan_env::{Cell, Grid};

/// A MAPF instance: agent `i` goes from `starts[i]` to `goals[i]` on `grid`.
/// Borrowed and `Copy`, so a caller keeps its map and scenario where they
/// are and hands the planner a view.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{Lacam, Limits, Planner, Problem};
/// let map = Map::load("rm-1.1").unwrap();
/// let scen = map.scenario.as_ref().unwrap();
/// let problem = Problem::new(&map.grid, &scen.starts, &scen.goals);
/// assert_eq!(problem.agents(), 2);
/// let sol = Lacam::default().solve(problem, &Limits::default()).unwrap();
/// assert_eq!(sol.plan.paths.len(), 2);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// The static grid.
    pub grid: &'a Grid,
    /// Each agent's start cell.
    pub starts: &'a [Cell],
    /// Each agent's goal cell (`goals.len()` should equal `starts.len()`:
    /// planners refuse the instance otherwise).
    pub goals: &'a [Cell],
}

impl<'a> Problem<'a> {
    /// The instance of `starts` and `goals` on `grid`. Nothing is checked
    /// here: a planner's `solve` checks the instance (equal lengths, free
    /// and distinct cells) and says what is wrong.
    pub fn new(grid: &'a Grid, starts: &'a [Cell], goals: &'a [Cell]) -> Self {
        Self {
            grid,
            starts,
            goals,
        }
    }

    /// The number of agents (starts).
    pub fn agents(&self) -> usize {
        self.starts.len()
    }
}
