//! An independent plan validator (it shares no code with the planners).

use buridan_env::{Cell, Grid};

use crate::plan::Plan;
use crate::rules::ConflictModel;

/// Why a plan is not a valid solution. Times are plan time steps; for moves
/// (`NonUnitMove`, `SwapConflict`, `FollowingConflict`) `time` is the step
/// `time → time + 1`.
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{validate, Plan, PlanError};
/// let grid = Grid::from_rows(&["..."]).unwrap();
/// let plan = Plan::new(vec![vec![Cell::new(0, 0), Cell::new(0, 2)]]);
/// let err = validate(&grid, &[Cell::new(0, 0)], &[Cell::new(0, 2)], &plan).unwrap_err();
/// assert!(matches!(err, PlanError::NonUnitMove { agent: 0, time: 0, .. }));
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlanError {
    /// Starts, goals and paths disagree on the number of agents.
    #[error("{starts} starts, {goals} goals and {paths} paths: the numbers of agents differ")]
    AgentCount {
        /// Number of starts.
        starts: usize,
        /// Number of goals.
        goals: usize,
        /// Number of paths in the plan.
        paths: usize,
    },
    /// An agent's path has no cell at all.
    #[error("agent {agent}: empty path")]
    EmptyPath {
        /// The agent.
        agent: usize,
    },
    /// A path does not begin at the agent's start.
    #[error("agent {agent}: path starts at {found}, its start is {expected}")]
    WrongStart {
        /// The agent.
        agent: usize,
        /// The agent's start.
        expected: Cell,
        /// The first cell of its path.
        found: Cell,
    },
    /// A path does not end on the agent's goal.
    #[error("agent {agent}: path ends at {found}, its goal is {expected}")]
    WrongGoal {
        /// The agent.
        agent: usize,
        /// The agent's goal.
        expected: Cell,
        /// The last cell of its path.
        found: Cell,
    },
    /// A path visits a wall or a cell outside the grid.
    #[error("agent {agent}: at time {time} on {cell}, a wall or outside the grid")]
    Blocked {
        /// The agent.
        agent: usize,
        /// The time of the visit.
        time: usize,
        /// The blocked cell.
        cell: Cell,
    },
    /// Two consecutive cells of a path are neither equal nor neighbours.
    #[error("agent {agent}: step {time}→{} from {from} to {to} is not a unit move or wait", time + 1)]
    NonUnitMove {
        /// The agent.
        agent: usize,
        /// The step `time → time + 1`.
        time: usize,
        /// Cell at `time`.
        from: Cell,
        /// Cell at `time + 1`.
        to: Cell,
    },
    /// Two moving (or waiting) agents share a cell at one time.
    #[error("vertex conflict: agents {first} and {second} both on {cell} at time {time}")]
    VertexConflict {
        /// Lower agent index.
        first: usize,
        /// Higher agent index.
        second: usize,
        /// The time.
        time: usize,
        /// The shared cell.
        cell: Cell,
    },
    /// An agent enters the goal on which another agent rests after its path ended.
    #[error("goal-resting conflict: agent {other} on {cell} at time {time}, where agent {resting} rests after its path ended")]
    RestingConflict {
        /// The agent whose path has ended (resting on its last cell).
        resting: usize,
        /// The agent running into it.
        other: usize,
        /// The time.
        time: usize,
        /// The goal cell.
        cell: Cell,
    },
    /// Two agents exchange cells in one step.
    #[error("swap conflict: agents {first} ({first_from}) and {second} ({second_from}) swap cells in step {time}→{}", time + 1)]
    SwapConflict {
        /// Lower agent index.
        first: usize,
        /// Higher agent index.
        second: usize,
        /// The step `time → time + 1`.
        time: usize,
        /// `first`'s cell at `time` (= `second`'s at `time + 1`).
        first_from: Cell,
        /// `second`'s cell at `time` (= `first`'s at `time + 1`).
        second_from: Cell,
    },
    /// (Only with [`ConflictModel::forbid_following`].) An agent enters the cell a
    /// higher-index agent leaves in the same step, a move the index-ordered
    /// environment blocks.
    #[error("following conflict: agent {follower} enters {cell} in step {time}→{} while agent {leader} (moving later in the env) leaves it", time + 1)]
    FollowingConflict {
        /// The lower-index agent entering the cell.
        follower: usize,
        /// The higher-index agent leaving it.
        leader: usize,
        /// The step `time → time + 1`.
        time: usize,
        /// The cell.
        cell: Cell,
    },
}

/// Checks `plan` against SPEC §5: each path starts at its start, ends on its
/// goal, makes only unit moves or waits, never touches a wall or leaves the
/// grid, and no two agents share a cell (resting agents included) or swap
/// cells. Following moves are allowed (see [`validate_with`]).
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{validate, Plan, PlanError};
/// let grid = Grid::from_rows(&["...", ".@."]).unwrap();
/// let (s, g) = ([Cell::new(0, 0)], [Cell::new(1, 0)]);
/// assert!(validate(&grid, &s, &g, &Plan::new(vec![vec![s[0], g[0]]])).is_ok());
/// let bad = Plan::new(vec![vec![s[0], Cell::new(0, 1), Cell::new(1, 1), g[0]]]);
/// assert!(matches!(validate(&grid, &s, &g, &bad), Err(PlanError::Blocked { time: 2, .. })));
/// ```
pub fn validate(
    grid: &Grid,
    starts: &[Cell],
    goals: &[Cell],
    plan: &Plan,
) -> Result<(), PlanError> {
    validate_with(grid, starts, goals, plan, ConflictModel::SIMULTANEOUS)
}

