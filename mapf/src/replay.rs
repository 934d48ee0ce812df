//! Replaying a plan through the environment ([`buridan_env::GridEnv`]).
//!
//! The plan is turned into one joint action per step and fed open-loop to a
//! `GridEnv` reset to the plan's starts and goals. Plans found under
//! [`ConflictModel::ENV_EXECUTABLE`](crate::ConflictModel::ENV_EXECUTABLE) (the default)
//! replay exactly: the episode terminates with success after exactly
//! `max(makespan, 1)` steps (the env only checks termination after a step,
//! so a plan of makespan 0 takes one all-stay step). Plans found under
//! [`ConflictModel::SIMULTANEOUS`](crate::ConflictModel::SIMULTANEOUS) may contain following
//! moves the env blocks; [`ReplayResult::blocked_following`] lists them and
//! [`ReplayResult::divergence`] shows where the env left the plan.

use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, EnvError, GridEnv, Map, Rules as RuleSet, Starts};

use crate::plan::Plan;

/// A plan that cannot be replayed at all.
///
/// ```
/// use buridan_env::{Cell, Map};
/// use buridan_mapf::{replay, Plan, ReplayError};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let (s, g) = ([Cell::new(1, 0)], [Cell::new(1, 2)]);
/// let plan = Plan::new(vec![vec![s[0], g[0]]]);
/// let err = replay(&map, &s, &g, &plan, 100).unwrap_err();
/// assert!(matches!(err, ReplayError::NotAMove { agent: 0, time: 0, .. }));
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReplayError {
    /// The plan has a different number of paths than there are agents.
    #[error("the plan has {paths} paths for {agents} agents")]
    AgentCount {
        /// Number of agents (starts).
        agents: usize,
        /// Number of paths.
        paths: usize,
    },
    /// An agent's path is empty or does not begin at its start.
    #[error("agent {agent}: the path does not begin at its start")]
    BadStart {
        /// The agent.
        agent: usize,
    },
    /// Two consecutive cells of a path are not one action apart.
    #[error("agent {agent}: step {time}→{} from {from} to {to} is no single action", time + 1)]
    NotAMove {
        /// The agent.
        agent: usize,
        /// The step `time → time + 1`.
        time: usize,
        /// Cell at `time`.
        from: Cell,
        /// Cell at `time + 1`.
        to: Cell,
    },
    /// The environment rejected the configuration or the instance.
    #[error("environment: {0}")]
    Env(#[from] EnvError),
    /// ([`replay_exact`] only.) The env did not execute the plan exactly.
    #[error("the env did not execute the plan of makespan {makespan} exactly: {result:?}")]
    Inexact {
        /// The plan's makespan.
        makespan: usize,
        /// What happened instead.
        result: Box<ReplayResult>,
    },
}

/// A following move the environment blocks: `follower` plans to enter
/// `cell` in step `time → time + 1` while `leader > follower`, which only
/// moves later in the env's index order, still stands there.
///
/// ```
/// let f = buridan_mapf::BlockedFollowing { time: 3, follower: 0, leader: 1, cell: buridan_env::Cell::new(1, 4) };
/// assert!(f.follower < f.leader);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BlockedFollowing {
    /// The step `time → time + 1`.
    pub time: usize,
    /// The lower-index agent that would be blocked.
    pub follower: usize,
    /// The higher-index agent leaving the cell.
    pub leader: usize,
    /// The cell.
    pub cell: Cell,
}

/// The first time the environment's positions differ from the plan's.
///
/// ```
/// use buridan_env::Cell;
/// let d = buridan_mapf::Divergence { time: 4, agent: 0, planned: Cell::new(1, 4), actual: Cell::new(1, 3) };
/// assert_ne!(d.planned, d.actual);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Divergence {
    /// The time (after `time` env steps).
    pub time: usize,
    /// The lowest agent off its planned cell.
    pub agent: usize,
    /// Where the plan has it.
    pub planned: Cell,
    /// Where the env has it.
    pub actual: Cell,
}

