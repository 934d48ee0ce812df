//! SPEC §2, rule by rule, on tiny hand-made grids and the bundled models.

mod common;

use std::collections::HashSet;
use std::sync::Arc;

use buridan_env::{episode_instance, Cell, EnvConfig, EnvError, GridEnv, Map, Starts};
use common::{c, env_on, pos, step};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

// ---------------------------------------------------------------- moves

#[test]
fn move_into_a_wall_is_blocked_and_counted() {
    // (0,1) is a wall.
    let mut env = env_on(&[".@.", "..."], &[(0, 0)], &[(1, 2)], 100);
    let (_, out) = step(&mut env, &[2]);
    assert_eq!(pos(&env), [(0, 0)]);
    assert_eq!(out.blocked_moves, 1);
    // A legal move afterwards is not blocked.
    let (_, out) = step(&mut env, &[3]);
    assert_eq!(pos(&env), [(1, 0)]);
    assert_eq!(out.blocked_moves, 0);
    // Up from (1,0) back to (0,0) works; right from (1,1) into (0,1) is the wall from below.
    step(&mut env, &[2]);
    let (_, out) = step(&mut env, &[1]);
    assert_eq!(pos(&env), [(1, 1)]);
    assert_eq!(out.blocked_moves, 1);
    assert_eq!(env.stats().blocked_moves, 2);
}

#[test]
fn moves_off_every_grid_edge_are_blocked() {
    // A 2x2 open grid: from each corner two moves leave the grid.
    for (start, off_grid) in [
        ((0, 0), [1u8, 4]),
        ((0, 1), [1, 2]),
        ((1, 1), [3, 2]),
        ((1, 0), [3, 4]),
    ] {
        let goal = (1 - start.0, 1 - start.1);
        let mut env = env_on(&["..", ".."], &[start], &[goal], 100);
        for a in off_grid {
            let (rewards, out) = step(&mut env, &[a]);
            assert_eq!(pos(&env), [start], "action {a} from {start:?}");
            assert_eq!(out.blocked_moves, 1);
            assert_eq!(rewards, [0.0]);
        }
        assert_eq!(env.stats().blocked_moves, 2);
    }
}

#[test]
fn the_four_moves_go_where_the_spec_says() {
    // 1 up (row-1), 2 right (col+1), 3 down (row+1), 4 left (col-1).
    for (a, to) in [
        (1u8, (0, 1)),
        (2, (1, 2)),
        (3, (2, 1)),
        (4, (1, 0)),
        (0, (1, 1)),
    ] {
        let mut env = env_on(&["...", "...", "..."], &[(1, 1)], &[(0, 0)], 100);
        let (_, out) = step(&mut env, &[a]);
        assert_eq!(pos(&env), [to], "action {a}");
        assert_eq!(out.blocked_moves, 0);
    }
}

#[test]
fn move_into_an_agent_that_stays_is_blocked() {
    let mut env = env_on(&["...."], &[(0, 0), (0, 1)], &[(0, 3), (0, 2)], 100);
    // Agent 0 pushes into agent 1 which stays; agent 1 pushing into agent 0 is blocked too.
    let (_, out) = step(&mut env, &[2, 0]);
    assert_eq!(pos(&env), [(0, 0), (0, 1)]);
    assert_eq!(out.blocked_moves, 1);
    let (_, out) = step(&mut env, &[0, 4]);
    assert_eq!(pos(&env), [(0, 0), (0, 1)]);
    assert_eq!(out.blocked_moves, 1);
    // Stay is never blocked.
    let (_, out) = step(&mut env, &[0, 0]);
    assert_eq!(out.blocked_moves, 0);
    assert_eq!(env.stats().blocked_moves, 2);
}

