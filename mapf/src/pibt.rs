//! PIBT, priority inheritance with backtracking (Okumura et al., IJCAI-19 /
//! AIJ 2022), as a one-step **configuration generator** and as a planner.
//!
//! A *configuration* is one cell per agent. PIBT computes the next
//! configuration from the current one: agents are visited in a priority
//! order; each agent tries its candidate cells (its neighbours and its own
//! cell) in order of increasing distance to its goal and *reserves* the first
//! one that is free at `t + 1`. If the reserved cell is occupied at `t` by an
//! agent `j` that has not decided yet, `j` **inherits** the priority and must
//! move away first (recursively); if `j` cannot, it reports failure
//! (**backtracking**) and the asking agent tries its next candidate. An agent
//! whose candidates all fail stays where it is.
//!
//! # The environment's index order: how the generator respects it
//!
//! The env moves agents one after the other in index order, and a move
//! succeeds only if its target is free *at that moment* (SPEC §2; see
//! [`ConflictModel`]). Under [`ConflictModel::ENV_EXECUTABLE`] (the default) the generator
//! therefore only lets agent `i` take a cell that, at time `t`, is
//!
//! 1. empty, or
//! 2. its own cell (a wait), or
//! 3. held by a **lower-index** agent `j < i` — which must then leave it
//!    (priority inheritance pushes `j` if it has not decided yet). `j` moves
//!    before `i` in the env, so the cell is free when `i`'s turn comes.
//!
//! A cell held by a higher-index agent `j > i` is never a candidate for `i`:
//! if `j` stayed it would be a vertex conflict, and if `j` left, the env
//! would still find `j` there when `i` moves (a *following conflict*). This
//! one rule also excludes swaps (one of the two agents would enter the cell
//! of a higher-index one) and rotations along cycles (some agent of the cycle
//! follows a higher-index one), so every generated step is executed by the
//! env exactly. Every output is checked once more against these rules before
//! it is returned. Under [`ConflictModel::SIMULTANEOUS`] rule 3 holds for any
//! `j ≠ i`, and swaps are excluded explicitly (rotations are allowed, as in
//! SPEC §5).
//!
//! The price of rule 3: a low-index agent cannot push a higher-index agent
//! out of its way within one step; it can only take the cell one step after
//! the other agent left. PIBT alone is incomplete anyway; LaCAM
//! ([`crate::lacam`]) makes the search complete on top of this generator.
//!
//! # Swap
//!
//! PIBT alone cannot make two agents pass each other in a single lane: the
//! one with priority pushes the other ahead of it, deeper into the lane, even
//! when the other's goal lies behind (two agents whose goals in a dead-end
//! aisle are in the wrong order livelock there). The *swap* operation of
//! LaCAM3 (Okumura, AAMAS-24, "Engineering LaCAM*") detects this and turns
//! the push into a pull: agent `i`, whose best cell is held by `j`, checks that
//! pushing `j` ahead along the lane would not let them pass (*swap required*)
//! and that backing away leads to a cell where the lane branches (*swap
//! possible*); if so, `i` tries its candidate cells in reverse order (backing
//! away first) and, having backed away, pulls `j` into its former cell. The
//! pair walks back to the branching cell, where the usual pushes let them
//! pass.
//!
//! Under the env's index order a pull is a *following move*: `j` can enter
//! `i`'s former cell in the same step only if `j > i`. For `j < i`, `i` backs
//! away alone, and at the next step the two stand one cell apart; the swap
//! decision recognises that gap too (`j` beyond `i`'s empty best cell) and
//! pulls `j` into the empty cell, which is free at `t` whatever the order, so
//! the pair keeps moving at full speed. Under [`ConflictModel::SIMULTANEOUS`]
//! following is legal, so the pull is always made in the same step (as in
//! LaCAM3).
//!
//! With the swap operation the generator also moves **queues** in a lane
//! under the index order (*waiting chains*): an agent that must leave a
//! lane past a queue pushes its neighbour, which must push the next one,
//! and so on — but where an agent would have to enter the cell of a
//! higher-index one, it cannot do so in the same step, and the whole push
//! fails. If the push fails, an agent that may wait (nobody pushes it, or
//! it was pushed by an agent that waits) waits instead and only asks its
//! neighbour to clear the cell; the neighbour, pushed by a waiting agent,
//! may in turn wait and pass the request on, until the head of the queue
//! moves. The failed attempt is undone first (an undo log of the
//! reservations), so the agents it touched decide afresh. Under
//! [`ConflictModel::SIMULTANEOUS`] a push moves a queue in one step, so
//! there are no waiting chains.
//!
//! The operation is off by default
//! (the collision shield and lifelong PIBT do not use it) and enabled by
//! [`Generator::with_swap`]; LaCAM and LaCAM* enable it
//! ([`crate::Lacam::swap`]). It only changes which step PIBT proposes first:
//! every step is still checked against the rules, and LaCAM's completeness
//! does not depend on it.
//!
//! # Constraints
//!
//! LaCAM calls the generator with *constraints* "agent `i` goes to cell `v`".
//! Constrained agents are placed first (a constraint breaking the rules makes
//! the call fail), then PIBT moves the others. If the constraints fix every
//! agent, the result is exactly the constrained configuration if it is a
//! legal step and a failure otherwise — the property LaCAM's completeness
//! rests on.
//!
//! ```
//! use buridan_env::Map;
//! use buridan_mapf::{replay_exact, validate_with, Limits, Pibt, Planner, ConflictModel, Problem};
//! let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
//! let scen = map.scenario.clone().unwrap();
//! let sol = Pibt::default().solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
//! validate_with(&map.grid, &scen.starts, &scen.goals, &sol.plan, ConflictModel::ENV_EXECUTABLE).unwrap();
//! replay_exact(&map, &scen.starts, &scen.goals, &sol.plan, 1000).unwrap();
//! ```