/// What happened when a plan was stepped through the environment.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{replay, Cbs, Limits, Planner, Problem};
/// let map = std::sync::Arc::new(Map::load("rm-1.3").unwrap());
/// let scen = map.scenario.clone().unwrap();
/// let sol = Cbs::default().solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// let r = replay(&map, &scen.starts, &scen.goals, &sol.plan, 100).unwrap();
/// assert!(r.is_exact(sol.plan.makespan()));
/// assert_eq!(r.terminated_at, Some(7));
/// ```
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ReplayResult {
    /// Env steps taken.
    pub steps: usize,
    /// All agents on their goals when the replay stopped (episode terminated).
    pub success: bool,
    /// The step count at which the episode terminated with success, if it did.
    pub terminated_at: Option<usize>,
    /// The episode was truncated at `t_max`.
    pub truncated: bool,
    /// Move requests the env refused.
    pub blocked_moves: u32,
    /// The first time the env's positions left the plan, if they did.
    pub divergence: Option<Divergence>,
    /// Following moves in the plan that the env's index order blocks
    /// (computed from the plan alone; empty for plans under
    /// [`ConflictModel::ENV_EXECUTABLE`](crate::ConflictModel::ENV_EXECUTABLE), and always
    /// empty under pogema rules, which allow following).
    pub blocked_following: Vec<BlockedFollowing>,
    /// Agents' cells when the replay stopped.
    pub final_positions: Vec<Cell>,
}

impl ReplayResult {
    /// Whether the env executed the plan exactly: no divergence, success,
    /// termination after exactly `max(makespan, 1)` steps.
    ///
    /// ```
    /// let r = buridan_mapf::ReplayResult {
    ///     steps: 5, success: true, terminated_at: Some(5), truncated: false, blocked_moves: 0,
    ///     divergence: None, blocked_following: vec![], final_positions: vec![],
    /// };
    /// assert!(r.is_exact(5) && !r.is_exact(4));
    /// ```
    pub fn is_exact(&self, makespan: usize) -> bool {
        self.success && self.divergence.is_none() && self.terminated_at == Some(makespan.max(1))
    }
}

/// The action (0 stay, 1 up, 2 right, 3 down, 4 left) moving `from` to `to`.
///
/// ```
/// use buridan_env::Cell;
/// assert_eq!(buridan_mapf::replay::action_between(Cell::new(1, 1), Cell::new(0, 1)), Some(1));
/// assert_eq!(buridan_mapf::replay::action_between(Cell::new(1, 1), Cell::new(1, 3)), None);
/// ```
pub fn action_between(from: Cell, to: Cell) -> Option<u8> {
    let (fr, fc, tr, tc) = (from.row, from.col, to.row, to.col);
    if (fr, fc) == (tr, tc) {
        Some(0)
    } else if fc == tc && tr + 1 == fr {
        Some(1)
    } else if fr == tr && tc == fc + 1 {
        Some(2)
    } else if fc == tc && tr == fr + 1 {
        Some(3)
    } else if fr == tr && tc + 1 == fc {
        Some(4)
    } else {
        None
    }
}

/// The plan as joint actions: `actions[t][i]` moves agent `i` from its cell
/// at `t` to its cell at `t + 1`, for `t < max(makespan, 1)`.
///
/// ```
/// use buridan_env::Cell;
/// let plan = buridan_mapf::Plan::new(vec![vec![Cell::new(0, 0), Cell::new(0, 1)], vec![Cell::new(1, 1)]]);
/// assert_eq!(buridan_mapf::replay::plan_actions(&plan).unwrap(), vec![vec![2, 0]]);
/// ```
pub fn plan_actions(plan: &Plan) -> Result<Vec<Vec<u8>>, ReplayError> {
    if let Some(agent) = plan.paths.iter().position(Vec::is_empty) {
        return Err(ReplayError::BadStart { agent });
    }
    let steps = plan.makespan().max(1);
    (0..steps)
        .map(|t| {
            (0..plan.agents())
                .map(|agent| {
                    let from = plan.position(agent, t).expect("non-empty path");
                    let to = plan.position(agent, t + 1).expect("non-empty path");
                    action_between(from, to).ok_or(ReplayError::NotAMove {
                        agent,
                        time: t,
                        from,
                        to,
                    })
                })
                .collect()
        })
        .collect()
}

