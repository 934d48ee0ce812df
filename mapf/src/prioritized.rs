//! Prioritized planning (Silver, AIIDE-05; Erdmann & Lozano-Pérez, 1987)
//! with randomized restarts (Bennewitz et al., 2002).
//!
//! Agents plan **one at a time** in a priority order. Each agent's path is
//! the shortest one (space-time A*, the low level of [`crate::Cbs`]) that
//! stays clear of the paths already planned, which are treated as moving
//! obstacles; after arriving, an agent rests on its goal for good, so later
//! agents may not pass its goal from then on, and an agent may only arrive
//! after the last time an earlier agent crosses its goal. Under
//! [`ConflictModel::ENV_EXECUTABLE`] the earlier paths also forbid the
//! *following* moves the environment would block: entering the cell an
//! earlier, higher-index agent leaves in the same step, or leaving a cell
//! an earlier, lower-index agent enters in the same step while having the
//! higher index oneself (see [`ConflictModel`]). Every plan therefore replays
//! exactly in the environment.
//!
//! One order costs `n` single-agent searches, so an attempt takes
//! milliseconds where joint searches (CBS, OD-A*) explode; the price is
//! incompleteness: an early agent may rest on a cell a later one must cross,
//! or cross a later agent's start before it can leave. When an order fails
//! the next is drawn at random (seeded: the same instance gives the same
//! plan), until a plan is found, every order has failed
//! ([`SolveError::OrdersExhausted`], for fleets small enough to count their
//! `n!` orders) or [`Limits::time`] / [`Limits::max_nodes`] (orders tried)
//! runs out. The first order puts the agents with the
//! longest way to go first. With [`Limits::max_makespan`] no path longer than
//! the cap is searched, so every plan returned fits it.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::Map;
//! use buridan_mapf::{replay_exact, Limits, Planner, Prioritized, Problem};
//! let map = Arc::new(Map::load("rm-2.2").unwrap());
//! let scen = map.scenario.clone().unwrap();
//! let sol = Prioritized::default()
//!     .solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default())
//!     .unwrap();
//! replay_exact(&map, &scen.starts, &scen.goals, &sol.plan, 100).unwrap();
//! assert!(sol.stats.expanded >= 1); // orders tried
//! ```

use crate::Problem;

use crate::graph::{distance_table, FastSet, Topology};
use crate::limits::{Budget, Limits, SolveError};
use crate::lowlevel::{space_time_astar, Constraints, LowResult};
use crate::pibt::TieBreaker;
use crate::plan::Plan;
use crate::planner::{Planner, Solution};
use crate::rules::ConflictModel;

/// Prioritized planning with randomized restarts (see the
/// [module docs](self)).
///
/// ```
/// use buridan_mapf::{Planner, Prioritized};
/// assert_eq!(Prioritized::default().name(), "pp");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Prioritized {
    /// The conflict model (default: following forbidden, env-executable plans).
    pub rules: ConflictModel,
    /// Seed of the random orders tried after the first one fails.
    pub seed: u64,
}

impl Default for Prioritized {
    fn default() -> Self {
        Self {
            rules: ConflictModel::default(),
            seed: 1,
        }
    }
}

impl Planner for Prioritized {
    fn rules(&self) -> ConflictModel {
        self.rules
    }

