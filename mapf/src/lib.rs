//! Classical multi-agent pathfinding baselines for the reference models
//! (SPEC §5): MA-A* and CBS, an independent plan validator, and a replay of
//! plans through the environment.
//!
//! - [`plan`]: [`Plan`], one timed path per agent; makespan and sum of costs.
//! - [`validate`](mod@validate): [`validate()`] / [`validate_with`], typed [`PlanError`]s.
//! - [`replay`](mod@replay): [`replay()`] a plan step by step in a [`buridan_env::GridEnv`].
//! - [`maastar`]: [`MaAstar`], A* over joint states.
//! - [`odastar`]: [`OdAstar`], A* with operator decomposition over the env's
//!   sequential step: makespan-optimal, complete, for small fleets.
//! - [`cbs`]: [`Cbs`], conflict-based search.
//! - [`pibt`]: [`Pibt`], priority inheritance with backtracking, and the
//!   configuration generator LaCAM builds on.
//! - [`lacam`]: [`Lacam`] (complete) and [`LacamStar`] (anytime, eventually
//!   optimal), search over configurations.
//! - [`prioritized`]: [`Prioritized`], one agent at a time around the
//!   earlier ones' paths, with randomized restarts.
//! - [`lifelong`]: [`LifelongPibt`], PIBT for goals that change on arrival.
//! - [`shield`]: [`Shield`], PIBT over a learned policy's action preferences
//!   (a collision shield whose joint moves the env executes exactly).
//! - [`planner`]: the [`Planner`] trait (`Send + Sync`), [`Solution`], [`Stats`],
//!   and [`Portfolio`] (several planners in turn, `"lacam+od-astar"`).
//! - [`limits`]: [`Limits`] (time, memory, nodes, makespan cap), [`SolveError`].
//! - [`rules`]: [`ConflictModel`], the conflict model, and how the env's two rule
//!   sets ([`buridan_env::Rules`]: thesis, pogema) map onto it.
//!
//! # The env's rule sets
//!
//! Under the env's **thesis** rules planners use [`ConflictModel::ENV_EXECUTABLE`]
//! (below); under **pogema** rules (simultaneous moves, POGEMA's soft
//! collisions) [`ConflictModel::SIMULTANEOUS`], standard MAPF as PIBT and LaCAM
//! define it: vertex and swap conflicts forbidden, following and rotations
//! allowed. [`planner_for_rules`] makes a planner for a rule set (OD-A*,
//! which searches the thesis step itself, is refused with
//! [`PlannerLookupError::UnsupportedRules`]); [`validate_with`] checks a plan
//! under `ConflictModel::from(rule_set)`; [`replay_with`] / [`replay_exact_with`]
//! step it through a [`buridan_env::GridEnv`] under that rule set.
//!
//! # Simultaneous plans and the sequential environment: following moves
//!
//! A plan is a set of timed paths executed **simultaneously**: between `t`
//! and `t + 1` all agents move at once, and SPEC §5 forbids vertex
//! conflicts (two agents in one cell at one time, including an agent resting
//! on its goal after its path ended) and swap conflicts (two agents
//! exchanging cells).
//!
//! The environment (SPEC §2) moves agents **one after the other in index
//! order**, and a move succeeds only if its target is free *at that moment*.
//! A **following move** is agent `i` entering, at `t + 1`, the cell that
//! agent `j` occupies at `t` and leaves in the same step. Under simultaneous
//! moves it is legal. In the environment it succeeds only if `j < i`
//! (`j` has already moved out when `i`'s turn comes); if `j > i`, `i` finds
//! the cell still occupied, stays where it is, and the rest of the plan no
//! longer matches the world. Rotations of three or more agents along a cycle
//! fail in the same way.
//!
//! Therefore every planner takes [`ConflictModel`], whose `forbid_following` option
//! is **on by default**: "agent `i` enters at `t + 1` the cell agent `j > i`
//! occupies at `t`" is then a third kind of conflict (a *following
//! conflict*), and every plan replays exactly in the environment
//! (termination with success after exactly `makespan` steps — [`replay()`]
//! reports it, [`replay_exact`] insists on it). With it **off** ([`ConflictModel::SIMULTANEOUS`]) plans are pure
//! SPEC §5 and can be shorter (rm-1.1: makespan 9 instead of 10, as in the
//! dissertation), but may not replay; [`ReplayResult::blocked_following`]
//! lists the following moves the env would block.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::Map;
//! use buridan_mapf::{replay, validate_with, Cbs, Limits, Planner, ConflictModel, Problem};
//! let map = Arc::new(Map::load("rm-1.1").unwrap());
//! let scen = map.scenario.clone().unwrap();
//! let (s, g) = (&scen.starts, &scen.goals);
//!
//! let sol = Cbs::default().solve(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! validate_with(&map.grid, s, g, &sol.plan, ConflictModel::ENV_EXECUTABLE).unwrap();
//! let r = replay(&map, s, g, &sol.plan, 100).unwrap();
//! assert!(r.is_exact(sol.plan.makespan()));
//! assert_eq!(r.terminated_at, Some(10));
//!
//! // Pure simultaneous semantics: makespan 9, but agent 0 follows agent 1
//! // (whichever agent ducks into the aisle), which the env blocks.
//! let fast = Cbs { rules: ConflictModel::SIMULTANEOUS, ..Cbs::default() };
//! let sol = fast.solve(Problem::new(&map.grid, s, g), &Limits::default()).unwrap();
//! assert_eq!((sol.plan.makespan(), sol.plan.sum_of_costs()), (9, 17));
//! let r = replay(&map, s, g, &sol.plan, 100).unwrap();
//! assert_eq!((r.blocked_following[0].follower, r.blocked_following[0].leader), (0, 1));
//! assert!(!r.success && !r.is_exact(9));
//! ```
//!
//! # Limits
//!
//! Every solve call gets [`Limits`] (default: 60 s of CPU time of the
//! solving thread, 2 GiB estimated from the allocated search structures, no
//! node or makespan cap) and returns
//! [`SolveError::TimeLimit`], [`SolveError::MemoryLimit`],
//! [`SolveError::NodeLimit`], [`SolveError::NoSolution`] or
//! [`SolveError::NoSolutionWithin`] instead of running on. CBS does not
//! terminate on unsolvable instances by itself (its constraint tree is
//! infinite); set [`Limits::max_makespan`] to make it end with
//! `NoSolutionWithin`, otherwise it ends at the time or memory limit.