/// The following moves of `plan` that the environment blocks: agent `i`
/// entering at `t + 1` the cell that agent `j > i` occupies at `t`.
///
/// ```
/// use buridan_env::Cell;
/// let c = |col| Cell::new(0, col);
/// let plan = buridan_mapf::Plan::new(vec![vec![c(0), c(1)], vec![c(1), c(2)]]);
/// let f = buridan_mapf::replay::blocked_following(&plan);
/// assert_eq!((f[0].follower, f[0].leader, f[0].time), (0, 1, 0));
/// ```
pub fn blocked_following(plan: &Plan) -> Vec<BlockedFollowing> {
    let n = plan.agents();
    let mut out = Vec::new();
    let at = |i: usize, t: usize| plan.position(i, t);
    for t in 0..plan.makespan() {
        for i in 0..n {
            let (Some(from), Some(to)) = (at(i, t), at(i, t + 1)) else {
                continue;
            };
            if from == to {
                continue;
            }
            for j in i + 1..n {
                if at(j, t) == Some(to) && at(j, t + 1) != Some(to) {
                    out.push(BlockedFollowing {
                        time: t,
                        follower: i,
                        leader: j,
                        cell: to,
                    });
                }
            }
        }
    }
    out
}

/// Steps `plan` through a [`GridEnv`] on `map` (an env configured with
/// `starts.len()` agents and `t_max`, reset to `starts`/`goals`) and reports
/// what happened. The replay stops when the episode ends or the plan's
/// actions run out.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{replay, MaAstar, Limits, Planner, Problem};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let scen = map.scenario.clone().unwrap();
/// let sol = MaAstar::default().solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// let r = replay(&map, &scen.starts, &scen.goals, &sol.plan, 100).unwrap();
/// assert!(r.is_exact(sol.plan.makespan()));
/// ```
pub fn replay(
    map: &Arc<Map>,
    starts: &[Cell],
    goals: &[Cell],
    plan: &Plan,
    t_max: u32,
) -> Result<ReplayResult, ReplayError> {
    replay_with(map, starts, goals, plan, t_max, RuleSet::Thesis)
}

/// [`replay`] in an env under the rule set `rules`: under pogema rules
/// plans valid under [`ConflictModel::SIMULTANEOUS`](crate::ConflictModel::SIMULTANEOUS)
/// (following, rotations) replay exactly, and nothing counts as a blocked
/// following move.
///
/// ```
/// use buridan_env::{Cell, Map, Rules as RuleSet};
/// use buridan_mapf::{replay_with, Plan};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let c = |col| Cell::new(1, col);
/// // Agent 0 follows agent 1 to the right.
/// let plan = Plan::new(vec![vec![c(0), c(1)], vec![c(1), c(2)]]);
/// let (s, g) = ([c(0), c(1)], [c(1), c(2)]);
/// let thesis = replay_with(&map, &s, &g, &plan, 100, RuleSet::Thesis).unwrap();
/// assert!(!thesis.is_exact(1) && thesis.blocked_following.len() == 1);
/// let pogema = replay_with(&map, &s, &g, &plan, 128, RuleSet::Pogema).unwrap();
/// assert!(pogema.is_exact(1) && pogema.blocked_following.is_empty());
/// ```
pub fn replay_with(
    map: &Arc<Map>,
    starts: &[Cell],
    goals: &[Cell],
    plan: &Plan,
    t_max: u32,
    rules: RuleSet,
) -> Result<ReplayResult, ReplayError> {
    let n = starts.len();
    if plan.agents() != n {
        return Err(ReplayError::AgentCount {
            agents: n,
            paths: plan.agents(),
        });
    }
    if let Some(agent) = (0..n).find(|&i| plan.position(i, 0) != Some(starts[i])) {
        return Err(ReplayError::BadStart { agent });
    }
    let actions = plan_actions(plan)?;
    let cfg = EnvConfig {
        agents: n,
        t_max,
        rules,
        starts: Starts::Random,
        ..EnvConfig::default()
    };
    // `GridEnv::new` resets to a generated episode first; a map too small for
    // 2n random cells can still host this instance via its fixed scenario.
    let mut env = match GridEnv::new(map.clone(), cfg.clone()) {
        Ok(env) => env,
        Err(EnvError::TooFewFreeCells { .. }) => GridEnv::new(
            map.clone(),
            EnvConfig {
                starts: Starts::Fixed,
                ..cfg
            },
        )?,
        Err(e) => return Err(e.into()),
    };
    env.reset_with(0, starts, goals)?;
    let mut rewards = vec![0.0; n];
    let mut result = ReplayResult {
        steps: 0,
        success: false,
        terminated_at: None,
        truncated: false,
        blocked_moves: 0,
        divergence: None,
        blocked_following: match rules {
            RuleSet::Thesis => blocked_following(plan),
            RuleSet::Pogema => Vec::new(),
        },
        final_positions: Vec::new(),
    };
    for (t, joint) in actions.iter().enumerate() {
        let out = env.step(joint, &mut rewards)?;
        result.steps = t + 1;
        result.blocked_moves += out.blocked_moves;
        if result.divergence.is_none() {
            result.divergence = (0..n).find_map(|agent| {
                let planned = plan.position(agent, t + 1)?;
                let actual = env.position(agent);
                (planned != actual).then_some(Divergence {
                    time: t + 1,
                    agent,
                    planned,
                    actual,
                })
            });
        }
        if out.terminated {
            result.success = true;
            result.terminated_at = Some(t + 1);
        }
        result.truncated = out.truncated;
        if out.done() {
            break;
        }
    }
    result.final_positions = env.positions();
    Ok(result)
}

