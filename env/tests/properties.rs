//! Property tests over random maps, agent counts, sensor ranges and action
//! streams: the env agrees step by step with an independent reference model
//! of SPEC §2, and its invariants and observation encodings hold throughout.
//!
//! Reward bounds, derived from the rules: per agent and step the terms are
//! +0.5 (first arrival, at most once per episode), +1 (all home, only on the
//! terminating step), −1 (truncation, only when off the goal, so never
//! together with +0.5 or +1 in the same step) and −1 for a shared cell (which
//! the sequential rule makes impossible). Hence a step reward is one of
//! {−1, 0, 0.5, 1, 1.5} ⊂ [−1, 1.5], an agent's episode return lies in
//! [−1, 1.5] (at most 0.5 + 1; at least −1, e.g. −0.5 when it arrived, left
//! and was truncated), and the episode reward summed over n agents lies in
//! [−n, 1.5n]. In lifelong mode a step reward is 0 or 0.5.

#![allow(clippy::needless_range_loop)] // index loops mirror the rules as written

mod common;

use std::collections::HashSet;
use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, Grid, GridEnv, Map};
use proptest::prelude::*;

#[derive(Debug, Clone)]
struct Case {
    height: usize,
    width: usize,
    walls: Vec<bool>,
    agents: usize,
    sensor_range: usize,
    t_max: u32,
    seed: u64,
    lifelong: bool,
    actions: Vec<Vec<u8>>,
}

fn case() -> impl Strategy<Value = Case> {
    (
        2usize..=7,
        2usize..=8,
        1usize..=4,
        0usize..=4,
        1u32..=25,
        any::<u64>(),
        prop::bool::weighted(0.2),
    )
        .prop_flat_map(
            |(height, width, agents, sensor_range, t_max, seed, lifelong)| {
                let agents = agents.min(height * width / 2);
                (
                    prop::collection::vec(prop::bool::weighted(0.3), height * width),
                    prop::collection::vec(prop::collection::vec(0u8..5, agents), 1..50),
                )
                    .prop_map(move |(mut walls, actions)| {
                        // Free walls, first ones first, until 2n distinct cells fit
                        // (lifelong needs only n + 1, so 2n covers it).
                        let mut free = walls.iter().filter(|w| !**w).count();
                        for w in walls.iter_mut() {
                            if free >= 2 * agents {
                                break;
                            }
                            if *w {
                                *w = false;
                                free += 1;
                            }
                        }
                        Case {
                            height,
                            width,
                            walls,
                            agents,
                            sensor_range,
                            t_max,
                            seed,
                            lifelong,
                            actions,
                        }
                    })
            },
        )
}

/// The thesis ruleset written out plainly, independent of the env's
/// padded-index implementation.
struct Reference {
    pos: Vec<Cell>,
    goals: Vec<Cell>,
    reached: Vec<bool>,
    t: u32,
}

struct RefStep {
    rewards: Vec<f32>,
    blocked: u32,
    terminated: bool,
    truncated: bool,
}

impl Reference {
    fn step(&mut self, grid: &Grid, t_max: u32, actions: &[u8]) -> RefStep {
        let n = self.pos.len();
        let mut blocked = 0;
        for (i, &a) in actions.iter().enumerate() {
            let (dr, dc): (isize, isize) = match a {
                0 => continue,
                1 => (-1, 0),
                2 => (0, 1),
                3 => (1, 0),
                4 => (0, -1),
                _ => unreachable!(),
            };
            let r = self.pos[i].row as isize + dr;
            let c = self.pos[i].col as isize + dc;
            let inside =
                r >= 0 && c >= 0 && (r as usize) < grid.height() && (c as usize) < grid.width();
            let target = Cell::new(r.max(0) as usize, c.max(0) as usize);
            let free = inside && !grid.walls()[target.row * grid.width() + target.col];
            if free && !self.pos.contains(&target) {
                self.pos[i] = target;
            } else {
                blocked += 1;
            }
        }
        self.t += 1;
        let mut rewards = vec![0.0; n];
        for i in 0..n {
            if self.pos[i] == self.goals[i] && !self.reached[i] {
                self.reached[i] = true;
                rewards[i] += 0.5;
            }
        }
        let all_home = (0..n).all(|i| self.pos[i] == self.goals[i]);
        let truncated = !all_home && self.t >= t_max;
        for i in 0..n {
            if all_home {
                rewards[i] += 1.0;
            } else if truncated && self.pos[i] != self.goals[i] {
                rewards[i] -= 1.0;
            }
        }
        RefStep {
            rewards,
            blocked,
            terminated: all_home,
            truncated,
        }
    }
}

