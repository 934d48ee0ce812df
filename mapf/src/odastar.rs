//! OD-A*: A* with operator decomposition (Standley, AAAI-10) over the env's
//! own step, makespan-optimal and complete.
//!
//! # Why
//!
//! The env moves agents **one after another in index order** (SPEC §2):
//! agent `i` moves into a cell iff it is free at that moment, lower-index
//! agents having already moved. Operator decomposition is exactly that
//! step: a search node is a configuration plus the index `k` of the agent
//! to move next, and expanding it tries agent `k`'s five actions against
//! the occupancy of the node itself. A full step is `n` such moves, so a
//! joint state has 5 successors instead of up to 5ⁿ, and there is no
//! conflict model to get right: every path through the search graph *is*
//! an env trajectory (no following, swap or rotation can appear, the env
//! blocks them the same way).
//!
//! Where it pays: layouts whose instances need agents to make room in a
//! specific order — two agents bound for one dead-end aisle must enter
//! deepest-goal first, the other waiting aside. PIBT's greedy step never
//! proposes the retreat, so LaCAM must find it by exhausting constraints,
//! and CBS branches on every cell of the aisle; an optimal search over
//! configurations with the shortest-path distance as heuristic walks
//! straight to it (rm-2.1b, README "Planners").
//!
//! # Search
//!
//! A node `(p, k)` lies inside a step: agents `< k` stand where they are
//! after it, agents `≥ k` where they were before it. Two objectives
//! ([`Objective`], as LaCAM*'s):
//!
//! - [`Objective::Makespan`] (the default): `g` counts full steps, and the
//!   bound is the largest of
//!
//!   ```text
//!   g + 1 + d_i(p_i)         agent i < k (moved this step)
//!   g + d_i(p_i)             agent i ≥ k
//!   g + 1 + D_ij(p_i, p_j)   pair i, j < k
//!   g + D_ij(p_i, p_j)       pair i, j ≥ k
//!   g + [k > 0]
//!   ```
//!
//!   with `d_i` the shortest-path distance to agent `i`'s goal on the
//!   static grid and `D_ij` the **pairwise** distance: the fewest steps in
//!   which agents `i` and `j` alone, moving simultaneously (vertex and swap
//!   conflicts only, a relaxation of the env's rules), stand on their goals
//!   together — one breadth-first search over the pairs of cells per pair
//!   of agents. `D_ij` is what sees the dead-end orderings: two agents whose
//!   goals lie in one aisle in the wrong order each see a short way home,
//!   the pair a long one. Pairs are used while the tables fit
//!   ([`PAIR_TABLE_BUDGET`]); pairs of agents split by the step (one moved,
//!   one not) are left out, so the bound may fall by one along an edge,
//!   and a node reached again more cheaply is reopened (A* stays optimal
//!   with an admissible heuristic).
//! - [`Objective::SumOfLoss`]: each agent move costs 1 unless the agent
//!   stays on its goal, and `f = g + Σ d_i(p_i)` (Standley's setting); its
//!   plans are what the env counts as sum of costs.
//!
//! Ties go to the fewest remaining agent-steps `Σ d_i`, then the deepest
//! node. The first goal configuration taken from the open list (between
//! steps, `k = 0`) is optimal for the objective. An exhausted open list
//! proves the instance unsolvable under the env's rules
//! ([`SolveError::NoSolution`]), or unsolvable within
//! [`Limits::max_makespan`] steps if one was set.
//!
//! The state space grows as cellsⁿ: this is the planner for small fleets
//! (the SPEC's 4 agents); LaCAM is the one that scales.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::Map;
//! use buridan_mapf::{replay_exact, Heuristic, Limits, MaAstar, OdAstar, Planner, Problem};
//! let map = Arc::new(Map::load("rm-1.1").unwrap());
//! let scen = map.scenario.clone().unwrap();
//! let (s, g) = (&scen.starts, &scen.goals);
//! let od = OdAstar::default().solve(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! replay_exact(&map, s, g, &od.plan, 100).unwrap();
//! // The same optimal makespan as MA-A* with the same heuristic (SPEC: 10).
//! let ma = MaAstar::with_heuristic(Heuristic::MaxDistance);
//! let reference = ma.solve(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! assert_eq!(od.plan.makespan(), reference.plan.makespan());
//! assert_eq!(od.plan.makespan(), 10);
//! // Sum of costs: CBS's optimum (18).
//! let soc = OdAstar::sum_of_loss().solve(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! assert_eq!(soc.plan.sum_of_costs(), 18);
//! ```