/// [`replay`], then insists that the env executed the plan exactly:
/// termination with success after exactly `max(makespan, 1)` steps, never
/// off the plan. Guaranteed for valid plans under
/// [`ConflictModel::ENV_EXECUTABLE`](crate::ConflictModel::ENV_EXECUTABLE) whose makespan
/// is at most `t_max`.
///
/// ```
/// use buridan_env::{Cell, Map};
/// use buridan_mapf::{replay::replay_exact, Plan, ReplayError};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let (s, g) = ([Cell::new(1, 0)], [Cell::new(1, 2)]);
/// let plan = Plan::new(vec![vec![s[0], Cell::new(1, 1), g[0]]]);
/// assert_eq!(replay_exact(&map, &s, &g, &plan, 100).unwrap().terminated_at, Some(2));
/// let err = replay_exact(&map, &s, &g, &plan, 1).unwrap_err();
/// assert!(matches!(err, ReplayError::Inexact { makespan: 2, .. }));
/// ```
pub fn replay_exact(
    map: &Arc<Map>,
    starts: &[Cell],
    goals: &[Cell],
    plan: &Plan,
    t_max: u32,
) -> Result<ReplayResult, ReplayError> {
    replay_exact_with(map, starts, goals, plan, t_max, RuleSet::Thesis)
}

/// [`replay_exact`] in an env under the rule set `rules` (see
/// [`replay_with`]). Guaranteed under pogema rules for valid plans under
/// [`ConflictModel::SIMULTANEOUS`](crate::ConflictModel::SIMULTANEOUS) whose makespan is at
/// most `t_max`.
///
/// ```
/// use buridan_env::{Cell, Map, Rules as RuleSet};
/// use buridan_mapf::{replay_exact_with, Plan, ReplayError};
/// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
/// let c = |col| Cell::new(1, col);
/// let plan = Plan::new(vec![vec![c(0), c(1)], vec![c(1), c(2)]]);
/// let (s, g) = ([c(0), c(1)], [c(1), c(2)]);
/// assert!(replay_exact_with(&map, &s, &g, &plan, 128, RuleSet::Pogema).is_ok());
/// let err = replay_exact_with(&map, &s, &g, &plan, 100, RuleSet::Thesis).unwrap_err();
/// assert!(matches!(err, ReplayError::Inexact { makespan: 1, .. }));
/// ```
pub fn replay_exact_with(
    map: &Arc<Map>,
    starts: &[Cell],
    goals: &[Cell],
    plan: &Plan,
    t_max: u32,
    rules: RuleSet,
) -> Result<ReplayResult, ReplayError> {
    let result = replay_with(map, starts, goals, plan, t_max, rules)?;
    let makespan = plan.makespan();
    if result.is_exact(makespan) {
        Ok(result)
    } else {
        Err(ReplayError::Inexact {
            makespan,
            result: Box::new(result),
        })
    }
}