fn check_observations(env: &GridEnv) -> Result<(), TestCaseError> {
    let grid = &env.map().grid;
    let n = env.agents();
    let r = env.config().sensor_range;
    let side = 2 * r + 1;
    let centre = r * side + r;
    let mut codes = vec![0u8; side * side];
    let mut obs = vec![0.0f32; env.local_obs_dim()];
    let mut mask = [0u8; 5];
    for i in 0..n {
        env.write_local_codes(i, &mut codes).unwrap();
        env.write_local_obs(i, &mut obs).unwrap();
        env.write_action_mask(i, &mut mask).unwrap();
        prop_assert!(codes.iter().all(|&c| c <= 4));
        // Every code from first principles: walls/outside 1, another agent 2,
        // own goal 3, another's goal 4, agents beat goals, else 0.
        let me = env.position(i);
        for (k, &code) in codes.iter().enumerate() {
            let row = me.row as isize + (k / side) as isize - r as isize;
            let col = me.col as isize + (k % side) as isize - r as isize;
            let inside = row >= 0
                && col >= 0
                && (row as usize) < grid.height()
                && (col as usize) < grid.width();
            let q = Cell::new(row.max(0) as usize, col.max(0) as usize);
            let want = if !inside || grid.is_wall(q) {
                1
            } else if (0..n).any(|j| j != i && env.position(j) == q) {
                2
            } else if env.goal(i) == q {
                3
            } else if (0..n).any(|j| env.goal(j) == q) {
                4
            } else {
                0
            };
            prop_assert_eq!(code, want, "agent {} window cell {}", i, k);
        }
        prop_assert_eq!(codes[centre] == 3, env.at_goal(i));
        prop_assert!(codes[centre] != 1 && codes[centre] != 2);
        // Other agents appear as 2 exactly where they stand inside the window.
        let visible_others = (0..n)
            .filter(|&j| j != i)
            .filter(|&j| {
                let p = env.position(j);
                p.row.abs_diff(me.row) <= r && p.col.abs_diff(me.col) <= r
            })
            .count();
        prop_assert_eq!(codes.iter().filter(|&&c| c == 2).count(), visible_others);
        prop_assert!(codes.iter().filter(|&&c| c == 3).count() <= 1);
        // One-hot rows sum to exactly 1 and agree with the codes.
        for (k, &code) in codes.iter().enumerate() {
            let row = &obs[5 * k..5 * k + 5];
            prop_assert_eq!(row.iter().sum::<f32>(), 1.0);
            prop_assert_eq!(row[code as usize], 1.0);
        }
        let tail = &obs[side * side * 5..];
        prop_assert!((0.0..=1.0).contains(&tail[0]) && (0.0..=1.0).contains(&tail[1]));
        prop_assert!((-1.0..=1.0).contains(&tail[2]) && (-1.0..=1.0).contains(&tail[3]));
        // Mask: stay always legal; a move legal iff the target is on the grid,
        // free and unoccupied, i.e. iff its window code is 0, 3 or 4.
        prop_assert_eq!(mask[0], 1);
        for a in 1..5u8 {
            let open = grid
                .neighbour(me, a)
                .is_some_and(|q| !grid.is_wall(q) && !env.positions().contains(&q));
            prop_assert_eq!(mask[a as usize] == 1, open, "agent {} action {}", i, a);
            if r >= 1 {
                let k = match a {
                    1 => centre - side,
                    2 => centre + 1,
                    3 => centre + side,
                    _ => centre - 1,
                };
                prop_assert_eq!(mask[a as usize] == 1, matches!(codes[k], 0 | 3 | 4));
            }
        }
    }
    // Central codes: 0, 1 or 2 + 2i / 3 + 2i; every agent exactly once.
    let cells = grid.height() * grid.width();
    let mut central = vec![0u16; cells];
    env.write_central_codes(&mut central).unwrap();
    prop_assert!(central.iter().all(|&c| (c as usize) <= 2 * n + 1));
    for i in 0..n {
        let at = |code: u16| central.iter().filter(|&&c| c == code).count();
        prop_assert_eq!(at(2 + 2 * i as u16), 1);
        prop_assert_eq!(central[grid.index(env.position(i))], 2 + 2 * i as u16);
        let goal_hidden = env.positions().contains(&env.goal(i));
        prop_assert_eq!(at(3 + 2 * i as u16), usize::from(!goal_hidden));
    }
    for (k, &wall) in grid.walls().iter().enumerate() {
        prop_assert_eq!(central[k] == 1, wall);
    }
    // Central planes: walls, one cell per agent plane and goal plane.
    let mut planes = vec![0.0f32; env.central_obs_dim()];
    env.write_central_obs(&mut planes).unwrap();
    prop_assert!(planes.iter().all(|&v| v == 0.0 || v == 1.0));
    for (k, &wall) in grid.walls().iter().enumerate() {
        prop_assert_eq!(planes[k] == 1.0, wall);
    }
    for p in 1..=2 * n {
        let plane = &planes[p * cells..(p + 1) * cells];
        prop_assert_eq!(plane.iter().sum::<f32>(), 1.0);
    }
    let mut joint = vec![0u8; 5 * n];
    env.write_joint_mask(&mut joint).unwrap();
    for i in 0..n {
        env.write_action_mask(i, &mut mask).unwrap();
        prop_assert_eq!(&joint[5 * i..5 * i + 5], &mask[..]);
    }
    Ok(())
}

