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
//! On large instances this search improves its first plan only a little
//! within a second (2–4 % of the sum of costs on POGEMA's warehouse): the
//! neighbour graph it relaxes is a thin slice of the configuration space.
//! So, minimising the sum of loss, LaCAM* refines by its search for the
//! first half of [`LacamStar::refine_time`] and, unless that proved the
//! plan optimal, by **large neighbourhood search** for the second half
//! ([`LacamStar::lns`], `lacam/lns.rs`: MAPF-LNS, as lacam3 refines): a few
//! agents' paths at a time are replanned around all the others and kept
//! when their sum of costs falls. Small instances are still proven optimal
//! by the search; large ones get LNS's plans (`docs/results/lacam-lns/`).
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
//! `within_cap` in [`LacamStar::lacam`] does the same for LaCAM*: minimising the
//! makespan it prunes by the cap and refines as usual (an exhausted search
//! proves its plan optimal, or that none fits); minimising the sum of loss
//! it refines as usual (LNS repairing a plan longer than the cap first,
//! see `lacam/lns.rs`) and, if its plan is still longer than the cap,
//! LaCAM within the cap takes the time left (its plan replaces the long
//! one, its proof ends the call). [`crate::planner_within_cap`] makes both so; the
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

use std::time::Duration;

use crate::limits::{Budget, Limits, SolveError};
use crate::pibt::Setup;
use crate::planner::{Planner, Solution, Stats};
use crate::rules::ConflictModel;
use crate::Problem;

mod lns;
mod search;

use search::{Generation, Search, Star};

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
    /// LaCAM's settings, which LaCAM* searches with: the conflict model,
    /// PIBT's seed, swap, random restarts, generators and the makespan cap
    /// ([`Lacam`]; TOML keys at the top level).
    #[serde(flatten)]
    pub lacam: Lacam,
    /// What to minimise (default: sum of loss).
    pub objective: Objective,
    /// CPU time after which a search that has a solution stops refining it
    /// and returns it (default 0.5 s: on the seed-42 episodes of the four
    /// layouts, 4 agents, the plans' sum of costs is within 0.5 % of what
    /// 1 s gives, `docs/results/planners/RESULTS.md`); `None` refines until the solution is
    /// proven optimal or [`Limits::time`] runs out. Without a solution the
    /// search goes on until the limits.
    pub refine_time: Option<Duration>,
    /// Refine by large neighbourhood search (MAPF-LNS, see the [module
    /// docs](self)) in the second half of `refine_time` (default on; sum of
    /// loss only): the search itself refines during the first half and,
    /// unless it proved its plan optimal by then, LNS shortens the plan
    /// until `refine_time`. Without a `refine_time` there is no LNS.
    #[serde(default = "lns_default")]
    pub lns: bool,
}

fn lns_default() -> bool {
    true
}

impl Default for LacamStar {
    fn default() -> Self {
        Self {
            lacam: Lacam::default(),
            objective: Objective::default(),
            refine_time: Some(Duration::from_millis(500)),
            lns: lns_default(),
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
        let mut clock = Budget::new(limits);
        let setup = Setup::new(problem)?;
        let cap = limits.max_makespan.filter(|_| self.lacam.within_cap);
        // With LNS the search refines for the first half of the time.
        let lns_until = self.refine_time.filter(|_| self.lns_applies());
        let star = Star {
            objective: self.objective,
            refine_time: match lns_until {
                Some(t) => Some(t / 2),
                None => self.refine_time,
            },
        };
        let mut search = Search::new(&setup, self.lacam.generator(), Some(star), limits);
        if self.objective == Objective::Makespan {
            search.cap = cap.map(|c| c as u64);
        }
        let found = match (search.run(), lns_until) {
            (Ok(out), Some(until)) if !out.proven_optimal => {
                Ok(self.shorten(out, &setup, cap, limits, &mut clock, until))
            }
            (other, _) => other,
        };
        self.within(found, cap, problem, limits, &clock)
    }

    /// Whether [`LacamStar::lns`] refines this search.
    fn lns_applies(&self) -> bool {
        self.lns && self.objective == Objective::SumOfLoss
    }

    /// The plan shortened by LNS until `until` on `clock`: within the cap
    /// (`cap`, from `within_cap` in [`LacamStar::lacam`]) a plan that does not fit is
    /// repaired first; otherwise its sum of loss never grows, and a
    /// makespan within [`Limits::max_makespan`] stays within it.
    fn shorten(
        &self,
        found: Outcome,
        setup: &Setup,
        cap: Option<usize>,
        limits: &Limits,
        clock: &mut Budget,
        until: Duration,
    ) -> Outcome {
        let plan = &found.solution.plan;
        let topo = &setup.topo;
        // Each agent's cells up to its arrival, as the LNS keeps them.
        let mut paths: Vec<Vec<u32>> = plan
            .clone()
            .trimmed()
            .paths
            .iter()
            .map(|p| topo.indices(p))
            .collect();
        let inst = lns::Instance {
            topo,
            dist: &setup.dist,
            starts: &setup.starts,
            goals: &setup.goals,
            forbid_following: self.lacam.rules.forbid_following,
            cap: cap.or(limits.max_makespan.filter(|&c| plan.makespan() <= c)),
        };
        let done = lns::refine(&inst, &mut paths, clock, until, self.lacam.seed);
        if done.accepted == 0 {
            return found;
        }
        let plan = crate::Plan::new(
            paths
                .iter()
                .map(|p| p.iter().map(|&c| topo.cell(c)).collect())
                .collect(),
        );
        let stats = Stats {
            expanded: found.solution.stats.expanded + done.iterations,
            wall_time: clock.elapsed(),
            ..found.solution.stats
        };
        Outcome {
            cost: sum_of_loss(&plan),
            solution: Solution { plan, stats },
            proven_optimal: false,
            first_cost: found.first_cost,
        }
    }

    /// Within a makespan cap, a sum-of-loss plan longer than the cap is
    /// replaced by LaCAM's within the cap (for the time left).
    fn within(
        &self,
        found: Result<Outcome, SolveError>,
        cap: Option<usize>,
        problem: Problem<'_>,
        limits: &Limits,
        clock: &Budget,
    ) -> Result<Outcome, SolveError> {
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
                    ..self.lacam
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
}

impl Planner for LacamStar {
    fn rules(&self) -> ConflictModel {
        self.lacam.rules
    }

    fn name(&self) -> &str {
        match (self.lacam.rules.forbid_following, self.objective) {
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
