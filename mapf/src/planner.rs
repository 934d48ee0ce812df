//! The [`Planner`] trait every baseline implements, and its result types.

use std::time::Duration;

use buridan_env::{Cell, Grid};

use crate::limits::{Limits, SolveError};
use crate::plan::Plan;

/// Search effort of one solve call.
///
/// ```
/// let s = buridan_mapf::Stats::default();
/// assert_eq!((s.expanded, s.generated, s.low_level_expanded), (0, 0, 0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    /// Expanded nodes: joint states (MA-A*), constraint-tree nodes (CBS),
    /// steps (PIBT) or search iterations, one constraint set each (LaCAM).
    pub expanded: u64,
    /// Generated nodes: joint successor states (MA-A*, before duplicate
    /// detection), constraint-tree children with a low-level path (CBS) or
    /// configurations produced by PIBT (PIBT, LaCAM).
    pub generated: u64,
    /// Low-level space-time A* expansions (CBS), constraint sets created
    /// (LaCAM); 0 for MA-A* and PIBT.
    pub low_level_expanded: u64,
    /// Wall-clock time of the call.
    pub wall_time: Duration,
}

/// A plan and what it cost to find.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{Cbs, Limits, Planner};
/// let map = Map::load("rm-1.1").unwrap();
/// let scen = map.scenario.unwrap();
/// let sol = Cbs::default().solve(&map.grid, &scen.starts, &scen.goals, &Limits::default()).unwrap();
/// assert_eq!(sol.plan.sum_of_costs(), 18);
/// assert!(sol.stats.expanded >= 1);
/// ```
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Solution {
    /// The conflict-free plan (paths trimmed after each agent's arrival).
    pub plan: Plan,
    /// Search effort.
    pub stats: Stats,
}

/// A classical MAPF solver: one-shot planning from starts to goals.
/// `Send + Sync`, so one planner can serve several evaluation threads.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{planner_by_name, Limits, Planner};
/// let map = Map::load("rm-1.3").unwrap();
/// let scen = map.scenario.unwrap();
/// let mut makespans = Vec::new();
/// for name in ["ma-astar", "cbs"] {
///     let planner: Box<dyn Planner> = planner_by_name(name).unwrap();
///     let sol = planner.solve(&map.grid, &scen.starts, &scen.goals, &Limits::default()).unwrap();
///     makespans.push(sol.plan.makespan());
/// }
/// // SPEC's MA-A* heuristic is inadmissible: 8 steps; CBS's plan needs 7.
/// assert_eq!(makespans, [8, 7]);
/// ```
pub trait Planner: Send + Sync {
    /// Short name for tables and logs (`"ma-astar"`, `"cbs"`, ...).
    fn name(&self) -> &str;

    /// Plans conflict-free paths from `starts[i]` to `goals[i]` on `grid`
    /// within `limits`.
    fn solve(
        &self,
        grid: &Grid,
        starts: &[Cell],
        goals: &[Cell],
        limits: &Limits,
    ) -> Result<Solution, SolveError>;
}

/// The default-configured planner of a name: `"ma-astar"` (also `"maastar"`,
/// `"ma-a*"`), `"cbs"`, `"pibt"`, `"lacam"` or `"lacam-star"` (also
/// `"lacam*"`).
///
/// ```
/// assert_eq!(buridan_mapf::planner_by_name("cbs").unwrap().name(), "cbs");
/// assert_eq!(buridan_mapf::planner_by_name("LaCAM*").unwrap().name(), "lacam-star");
/// assert!(buridan_mapf::planner_by_name("dijkstra").is_none());
/// ```
pub fn planner_by_name(name: &str) -> Option<Box<dyn Planner>> {
    match name.to_ascii_lowercase().as_str() {
        "ma-astar" | "maastar" | "ma-a*" | "ma_astar" => Some(Box::new(crate::MaAstar::default())),
        "cbs" => Some(Box::new(crate::Cbs::default())),
        "pibt" => Some(Box::new(crate::Pibt::default())),
        "lacam" => Some(Box::new(crate::Lacam::default())),
        "lacam-star" | "lacam*" | "lacam_star" | "lacamstar" => {
            Some(Box::new(crate::LacamStar::default()))
        }
        _ => None,
    }
}
