//! Lifelong PIBT: one PIBT step per env step, towards goals that change.
//!
//! In lifelong MAPF an agent that reaches its goal at once gets a new one
//! (the env's `lifelong` mode draws it, [`buridan_env::EnvConfig::lifelong`]),
//! and the measure is the **throughput**, goals reached per step. PIBT is the
//! classical solver for it (Okumura et al. 2022): it plans no paths, it only
//! computes the next configuration from the current positions and goals,
//! with priorities that grow while an agent is away from its goal and drop
//! back when it arrives. In graphs where every pair of neighbours lies on a
//! cycle PIBT guarantees that the highest-priority agent reaches its goal;
//! the reference layouts have dead ends, so it is a strong heuristic here,
//! not a guarantee.
//!
//! Every step comes from the configuration generator of [`crate::pibt`], so
//! under [`ConflictModel::ENV_EXECUTABLE`] the env executes it exactly (no move is
//! ever blocked, see [`run_episode`]).
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::{EnvConfig, Map};
//! use buridan_mapf::lifelong::{run_episode, LifelongPibt};
//! let map = Arc::new(Map::load("rm-2.1").unwrap());
//! let cfg = EnvConfig { agents: 8, lifelong: true, t_max: 200, seed: 42, ..EnvConfig::default() };
//! let mut pibt = LifelongPibt::new(&map.grid, Default::default(), 0);
//! let stats = run_episode(&map, &cfg, 0, &mut pibt).unwrap();
//! assert_eq!((stats.length, stats.blocked_moves), (200, 0));
//! assert!(stats.throughput() > 0.1, "{}", stats.throughput());
//! ```

use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, EnvError, EpisodeStats, Grid, GridEnv, Map};

use crate::graph::{distance_table, Topology};
use crate::limits::{check_online, InstanceError};
use crate::pibt::{online_step, Generator};
use crate::replay::action_between;
use crate::rules::ConflictModel;

/// PIBT for lifelong MAPF (see the [module docs](self)): call
/// [`LifelongPibt::step`] with the current positions and goals once per
/// env step.
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::lifelong::LifelongPibt;
/// let grid = Grid::from_rows(&["....", ".@@.", "...."]).unwrap();
/// let mut pibt = LifelongPibt::new(&grid, Default::default(), 0);
/// let (pos, goals) = ([Cell::new(0, 0), Cell::new(2, 3)], [Cell::new(0, 3), Cell::new(2, 0)]);
/// let next = pibt.step(&pos, &goals).unwrap();
/// assert_eq!(next, [Cell::new(0, 1), Cell::new(2, 2)]);
/// assert_eq!(pibt.actions(&next, &goals).unwrap(), [2, 4]);
/// ```
pub struct LifelongPibt {
    grid: Grid,
    topo: Topology,
    rules: ConflictModel,
    seed: u64,
    steps: u64,
    /// Each agent's goal (cell index) and distance table.
    goals: Vec<u32>,
    dist: Vec<Vec<u32>>,
    priorities: Vec<f64>,
}

impl LifelongPibt {
    /// A planner for `grid` under `rules`; `seed` drives the tie-breaking.
    pub fn new(grid: &Grid, rules: ConflictModel, seed: u64) -> Self {
        Self {
            grid: grid.clone(),
            topo: Topology::new(grid),
            rules,
            seed,
            steps: 0,
            goals: Vec::new(),
            dist: Vec::new(),
            priorities: Vec::new(),
        }
    }

    /// Every agent's next cell. Agents whose goal changed get a fresh
    /// distance table and priority; the number of agents may not change
    /// between calls without a new goal for everyone.
    ///
    /// Positions must be pairwise distinct; goals may be shared (POGEMA's
    /// lifelong tasks are not exclusive). Of two agents heading for one
    /// cell, the first there stands on it until its own goal changes; the
    /// other's priority grows while it waits, so it outranks the one on the
    /// cell and pushes it off (priority inheritance) rather than waiting
    /// forever, also when the one on the cell has nowhere to go.
    pub fn step(&mut self, positions: &[Cell], goals: &[Cell]) -> Result<Vec<Cell>, InstanceError> {
        check_online(&self.grid, positions, goals)?;
        let n = positions.len();
        if self.goals.len() != n {
            self.goals = vec![u32::MAX; n];
            self.dist = vec![Vec::new(); n];
            self.priorities = vec![0.0; n];
        }
        let cur: Vec<u32> = positions.iter().map(|&c| self.topo.index(c)).collect();
        let cells = self.topo.cells() as f64 + 1.0;
        for (i, &g) in goals.iter().enumerate() {
            let gi = self.topo.index(g);
            if self.goals[i] != gi {
                self.goals[i] = gi;
                self.dist[i] = distance_table(&self.grid, g);
                // A new task: priority restarts from its distance fraction.
                self.priorities[i] = f64::from(self.dist[i][cur[i] as usize]).min(cells) / cells;
            }
        }
        let next = online_step(
            Generator::new(&self.topo, self.rules, self.seed ^ self.steps),
            &self.dist,
            &cur,
            &self.goals,
            &mut self.priorities,
            &[],
        );
        self.steps += 1;
        Ok(next.iter().map(|&c| self.topo.cell(c)).collect())
    }

    /// The env actions that move every agent from `positions` one PIBT step
    /// on (0 stay, 1 up, 2 right, 3 down, 4 left).
    pub fn actions(
        &mut self,
        positions: &[Cell],
        goals: &[Cell],
    ) -> Result<Vec<u8>, InstanceError> {
        let next = self.step(positions, goals)?;
        Ok(positions
            .iter()
            .zip(&next)
            .map(|(&a, &b)| action_between(a, b).expect("PIBT moves to neighbours"))
            .collect())
    }
}

/// Why a lifelong episode could not be run.
#[derive(Debug, thiserror::Error)]
pub enum LifelongError {
    /// The env refused the configuration or an action.
    #[error("environment: {0}")]
    Env(#[from] EnvError),
    /// The env's positions and goals are no valid instance.
    #[error("instance: {0}")]
    Instance(#[from] InstanceError),
}

/// Runs one env episode (`cfg`, usually with `lifelong: true`) driven by
/// `pibt` until it ends (`T_max`), and returns the env's statistics:
/// `goals_reached`, `throughput()`, `blocked_moves` (0 under env rules).
pub fn run_episode(
    map: &Arc<Map>,
    cfg: &EnvConfig,
    episode: u64,
    pibt: &mut LifelongPibt,
) -> Result<EpisodeStats, LifelongError> {
    let mut env = GridEnv::with_episode(map.clone(), cfg.clone(), episode)?;
    let mut rewards = vec![0.0; cfg.agents];
    loop {
        let actions = pibt.actions(&env.positions(), &env.goals())?;
        if env.step(&actions, &mut rewards)?.done() {
            return Ok(env.stats());
        }
    }
}
