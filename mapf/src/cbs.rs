//! CBS, conflict-based search (SPEC §5), in its plain form.
//!
//! The high level searches a binary constraint tree best-first on the sum of
//! costs (ties: fewer conflicts, then the newer node). A node holds one path
//! per agent, each optimal for that agent under the node's constraints; the
//! first conflict in time order is split into two children, each forbidding
//! it for one of the two agents:
//!
//! - vertex conflict (`a`, `b` on `c` at `t`): `a` not on `c` at `t` | `b`
//!   not on `c` at `t` (this covers agents resting on their goals);
//! - swap conflict (`a: x→y`, `b: y→x` in step `t`): `a` not moving `x→y`
//!   at `t` | `b` not moving `y→x` at `t`;
//! - following conflict (with [`ConflictModel::forbid_following`]; follower `i`
//!   enters `c` at `t + 1` where leader `j > i` stands at `t`): `i` not on `c`
//!   at `t + 1` | `j` not on `c` at `t`.
//!
//! Every conflict-free solution satisfies one of the two constraints, so CBS
//! returns a plan of minimal sum of costs under the chosen rules.
//!
//! The low level is a space-time A* ([`LowLevelHeuristic::Manhattan`] by
//! default, as SPEC §5 says; [`LowLevelHeuristic::TrueDistance`], the
//! shortest-path distance on the static grid, is admissible as well and
//! expands fewer nodes). An agent rests on its goal after arriving, so its
//! path may only end after the last vertex constraint on its goal cell.

use crate::Problem;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::rc::Rc;

use crate::graph::{distance_table, manhattan_table, Topology, NONE};
use crate::limits::{Budget, Limits, SolveError};
use crate::lowlevel::{space_time_astar, Cat, Constraints, LowResult};
use crate::plan::Plan;
use crate::planner::{Planner, Solution};
use crate::rules::ConflictModel;

/// The heuristic of CBS's low-level space-time A*.
///
/// ```
/// assert_eq!(buridan_mapf::LowLevelHeuristic::default(), buridan_mapf::LowLevelHeuristic::Manhattan);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum LowLevelHeuristic {
    /// Manhattan distance to the goal (SPEC §5).
    #[default]
    Manhattan,
    /// Shortest-path distance on the static grid ([`Grid::distances_to`]):
    /// also admissible, better informed around walls.
    TrueDistance,
}

/// Conflict-based search (see the [module docs](self)).
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{Cbs, Limits, Planner, ConflictModel, Problem};
/// let map = Map::load("rm-1.1").unwrap();
/// let scen = map.scenario.unwrap();
/// let sol = Cbs::default().solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// assert_eq!((sol.plan.sum_of_costs(), sol.plan.makespan()), (18, 10));
/// let pure = Cbs { rules: ConflictModel::SIMULTANEOUS, ..Cbs::default() };
/// let sol = pure.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// assert_eq!(sol.plan.sum_of_costs(), 17);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Cbs {
    /// The conflict model (default: following forbidden, env-executable plans).
    pub rules: ConflictModel,
    /// The low-level heuristic (default: Manhattan).
    pub heuristic: LowLevelHeuristic,
    /// Low-level ties go to paths with fewer conflicts (default: off).
    pub conflict_avoidance: bool,
    /// Bypass: adopt an equal-cost child path with fewer conflicts instead of
    /// splitting (default: off).
    pub bypass: bool,
}

impl Cbs {
    /// CBS with conflict avoidance, bypass and the true-distance heuristic
    /// (still optimal for the sum of costs; default rules).
    ///
    /// ```
    /// use buridan_env::Map;
    /// use buridan_mapf::{Cbs, Limits, Planner, Problem};
    /// let map = Map::load("rm-2.2").unwrap();
    /// let scen = map.scenario.unwrap();
    /// let cbs = Cbs::improved();
    /// assert_eq!(cbs.name(), "cbs-improved");
    /// let sol = cbs.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
    /// let plain = Cbs::default().solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
    /// assert_eq!(sol.plan.sum_of_costs(), plain.plan.sum_of_costs());
    /// assert!(sol.stats.expanded < plain.stats.expanded);
    /// ```
    pub fn improved() -> Self {
        Self {
            rules: ConflictModel::default(),
            heuristic: LowLevelHeuristic::TrueDistance,
            conflict_avoidance: true,
            bypass: true,
        }
    }
}

