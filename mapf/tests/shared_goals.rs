//! Shared goals (POGEMA's lifelong tasks are not exclusive): lifelong PIBT
//! and the shield take them, and an agent whose goal is held by a parked
//! agent is not stuck there forever.

use buridan_env::{Cell, Grid};
use buridan_mapf::lifelong::LifelongPibt;
use buridan_mapf::shield::{ActionOrder, Shield};

/// A corridor with a siding below its middle.
fn corridor() -> Grid {
    Grid::from_rows(&[".......", "@@@.@@@"]).unwrap()
}

/// Steps lifelong PIBT from `start` towards fixed `goals` (nobody gets a
/// new goal, so an agent on its goal stays parked unless pushed) and
/// returns, per agent, the first step at which it stood on its goal.
fn first_arrivals(start: &[Cell], goals: &[Cell], steps: usize) -> Vec<Option<usize>> {
    let grid = corridor();
    let mut pibt = LifelongPibt::new(&grid, Default::default(), 0);
    let mut pos = start.to_vec();
    let mut first = vec![None; start.len()];
    for t in 1..=steps {
        let next = pibt.step(&pos, goals).unwrap();
        for (i, (&a, &b)) in pos.iter().zip(&next).enumerate() {
            assert!(a.manhattan(b) <= 1, "agent {i} jumped");
        }
        let mut cells = next.clone();
        cells.sort();
        cells.dedup();
        assert_eq!(
            cells.len(),
            next.len(),
            "two agents on one cell at step {t}"
        );
        pos = next;
        for (i, f) in first.iter_mut().enumerate() {
            if f.is_none() && pos[i] == goals[i] {
                *f = Some(t);
            }
        }
    }
    first
}

#[test]
fn a_goal_held_by_a_parked_agent_is_reached_in_the_end() {
    // Agent 1 stands on its goal, the cell agent 0 must reach; agent 1's
    // priority stays low while agent 0's grows, so agent 0 pushes it off.
    let goal = Cell::new(0, 5);
    let first = first_arrivals(&[Cell::new(0, 0), goal], &[goal, goal], 40);
    assert!(
        first[0].is_some(),
        "agent 0 never reached the held goal: {first:?}"
    );
}

#[test]
fn two_agents_heading_for_one_cell_both_get_there() {
    let goal = Cell::new(0, 3);
    let first = first_arrivals(&[Cell::new(0, 0), Cell::new(0, 6)], &[goal, goal], 40);
    assert!(first.iter().all(Option::is_some), "{first:?}");
}

#[test]
fn the_shield_takes_shared_goals() {
    let grid = corridor();
    let goal = Cell::new(0, 3);
    let pos = [Cell::new(0, 2), Cell::new(0, 4)];
    // Both want to step onto the shared goal: one gets it, the other waits.
    let right_first: ActionOrder = [2, 0, 1, 3, 4];
    let left_first: ActionOrder = [4, 0, 1, 2, 3];
    for mut shield in [Shield::new(&grid), Shield::new(&grid).with_goal_settling(4)] {
        let mut actions = [0u8; 2];
        shield
            .step(
                &pos,
                &[goal, goal],
                &[right_first, left_first],
                &mut actions,
            )
            .unwrap();
        let moved = actions.iter().filter(|&&a| a != 0).count();
        assert_eq!(moved, 1, "{actions:?}");
    }
}