#[test]
fn lower_index_moves_first_and_frees_its_cell_for_higher_ones() {
    // Agent 0 in front (col 1), agent 1 behind (col 0); both move right:
    // agent 0 leaves col 1 first, so agent 1 may enter it in the same step.
    let mut env = env_on(&["...."], &[(0, 1), (0, 0)], &[(0, 3), (0, 2)], 100);
    let (_, out) = step(&mut env, &[2, 2]);
    assert_eq!(pos(&env), [(0, 2), (0, 1)]);
    assert_eq!(out.blocked_moves, 0);
}

#[test]
fn a_cell_vacated_later_by_a_higher_index_agent_cannot_be_entered() {
    // Agent 1 in front (col 1), agent 0 behind (col 0); both move right:
    // agent 0 moves first while col 1 is still occupied, so it stays.
    let mut env = env_on(&["...."], &[(0, 0), (0, 1)], &[(0, 2), (0, 3)], 100);
    let (_, out) = step(&mut env, &[2, 2]);
    assert_eq!(pos(&env), [(0, 0), (0, 2)]);
    assert_eq!(out.blocked_moves, 1);
}

#[test]
fn a_train_moves_as_a_whole_only_in_index_order() {
    // Front to back 0, 1, 2: everybody moves.
    let mut env = env_on(
        &["....."],
        &[(0, 2), (0, 1), (0, 0)],
        &[(0, 4), (0, 3), (0, 2)],
        100,
    );
    let (_, out) = step(&mut env, &[2, 2, 2]);
    assert_eq!(pos(&env), [(0, 3), (0, 2), (0, 1)]);
    assert_eq!(out.blocked_moves, 0);
    // Front to back 2, 1, 0: only the front agent moves.
    let mut env = env_on(
        &["....."],
        &[(0, 0), (0, 1), (0, 2)],
        &[(0, 2), (0, 3), (0, 4)],
        100,
    );
    let (_, out) = step(&mut env, &[2, 2, 2]);
    assert_eq!(pos(&env), [(0, 0), (0, 1), (0, 3)]);
    assert_eq!(out.blocked_moves, 2);
}

#[test]
fn no_swap_is_possible() {
    // Head-on in a corridor: both blocked.
    let mut env = env_on(&["...."], &[(0, 1), (0, 2)], &[(0, 3), (0, 0)], 100);
    let (_, out) = step(&mut env, &[2, 4]);
    assert_eq!(pos(&env), [(0, 1), (0, 2)]);
    assert_eq!(out.blocked_moves, 2);
    // Vertical neighbours too.
    let mut env = env_on(&[".", "."], &[(0, 0), (1, 0)], &[(1, 0), (0, 0)], 100);
    let (_, out) = step(&mut env, &[3, 1]);
    assert_eq!(pos(&env), [(0, 0), (1, 0)]);
    assert_eq!(out.blocked_moves, 2);
    // A full 2x2 rotation cannot happen either: every target is occupied.
    let mut env = env_on(
        &["..", ".."],
        &[(0, 0), (0, 1), (1, 1), (1, 0)],
        &[(0, 1), (1, 1), (1, 0), (0, 0)],
        100,
    );
    let (_, out) = step(&mut env, &[2, 3, 4, 1]);
    assert_eq!(pos(&env), [(0, 0), (0, 1), (1, 1), (1, 0)]);
    assert_eq!(out.blocked_moves, 4);
}

#[test]
fn a_rotation_with_one_hole_advances_in_index_order() {
    // 2x2 ring, hole at (1,0), everybody turns clockwise. In index order:
    // agent 0 (0,0)->(0,1) is still occupied by agent 1 -> blocked; agent 1
    // (0,1)->(1,1) is still occupied by agent 2 -> blocked; agent 2
    // (1,1)->(1,0) is the hole -> moves. Only the last agent advances.
    let mut env = env_on(
        &["..", ".."],
        &[(0, 0), (0, 1), (1, 1)],
        &[(0, 1), (1, 1), (1, 0)],
        100,
    );
    let (_, out) = step(&mut env, &[2, 3, 4]);
    assert_eq!(pos(&env), [(0, 0), (0, 1), (1, 0)]);
    assert_eq!(out.blocked_moves, 2);
}