impl Planner for Cbs {
    fn rules(&self) -> ConflictModel {
        self.rules
    }

    fn name(&self) -> &str {
        let plain = !self.conflict_avoidance && !self.bypass;
        let improved = self.conflict_avoidance
            && self.bypass
            && self.heuristic == LowLevelHeuristic::TrueDistance;
        match (plain, improved, self.heuristic, self.rules.forbid_following) {
            (true, _, LowLevelHeuristic::Manhattan, true) => "cbs",
            (true, _, LowLevelHeuristic::TrueDistance, true) => "cbs-truedistance",
            (true, _, LowLevelHeuristic::Manhattan, false) => "cbs-simultaneous",
            (true, _, LowLevelHeuristic::TrueDistance, false) => "cbs-truedistance-simultaneous",
            (_, true, _, true) => "cbs-improved",
            (_, true, _, false) => "cbs-improved-simultaneous",
            (false, false, _, true) => "cbs-custom",
            (false, false, _, false) => "cbs-custom-simultaneous",
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        let mut budget = Budget::start(problem, limits)?;
        let (grid, starts, goals) = (problem.grid, problem.starts, problem.goals);
        let topo = Topology::new(grid);
        let h = goals
            .iter()
            .map(|&g| match self.heuristic {
                LowLevelHeuristic::Manhattan => manhattan_table(&topo, g),
                LowLevelHeuristic::TrueDistance => distance_table(grid, g),
            })
            .collect();
        let mut search = HighLevel {
            topo: &topo,
            h,
            starts: starts.iter().map(|&s| topo.index(s)).collect(),
            goals: goals.iter().map(|&g| topo.index(g)).collect(),
            forbid_following: self.rules.forbid_following,
            conflict_avoidance: self.conflict_avoidance,
            bypass: self.bypass,
            nodes: Vec::new(),
            capped: false,
            budget: &mut budget,
        };
        let plan = search.run()?;
        Ok(Solution {
            plan,
            stats: budget.stats(),
        })
    }
}

/// A constraint on one agent.
#[derive(Debug, Clone, Copy)]
enum Constraint {
    /// Not on `cell` at `t`.
    Vertex { agent: u32, cell: u32, t: u32 },
    /// Not moving `from → to` in step `t → t + 1`.
    Edge {
        agent: u32,
        from: u32,
        to: u32,
        t: u32,
    },
}

impl Constraint {
    fn agent(&self) -> usize {
        match *self {
            Constraint::Vertex { agent, .. } | Constraint::Edge { agent, .. } => agent as usize,
        }
    }
}

/// A conflict between two agents.
#[derive(Debug, Clone, Copy)]
enum Conflict {
    Vertex {
        a: u32,
        b: u32,
        cell: u32,
        t: u32,
    },
    /// `a` moves `a_from → a_to` and `b` the other way in step `t → t + 1`.
    Swap {
        a: u32,
        b: u32,
        a_from: u32,
        a_to: u32,
        t: u32,
    },
    /// `follower` enters `cell` at `t + 1` where `leader` stands at `t`.
    Following {
        follower: u32,
        leader: u32,
        cell: u32,
        t: u32,
    },
}

impl Conflict {
    /// The two constraints of the split.
    fn split(self) -> [Constraint; 2] {
        match self {
            Conflict::Vertex { a, b, cell, t } => [
                Constraint::Vertex { agent: a, cell, t },
                Constraint::Vertex { agent: b, cell, t },
            ],
            Conflict::Swap {
                a,
                b,
                a_from,
                a_to,
                t,
            } => [
                Constraint::Edge {
                    agent: a,
                    from: a_from,
                    to: a_to,
                    t,
                },
                Constraint::Edge {
                    agent: b,
                    from: a_to,
                    to: a_from,
                    t,
                },
            ],
            Conflict::Following {
                follower,
                leader,
                cell,
                t,
            } => [
                Constraint::Vertex {
                    agent: follower,
                    cell,
                    t: t + 1,
                },
                Constraint::Vertex {
                    agent: leader,
                    cell,
                    t,
                },
            ],
        }
    }
}

type Path = Rc<[u32]>;

/// Sum of costs of paths that end at their arrival.
fn cost_of(paths: &[Path]) -> u64 {
    paths.iter().map(|p| p.len() as u64 - 1).sum()
}

/// A constraint-tree node. The constraints of a node are those on the chain
/// from it to the root; the paths of an expanded node are dropped.
struct CtNode {
    parent: u32,
    constraint: Option<Constraint>,
    paths: Vec<Path>,
    cost: u64,
}

/// Open-list entry: max-heap on (−cost, −conflicts, id): cheapest, then
/// fewest conflicts, then newest.
type OpenEntry = (Reverse<u64>, Reverse<u32>, u32);

struct HighLevel<'a> {
    topo: &'a Topology,
    h: Vec<Vec<u32>>,
    starts: Vec<u32>,
    goals: Vec<u32>,
    forbid_following: bool,
    conflict_avoidance: bool,
    bypass: bool,
    nodes: Vec<CtNode>,
    /// Some low-level search was cut by the makespan cap.
    capped: bool,
    budget: &'a mut Budget,
}

