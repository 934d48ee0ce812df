//! MA-A* (SPEC §5): A* over the joint state of all agents.
//!
//! All agents move simultaneously each step: the up to 5ⁿ joint moves of a
//! state are generated agent by agent (depth first, agent 0 first), pruning a
//! branch as soon as the agent just placed conflicts with an agent placed
//! before it (vertex, swap) or, with [`ConflictModel::forbid_following`], enters the
//! current cell of a higher-index agent. `g` = joint steps, duplicate
//! detection and a closed set on the joint positions (a closed state is never
//! reopened).
//!
//! **Optimality.** The SPEC heuristic, [`Heuristic::SumManhattan`] (Σ of
//! Manhattan distances, as in the dissertation), is *not admissible* for the
//! number of joint steps (one joint step can lower it by `n`), so MA-A* with
//! it is **not guaranteed makespan-optimal** — it behaves more greedily and
//! is faster. [`Heuristic::MaxManhattan`] and [`Heuristic::MaxDistance`] are
//! admissible and consistent, so with them the plan has the optimal makespan
//! (under the chosen [`ConflictModel`]).

use crate::Problem;
use std::cmp::Reverse;
use std::collections::hash_map::Entry;

use crate::graph::{distance_table, manhattan_table, FastMap, Topology, NONE};
use crate::joint::{solve_keyed, Arena, JointKey, JointSearch};
use crate::limits::{Budget, Limits, SolveError};
use crate::plan::Plan;
use crate::planner::{Planner, Solution};
use crate::rules::ConflictModel;

/// The heuristic of [`MaAstar`].
///
/// ```
/// assert_eq!(buridan_mapf::Heuristic::default(), buridan_mapf::Heuristic::SumManhattan);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Heuristic {
    /// Σ Manhattan distances to the goals (SPEC §5, the dissertation's
    /// choice): inadmissible for makespan, no optimality guarantee.
    #[default]
    SumManhattan,
    /// max Manhattan distance to the goals: admissible, makespan-optimal.
    MaxManhattan,
    /// max shortest-path distance on the static grid (walls respected):
    /// admissible and stronger than `MaxManhattan`, makespan-optimal.
    MaxDistance,
}

/// MA-A*: A* over joint states (see the [module docs](self)).
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{Heuristic, Limits, MaAstar, Planner, ConflictModel, Problem};
/// let map = Map::load("rm-1.1").unwrap();
/// let scen = map.scenario.unwrap();
/// let optimal = MaAstar { heuristic: Heuristic::MaxDistance, rules: ConflictModel::default() };
/// let sol = optimal.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// assert_eq!(sol.plan.makespan(), 10); // 9 needs a following move the env blocks
/// let simultaneous = MaAstar { heuristic: Heuristic::MaxDistance, rules: ConflictModel::SIMULTANEOUS };
/// let sol = simultaneous.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// assert_eq!(sol.plan.makespan(), 9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct MaAstar {
    /// The heuristic (default: SPEC's Σ Manhattan).
    pub heuristic: Heuristic,
    /// The conflict model (default: following forbidden, env-executable plans).
    pub rules: ConflictModel,
}

impl MaAstar {
    /// MA-A* with the given heuristic and the default rules.
    ///
    /// ```
    /// let a = buridan_mapf::MaAstar::with_heuristic(buridan_mapf::Heuristic::MaxManhattan);
    /// assert!(a.rules.forbid_following);
    /// ```
    pub fn with_heuristic(heuristic: Heuristic) -> Self {
        Self {
            heuristic,
            ..Self::default()
        }
    }
}

impl Planner for MaAstar {
    fn rules(&self) -> ConflictModel {
        self.rules
    }

    fn name(&self) -> &str {
        match (self.heuristic, self.rules.forbid_following) {
            (Heuristic::SumManhattan, true) => "ma-astar",
            (Heuristic::MaxManhattan, true) => "ma-astar-maxmanhattan",
            (Heuristic::MaxDistance, true) => "ma-astar-maxdistance",
            (Heuristic::SumManhattan, false) => "ma-astar-simultaneous",
            (Heuristic::MaxManhattan, false) => "ma-astar-maxmanhattan-simultaneous",
            (Heuristic::MaxDistance, false) => "ma-astar-maxdistance-simultaneous",
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        let mut budget = Budget::start(problem, limits)?;
        let (grid, starts, goals) = (problem.grid, problem.starts, problem.goals);
        let topo = Topology::new(grid);
        let h: Vec<Vec<u32>> = goals
            .iter()
            .map(|&g| match self.heuristic {
                Heuristic::SumManhattan | Heuristic::MaxManhattan => manhattan_table(&topo, g),
                Heuristic::MaxDistance => distance_table(grid, g),
            })
            .collect();
        let bits = usize::BITS - (topo.cells().max(2) - 1).leading_zeros();
        let mut search = Search {
            topo: &topo,
            h,
            sum: self.heuristic == Heuristic::SumManhattan,
            forbid_following: self.rules.forbid_following,
            bits,
            goals: topo.indices(goals),
            joint: Arena::new(goals.len(), &mut budget),
        };
        solve_keyed(&mut search, &topo, starts, starts.len(), bits)
    }
}

#[derive(Clone, Copy)]
struct Node {
    parent: u32,
    g: u32,
    closed: bool,
}

/// Open-list entry: max-heap on (−f, g, −id): lowest f, then deepest, then oldest.
type OpenEntry = (Reverse<u32>, u32, Reverse<u32>);

struct Search<'a> {
    topo: &'a Topology,
    h: Vec<Vec<u32>>,
    sum: bool,
    forbid_following: bool,
    /// Bits per cell in a packed key.
    bits: u32,
    /// The goal configuration.
    goals: Vec<u32>,
    joint: Arena<'a, Node, OpenEntry>,
}

