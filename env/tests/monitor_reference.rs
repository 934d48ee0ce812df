//! The optimised deadlock detector (`buridan_env::monitor::StallMonitor`)
//! against the straightforward implementation it replaced
//! (`common::reference_monitor`): the same verdicts and counters after
//! every step, on random synthetic episodes (dense crowds, arbitrary
//! distance fields, new goals, resets, every window and radius) and on
//! random-action episodes of the real env in both modes.

mod common;

use std::sync::Arc;

use buridan_env::monitor::StallMonitor;
use buridan_env::{EnvConfig, GridEnv, Map};
use common::reference_monitor::ReferenceMonitor;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Everything either monitor reports, after one step.
fn verdicts_agree(fast: &StallMonitor, slow: &ReferenceMonitor, agents: usize, at: &str) {
    for i in 0..agents {
        assert_eq!(fast.state(i), slow.state(i), "{at}: state of agent {i}");
        assert_eq!(fast.is_stuck(i), slow.is_stuck(i), "{at}: agent {i} stuck");
    }
    assert_eq!(
        (fast.stuck(), fast.deadlocked(), fast.livelocked()),
        (slow.stuck(), slow.deadlocked(), slow.livelocked()),
        "{at}: stuck, deadlocked, livelocked"
    );
    assert_eq!(
        (
            fast.deadlock_steps(),
            fast.livelock_steps(),
            fast.deadlock_events(),
            fast.deadlocked_agents()
        ),
        (
            slow.deadlock_steps(),
            slow.livelock_steps(),
            slow.deadlock_events(),
            slow.deadlocked_agents()
        ),
        "{at}: episode counters"
    );
    assert_eq!(
        fast.agent_deadlock_steps(),
        slow.agent_deadlock_steps(),
        "{at}"
    );
    assert_eq!(
        fast.agent_livelock_steps(),
        slow.agent_livelock_steps(),
        "{at}"
    );
}