use crate::Problem;
use std::cmp::Reverse;
use std::collections::hash_map::Entry;

use buridan_env::Cell;

use crate::graph::{distance_table, FastMap, Topology, NONE};
use crate::joint::{solve_keyed, Arena, JointKey, JointSearch};
use crate::lacam::Objective;
use crate::limits::{Budget, Limits, SolveError};
use crate::plan::Plan;
use crate::planner::{Planner, Solution};

/// OD-A*: makespan-optimal A* over the env's sequential step (see the
/// [module docs](self)).
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{Limits, OdAstar, Planner, SolveError, Problem};
/// // Two agents cannot swap in a corridor: the search proves it.
/// let grid = Grid::from_rows(&["..."]).unwrap();
/// let (s, g) = ([Cell::new(0, 0), Cell::new(0, 1)], [Cell::new(0, 1), Cell::new(0, 0)]);
/// let err = OdAstar::default().solve(Problem::new(&grid, &s, &g), &Limits::default()).unwrap_err();
/// assert_eq!(err, SolveError::NoSolution);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct OdAstar {
    /// What the plan minimises (default: the makespan, the env's timesteps).
    pub objective: Objective,
}

impl Default for OdAstar {
    fn default() -> Self {
        Self {
            objective: Objective::Makespan,
        }
    }
}

impl OdAstar {
    /// OD-A* minimising the sum of loss (agent-steps off the goal).
    ///
    /// ```
    /// use buridan_mapf::{Objective, OdAstar};
    /// assert_eq!(OdAstar::sum_of_loss().objective, Objective::SumOfLoss);
    /// assert_eq!(OdAstar::default().objective, Objective::Makespan);
    /// ```
    pub fn sum_of_loss() -> Self {
        Self {
            objective: Objective::SumOfLoss,
        }
    }
}

/// Most entries (cells² per pair of agents, 2 bytes each: 32 MiB) the
/// pairwise tables of [`Objective::Makespan`] may take; beyond it (large
/// maps or fleets) the search runs on the single-agent distances alone.
/// The reference models need 40k entries per pair (rm-2.1b, 200 cells).
pub const PAIR_TABLE_BUDGET: usize = 1 << 24;

impl Planner for OdAstar {
    fn name(&self) -> &str {
        match self.objective {
            Objective::Makespan => "od-astar",
            Objective::SumOfLoss => "od-astar-soc",
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        let mut budget = Budget::start(problem, limits)?;
        let (grid, starts, goals) = (problem.grid, problem.starts, problem.goals);
        let topo = Topology::new(grid);
        let n = starts.len();
        // The key holds the n cells and the next agent's index.
        let bits = usize::BITS - (topo.cells().max(n + 1).max(2) - 1).leading_zeros();
        let makespan = self.objective == Objective::Makespan;
        let entries = topo
            .cells()
            .saturating_mul(topo.cells())
            .saturating_mul(n * n.saturating_sub(1) / 2);
        let pairs = if makespan && entries <= PAIR_TABLE_BUDGET {
            pair_tables(&topo, goals, &budget)?
        } else {
            Vec::new()
        };
        let mut search = Search {
            makespan,
            pairs,
            topo: &topo,
            dist: goals.iter().map(|&g| distance_table(grid, g)).collect(),
            bits,
            goals: topo.indices(goals),
            joint: Arena::new(goals.len(), &mut budget),
        };
        solve_keyed(&mut search, &topo, starts, n + 1, bits)
    }
}

#[derive(Clone, Copy)]
struct Node {
    parent: u32,
    /// Full steps completed.
    steps: u32,
    /// Cost so far under the objective (makespan: `steps`).
    g: u32,
    /// The agent to move next (0: between steps).
    next: u32,
    closed: bool,
}

/// Open-list entry, a max-heap on (−f, −Σd, depth, −id).
type OpenEntry = (Reverse<u32>, Reverse<u32>, u32, Reverse<u32>);

struct Search<'a> {
    makespan: bool,
    /// `(i, j, D_ij)` for every pair `i < j` (empty: no pairwise bound);
    /// `D_ij[a * cells + b]` for agent `i` on `a`, `j` on `b`.
    pairs: Vec<(usize, usize, Vec<u16>)>,
    topo: &'a Topology,
    /// Per agent, per cell: shortest-path distance to the agent's goal.
    dist: Vec<Vec<u32>>,
    /// Bits per cell in a packed key.
    bits: u32,
    /// The goal configuration.
    goals: Vec<u32>,
    joint: Arena<'a, Node, OpenEntry>,
}