#![warn(missing_docs)]

pub mod cbs;
pub mod dead_ends;
mod graph;
mod joint;
pub mod lacam;
pub mod lanes;
pub mod lifelong;
pub mod limits;
mod lowlevel;
pub mod maastar;
pub mod odastar;
pub mod pibt;
pub mod plan;
pub mod planner;
pub mod prioritized;
mod problem;
pub mod replay;
pub mod rules;
pub mod shield;
pub mod validate;

pub use cbs::{Cbs, LowLevelHeuristic};
pub use lacam::{Lacam, LacamStar, Objective, Outcome};
pub use lifelong::LifelongPibt;
pub use limits::{InstanceError, Limits, SolveError};
pub use maastar::{Heuristic, MaAstar};
pub use odastar::OdAstar;
pub use pibt::Pibt;
pub use plan::Plan;
pub use planner::{
    planner_by_name, planner_for_rules, planner_within_cap, Planner, PlannerLookupError, Portfolio,
    Solution, Stats,
};
pub use prioritized::Prioritized;
pub use problem::Problem;
pub use replay::{
    replay, replay_exact, replay_exact_with, replay_with, BlockedFollowing, Divergence,
    ReplayError, ReplayResult,
};
pub use rules::ConflictModel;
pub use shield::{ActionOrder, Shield, ShieldError};
pub use validate::{validate, validate_with, PlanError};