    fn name(&self) -> &str {
        if self.rules.forbid_following {
            "pp"
        } else {
            "pp-simultaneous"
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        let mut budget = Budget::start(problem, limits)?;
        let (grid, starts, goals) = (problem.grid, problem.starts, problem.goals);
        let topo = Topology::new(grid);
        let h: Vec<Vec<u32>> = goals.iter().map(|&g| distance_table(grid, g)).collect();
        let starts: Vec<u32> = starts.iter().map(|&s| topo.index(s)).collect();
        let goals: Vec<u32> = goals.iter().map(|&g| topo.index(g)).collect();
        let n = starts.len();

        if let Some(cap) = budget.max_makespan() {
            if (0..n).any(|i| h[i][starts[i] as usize] as usize > cap) {
                return Err(SolveError::NoSolutionWithin { max_makespan: cap });
            }
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(h[i][starts[i] as usize]));
        let mut rng = TieBreaker::new(self.seed);
        // Few agents have few orders: trying each once ends the search.
        let all_orders = (1..=n as u64).try_fold(1u64, |acc, k| acc.checked_mul(k));
        let mut tried: FastSet<Vec<usize>> = FastSet::default();
        loop {
            if all_orders.is_some() {
                while tried.contains(&order) {
                    shuffle(&mut order, &mut rng);
                }
                tried.insert(order.clone());
            }
            budget.on_expand(|| 0)?;
            budget.check_time()?;
            let attempt = Attempt {
                topo: &topo,
                h: &h,
                starts: &starts,
                goals: &goals,
                forbid_following: self.rules.forbid_following,
            };
            if let Some(paths) = attempt.run(&order, &mut budget)? {
                let plan = Plan::new(
                    paths
                        .into_iter()
                        .map(|p| p.into_iter().map(|c| topo.cell(c)).collect())
                        .collect(),
                )
                .trimmed();
                return Ok(Solution {
                    plan,
                    stats: budget.stats(),
                });
            }
            if all_orders.is_some_and(|all| tried.len() as u64 >= all) {
                return Err(SolveError::OrdersExhausted {
                    orders: tried.len() as u64,
                });
            }
            shuffle(&mut order, &mut rng);
        }
    }
}

/// Fisher–Yates with the planners' deterministic generator.
fn shuffle(order: &mut [usize], rng: &mut TieBreaker) {
    for i in (1..order.len()).rev() {
        let j = rng.next() as usize % (i + 1);
        order.swap(i, j);
    }
}

/// One pass over one priority order.
struct Attempt<'a> {
    topo: &'a Topology,
    h: &'a [Vec<u32>],
    starts: &'a [u32],
    goals: &'a [u32],
    forbid_following: bool,
}

impl Attempt<'_> {
    /// Every agent's path (indexed by agent), or `None` if some agent of
    /// `order` found no path around the earlier ones.
    fn run(
        &self,
        order: &[usize],
        budget: &mut Budget,
    ) -> Result<Option<Vec<Vec<u32>>>, SolveError> {
        let mut paths: Vec<Option<Vec<u32>>> = vec![None; order.len()];
        for (k, &agent) in order.iter().enumerate() {
            let earlier = order[..k]
                .iter()
                .map(|&j| (j, paths[j].as_deref().unwrap_or_default()));
            let cons = self.constraints(agent, earlier);
            let result = space_time_astar(
                self.topo,
                self.starts[agent],
                self.goals[agent],
                &self.h[agent],
                &cons,
                None,
                budget.max_makespan(),
                budget,
            )?;
            match result {
                LowResult::Path(p) => {
                    budget.generated += 1;
                    paths[agent] = Some(p);
                }
                LowResult::NoPath { .. } => return Ok(None),
            }
        }
        Ok(Some(
            paths.into_iter().map(Option::unwrap_or_default).collect(),
        ))
    }

    /// What the earlier agents' paths forbid `agent`.
    fn constraints<'p>(
        &self,
        agent: usize,
        earlier: impl Iterator<Item = (usize, &'p [u32])>,
    ) -> Constraints {
        let mut cons = Constraints::new(self.goals[agent]);
        for (j, path) in earlier {
            let arrival = path.len() as u32 - 1;
            for (t, step) in path.windows(2).enumerate() {
                let t = t as u32;
                let (from, to) = (step[0], step[1]);
                cons.add_vertex(from, t);
                if from == to {
                    continue;
                }
                cons.add_edge(to, from, t); // no swap
                if self.forbid_following {
                    if j > agent {
                        // `agent` may not follow `j` into the cell it leaves.
                        cons.add_vertex(from, t + 1);
                    } else {
                        // `j` (lower index) may not follow `agent` out of `to`.
                        cons.add_vertex(to, t);
                    }
                }
            }
            cons.add_blocked_from(self.goals[j], arrival);
        }
        cons
    }
}
