//! The validator rejects crafted bad plans with the right typed error, and
//! replay shows how following moves break in the index-ordered env.

use std::sync::Arc;

use buridan_env::{Cell, Grid, Map};
use buridan_mapf::{
    replay, validate, validate_with, BlockedFollowing, ConflictModel, Divergence, Plan, PlanError,
    ReplayError,
};

fn c(row: usize, col: usize) -> Cell {
    Cell::new(row, col)
}

/// ```text
///   0123
/// 0 ....
/// 1 .@..
/// 2 ....
/// ```
fn grid() -> Grid {
    Grid::from_rows(&["....", ".@..", "...."]).unwrap()
}

fn plan(paths: &[&[Cell]]) -> Plan {
    Plan::new(paths.iter().map(|p| p.to_vec()).collect())
}

#[test]
fn a_valid_plan_passes_both_rule_sets() {
    let g = grid();
    // Agent 0 along the top row, agent 1 along the bottom row.
    let p = plan(&[
        &[c(0, 0), c(0, 1), c(0, 2)],
        &[c(2, 3), c(2, 2), c(2, 1), c(2, 0)],
    ]);
    let (s, goals) = ([c(0, 0), c(2, 3)], [c(0, 2), c(2, 0)]);
    assert_eq!(validate(&g, &s, &goals, &p), Ok(()));
    assert_eq!(
        validate_with(&g, &s, &goals, &p, ConflictModel::ENV_EXECUTABLE),
        Ok(())
    );
    assert_eq!((p.makespan(), p.sum_of_costs()), (3, 5));
}

#[test]
fn vertex_conflict() {
    let g = grid();
    let p = plan(&[&[c(0, 0), c(0, 1), c(0, 2)], &[c(0, 2), c(0, 1), c(0, 0)]]);
    let err = validate(&g, &[c(0, 0), c(0, 2)], &[c(0, 2), c(0, 0)], &p).unwrap_err();
    assert_eq!(
        err,
        PlanError::VertexConflict {
            first: 0,
            second: 1,
            time: 1,
            cell: c(0, 1)
        }
    );
    assert_eq!(
        err.to_string(),
        "vertex conflict: agents 0 and 1 both on (0, 1) at time 1"
    );
}

#[test]
fn swap_conflict() {
    let g = grid();
    let p = plan(&[&[c(0, 0), c(0, 1)], &[c(0, 1), c(0, 0)]]);
    let err = validate(&g, &[c(0, 0), c(0, 1)], &[c(0, 1), c(0, 0)], &p).unwrap_err();
    assert_eq!(
        err,
        PlanError::SwapConflict {
            first: 0,
            second: 1,
            time: 0,
            first_from: c(0, 0),
            second_from: c(0, 1)
        }
    );
}

#[test]
fn wall_and_outside_the_grid() {
    let g = grid();
    let p = plan(&[&[c(0, 1), c(1, 1), c(2, 1)]]);
    assert_eq!(
        validate(&g, &[c(0, 1)], &[c(2, 1)], &p),
        Err(PlanError::Blocked {
            agent: 0,
            time: 1,
            cell: c(1, 1)
        })
    );
    let p = plan(&[&[c(0, 3), c(0, 4), c(0, 3)]]);
    assert_eq!(
        validate(&g, &[c(0, 3)], &[c(0, 3)], &p),
        Err(PlanError::Blocked {
            agent: 0,
            time: 1,
            cell: c(0, 4)
        })
    );
}

#[test]
fn teleport_and_diagonal_moves() {
    let g = grid();
    let p = plan(&[&[c(0, 0), c(0, 2), c(0, 3)]]);
    assert_eq!(
        validate(&g, &[c(0, 0)], &[c(0, 3)], &p),
        Err(PlanError::NonUnitMove {
            agent: 0,
            time: 0,
            from: c(0, 0),
            to: c(0, 2)
        })
    );
    let p = plan(&[&[c(2, 2), c(1, 3)]]);
    assert!(matches!(
        validate(&g, &[c(2, 2)], &[c(1, 3)], &p),
        Err(PlanError::NonUnitMove { time: 0, .. })
    ));
}

#[test]
fn wrong_start_and_wrong_goal() {
    let g = grid();
    let p = plan(&[&[c(0, 0), c(0, 1)]]);
    assert_eq!(
        validate(&g, &[c(2, 0)], &[c(0, 1)], &p),
        Err(PlanError::WrongStart {
            agent: 0,
            expected: c(2, 0),
            found: c(0, 0)
        })
    );
    assert_eq!(
        validate(&g, &[c(0, 0)], &[c(0, 2)], &p),
        Err(PlanError::WrongGoal {
            agent: 0,
            expected: c(0, 2),
            found: c(0, 1)
        })
    );
}

#[test]
fn goal_resting_conflict() {
    let g = grid();
    // Agent 0 arrives on (0, 2) at t = 1 and rests there; agent 1 walks
    // through (0, 2) at t = 3, after agent 0's path has ended.
    let p = plan(&[
        &[c(0, 1), c(0, 2)],
        &[c(2, 3), c(1, 3), c(0, 3), c(0, 2), c(0, 1)],
    ]);
    let err = validate(&g, &[c(0, 1), c(2, 3)], &[c(0, 2), c(0, 1)], &p).unwrap_err();
    assert_eq!(
        err,
        PlanError::RestingConflict {
            resting: 0,
            other: 1,
            time: 3,
            cell: c(0, 2)
        }
    );
}