// ---------------------------------------------------------------- rewards

#[test]
fn first_reach_reward_is_paid_once_per_episode() {
    // Agent 0: start (0,0), goal (0,1). Agent 1 at (0,3), goal (0,2), waits.
    let mut env = env_on(&["...."], &[(0, 0), (0, 3)], &[(0, 1), (0, 2)], 100);
    let (r, out) = step(&mut env, &[2, 0]);
    assert_eq!(r, [0.5, 0.0]);
    assert!(!out.done());
    // Staying on the goal pays nothing more.
    let (r, _) = step(&mut env, &[0, 0]);
    assert_eq!(r, [0.0, 0.0]);
    // Leave and come back: no second reward.
    let (r, _) = step(&mut env, &[4, 0]);
    assert_eq!(r, [0.0, 0.0]);
    let (r, out) = step(&mut env, &[2, 0]);
    assert_eq!(r, [0.0, 0.0]);
    assert!(!out.done());
    assert_eq!(env.stats().goals_reached, 1);
    // Agent 1 arrives: +0.5 for it, +1 for everybody, termination.
    let (r, out) = step(&mut env, &[0, 4]);
    assert_eq!(r, [1.0, 1.5]);
    assert!(out.terminated && !out.truncated && out.done());
    let s = env.stats();
    assert_eq!(s.reward, 3.0);
    assert_eq!(s.length, 5);
    assert!(s.success);
    assert_eq!(s.agents_at_goal, 2);
    assert_eq!(s.goals_reached, 2);
    assert!(env.is_over());
    // The finished episode refuses further steps.
    let mut rewards = [0.0; 2];
    assert_eq!(env.step(&[0, 0], &mut rewards), Err(EnvError::EpisodeOver));
    // reset starts over with fresh first-reach flags.
    env.reset_to(0).unwrap();
    assert_eq!(pos(&env), [(0, 0), (0, 3)]);
    assert_eq!(env.t(), 0);
    let (r, _) = step(&mut env, &[2, 0]);
    assert_eq!(r, [0.5, 0.0]);
}

#[test]
fn goals_are_checked_after_the_step_so_a_start_on_the_goal_pays_at_step_one() {
    let mut env = env_on(&["..."], &[(0, 0), (0, 2)], &[(0, 0), (0, 1)], 100);
    let (r, out) = step(&mut env, &[0, 0]);
    assert_eq!(r, [0.5, 0.0]);
    assert!(!out.done());
    // Everybody starting home: the first step terminates with 0.5 + 1 each.
    let mut env = env_on(&["..."], &[(0, 0), (0, 2)], &[(0, 0), (0, 2)], 100);
    let (r, out) = step(&mut env, &[0, 0]);
    assert_eq!(r, [1.5, 1.5]);
    assert!(out.terminated);
    assert_eq!(env.stats().length, 1);
}

#[test]
fn reaching_the_goal_on_the_last_step_terminates_instead_of_truncating() {
    let mut env = env_on(&["..."], &[(0, 0)], &[(0, 2)], 2);
    let (r, out) = step(&mut env, &[2]);
    assert_eq!((r[0], out.done()), (0.0, false));
    let (r, out) = step(&mut env, &[2]);
    assert_eq!(r, [1.5]);
    assert!(out.terminated && !out.truncated);
    assert!(env.stats().success);
}

#[test]
fn truncation_at_a_configurable_t_max_penalises_agents_off_their_goals() {
    // Agent 0 reaches its goal at step 1, agent 1 never moves.
    let mut env = env_on(&["...."], &[(0, 0), (0, 3)], &[(0, 1), (0, 2)], 3);
    let (r, out) = step(&mut env, &[2, 0]);
    assert_eq!(r, [0.5, 0.0]);
    assert!(!out.done());
    let (r, out) = step(&mut env, &[0, 0]);
    assert_eq!(r, [0.0, 0.0]);
    assert!(!out.done());
    assert_eq!(env.t(), 2);
    let (r, out) = step(&mut env, &[0, 0]);
    assert_eq!(r, [0.0, -1.0]);
    assert!(out.truncated && !out.terminated);
    let s = env.stats();
    assert_eq!((s.length, s.success, s.agents_at_goal), (3, false, 1));
    assert_eq!(s.reward, -0.5);
    assert_eq!(env.step(&[0, 0], &mut [0.0; 2]), Err(EnvError::EpisodeOver));
}