impl Search<'_> {
    /// The open-list entry of node `id` with cells `p` (see the module docs).
    fn entry(&self, p: &[u32], node: &Node, id: u32) -> OpenEntry {
        let (g, k) = (node.g, node.next as usize);
        let depth = node.steps * self.joint.n as u32 + k as u32;
        let (mut sum, mut f) = (0, g + u32::from(k > 0));
        for (i, (&c, d)) in p.iter().zip(&self.dist).enumerate() {
            let d = d[c as usize];
            sum += d;
            f = f.max(g + u32::from(i < k) + d);
        }
        if !self.makespan {
            return (Reverse(g + sum), Reverse(0), depth, Reverse(id));
        }
        let cells = self.topo.cells();
        for (i, j, table) in &self.pairs {
            let (moved_i, moved_j) = (*i < k, *j < k);
            if moved_i == moved_j {
                let d = u32::from(table[p[*i] as usize * cells + p[*j] as usize]);
                f = f.max(g + u32::from(moved_i) + d);
            }
        }
        (Reverse(f), Reverse(sum), depth, Reverse(id))
    }

    fn key<K: JointKey>(&self, p: &[u32], next: u32, scratch: &mut Vec<u32>) -> K {
        scratch.clear();
        scratch.extend_from_slice(p);
        scratch.push(next);
        K::pack(scratch, self.bits)
    }

    /// Bytes held by the search, from the allocated capacities.
    fn bytes<K: JointKey>(&self, index: &FastMap<K, u32>) -> usize {
        self.pairs
            .iter()
            .map(|(_, _, t)| t.len() * 2)
            .sum::<usize>()
            + self.joint.bytes(index, self.joint.n + 1)
    }

    fn insert<K: JointKey>(
        &mut self,
        p: &[u32],
        node: Node,
        index: &mut FastMap<K, u32>,
        scratch: &mut Vec<u32>,
    ) -> Result<(), SolveError> {
        if self.joint.budget.count_generated() {
            self.joint.budget.check(self.bytes::<K>(index))?;
        }
        match index.entry(self.key(p, node.next, scratch)) {
            Entry::Occupied(e) => {
                let id = *e.get();
                let known = self.joint.nodes[id as usize];
                // Reopened if closed: the pairwise bound is admissible,
                // not consistent.
                if node.g < known.g {
                    self.joint.nodes[id as usize] = node;
                    let entry = self.entry(p, &node, id);
                    self.joint.open.push(entry);
                }
            }
            Entry::Vacant(e) => {
                let id = self.joint.nodes.len() as u32;
                e.insert(id);
                self.joint.states.extend_from_slice(p);
                self.joint.nodes.push(node);
                let entry = self.entry(p, &node, id);
                self.joint.open.push(entry);
            }
        }
        Ok(())
    }

    /// The plan: the configurations between steps along the parent chain.
    fn reconstruct(&self, goal: u32) -> Plan {
        let between_steps = |node: &Node| node.next == 0;
        self.joint
            .plan(self.topo, goal, |node| node.parent, between_steps)
    }
}

