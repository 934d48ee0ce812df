//! The search itself: LaCAM's high-level depth-first search over
//! configurations with its lazily built constraint trees, and LaCAM*'s
//! costs, neighbour graph and pruning on top (the steps are the module
//! docs' of [`super`]).

use std::collections::VecDeque;
use std::time::Duration;

use crate::graph::{FastMap, NONE};
use crate::limits::{Budget, Limits, SolveError};
use crate::pibt::{Generator, Setup, TieBreaker};
use crate::planner::{Solution, Stats};
use crate::rules::ConflictModel;

use super::{Objective, Outcome};

/// How the search generates and orders successors (shared by LaCAM and
/// LaCAM*).
#[derive(Clone, Copy)]
pub(super) struct Generation {
    pub(super) rules: ConflictModel,
    pub(super) seed: u64,
    pub(super) swap: bool,
    pub(super) restart: f64,
    pub(super) generators: u32,
}

/// LaCAM*'s settings.
#[derive(Clone, Copy)]
pub(super) struct Star {
    pub(super) objective: Objective,
    pub(super) refine_time: Option<Duration>,
}

/// A high-level node: a configuration and its lazily expanded successors.
struct HNode {
    config: Box<[u32]>,
    parent: u32,
    /// Agents by decreasing PIBT priority.
    order: Box<[u32]>,
    priorities: Box<[f64]>,
    /// Constraint sets still to try (ids into the low-level arena).
    tree: VecDeque<u32>,
    /// Cost from the start along the parent chain (LaCAM*).
    g: u64,
    /// Admissible estimate of the cost to the goal (LaCAM*).
    h: u64,
    /// Known successors (LaCAM*).
    neighbours: Vec<u32>,
}

/// A constraint set, as the last constraint and a link to the rest:
/// `who` goes to `cell`; `depth` constraints in total.
#[derive(Clone, Copy)]
struct LNode {
    parent: u32,
    who: u32,
    cell: u32,
    depth: u32,
}

pub(super) struct Search<'a> {
    setup: &'a Setup,
    /// The configuration generators (at least one), each with its own
    /// tie-breaking.
    gens: Vec<Generator<'a>>,
    star: Option<Star>,
    budget: Budget,
    nodes: Vec<HNode>,
    low: Vec<LNode>,
    explored: FastMap<Box<[u32]>, u32>,
    open: Vec<u32>,
    goal_node: Option<u32>,
    first_cost: u64,
    /// Random restarts: probability and the dice.
    restart: f64,
    dice: TieBreaker,
    /// Within a makespan cap (the objective is the makespan): nodes that
    /// cannot lead to a plan within it are pruned.
    pub(super) cap: Option<u64>,
    /// LaCAM within a cap: return the first plan within it.
    pub(super) first_fit: bool,
}

impl<'a> Search<'a> {
    pub(super) fn new(
        setup: &'a Setup,
        how: Generation,
        star: Option<Star>,
        limits: &Limits,
    ) -> Self {
        let gens = (0..u64::from(how.generators.max(1)))
            .map(|k| {
                let gen = Generator::new(&setup.topo, how.rules, how.seed.wrapping_add(k));
                if how.swap {
                    gen.with_swap(&setup.dist, &setup.goals)
                } else {
                    gen
                }
            })
            .collect();
        Self {
            setup,
            gens,
            star,
            budget: Budget::new(limits),
            nodes: Vec::new(),
            // The root of every low-level tree: no constraint.
            low: vec![LNode {
                parent: NONE,
                who: NONE,
                cell: NONE,
                depth: 0,
            }],
            explored: FastMap::default(),
            open: Vec::new(),
            goal_node: None,
            first_cost: 0,
            restart: how.restart,
            // Its own stream: restarts do not shift PIBT's tie-breaking.
            dice: TieBreaker::new(how.seed ^ 0xD1CE),
            cap: None,
            first_fit: false,
        }
    }

    fn objective(&self) -> Objective {
        self.star.map_or(Objective::SumOfLoss, |s| s.objective)
    }

    /// Cost of the step `from → to`.
    fn edge_cost(&self, from: &[u32], to: &[u32]) -> u64 {
        let goals = &self.setup.goals;
        match self.objective() {
            Objective::SumOfLoss => (0..goals.len())
                .filter(|&i| from[i] != goals[i] || to[i] != goals[i])
                .count() as u64,
            Objective::Makespan => u64::from(from != &goals[..] || to != &goals[..]),
        }
    }

    fn heuristic(&self, config: &[u32]) -> u64 {
        let d = (0..config.len()).map(|i| u64::from(self.setup.dist[i][config[i] as usize]));
        match self.objective() {
            Objective::SumOfLoss => d.sum(),
            Objective::Makespan => d.max().unwrap_or(0),
        }
    }