#[test]
fn an_agent_that_left_its_goal_is_penalised_at_truncation() {
    let mut env = env_on(&["...."], &[(0, 0), (0, 3)], &[(0, 1), (0, 2)], 2);
    assert_eq!(step(&mut env, &[2, 0]).0, [0.5, 0.0]);
    let (r, out) = step(&mut env, &[4, 0]);
    assert!(out.truncated);
    assert_eq!(r, [-1.0, -1.0]);
    assert_eq!(env.stats().reward, -1.5);
}

#[test]
fn four_agents_truncated_with_nobody_home_score_exactly_minus_four() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let cfg = EnvConfig {
        agents: 4,
        starts: Starts::Fixed,
        ..EnvConfig::default()
    };
    assert_eq!(cfg.t_max, 100, "default T_max");
    let mut env = GridEnv::new(map, cfg).unwrap();
    let mut rewards = [0.0; 4];
    for t in 1..=100 {
        let out = env.step(&[0; 4], &mut rewards).unwrap();
        if t < 100 {
            assert!(!out.done(), "step {t}");
            assert_eq!(rewards, [0.0; 4]);
        } else {
            assert!(out.truncated && !out.terminated);
            assert_eq!(rewards, [-1.0; 4]);
        }
    }
    let s = env.stats();
    assert_eq!(s.reward, -4.0);
    assert_eq!((s.length, s.success, s.agents_at_goal), (100, false, 0));
}

#[test]
fn random_truncated_episodes_follow_the_default_t_max() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let mut env = GridEnv::new(map, EnvConfig::default()).unwrap();
    let mut rewards = [0.0; 4];
    let mut t = 0;
    loop {
        t += 1;
        if env.step(&[0; 4], &mut rewards).unwrap().done() {
            break;
        }
    }
    assert_eq!(t, 100);
    assert_eq!(env.stats().reward, -4.0);
}

// ------------------------------------------- shortest fixed episodes (BFS)

/// Breadth-first search over joint actions (5^n per state, state = the
/// agents' positions) from the fixed scenario of `id`, using `reset_with` and
/// `step` on clones. Returns the length and the episode reward of the
/// shortest successful episode, and checks that no shorter one exists.
fn shortest_successful_episode(id: &str) -> (u32, f32) {
    let map = Arc::new(Map::load(id).unwrap());
    let scen = map.scenario.clone().unwrap();
    let n = scen.starts.len();
    let cfg = EnvConfig {
        agents: n,
        starts: Starts::Fixed,
        ..EnvConfig::default()
    };
    let mut root = GridEnv::new(map, cfg).unwrap();
    root.reset_with(0, &scen.starts, &scen.goals).unwrap();
    let joint_actions: Vec<Vec<u8>> = (0..5usize.pow(n as u32))
        .map(|mut k| {
            (0..n)
                .map(|_| {
                    let a = (k % 5) as u8;
                    k /= 5;
                    a
                })
                .collect()
        })
        .collect();
    let mut seen: HashSet<Vec<Cell>> = HashSet::from([root.positions()]);
    let mut frontier = vec![root];
    let mut rewards = vec![0.0; n];
    let mut depth = 0;
    while !frontier.is_empty() {
        depth += 1;
        let mut next = Vec::new();
        let mut found: Option<f32> = None;
        for env in &frontier {
            for actions in &joint_actions {
                let mut child = env.clone();
                let out = child.step(actions, &mut rewards).unwrap();
                if out.terminated {
                    let s = child.stats();
                    assert_eq!(s.length, depth);
                    assert!(s.success);
                    // Every successful episode of the same length scores the same.
                    if let Some(r) = found {
                        assert_eq!(r, s.reward);
                    }
                    found = Some(s.reward);
                } else if !out.done() && seen.insert(child.positions()) {
                    next.push(child);
                }
            }
        }
        if let Some(reward) = found {
            return (depth, reward);
        }
        frontier = next;
    }
    panic!("{id}: no successful episode within T_max");
}