impl JointSearch for Search<'_> {
    fn budget(&self) -> &Budget {
        self.joint.budget
    }

    fn run<K: JointKey>(&mut self, start: &[u32]) -> Result<Plan, SolveError> {
        let n = self.joint.n;
        let mut scratch = Vec::with_capacity(n + 1);
        let mut index: FastMap<K, u32> = FastMap::default();
        index.insert(self.key(start, 0, &mut scratch), 0);
        let root = Node {
            parent: NONE,
            steps: 0,
            g: 0,
            next: 0,
            closed: false,
        };
        self.joint.states.extend_from_slice(start);
        self.joint.nodes.push(root);
        self.joint.open.push(self.entry(start, &root, 0));
        let cap = self.joint.budget.max_makespan().map(|c| c as u32);
        let mut capped = false;
        let mut cur = vec![0u32; n];
        while let Some((_, _, _, Reverse(id))) = self.joint.open.pop() {
            let node = self.joint.nodes[id as usize];
            if node.closed {
                continue;
            }
            self.joint.nodes[id as usize].closed = true;
            let bytes = self.bytes::<K>(&index);
            self.joint.budget.on_expand(|| bytes)?;
            cur.copy_from_slice(self.joint.cells(id));
            if node.next == 0 && cur == self.goals {
                return Ok(self.reconstruct(id));
            }
            if node.next == 0 && cap.is_some_and(|c| node.steps >= c) {
                capped = true;
                continue;
            }
            let k = node.next as usize;
            let (steps, next) = if k + 1 == n {
                (node.steps + 1, 0)
            } else {
                (node.steps, k as u32 + 1)
            };
            let here = cur[k];
            for to in *self.topo.moves(here) {
                // A move into an occupied cell leaves the agent in place:
                // the same successor as staying.
                if to == NONE || (to != here && cur.contains(&to)) {
                    continue;
                }
                let g = if self.makespan {
                    steps
                } else {
                    node.g + u32::from(to != here || here != self.goals[k])
                };
                cur[k] = to;
                let child = Node {
                    parent: id,
                    steps,
                    g,
                    next,
                    closed: false,
                };
                self.insert(&cur, child, &mut index, &mut scratch)?;
                cur[k] = here;
            }
        }
        Err(self.joint.budget.exhausted(capped))
    }
}

/// Pairwise distances `D_ij` for every pair of agents (see the module
/// docs): a breadth-first search from the pair of goals over pairs of
/// cells, two agents moving simultaneously without vertex or swap
/// conflicts. That graph is undirected (a joint move reversed is a joint
/// move), so distances from the goals are distances to them. Unreachable
/// pairs get `u16::MAX`. The clock is checked after every table.
fn pair_tables(
    topo: &Topology,
    goals: &[Cell],
    budget: &Budget,
) -> Result<Vec<(usize, usize, Vec<u16>)>, SolveError> {
    let cells = topo.cells();
    let goal: Vec<u32> = goals.iter().map(|&g| topo.index(g)).collect();
    let mut out = Vec::new();
    for i in 0..goal.len() {
        for j in i + 1..goal.len() {
            budget.check_time()?;
            let mut dist = vec![u16::MAX; cells * cells];
            let start = goal[i] as usize * cells + goal[j] as usize;
            dist[start] = 0;
            let mut queue = std::collections::VecDeque::from([(goal[i], goal[j])]);
            while let Some((a, b)) = queue.pop_front() {
                let d = dist[a as usize * cells + b as usize];
                for &na in topo.moves(a) {
                    if na == NONE {
                        continue;
                    }
                    for &nb in topo.moves(b) {
                        if nb == NONE || nb == na || (na == b && nb == a) {
                            continue;
                        }
                        let slot = &mut dist[na as usize * cells + nb as usize];
                        if *slot == u16::MAX {
                            *slot = d.saturating_add(1);
                            queue.push_back((na, nb));
                        }
                    }
                }
            }
            out.push((i, j, dist));
        }
    }
    Ok(out)
}
