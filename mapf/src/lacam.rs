//! LaCAM, lazy constraints addition search for MAPF (Okumura, AAAI-23), and
//! LaCAM*, its anytime, eventually optimal version (Okumura, IJCAI-23).
//!
//! # LaCAM
//!
//! A search over **configurations** (one cell per agent), depth-first. The
//! successors of a configuration are not enumerated up front (5ⁿ of them)
//! but produced one at a time, lazily, by the PIBT configuration generator
//! ([`crate::pibt`]) under **constraints** "agent `i` goes to cell `v`". Each
//! high-level node owns a breadth-first queue of constraint sets (the
//! *low-level tree*): the empty set first, then every choice of cell for the
//! first agent of the node's order, then for the first two agents, and so on.
//! One iteration:
//!
//! 1. take the node `N` on top of the stack (`Open`); if its configuration is
//!    the goal, backtrack the parents into a plan;
//! 2. pop the next constraint set `C` from `N`'s queue (an exhausted queue
//!    pops `N` off the stack); if `C` fixes fewer than `n` agents, queue its
//!    extensions by the next agent of `N`'s order (each of its cells);
//! 3. ask PIBT for a successor of `N` that meets `C`; a new configuration
//!    becomes a new node on top of the stack, a known one goes back on top
//!    (*reinsertion*, from LaCAM*: it keeps the search near the region that
//!    matters and the plans short) — or, with probability
//!    [`Lacam::restart`], the start configuration does (a *random restart*,
//!    as in LaCAM3: a depth-first search that went down a hopeless branch
//!    otherwise spends its whole budget there).
//!
//! The plan is the fewest-steps path from the start to the goal over all
//! edges the search has seen (breadth-first), not just the depth-first
//! parent chain.
//!
//! **Completeness.** A constraint set fixing all `n` agents makes the
//! generator return exactly that configuration if it is a legal step (and
//! fail otherwise), so a node whose queue is exhausted has generated every
//! legal successor. The search space (configurations × constraint sets) is
//! finite, so LaCAM either returns a plan or, once `Open` is empty, has
//! visited every configuration reachable from the start: the instance is
//! **proven unsolvable** ([`SolveError::NoSolution`]).
//!
//! **Env rules.** "Legal step" is a step of the generator's rules
//! ([`crate::pibt`] explains how it respects the env's index order), so
//! every plan replays exactly in the env under [`ConflictModel::ENV_EXECUTABLE`],
//! and an unsolvable verdict is relative to those rules: four agents that
//! must rotate around a 2×2 block can do so simultaneously
//! ([`ConflictModel::SIMULTANEOUS`]) but never in the env.
//!
//! # LaCAM*
//!
//! The same search, continued after the first solution: every node keeps
//! `g` (cost from the start along its parent), `h` (an admissible estimate)
//! and its known neighbours; reaching a known configuration again adds the
//! edge and relaxes `g` Dijkstra-style through the neighbour graph
//! (re-parenting nodes, so the goal's parent chain is always the cheapest
//! known path). Nodes with `g + h ≥` the best solution's cost are pruned.
//! When `Open` runs empty the solution is optimal for the [`Objective`];
//! otherwise the time budget returns the best plan so far.
//!
//! Both honour [`Limits::time`], [`Limits::memory_bytes`] (estimated from
//! the stored nodes, constraint sets and explored table) and
//! [`Limits::max_nodes`] (search iterations). [`Limits::max_makespan`] is
//! not used (the search is finite without it) unless [`Lacam::within_cap`]
//! is set.
//!
//! # LaCAM within a makespan cap
//!
//! With [`Lacam::within_cap`] and [`Limits::max_makespan`] set, LaCAM runs
//! as LaCAM* minimising the makespan and returns the first plan whose
//! makespan is within the cap: a longer first plan is refined rather than
//! returned. Nodes whose `g + h` exceeds the cap are pruned from the start
//! (`h`, the longest remaining distance, is admissible), so an exhausted
//! search proves that no plan within the cap exists
//! ([`SolveError::NoSolutionWithin`]); at a limit the shortest plan found
//! so far is returned even if it is longer than the cap.
//!
//! [`LacamStar::within_cap`] does the same for LaCAM*: minimising the
//! makespan it prunes by the cap and refines as usual (an exhausted search
//! proves its plan optimal, or that none fits); minimising the sum of loss
//! it refines as usual and, if its plan is longer than the cap, LaCAM
//! within the cap takes the time left (its plan replaces the long one, its
//! proof ends the call). [`crate::planner_within_cap`] makes both so; the
//! planner controllers of `learner eval` plan within the episode's T_max.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::Map;
//! use buridan_mapf::{replay_exact, Cbs, Lacam, LacamStar, Limits, Planner, Problem};
//! let map = Arc::new(Map::load("rm-1.1").unwrap());
//! let scen = map.scenario.clone().unwrap();
//! let (s, g) = (&scen.starts, &scen.goals);
//! let fast = Lacam::default().solve(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! replay_exact(&map, s, g, &fast.plan, 1000).unwrap();
//! let star = LacamStar::default().search(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! assert!(star.proven_optimal);
//! let cbs = Cbs::default().solve(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! assert_eq!(star.solution.plan.sum_of_costs(), cbs.plan.sum_of_costs()); // 18
//! ```