#[test]
fn rm_1_1_shortest_fixed_episode_is_10_steps_and_scores_3() {
    assert_eq!(shortest_successful_episode("rm-1.1"), (10, 3.0));
}

#[test]
fn rm_1_2_shortest_fixed_episode_is_16_steps() {
    assert_eq!(shortest_successful_episode("rm-1.2"), (16, 3.0));
}

#[test]
fn rm_1_3_shortest_fixed_episode_is_7_steps() {
    assert_eq!(shortest_successful_episode("rm-1.3"), (7, 3.0));
}

#[test]
fn rm_1_1_optimal_plan_by_hand() {
    // Agent 0 (1,1)->(1,8), agent 1 (1,7)->(1,0); the evasion aisle is (0,4).
    // Agent 0 parks in the aisle at step 4 while agent 1 takes (1,4) in the
    // same step (vacated earlier by the lower index); agent 0 can come back
    // down only at step 6, once agent 1 has left (1,4) in step 5.
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let cfg = EnvConfig {
        agents: 2,
        starts: Starts::Fixed,
        ..EnvConfig::default()
    };
    let mut env = GridEnv::new(map, cfg).unwrap();
    assert_eq!(pos(&env), [(1, 1), (1, 7)]);
    let plan: [[u8; 2]; 10] = [
        [2, 4],
        [2, 4],
        [2, 4], // agent 1 blocked: agent 0 took (1,4)
        [1, 4], // agent 0 up into the aisle, agent 1 into the vacated (1,4)
        [3, 4], // agent 0 blocked: (1,4) is still occupied when it moves
        [3, 4],
        [2, 4],
        [2, 4], // agent 1 reaches (1,0)
        [2, 0],
        [2, 0], // agent 0 reaches (1,8)
    ];
    let expected = [
        [(1, 2), (1, 6)],
        [(1, 3), (1, 5)],
        [(1, 4), (1, 5)],
        [(0, 4), (1, 4)],
        [(0, 4), (1, 3)],
        [(1, 4), (1, 2)],
        [(1, 5), (1, 1)],
        [(1, 6), (1, 0)],
        [(1, 7), (1, 0)],
        [(1, 8), (1, 0)],
    ];
    let mut total_blocked = 0;
    for (t, (a, p)) in plan.iter().zip(expected).enumerate() {
        let (r, out) = step(&mut env, a);
        assert_eq!(pos(&env), p, "step {}", t + 1);
        total_blocked += out.blocked_moves;
        match t + 1 {
            8 => assert_eq!(r, [0.0, 0.5]),
            10 => {
                assert_eq!(r, [1.5, 1.0]);
                assert!(out.terminated);
            }
            _ => assert_eq!(r, [0.0, 0.0], "step {}", t + 1),
        }
    }
    assert_eq!(total_blocked, 2);
    assert_eq!(env.stats().reward, 3.0);
}

// ------------------------------------------------- starts, goals, seeds

fn random_actions(rng: &mut ChaCha8Rng, n: usize) -> Vec<u8> {
    (0..n).map(|_| rng.random_range(0..5u8)).collect()
}

/// Starts, goals, and per step the positions and rewards of one episode.
type Trajectory = (Vec<Cell>, Vec<Cell>, Vec<Vec<Cell>>, Vec<Vec<f32>>);