    fn add_node(&mut self, config: Vec<u32>, parent: u32, priorities: Vec<f64>, g: u64) -> u32 {
        let n = config.len();
        let id = self.nodes.len() as u32;
        let h = self.heuristic(&config);
        let order = Setup::order(&priorities).into_boxed_slice();
        let config = config.into_boxed_slice();
        self.explored.insert(config.clone(), id);
        self.nodes.push(HNode {
            config,
            parent,
            order,
            priorities: priorities.into_boxed_slice(),
            tree: VecDeque::from([0]),
            g,
            h,
            neighbours: Vec::new(),
        });
        // Node, two copies of the configuration, order, priorities, map entry.
        self.budget
            .hold(std::mem::size_of::<HNode>() + n * (4 + 4 + 4 + 8) + 48);
        id
    }

    pub(super) fn run(mut self) -> Result<Outcome, SolveError> {
        let n = self.setup.starts.len();
        let root = self.add_node(
            self.setup.starts.clone(),
            NONE,
            self.setup.initial_priorities(),
            0,
        );
        self.open.push(root);
        let mut constraints: Vec<(u32, u32)> = Vec::with_capacity(n);
        let mut next = Vec::with_capacity(n);
        let mut candidate = Vec::with_capacity(n);
        // High-level search over configurations, depth-first on `Open`.
        while let Some(&top) = self.open.last() {
            let open_bytes = self.open.len() * 4;
            if let Err(e) = self.budget.on_expand(|| open_bytes) {
                return self.best_or(e);
            }
            if self.goal_node.is_some() && self.budget.expanded & 255 == 0 {
                if let Some(refine) = self.star.and_then(|s| s.refine_time) {
                    if self.budget.cpu_elapsed() > refine {
                        return Ok(self.outcome(false));
                    }
                }
            }
            // 1. Goal check on the node on top of `Open`.
            let node = &self.nodes[top as usize];
            if self.goal_node.is_none() && node.config[..] == self.setup.goals[..] {
                self.goal_node = Some(top);
                self.first_cost = node.g;
                if self.star.is_none() || self.within_cap() {
                    return Ok(self.outcome(false));
                }
            }
            // (LaCAM*) Prune nodes that cannot beat the best solution (or,
            // within a cap, lead to a plan within it).
            if self.bound().is_some_and(|b| b <= node.g + node.h) {
                self.open.pop();
                continue;
            }
            // 2. Low-level search: the next constraint set from the node's
            // constraint tree (exhausted: the node leaves `Open`) ...
            let Some(c) = self.nodes[top as usize].tree.pop_front() else {
                self.open.pop();
                continue;
            };
            // ... and its children, one per cell of the next agent in order.
            let low = self.low[c as usize];
            if (low.depth as usize) < n {
                let node = &self.nodes[top as usize];
                let who = node.order[low.depth as usize];
                let here = node.config[who as usize];
                for &cell in self.setup.topo.moves(here) {
                    if cell == NONE {
                        continue;
                    }
                    let id = self.low.len() as u32;
                    self.low.push(LNode {
                        parent: c,
                        who,
                        cell,
                        depth: low.depth + 1,
                    });
                    self.nodes[top as usize].tree.push_back(id);
                    self.budget.hold(std::mem::size_of::<LNode>() + 4);
                }
            }
            // 3. Successor generation: PIBT under the constraints.
            constraints.clear();
            let mut k = c;
            while self.low[k as usize].depth > 0 {
                let l = self.low[k as usize];
                constraints.push((l.who, l.cell));
                k = l.parent;
            }
            // With several generators, the successor of least cost plus
            // heuristic (the first on ties).
            let mut best = None;
            for k in 0..self.gens.len() {
                let node = &self.nodes[top as usize];
                if !self.gens[k].generate(
                    &self.setup.dist,
                    &node.config,
                    &node.order,
                    &constraints,
                    &mut candidate,
                ) {
                    continue;
                }
                let f = if self.gens.len() > 1 {
                    self.edge_cost(&node.config, &candidate) + self.heuristic(&candidate)
                } else {
                    0
                };
                if best.is_none_or(|b| f < b) {
                    best = Some(f);
                    std::mem::swap(&mut next, &mut candidate);
                }
            }
            if best.is_none() {
                continue;
            }
            self.budget.generated += 1;
            // 4. Duplicate detection: a known configuration is re-inserted,
            // a new one becomes a new high-level node.
            if let Some(&known) = self.explored.get(&next[..]) {
                if !self.nodes[top as usize].neighbours.contains(&known) {
                    self.nodes[top as usize].neighbours.push(known);
                    self.budget.hold(4);
                }
                if self.star.is_some() {
                    self.relax(top);
                    if self.within_cap() {
                        return Ok(self.outcome(false));
                    }
                }
                // Reinsertion: the known node goes back on top of `Open`.
                // Measured on rm-2.1b (4 agents, 100 episodes, 2 s): without
                // it LaCAM plans 88 instances but only 63 within T_max (the
                // depth-first chains wander); with it 81 and 81. Sometimes
                // the start goes on top instead (a random restart); nothing
                // leaves `Open` for it, so the search stays complete.
                let restart = f64::from(self.dice.next()) < self.restart * 4_294_967_296.0;
                self.open.push(if restart { 0 } else { known });
            } else {
                let node = &self.nodes[top as usize];
                let mut priorities = node.priorities.to_vec();
                self.setup.update_priorities(&mut priorities, &next);
                let g = node.g + self.edge_cost(&node.config, &next);
                let id = self.add_node(next.clone(), top, priorities, g);
                self.nodes[top as usize].neighbours.push(id);
                self.budget.hold(4);
                self.open.push(id);
            }
        }
        match (self.goal_node, self.cap) {
            // Exhausted with a plan within the cap (LaCAM*): optimal.
            (Some(goal), cap) if cap.is_none_or(|c| self.nodes[goal as usize].g <= c) => {
                Ok(self.outcome(true))
            }
            // Exhausted: no node with `g + h` within the cap leads to the goal.
            (_, Some(cap)) => Err(SolveError::NoSolutionWithin {
                max_makespan: cap as usize,
            }),
            (_, None) => Err(SolveError::NoSolution),
        }
    }