use crate::Problem;
use std::collections::VecDeque;
use std::time::Duration;

use crate::graph::{FastMap, NONE};
use crate::limits::{Budget, Limits, SolveError};
use crate::pibt::{Generator, Setup, TieBreaker};
use crate::planner::{Planner, Solution, Stats};
use crate::rules::ConflictModel;

/// What LaCAM* minimises.
///
/// ```
/// assert_eq!(buridan_mapf::Objective::default(), buridan_mapf::Objective::SumOfLoss);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Objective {
    /// Sum over steps of the agents not resting on their goals (a step in
    /// which an agent stays on its goal costs 0). Equals the sum of costs of
    /// plans in which no agent leaves its goal again, and never exceeds it.
    #[default]
    SumOfLoss,
    /// The number of steps until all agents stand on their goals.
    Makespan,
}

/// LaCAM: complete, suboptimal, fast (see the [module docs](self)).
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{Lacam, Limits, Planner, SolveError, Problem};
/// // Two agents cannot swap in a corridor: LaCAM proves it.
/// let grid = Grid::from_rows(&["..."]).unwrap();
/// let (s, g) = ([Cell::new(0, 0), Cell::new(0, 1)], [Cell::new(0, 1), Cell::new(0, 0)]);
/// let err = Lacam::default().solve(Problem::new(&grid, &s, &g), &Limits::default()).unwrap_err();
/// assert_eq!(err, SolveError::NoSolution);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Lacam {
    /// The conflict model (default: env-executable plans).
    pub rules: ConflictModel,
    /// Seed of PIBT's tie-breaking.
    pub seed: u64,
    /// PIBT's *swap* operation in the configuration generator (default
    /// on under both rule sets; see [`crate::pibt`]): agents that must pass
    /// each other in a single lane back out to where it branches. Measured
    /// under pogema rules ([`ConflictModel::SIMULTANEOUS`]) on POGEMA's
    /// maze instances (`mazes` example, 10 s CPU, T_max 128): without it
    /// LaCAM plans 19 and 14 of 24 maps (every 4th) at 48 and 64 agents,
    /// the rest run out of time; with it all 96 maps at every count are
    /// planned within 0.9 s, and 86–93 of the 96 plans at 64 agents
    /// (seeds 0–4) are within T_max. On the warehouse set (every 4th
    /// seed, 32–192 agents) both plan all instances in milliseconds, with
    /// sums of costs within 0.5 %.
    #[serde(default = "swap_default")]
    pub swap: bool,
    /// Probability that reaching a known configuration sends the search
    /// back to the start instead of to that configuration (default 0.1; 0
    /// turns random restarts off). Measured on the seed-42 episodes with 1 s
    /// per instance (`docs/results/planners/RESULTS.md`): on rm-2.1b with 4
    /// agents the worst case drops from over 1 s (episode 2 unsolved) to
    /// 0.9 ms; with 16 agents 89 instead of 44 of 100 are planned.
    #[serde(default = "restart_default")]
    pub restart: f64,
    /// Configuration generators per successor (default 1): PIBT runs this
    /// many times under the same constraints, each with its own
    /// tie-breaking seed, and the successor with the least cost plus
    /// heuristic is kept (LaCAM3's Monte-Carlo configuration generation).
    /// Measured under pogema rules on the 96 maze maps at 64 agents (seeds
    /// 0–4, 10 s): plans within T_max 128 for 90.4, 90.2 and 87.6 of 96 on
    /// average with 1, 4 and 10 generators, worst CPU time 1.2, 4.1 and
    /// 3.5 s; LaCAM* on the warehouse (every 4th seed, 0.5 s refinement)
    /// ends 2.6 % lower in sum of costs at 192 agents with 4 than with 1.
    #[serde(default = "generators_default")]
    pub generators: u32,
    /// Search on until a plan within [`Limits::max_makespan`] is found
    /// (default off; see [LaCAM within a makespan cap](self#lacam-within-a-makespan-cap)).
    #[serde(default)]
    pub within_cap: bool,
}