/// [`validate`] under explicit [`ConflictModel`]: with `forbid_following` also
/// rejects following conflicts, making the plan exactly executable in the
/// environment. The first problem found is reported: per-agent problems
/// first, then conflicts in time order.
///
/// ```
/// use buridan_env::{Cell, Grid};
/// use buridan_mapf::{validate_with, Plan, PlanError, ConflictModel};
/// let grid = Grid::from_rows(&["..."]).unwrap();
/// let c = |col| Cell::new(0, col);
/// // Agent 0 follows agent 1 to the right: fine simultaneously, not in the env.
/// let plan = Plan::new(vec![vec![c(0), c(1)], vec![c(1), c(2)]]);
/// let (s, g) = ([c(0), c(1)], [c(1), c(2)]);
/// assert!(validate_with(&grid, &s, &g, &plan, ConflictModel::SIMULTANEOUS).is_ok());
/// let err = validate_with(&grid, &s, &g, &plan, ConflictModel::ENV_EXECUTABLE).unwrap_err();
/// assert!(matches!(err, PlanError::FollowingConflict { follower: 0, leader: 1, time: 0, .. }));
/// ```
pub fn validate_with(
    grid: &Grid,
    starts: &[Cell],
    goals: &[Cell],
    plan: &Plan,
    rules: ConflictModel,
) -> Result<(), PlanError> {
    let n = plan.paths.len();
    if starts.len() != n || goals.len() != n {
        return Err(PlanError::AgentCount {
            starts: starts.len(),
            goals: goals.len(),
            paths: n,
        });
    }
    for (agent, path) in plan.paths.iter().enumerate() {
        let (Some(&first), Some(&last)) = (path.first(), path.last()) else {
            return Err(PlanError::EmptyPath { agent });
        };
        if first != starts[agent] {
            return Err(PlanError::WrongStart {
                agent,
                expected: starts[agent],
                found: first,
            });
        }
        if last != goals[agent] {
            return Err(PlanError::WrongGoal {
                agent,
                expected: goals[agent],
                found: last,
            });
        }
        if let Some(time) = path.iter().position(|&c| grid.is_wall(c)) {
            return Err(PlanError::Blocked {
                agent,
                time,
                cell: path[time],
            });
        }
        for (time, w) in path.windows(2).enumerate() {
            if w[0].manhattan(w[1]) > 1 {
                return Err(PlanError::NonUnitMove {
                    agent,
                    time,
                    from: w[0],
                    to: w[1],
                });
            }
        }
    }
    // All cells are inside the grid now. One occupancy table, reset per step.
    let horizon = plan.paths.iter().map(Vec::len).max().unwrap_or(1) - 1;
    let at = |agent: usize, t: usize| {
        let p = &plan.paths[agent];
        p[t.min(p.len() - 1)]
    };
    const NOBODY: usize = usize::MAX;
    let mut occupant = vec![NOBODY; grid.height() * grid.width()];
    for t in 0..=horizon {
        // Vertex conflicts at time t (agents in index order: the lower index
        // of a pair is already in the table when the higher one arrives).
        let mut conflict = None;
        for b in 0..n {
            let cell = at(b, t);
            let slot = &mut occupant[grid.index(cell)];
            if *slot != NOBODY && conflict.is_none() {
                let a = *slot;
                let resting = |x: usize| t >= plan.paths[x].len();
                conflict = Some(if resting(a) {
                    PlanError::RestingConflict {
                        resting: a,
                        other: b,
                        time: t,
                        cell,
                    }
                } else if resting(b) {
                    PlanError::RestingConflict {
                        resting: b,
                        other: a,
                        time: t,
                        cell,
                    }
                } else {
                    PlanError::VertexConflict {
                        first: a,
                        second: b,
                        time: t,
                        cell,
                    }
                });
            } else if *slot == NOBODY {
                *slot = b;
            }
        }
        if conflict.is_none() && t < horizon {
            // Moves t → t+1 against the occupancy at time t.
            'moves: for a in 0..n {
                let (from, to) = (at(a, t), at(a, t + 1));
                if from == to {
                    continue;
                }
                let b = occupant[grid.index(to)];
                if b == NOBODY {
                    continue;
                }
                if at(b, t + 1) == from {
                    if a < b {
                        conflict = Some(PlanError::SwapConflict {
                            first: a,
                            second: b,
                            time: t,
                            first_from: from,
                            second_from: to,
                        });
                        break 'moves;
                    }
                } else if rules.forbid_following && b > a && at(b, t + 1) != to {
                    conflict = Some(PlanError::FollowingConflict {
                        follower: a,
                        leader: b,
                        time: t,
                        cell: to,
                    });
                    break 'moves;
                }
            }
        }
        for b in 0..n {
            occupant[grid.index(at(b, t))] = NOBODY;
        }
        if let Some(err) = conflict {
            return Err(err);
        }
    }
    Ok(())
}