/// A synthetic episode: `agents` agents crowd a `side × side` box without
/// walls (cells may be shared: the monitor does not care), mostly waiting
/// so that jams form; each agent's distance field is random but 0 exactly
/// on its goal, so "closer to the goal" is arbitrary; with `lifelong`, an
/// agent on its goal sometimes gets a new one; now and then the episode
/// restarts.
fn synthetic_episode(seed: u64, agents: usize, window: u32, radius: usize, side: usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let lifelong = rng.random_bool(0.5);
    let stay = rng.random_range(0.3..0.95);
    let cells_per_map = side * side;
    // Per agent and goal cell, a distance field over the box.
    let fields: Vec<Vec<u16>> = (0..cells_per_map)
        .map(|goal| {
            (0..cells_per_map)
                .map(|c| {
                    if c == goal {
                        0
                    } else {
                        rng.random_range(1..=2 * side as u16)
                    }
                })
                .collect()
        })
        .collect();
    let random_cell = |rng: &mut ChaCha8Rng| (rng.random_range(0..side), rng.random_range(0..side));
    let mut cells: Vec<(usize, usize)> = (0..agents).map(|_| random_cell(&mut rng)).collect();
    let mut goals: Vec<usize> = (0..agents)
        .map(|_| rng.random_range(0..cells_per_map))
        .collect();
    let mut fast = StallMonitor::new(agents, window).with_radius(radius);
    let mut slow = ReferenceMonitor::new(agents, window).with_radius(radius);
    let index = |(r, c): (usize, usize)| r * side + c;
    for round in 0..3 {
        {
            let goals = goals.clone();
            let dist = |i: usize, cell: (usize, usize)| fields[goals[i]][index(cell)];
            fast.reset(&cells, dist);
            slow.reset(&cells, dist);
        }
        verdicts_agree(&fast, &slow, agents, &format!("reset {round}"));
        for t in 0..rng.random_range(1..120) {
            let mut new_goal = vec![false; agents];
            for i in 0..agents {
                if !rng.random_bool(stay) {
                    let (r, c) = cells[i];
                    cells[i] = match rng.random_range(0..5) {
                        0 => (r.saturating_sub(1), c),
                        1 => ((r + 1).min(side - 1), c),
                        2 => (r, c.saturating_sub(1)),
                        3 => (r, (c + 1).min(side - 1)),
                        // A jump: the monitor must not assume unit moves.
                        _ => random_cell(&mut rng),
                    };
                }
                if lifelong && index(cells[i]) == goals[i] && rng.random_bool(0.7) {
                    goals[i] = rng.random_range(0..cells_per_map);
                    new_goal[i] = true;
                }
            }
            let at_goal: Vec<bool> = (0..agents).map(|i| index(cells[i]) == goals[i]).collect();
            let dist = |i: usize, cell: (usize, usize)| fields[goals[i]][index(cell)];
            fast.observe(&cells, &at_goal, &new_goal, dist);
            slow.observe(&cells, &at_goal, &new_goal, dist);
            verdicts_agree(&fast, &slow, agents, &format!("round {round} step {t}"));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn optimised_monitor_matches_the_reference_on_synthetic_episodes(
        seed in any::<u64>(),
        agents in 1usize..=24,
        window in 1u32..=12,
        radius in 0usize..=5,
        side in 2usize..=9,
    ) {
        synthetic_episode(seed, agents, window, radius, side);
    }
}

#[test]
fn optimised_monitor_matches_the_reference_on_large_crowds_radii_and_windows() {
    for (seed, agents, window, radius) in [
        (1, 9, 1, usize::MAX),
        (2, 17, 40, 1 << 40),
        (3, 3, 17, 0),
        (4, 33, 9, 100),
        (5, 64, 4, 3),
        (6, 70, 4, 3),
        (7, 130, 2, 2),
    ] {
        synthetic_episode(seed, agents, window, radius, 6);
    }
}

/// Random-action episodes of the env on rm-2.1: a reference monitor fed
/// from the env's public state agrees with the env's own after every step.
#[test]
fn optimised_monitor_matches_the_reference_in_env_episodes() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let grid = &map.grid;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for (agents, window, lifelong) in [
        (4, 8, false),
        (16, 8, false),
        (16, 8, true),
        (8, 4, true),
        (24, 3, false),
        (2, 1, false),
    ] {
        let cfg = EnvConfig {
            agents,
            stall_window: window,
            lifelong,
            ..EnvConfig::default()
        };
        let mut env = GridEnv::new(map.clone(), cfg).unwrap();
        let mut slow = ReferenceMonitor::new(agents, window);
        let mut rewards = vec![0.0; agents];
        for episode in 0..6 {
            env.reset_to(episode).unwrap();
            let mut goals = env.goals();
            let cells = |env: &GridEnv| -> Vec<(usize, usize)> {
                env.positions().iter().map(|c| (c.row, c.col)).collect()
            };
            {
                let fields: Vec<_> = goals.iter().map(|&g| grid.distances_to(g)).collect();
                slow.reset(&cells(&env), |i, (r, c)| {
                    fields[i][grid.index(buridan_env::Cell::new(r, c))]
                });
            }
            verdicts_agree(env.monitor(), &slow, agents, "reset");
            loop {
                // Mostly waiting in some episodes, so that jams form.
                let stay = [0.2, 0.6, 0.9][episode as usize % 3];
                let actions: Vec<u8> = (0..agents)
                    .map(|_| {
                        if rng.random_bool(stay) {
                            0
                        } else {
                            rng.random_range(1..5)
                        }
                    })
                    .collect();
                let out = env.step(&actions, &mut rewards).unwrap();
                let now = env.goals();
                let new_goal: Vec<bool> = now.iter().zip(&goals).map(|(a, b)| a != b).collect();
                goals = now;
                let at_goal: Vec<bool> = (0..agents).map(|i| env.at_goal(i)).collect();
                let fields: Vec<_> = goals.iter().map(|&g| grid.distances_to(g)).collect();
                slow.observe(&cells(&env), &at_goal, &new_goal, |i, (r, c)| {
                    fields[i][grid.index(buridan_env::Cell::new(r, c))]
                });
                let at = format!("{agents} agents, episode {episode}, t = {}", env.t());
                verdicts_agree(env.monitor(), &slow, agents, &at);
                if out.done() {
                    break;
                }
            }
        }
    }
}