fn swap_default() -> bool {
    true
}

fn restart_default() -> f64 {
    0.1
}

fn generators_default() -> u32 {
    1
}

impl Default for Lacam {
    fn default() -> Self {
        Self {
            rules: ConflictModel::default(),
            seed: 0,
            swap: swap_default(),
            restart: restart_default(),
            generators: generators_default(),
            within_cap: false,
        }
    }
}

/// LaCAM*: LaCAM that keeps improving its solution (see the
/// [module docs](self)).
///
/// ```
/// use std::time::Duration;
/// let star = buridan_mapf::LacamStar::default();
/// assert_eq!(star.refine_time, Some(Duration::from_millis(500)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LacamStar {
    /// The conflict model (default: env-executable plans).
    pub rules: ConflictModel,
    /// Seed of PIBT's tie-breaking.
    pub seed: u64,
    /// What to minimise (default: sum of loss).
    pub objective: Objective,
    /// CPU time after which a search that has a solution stops refining it
    /// and returns it (default 0.5 s: on the seed-42 episodes of the four
    /// layouts, 4 agents, the plans' sum of costs is within 0.5 % of what
    /// 1 s gives, `docs/results/planners/RESULTS.md`); `None` refines until the solution is
    /// proven optimal or [`Limits::time`] runs out. Without a solution the
    /// search goes on until the limits.
    pub refine_time: Option<Duration>,
    /// PIBT's *swap* operation (default on, see [`Lacam::swap`]).
    #[serde(default = "swap_default")]
    pub swap: bool,
    /// Random restarts (default 0.1, see [`Lacam::restart`]).
    #[serde(default = "restart_default")]
    pub restart: f64,
    /// Configuration generators per successor (default 1, see
    /// [`Lacam::generators`]).
    #[serde(default = "generators_default")]
    pub generators: u32,
    /// Return a plan within [`Limits::max_makespan`] (default off; see
    /// [LaCAM within a makespan cap](self#lacam-within-a-makespan-cap)).
    #[serde(default)]
    pub within_cap: bool,
}

impl Default for LacamStar {
    fn default() -> Self {
        Self {
            rules: ConflictModel::default(),
            seed: 0,
            objective: Objective::default(),
            refine_time: Some(Duration::from_millis(500)),
            swap: swap_default(),
            restart: restart_default(),
            generators: generators_default(),
            within_cap: false,
        }
    }
}

/// What [`LacamStar::search`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outcome {
    /// The best plan and the search effort.
    pub solution: Solution,
    /// The search space was exhausted: the plan is optimal for the
    /// objective (under the rules).
    pub proven_optimal: bool,
    /// The objective's value of the first solution found.
    pub first_cost: u64,
    /// The objective's value of the returned plan.
    pub cost: u64,
}

impl Planner for Lacam {
    fn rules(&self) -> ConflictModel {
        self.rules
    }