impl Search<'_> {
    fn heuristic(&self, cells: &[u32]) -> u32 {
        let it = cells.iter().zip(&self.h).map(|(&c, h)| h[c as usize]);
        if self.sum {
            it.sum()
        } else {
            it.max().unwrap_or(0)
        }
    }

    /// Bytes held by the search, from the allocated capacities.
    fn bytes<K: JointKey>(&self, index: &FastMap<K, u32>) -> usize {
        self.joint.bytes(index, self.joint.n)
    }

    /// Places agent `i` (agents `< i` are placed in `next`), recursing to the
    /// next agent; a complete joint move is inserted as a successor.
    fn expand<K: JointKey>(
        &mut self,
        i: usize,
        cur: &[u32],
        next: &mut [u32],
        parent: u32,
        g: u32,
        index: &mut FastMap<K, u32>,
    ) -> Result<(), SolveError> {
        if i == self.joint.n {
            return self.insert(next, parent, g, index);
        }
        let here = cur[i];
        let moves = *self.topo.moves(here);
        'actions: for to in moves {
            if to == NONE {
                continue;
            }
            for j in 0..i {
                // Vertex conflict, or swap with an earlier agent.
                if next[j] == to || (to != here && next[j] == here && cur[j] == to) {
                    continue 'actions;
                }
            }
            if self.forbid_following && to != here && cur[i + 1..].contains(&to) {
                // Agent j > i holds `to` now: it stays (vertex conflict) or
                // leaves (following move the env blocks).
                continue;
            }
            next[i] = to;
            self.expand(i + 1, cur, next, parent, g, index)?;
        }
        Ok(())
    }

    fn insert<K: JointKey>(
        &mut self,
        next: &[u32],
        parent: u32,
        g: u32,
        index: &mut FastMap<K, u32>,
    ) -> Result<(), SolveError> {
        if self.joint.budget.count_generated() {
            self.joint.budget.check(self.bytes::<K>(index))?;
        }
        match index.entry(K::pack(next, self.bits)) {
            Entry::Occupied(e) => {
                let id = *e.get();
                let node = &mut self.joint.nodes[id as usize];
                if !node.closed && g < node.g {
                    node.g = g;
                    node.parent = parent;
                    let f = g + self.heuristic(next);
                    self.joint.open.push((Reverse(f), g, Reverse(id)));
                }
            }
            Entry::Vacant(e) => {
                let id = self.joint.nodes.len() as u32;
                e.insert(id);
                self.joint.states.extend_from_slice(next);
                self.joint.nodes.push(Node {
                    parent,
                    g,
                    closed: false,
                });
                let f = g + self.heuristic(next);
                self.joint.open.push((Reverse(f), g, Reverse(id)));
            }
        }
        Ok(())
    }

    fn reconstruct(&self, goal: u32) -> Plan {
        self.joint
            .plan(self.topo, goal, |node| node.parent, |_| true)
    }
}

impl JointSearch for Search<'_> {
    fn budget(&self) -> &Budget {
        self.joint.budget
    }

    fn run<K: JointKey>(&mut self, start: &[u32]) -> Result<Plan, SolveError> {
        let n = self.joint.n;
        let mut index: FastMap<K, u32> = FastMap::default();
        index.insert(K::pack(start, self.bits), 0);
        self.joint.states.extend_from_slice(start);
        self.joint.nodes.push(Node {
            parent: NONE,
            g: 0,
            closed: false,
        });
        self.joint
            .open
            .push((Reverse(self.heuristic(start)), 0, Reverse(0)));
        let cap = self.joint.budget.max_makespan();
        let mut capped = false;
        let mut cur = vec![0u32; n];
        let mut next = vec![0u32; n];
        while let Some((_, g, Reverse(id))) = self.joint.open.pop() {
            let node = self.joint.nodes[id as usize];
            if node.closed || node.g != g {
                continue;
            }
            self.joint.nodes[id as usize].closed = true;
            let bytes = self.bytes::<K>(&index);
            self.joint.budget.on_expand(|| bytes)?;
            cur.copy_from_slice(self.joint.cells(id));
            if cur == self.goals {
                return Ok(self.reconstruct(id));
            }
            if cap.is_some_and(|c| g as usize >= c) {
                capped = true;
                continue;
            }
            self.expand(0, &cur, &mut next, id, g + 1, &mut index)?;
        }
        Err(self.joint.budget.exhausted(capped))
    }
}