impl HighLevel<'_> {
    fn run(&mut self) -> Result<Plan, SolveError> {
        let n = self.starts.len();
        let mut root_paths: Vec<Path> = Vec::with_capacity(n);
        for agent in 0..n {
            let cons = Constraints::new(self.goals[agent]);
            match self.low_level(agent, &cons, &root_paths)? {
                Some(p) => root_paths.push(p),
                None => return Err(self.no_solution()),
            }
        }
        let mut open = BinaryHeap::new();
        let root = self.add_node(NONE, None, root_paths);
        let (_, conflicts) = self.conflicts(&self.nodes[root as usize].paths);
        open.push((
            Reverse(self.nodes[root as usize].cost),
            Reverse(conflicts),
            root,
        ));
        while let Some((_, _, id)) = open.pop() {
            let open_bytes = open.len() * std::mem::size_of::<OpenEntry>();
            self.budget.on_expand(|| open_bytes)?;
            let paths = std::mem::take(&mut self.nodes[id as usize].paths);
            let (first, conflicts) = self.conflicts(&paths);
            let Some(conflict) = first else {
                return Ok(self.plan(&paths));
            };
            let cost = self.nodes[id as usize].cost;
            let mut children = Vec::with_capacity(2);
            for constraint in conflict.split() {
                let agent = constraint.agent();
                let cons = self.constraints_of(id, agent, constraint);
                let Some(path) = self.low_level(agent, &cons, &paths)? else {
                    continue;
                };
                let mut child_paths = paths.clone();
                child_paths[agent] = path;
                let (_, child_conflicts) = self.conflicts(&child_paths);
                children.push((constraint, child_paths, child_conflicts));
            }
            if self.bypass {
                // An equal-cost child with fewer conflicts: its path also
                // satisfies this node's constraints, so take it and retry.
                let best = children
                    .iter()
                    .enumerate()
                    .filter(|(_, (_, p, c))| *c < conflicts && cost_of(p) == cost)
                    .min_by_key(|(_, (_, _, c))| *c)
                    .map(|(i, _)| i);
                if let Some(i) = best {
                    let (_, child_paths, child_conflicts) = children.swap_remove(i);
                    self.nodes[id as usize].paths = child_paths;
                    open.push((Reverse(cost), Reverse(child_conflicts), id));
                    continue;
                }
            }
            for (constraint, child_paths, child_conflicts) in children {
                self.budget.generated += 1;
                let child = self.add_node(id, Some(constraint), child_paths);
                open.push((
                    Reverse(self.nodes[child as usize].cost),
                    Reverse(child_conflicts),
                    child,
                ));
            }
            // The expanded node keeps only its constraint; its paths live on
            // in the children (shared) or are freed.
            self.budget
                .release(paths.len() * std::mem::size_of::<Path>());
        }
        Err(self.no_solution())
    }

    fn no_solution(&self) -> SolveError {
        self.budget.exhausted(self.capped)
    }

    fn add_node(&mut self, parent: u32, constraint: Option<Constraint>, paths: Vec<Path>) -> u32 {
        let cost = cost_of(&paths);
        // The node, its path pointers and the one new path it owns.
        self.budget.hold(
            std::mem::size_of::<CtNode>()
                + paths.len() * std::mem::size_of::<Path>()
                + constraint.map_or(0, |c| paths[c.agent()].len() * 4 + 16),
        );
        self.nodes.push(CtNode {
            parent,
            constraint,
            paths,
            cost,
        });
        self.nodes.len() as u32 - 1
    }

    /// All constraints on `agent` along the chain from `id` to the root, plus `extra`.
    fn constraints_of(&self, id: u32, agent: usize, extra: Constraint) -> Constraints {
        let mut cons = Constraints::new(self.goals[agent]);
        let mut add = |c: Constraint| match c {
            Constraint::Vertex { cell, t, .. } => cons.add_vertex(cell, t),
            Constraint::Edge { from, to, t, .. } => cons.add_edge(from, to, t),
        };
        add(extra);
        let mut k = id;
        while k != NONE {
            let node = &self.nodes[k as usize];
            if let Some(c) = node.constraint.filter(|c| c.agent() == agent) {
                add(c);
            }
            k = node.parent;
        }
        cons
    }

    /// Agent `agent`'s best path under `cons`; `paths` (the other agents'
    /// current paths, possibly fewer than all) feed the conflict avoidance.
    fn low_level(
        &mut self,
        agent: usize,
        cons: &Constraints,
        paths: &[Path],
    ) -> Result<Option<Path>, SolveError> {
        let cat = (self.conflict_avoidance && !paths.is_empty()).then(|| Cat::new(paths, agent));
        let result = space_time_astar(
            self.topo,
            self.starts[agent],
            self.goals[agent],
            &self.h[agent],
            cons,
            cat.as_ref(),
            self.budget.max_makespan(),
            self.budget,
        )?;
        Ok(match result {
            LowResult::Path(p) => Some(p.into()),
            LowResult::NoPath { capped } => {
                self.capped |= capped;
                None
            }
        })
    }

    /// The first conflict in time order (vertex conflicts at `t` before moves
    /// `t → t + 1`) and the number of conflicting (pair, time) events.
    fn conflicts(&self, paths: &[Path]) -> (Option<Conflict>, u32) {
        let n = paths.len();
        let horizon = paths.iter().map(|p| p.len()).max().unwrap_or(1) - 1;
        let at = |i: usize, t: usize| {
            let p = &paths[i];
            p[t.min(p.len() - 1)]
        };
        let mut first = None;
        let mut count = 0u32;
        let mut note = |c: Conflict, first: &mut Option<Conflict>| {
            count += 1;
            if first.is_none() {
                *first = Some(c);
            }
        };
        for t in 0..=horizon {
            for a in 0..n {
                let pa = at(a, t);
                for b in a + 1..n {
                    if pa == at(b, t) {
                        let c = Conflict::Vertex {
                            a: a as u32,
                            b: b as u32,
                            cell: pa,
                            t: t as u32,
                        };
                        note(c, &mut first);
                    }
                }
            }
            if t == horizon {
                break;
            }
            for a in 0..n {
                let (a0, a1) = (at(a, t), at(a, t + 1));
                if a0 == a1 {
                    continue;
                }
                for b in 0..n {
                    if b == a {
                        continue;
                    }
                    let (b0, b1) = (at(b, t), at(b, t + 1));
                    if b0 != a1 {
                        continue;
                    }
                    if b1 == a0 {
                        if a < b {
                            let c = Conflict::Swap {
                                a: a as u32,
                                b: b as u32,
                                a_from: a0,
                                a_to: a1,
                                t: t as u32,
                            };
                            note(c, &mut first);
                        }
                    } else if self.forbid_following && b > a && b1 != b0 {
                        let c = Conflict::Following {
                            follower: a as u32,
                            leader: b as u32,
                            cell: a1,
                            t: t as u32,
                        };
                        note(c, &mut first);
                    }
                }
            }
        }
        (first, count)
    }

    fn plan(&self, paths: &[Path]) -> Plan {
        Plan::new(
            paths
                .iter()
                .map(|p| p.iter().map(|&c| self.topo.cell(c)).collect())
                .collect(),
        )
        .trimmed()
    }
}