/// Positions and rewards of one episode driven by a seeded action stream.
fn trajectory(map: &Arc<Map>, cfg: &EnvConfig, episode: u64) -> Trajectory {
    let mut env = GridEnv::with_episode(map.clone(), cfg.clone(), episode).unwrap();
    let (starts, goals) = (env.positions(), env.goals());
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (mut ps, mut rs) = (Vec::new(), Vec::new());
    let mut rewards = vec![0.0; cfg.agents];
    loop {
        let out = env
            .step(&random_actions(&mut rng, cfg.agents), &mut rewards)
            .unwrap();
        ps.push(env.positions());
        rs.push(rewards.clone());
        if out.done() {
            break;
        }
    }
    (starts, goals, ps, rs)
}

#[test]
fn episodes_are_reproducible_from_map_agents_seed_and_index() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let cfg = EnvConfig {
        seed: 42,
        ..EnvConfig::default()
    };
    let a = trajectory(&map, &cfg, 3);
    let b = trajectory(&map, &cfg, 3);
    assert_eq!(a, b);
    assert_eq!(a.2.len(), 100);
    // The same instance as episode_instance gives.
    let scen = episode_instance(&map, 4, Starts::Random, 42, 3).unwrap();
    assert_eq!((scen.starts, scen.goals), (a.0.clone(), a.1.clone()));
    // Resetting an env that played other episodes gives the same episode again.
    let mut env = GridEnv::with_episode(map.clone(), cfg.clone(), 0).unwrap();
    env.reset_to(3).unwrap();
    assert_eq!((env.positions(), env.goals()), (a.0.clone(), a.1.clone()));
    // reset_next strides from the current index.
    env.reset_next(5).unwrap();
    assert_eq!(env.episode(), 8);
    let c8 = episode_instance(&map, 4, Starts::Random, 42, 8).unwrap();
    assert_eq!(env.positions(), c8.starts);
    // Another episode index or another seed gives another instance.
    let other = trajectory(&map, &cfg, 4);
    assert_ne!((&a.0, &a.1), (&other.0, &other.1));
    let reseeded = trajectory(
        &map,
        &EnvConfig {
            seed: 43,
            ..cfg.clone()
        },
        3,
    );
    assert_ne!((&a.0, &a.1), (&reseeded.0, &reseeded.1));
}

#[test]
fn random_starts_and_goals_are_2n_distinct_free_cells() {
    for (id, n) in [("rm-1.4", 4), ("rm-2.1", 16), ("rm-1.1", 5), ("rm-3.1", 1)] {
        let map = Map::load(id).unwrap();
        let mut distinct_instances = HashSet::new();
        for episode in 0..200 {
            let s = episode_instance(&map, n, Starts::Random, 7, episode).unwrap();
            assert_eq!((s.starts.len(), s.goals.len()), (n, n));
            let all: HashSet<Cell> = s.starts.iter().chain(&s.goals).copied().collect();
            assert_eq!(all.len(), 2 * n, "{id} episode {episode}");
            assert!(all.iter().all(|&c| !map.grid.is_wall(c)));
            distinct_instances.insert((s.starts, s.goals));
        }
        assert!(
            distinct_instances.len() > 150,
            "{id}: {}",
            distinct_instances.len()
        );
    }
    // Exactly 2n free cells: every free cell is used.
    let map = Map {
        name: "tight".into(),
        grid: buridan_env::Grid::from_rows(&[".@.", "@@@", ".@."]).unwrap(),
        scenario: None,
    };
    for episode in 0..20 {
        let s = episode_instance(&map, 2, Starts::Random, 1, episode).unwrap();
        let mut all: Vec<Cell> = s.starts.iter().chain(&s.goals).copied().collect();
        all.sort();
        assert_eq!(all, [c(0, 0), c(0, 2), c(2, 0), c(2, 2)]);
    }
}