mod generator;
mod setup;
mod swap;

use crate::Problem;

pub(crate) use generator::{Generator, Preference, TieBreaker};
pub(crate) use setup::{online_step, Setup};

use crate::limits::{Budget, Limits, SolveError};
use crate::planner::{Planner, Solution};
use crate::rules::ConflictModel;

/// PIBT as a one-shot planner: apply the generator step after step until
/// every agent stands on its goal. Fast, but incomplete: agents can
/// livelock, in which case it gives up after `max_steps` steps with
/// [`SolveError::StepLimit`]. It never claims an instance unsolvable unless
/// a goal is unreachable ([`crate::Lacam`] can prove it).
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{Limits, Pibt, Planner, SolveError, Problem};
/// // Two agents must swap in a corridor: impossible, PIBT gives up.
/// let grid = Grid::from_rows(&["..."]).unwrap();
/// let (s, g) = ([Cell::new(0, 0), Cell::new(0, 1)], [Cell::new(0, 1), Cell::new(0, 0)]);
/// let pibt = Pibt { max_steps: 50, ..Pibt::default() };
/// let err = pibt.solve(Problem::new(&grid, &s, &g), &Limits::default()).unwrap_err();
/// assert_eq!(err, SolveError::StepLimit { steps: 50 });
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Pibt {
    /// The conflict model (default: env-executable, see the module docs).
    pub rules: ConflictModel,
    /// Steps after which PIBT gives up (default 1000;
    /// [`Limits::max_makespan`] lowers it).
    pub max_steps: usize,
    /// Seed of the tie-breaking between equally good cells.
    pub seed: u64,
    /// The *swap* operation (see the [module docs](self#swap); default
    /// off, as in the collision shield and lifelong PIBT).
    #[serde(default)]
    pub swap: bool,
}

impl Default for Pibt {
    fn default() -> Self {
        Self {
            rules: ConflictModel::default(),
            max_steps: 1000,
            seed: 0,
            swap: false,
        }
    }
}

impl Planner for Pibt {
    fn rules(&self) -> ConflictModel {
        self.rules
    }

    fn name(&self) -> &str {
        if self.rules.forbid_following {
            "pibt"
        } else {
            "pibt-simultaneous"
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        let setup = Setup::new(problem)?;
        let mut budget = Budget::new(limits);
        let max_steps = limits
            .max_makespan
            .map_or(self.max_steps, |m| m.min(self.max_steps));
        let n = problem.agents();
        let mut gen = Generator::new(&setup.topo, self.rules, self.seed);
        if self.swap {
            gen = gen.with_swap(&setup.dist, &setup.goals);
        }
        let mut priorities = setup.initial_priorities();
        let mut configs = vec![setup.starts.clone()];
        let mut next = Vec::with_capacity(n);
        let row_bytes = n * 4 + 24;
        while configs.last() != Some(&setup.goals) {
            if configs.len() > max_steps {
                return Err(SolveError::StepLimit { steps: max_steps });
            }
            budget.on_expand(|| configs.len() * row_bytes)?;
            // Agents by priority; PIBT from each gives the next configuration.
            let order = Setup::order(&priorities);
            let cur = configs.last().expect("starts are in");
            if !gen.generate(&setup.dist, cur, &order, &[], &mut next) {
                // Without constraints every agent can at least stay.
                return Err(SolveError::StepLimit {
                    steps: configs.len() - 1,
                });
            }
            budget.generated += 1;
            // Update priorities: up off the goal, back to the tie-breaker on it.
            setup.update_priorities(&mut priorities, &next);
            configs.push(next.clone());
        }
        Ok(Solution {
            plan: setup.plan(&configs),
            stats: budget.stats(),
        })
    }
}