fn check_state(env: &GridEnv) -> Result<(), TestCaseError> {
    let grid = &env.map().grid;
    let positions = env.positions();
    let distinct: HashSet<_> = positions.iter().collect();
    prop_assert_eq!(distinct.len(), positions.len(), "two agents in one cell");
    prop_assert!(
        positions.iter().all(|&p| !grid.is_wall(p)),
        "agent on a wall"
    );
    let goals = env.goals();
    let distinct: HashSet<_> = goals.iter().collect();
    prop_assert_eq!(distinct.len(), goals.len(), "shared goal");
    prop_assert!(goals.iter().all(|&p| !grid.is_wall(p)), "goal on a wall");
    Ok(())
}

fn run(case: Case) -> Result<(), TestCaseError> {
    let grid = Grid::from_walls(case.height, case.width, case.walls.clone());
    let map = Arc::new(Map {
        name: "prop".into(),
        grid,
        scenario: None,
    });
    let cfg = EnvConfig {
        agents: case.agents,
        t_max: case.t_max,
        seed: case.seed,
        sensor_range: case.sensor_range,
        lifelong: case.lifelong,
        ..EnvConfig::default()
    };
    let n = case.agents;
    let mut env = GridEnv::new(map.clone(), cfg).unwrap();
    let new_reference = |env: &GridEnv| Reference {
        pos: env.positions(),
        goals: env.goals(),
        reached: vec![false; n],
        t: 0,
    };
    let mut reference = new_reference(&env);
    let mut returns = vec![0.0f32; n];
    let mut rewards = vec![0.0f32; n];
    check_state(&env)?;
    check_observations(&env)?;
    for actions in &case.actions {
        let before = env.positions();
        let out = env.step(actions, &mut rewards).unwrap();
        check_state(&env)?;
        check_observations(&env)?;
        for (p, q) in before.iter().zip(env.positions()) {
            prop_assert!(p.manhattan(q) <= 1);
        }
        for (i, &r) in rewards.iter().enumerate() {
            prop_assert!((-1.0..=1.5).contains(&r), "agent {} reward {}", i, r);
            returns[i] += r;
        }
        if case.lifelong {
            prop_assert!(rewards.iter().all(|&r| r == 0.0 || r == 0.5));
            prop_assert!(!out.terminated);
            prop_assert_eq!(out.truncated, env.t() == case.t_max);
        } else {
            prop_assert!(rewards
                .iter()
                .all(|r| [-1.0, 0.0, 0.5, 1.0, 1.5].contains(r)));
            let expected = reference.step(&env.map().grid, case.t_max, actions);
            prop_assert_eq!(env.positions(), reference.pos.clone());
            prop_assert_eq!(&rewards, &expected.rewards);
            prop_assert_eq!(out.blocked_moves, expected.blocked);
            prop_assert_eq!(out.terminated, expected.terminated);
            prop_assert_eq!(out.truncated, expected.truncated);
        }
        if out.done() {
            let stats = env.stats();
            let total: f32 = returns.iter().sum();
            prop_assert_eq!(stats.reward, total);
            if !case.lifelong {
                prop_assert!(
                    returns.iter().all(|r| (-1.0..=1.5).contains(r)),
                    "{:?}",
                    returns
                );
                prop_assert!((-(n as f32)..=1.5 * n as f32).contains(&total));
                prop_assert_eq!(stats.success, out.terminated);
                if out.terminated {
                    prop_assert_eq!(total, 1.5 * n as f32);
                }
            }
            env.reset_next(1).unwrap();
            reference = new_reference(&env);
            returns.iter_mut().for_each(|r| *r = 0.0);
            check_state(&env)?;
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn env_matches_the_reference_rules_and_keeps_its_invariants(case in case()) {
        run(case)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Malformed text never panics the parsers: it either parses or gives a
    /// parse error with a line inside the text.
    #[test]
    fn map_parser_never_panics(text in "(type octile\n)?(height [0-9x]{0,2}\n)?(width [0-9]{0,2}\n)?(map\n)?([.@TGx]{0,5}\n){0,6}") {
        match buridan_env::map::parse_map("p.map", &text) {
            Ok(grid) => prop_assert!(grid.height() > 0 && grid.width() > 0),
            Err(buridan_env::MapError::Parse { line, .. }) => {
                prop_assert!(line >= 1 && line <= text.lines().count() + 1, "line {} of {:?}", line, text);
            }
            Err(other) => prop_assert!(false, "unexpected error {:?}", other),
        }
    }
}