#[test]
fn agent_count_and_empty_paths() {
    let g = grid();
    let p = plan(&[&[c(0, 0)]]);
    assert_eq!(
        validate(&g, &[c(0, 0), c(0, 1)], &[c(0, 0), c(0, 1)], &p),
        Err(PlanError::AgentCount {
            starts: 2,
            goals: 2,
            paths: 1
        })
    );
    let p = plan(&[&[c(0, 0)], &[]]);
    assert_eq!(
        validate(&g, &[c(0, 0), c(0, 1)], &[c(0, 0), c(0, 1)], &p),
        Err(PlanError::EmptyPath { agent: 1 })
    );
}

#[test]
fn following_is_a_conflict_only_when_forbidden_and_only_behind_a_higher_index() {
    let g = Grid::from_rows(&["...."]).unwrap();
    let r = |col| c(0, col);
    // Agent 0 follows agent 1: blocked in the env.
    let p = plan(&[&[r(0), r(1)], &[r(1), r(2)]]);
    let (s, goals) = ([r(0), r(1)], [r(1), r(2)]);
    assert_eq!(validate(&g, &s, &goals, &p), Ok(()));
    assert_eq!(
        validate_with(&g, &s, &goals, &p, ConflictModel::ENV_EXECUTABLE),
        Err(PlanError::FollowingConflict {
            follower: 0,
            leader: 1,
            time: 0,
            cell: r(1)
        })
    );
    // Agent 1 follows agent 0: agent 0 moves first in the env, fine.
    let p = plan(&[&[r(1), r(2)], &[r(0), r(1)]]);
    let (s, goals) = ([r(1), r(0)], [r(2), r(1)]);
    assert_eq!(
        validate_with(&g, &s, &goals, &p, ConflictModel::ENV_EXECUTABLE),
        Ok(())
    );
    // A rotation of four agents in a 2×2 block has no swap and no vertex
    // conflict, but always a following conflict.
    let g2 = Grid::from_rows(&["..", ".."]).unwrap();
    let (a, b, cc, d) = (c(0, 0), c(0, 1), c(1, 1), c(1, 0));
    let p = plan(&[&[a, b], &[b, cc], &[cc, d], &[d, a]]);
    let (s, goals) = ([a, b, cc, d], [b, cc, d, a]);
    assert_eq!(validate(&g2, &s, &goals, &p), Ok(()));
    assert!(matches!(
        validate_with(&g2, &s, &goals, &p, ConflictModel::ENV_EXECUTABLE),
        Err(PlanError::FollowingConflict { .. })
    ));
}

/// The 9-step rm-1.1 plan of the dissertation: agent 1 ducks into the aisle
/// (0, 4) and agent 0 follows it into (1, 4) in step 3→4, which the env
/// blocks because agent 1 moves after agent 0.
fn rm11_nine_step_plan() -> Plan {
    let row = |cols: &[usize]| cols.iter().map(|&col| c(1, col)).collect::<Vec<_>>();
    let agent0 = row(&[1, 2, 3, 3, 4, 5, 6, 7, 8]);
    let mut agent1 = row(&[7, 6, 5, 4]);
    agent1.push(c(0, 4));
    agent1.extend(row(&[4, 3, 2, 1, 0]));
    Plan::new(vec![agent0, agent1])
}

#[test]
fn replay_reports_blocked_following_moves() {
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let scen = map.scenario.clone().unwrap();
    let (s, g) = (&scen.starts, &scen.goals);
    let p = rm11_nine_step_plan();
    assert_eq!((p.makespan(), p.sum_of_costs()), (9, 17));
    assert_eq!(validate(&map.grid, s, g, &p), Ok(()));
    assert!(matches!(
        validate_with(&map.grid, s, g, &p, ConflictModel::ENV_EXECUTABLE),
        Err(PlanError::FollowingConflict {
            follower: 0,
            leader: 1,
            time: 3,
            ..
        })
    ));
    let r = replay(&map, s, g, &p, 100).unwrap();
    assert_eq!(
        r.blocked_following,
        vec![BlockedFollowing {
            time: 3,
            follower: 0,
            leader: 1,
            cell: c(1, 4)
        }]
    );
    assert_eq!(
        r.divergence,
        Some(Divergence {
            time: 4,
            agent: 0,
            planned: c(1, 4),
            actual: c(1, 3)
        })
    );
    assert!(!r.success && !r.is_exact(9));
    assert!(r.blocked_moves >= 1);
    assert_eq!(r.steps, 9);
}

#[test]
fn replay_edge_cases() {
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    // Makespan 0: one all-stay step terminates the episode.
    let (s, g) = ([c(1, 0)], [c(1, 0)]);
    let r = replay(&map, &s, &g, &plan(&[&[c(1, 0)]]), 100).unwrap();
    assert!(r.is_exact(0));
    assert_eq!(r.terminated_at, Some(1));
    // T_max shorter than the plan: truncated.
    let (s, g) = ([c(1, 0)], [c(1, 3)]);
    let p = plan(&[&[c(1, 0), c(1, 1), c(1, 2), c(1, 3)]]);
    let r = replay(&map, &s, &g, &p, 2).unwrap();
    assert!(r.truncated && !r.success && r.steps == 2);
    assert!(replay(&map, &s, &g, &p, 3).unwrap().is_exact(3));
    // Malformed plans.
    assert_eq!(
        replay(&map, &s, &g, &Plan::default(), 10),
        Err(ReplayError::AgentCount {
            agents: 1,
            paths: 0
        })
    );
    assert_eq!(
        replay(&map, &s, &g, &plan(&[&[c(1, 1), c(1, 2)]]), 10),
        Err(ReplayError::BadStart { agent: 0 })
    );
    assert!(matches!(
        replay(&map, &s, &g, &plan(&[&[c(1, 0), c(1, 3)]]), 10),
        Err(ReplayError::NotAMove { .. })
    ));
}