    fn name(&self) -> &str {
        if self.rules.forbid_following {
            "lacam"
        } else {
            "lacam-simultaneous"
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        let setup = Setup::new(problem)?;
        let cap = limits.max_makespan.filter(|_| self.within_cap);
        // Within a cap: LaCAM* on the makespan until a plan fits.
        let star = cap.map(|_| Star {
            objective: Objective::Makespan,
            refine_time: None,
        });
        let mut search = Search::new(&setup, self.generator(), star, limits);
        search.cap = cap.map(|c| c as u64);
        search.first_fit = true;
        search.run().map(|o| o.solution)
    }
}

impl Lacam {
    fn generator(&self) -> Generation {
        Generation {
            rules: self.rules,
            seed: self.seed,
            swap: self.swap,
            restart: self.restart,
            generators: self.generators,
        }
    }
}

impl LacamStar {
    /// Solves and tells whether the plan is proven optimal.
    ///
    /// ```
    /// use buridan_env::Map;
    /// use buridan_mapf::{LacamStar, Limits, Problem};
    /// let map = Map::load("rm-1.3").unwrap();
    /// let scen = map.scenario.unwrap();
    /// let out = LacamStar::default().search(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
    /// assert!(out.proven_optimal && out.cost <= out.first_cost);
    /// assert_eq!(out.solution.plan.makespan(), 7);
    /// ```
    pub fn search(&self, problem: Problem<'_>, limits: &Limits) -> Result<Outcome, SolveError> {
        let clock = Budget::new(limits);
        let setup = Setup::new(problem)?;
        let cap = limits.max_makespan.filter(|_| self.within_cap);
        let star = Star {
            objective: self.objective,
            refine_time: self.refine_time,
        };
        let mut search = Search::new(&setup, self.lacam().generator(), Some(star), limits);
        if self.objective == Objective::Makespan {
            search.cap = cap.map(|c| c as u64);
        }
        let found = search.run();
        let Some(cap) = cap else {
            return found;
        };
        match found {
            Ok(out) if out.solution.plan.makespan() > cap => {
                // The sum-of-loss plan is too long: LaCAM within the cap
                // for the time left; at its limit the long plan stands.
                let left = Limits {
                    time: limits.time.saturating_sub(clock.cpu_elapsed()),
                    ..*limits
                };
                let within = Lacam {
                    within_cap: true,
                    ..self.lacam()
                };
                match within.solve(problem, &left) {
                    Ok(solution) if solution.plan.makespan() <= cap => Ok(Outcome {
                        cost: sum_of_loss(&solution.plan),
                        solution,
                        proven_optimal: false,
                        first_cost: out.first_cost,
                    }),
                    Err(e @ SolveError::NoSolutionWithin { .. }) => Err(e),
                    _ => Ok(out),
                }
            }
            other => other,
        }
    }

    /// LaCAM with these settings (returning its first plan).
    fn lacam(&self) -> Lacam {
        Lacam {
            rules: self.rules,
            seed: self.seed,
            swap: self.swap,
            restart: self.restart,
            generators: self.generators,
            within_cap: false,
        }
    }
}

impl Planner for LacamStar {
    fn rules(&self) -> ConflictModel {
        self.rules
    }

    fn name(&self) -> &str {
        match (self.rules.forbid_following, self.objective) {
            (true, Objective::SumOfLoss) => "lacam-star",
            (true, Objective::Makespan) => "lacam-star-makespan",
            (false, Objective::SumOfLoss) => "lacam-star-simultaneous",
            (false, Objective::Makespan) => "lacam-star-makespan-simultaneous",
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        self.search(problem, limits).map(|o| o.solution)
    }
}

/// How the search generates and orders successors (shared by LaCAM and
/// LaCAM*).
#[derive(Clone, Copy)]
struct Generation {
    rules: ConflictModel,
    seed: u64,
    swap: bool,
    restart: f64,
    generators: u32,
}

/// LaCAM*'s settings.
#[derive(Clone, Copy)]
struct Star {
    objective: Objective,
    refine_time: Option<Duration>,
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

struct Search<'a> {
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
    /// Estimated bytes held by the search.
    bytes: usize,
    /// Random restarts: probability and the dice.
    restart: f64,
    dice: TieBreaker,
    /// Within a makespan cap (the objective is the makespan): nodes that
    /// cannot lead to a plan within it are pruned.
    cap: Option<u64>,
    /// LaCAM within a cap: return the first plan within it.
    first_fit: bool,
}

impl<'a> Search<'a> {
    fn new(setup: &'a Setup, how: Generation, star: Option<Star>, limits: &Limits) -> Self {
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
            bytes: 0,
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
        self.bytes += std::mem::size_of::<HNode>() + n * (4 + 4 + 4 + 8) + 48;
        id
    }

    fn run(mut self) -> Result<Outcome, SolveError> {
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
            let bytes = self.bytes + self.open.len() * 4;
            if let Err(e) = self.budget.on_expand(|| bytes) {
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
                    self.bytes += std::mem::size_of::<LNode>() + 4;
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
                    self.bytes += 4;
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
                self.bytes += 4;
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

/// The sum of loss of `plan`: over agents and steps, the steps in which
/// the agent is not resting on its final cell ([`Objective::SumOfLoss`]).
fn sum_of_loss(plan: &crate::Plan) -> u64 {
    let horizon = plan.makespan();
    (0..plan.agents())
        .map(|i| {
            let goal = plan.position(i, horizon);
            (0..horizon)
                .filter(|&t| plan.position(i, t) != goal || plan.position(i, t + 1) != goal)
                .count() as u64
        })
        .sum()
}