    /// Nodes with `g + h` at least this cannot lead to a plan worth
    /// having: cheaper than the best solution (LaCAM*) and, within a cap,
    /// with a makespan within it.
    fn bound(&self) -> Option<u64> {
        let best = self.goal_node.map(|goal| self.nodes[goal as usize].g);
        let cap = self.cap.map(|c| c + 1);
        match (best, cap) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// LaCAM within a cap: the best plan so far fits it.
    fn within_cap(&self) -> bool {
        if !self.first_fit {
            return false;
        }
        match (self.goal_node, self.cap) {
            (Some(goal), Some(cap)) => self.nodes[goal as usize].g <= cap,
            _ => false,
        }
    }

    /// Propagates a cheaper `g` from `from` through the neighbour graph,
    /// re-parenting improved nodes; improved nodes that could still beat the
    /// best solution (or fit the cap, see [`Search::bound`]) go back on `Open`.
    fn relax(&mut self, from: u32) {
        let mut stack = vec![from];
        while let Some(a) = stack.pop() {
            for k in 0..self.nodes[a as usize].neighbours.len() {
                let b = self.nodes[a as usize].neighbours[k];
                let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
                let g = na.g + self.edge_cost(&na.config, &nb.config);
                if g < nb.g {
                    let h = nb.h;
                    let nb = &mut self.nodes[b as usize];
                    nb.g = g;
                    nb.parent = a;
                    stack.push(b);
                    if self.bound().is_some_and(|bound| g + h < bound) {
                        self.open.push(b);
                    }
                }
            }
        }
    }

    /// On a limit: LaCAM* returns its best plan, otherwise the error.
    fn best_or(self, e: SolveError) -> Result<Outcome, SolveError> {
        match (self.goal_node, &e) {
            (
                Some(_),
                SolveError::TimeLimit { .. }
                | SolveError::MemoryLimit { .. }
                | SolveError::NodeLimit { .. },
            ) => Ok(self.outcome(false)),
            _ => Err(e),
        }
    }

    /// The fewest-steps path from the start to `goal` over the explored
    /// graph (every edge seen during the search), by breadth-first search:
    /// LaCAM's depth-first parent chain can be much longer.
    fn shortest_chain(&self, goal: u32) -> Vec<u32> {
        let mut parent = vec![NONE; self.nodes.len()];
        let mut queue = VecDeque::from([0u32]);
        parent[0] = 0;
        while let Some(a) = queue.pop_front() {
            if a == goal {
                break;
            }
            for &b in &self.nodes[a as usize].neighbours {
                if parent[b as usize] == NONE {
                    parent[b as usize] = a;
                    queue.push_back(b);
                }
            }
        }
        let mut chain = vec![goal];
        let mut k = goal;
        while k != 0 {
            k = parent[k as usize];
            chain.push(k);
        }
        chain.reverse();
        chain
    }

    fn outcome(&self, proven_optimal: bool) -> Outcome {
        let goal = self.goal_node.expect("called with a solution");
        let chain = if self.star.is_some() {
            // LaCAM*: the parent chain is the cheapest known path.
            let mut chain = Vec::new();
            let mut k = goal;
            while k != NONE {
                chain.push(k);
                k = self.nodes[k as usize].parent;
            }
            chain.reverse();
            chain
        } else {
            self.shortest_chain(goal)
        };
        let configs: Vec<Vec<u32>> = chain
            .iter()
            .map(|&k| self.nodes[k as usize].config.to_vec())
            .collect();
        Outcome {
            solution: Solution {
                plan: self.setup.plan(&configs),
                stats: Stats {
                    low_level_expanded: self.low.len() as u64 - 1,
                    ..self.budget.stats()
                },
            },
            proven_optimal,
            first_cost: self.first_cost,
            cost: self.nodes[goal as usize].g,
        }
    }
}