#[test]
fn fixed_starts_come_from_the_scen_file_in_agent_order() {
    let map = Arc::new(Map::load("rm-3.1").unwrap());
    let cfg = EnvConfig {
        agents: 3,
        starts: Starts::Fixed,
        seed: 123,
        ..EnvConfig::default()
    };
    // x = column, y = row: line 1 is "0 15 22 17" -> start (15, 0), goal (17, 22).
    for episode in [0, 1, 17] {
        let env = GridEnv::with_episode(map.clone(), cfg.clone(), episode).unwrap();
        assert_eq!(env.positions(), [c(15, 0), c(6, 23), c(16, 22)]);
        assert_eq!(env.goals(), [c(17, 22), c(19, 4), c(16, 0)]);
    }
}

// ---------------------------------------------------------------- lifelong

#[test]
fn lifelong_mode_draws_a_new_goal_on_arrival_and_never_terminates() {
    let map = common::map_from_rows(&["....."], &[(0, 0)], &[(0, 1)]);
    let cfg = EnvConfig {
        lifelong: true,
        t_max: 40,
        seed: 5,
        ..common::fixed_cfg(1, 40)
    };
    let mut env = GridEnv::new(map, cfg).unwrap();
    let mut arrivals = 0;
    let mut rewards = [0.0];
    for t in 1..=40 {
        let before = env.goal(0);
        let here = env.position(0).col;
        let a = if before.col > here { 2 } else { 4 };
        let out = env.step(&[a], &mut rewards).unwrap();
        assert!(!out.terminated);
        if env.position(0) == before {
            arrivals += 1;
            assert_eq!(rewards, [0.5], "step {t}");
            assert_ne!(env.goal(0), before, "a new goal is drawn at once");
        } else {
            assert_eq!(rewards, [0.0], "step {t}");
        }
        assert_eq!(
            out.truncated,
            t == 40,
            "no penalty, truncation at T_max only"
        );
    }
    let s = env.stats();
    assert!(
        arrivals >= 10,
        "greedy agent on a corridor arrives often: {arrivals}"
    );
    assert_eq!(s.goals_reached, arrivals);
    assert_eq!(s.reward, 0.5 * arrivals as f32);
    assert!(!s.success);
    assert_eq!(s.length, 40);
    assert_eq!(s.throughput(), arrivals as f64 / 40.0);
}

#[test]
fn lifelong_goals_stay_distinct_and_reproducible() {
    let map = Arc::new(Map::load("rm-1.4").unwrap());
    let cfg = EnvConfig {
        agents: 4,
        lifelong: true,
        t_max: 300,
        seed: 11,
        ..EnvConfig::default()
    };
    let run = || {
        let mut env = GridEnv::with_episode(map.clone(), cfg.clone(), 2).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut goals = Vec::new();
        let mut rewards = [0.0; 4];
        loop {
            // Greedy towards the goal with some noise, to produce arrivals.
            let actions: Vec<u8> = (0..4)
                .map(|i| {
                    if rng.random_bool(0.2) {
                        return rng.random_range(0..5u8);
                    }
                    let d = env.map().grid.distances_to(env.goal(i));
                    let here = env.position(i);
                    (1..5u8)
                        .filter_map(|a| env.map().grid.neighbour(here, a).map(|n| (a, n)))
                        .filter(|&(_, n)| !env.map().grid.is_wall(n))
                        .min_by_key(|&(_, n)| d[env.map().grid.index(n)])
                        .map_or(0, |(a, _)| a)
                })
                .collect();
            let out = env.step(&actions, &mut rewards).unwrap();
            let g = env.goals();
            let distinct: HashSet<_> = g.iter().collect();
            assert_eq!(distinct.len(), 4, "goals stay pairwise distinct");
            assert!(g.iter().all(|&c| !env.map().grid.is_wall(c)));
            goals.push(g);
            assert!(!out.terminated);
            if out.done() {
                break;
            }
        }
        (goals, env.stats())
    };
    let (a, sa) = run();
    let (b, sb) = run();
    assert_eq!(a, b);
    assert_eq!(sa, sb);
    assert!(sa.goals_reached > 10, "{}", sa.goals_reached);
    assert_eq!(sa.length, 300);
    assert_eq!(sa.reward, 0.5 * sa.goals_reached as f32);
}
