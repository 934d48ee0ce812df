//! Deadlock and livelock detection (definitions in `buridan_env::monitor`),
//! driven through real episodes of `GridEnv`.

mod common;

use buridan_env::{EnvConfig, GridEnv};
use common::{env_on, map_from_rows, pos, step};

#[test]
fn two_agents_pushing_head_on_in_a_corridor_deadlock() {
    // 1-wide corridor; agent 0 at col 2 wants col 5, agent 1 at col 3 wants col 0.
    let mut env = env_on(&["......"], &[(0, 2), (0, 3)], &[(0, 5), (0, 0)], 100);
    assert_eq!(env.config().stall_window, 8);
    for t in 1..=7 {
        let (_, out) = step(&mut env, &[2, 4]);
        assert_eq!(out.blocked_moves, 2);
        assert_eq!(
            env.monitor().deadlocked(),
            0,
            "step {t}: window not full yet"
        );
    }
    step(&mut env, &[2, 4]);
    assert_eq!(pos(&env), [(0, 2), (0, 3)]);
    assert_eq!(env.monitor().deadlocked(), 2);
    assert_eq!(env.monitor().livelocked(), 0);
    assert_eq!(env.monitor().deadlock_events(), 2);
    assert_eq!(env.monitor().deadlock_steps(), 1);
    // Still pushing: still deadlocked, no new events, one more deadlock step.
    step(&mut env, &[2, 4]);
    assert_eq!(env.monitor().deadlocked(), 2);
    assert_eq!(env.monitor().deadlock_events(), 2);
    assert_eq!(env.monitor().deadlock_steps(), 2);
    // Agent 1 pauses: its window restarts; agent 0 keeps pushing and stays deadlocked.
    step(&mut env, &[2, 0]);
    assert_eq!(env.monitor().deadlocked(), 1);
    assert_eq!(env.monitor().deadlock_steps(), 3);
    // Agent 1 pushes again: deadlocked anew after a full window = a third event.
    for _ in 0..7 {
        step(&mut env, &[2, 4]);
        assert_eq!(env.monitor().deadlocked(), 1);
    }
    step(&mut env, &[2, 4]);
    assert_eq!(env.monitor().deadlocked(), 2);
    assert_eq!(env.monitor().deadlock_events(), 3);
    let s = env.stats();
    assert_eq!(
        (s.deadlock_events, s.deadlock_steps, s.livelock_steps),
        (3, 11, 0)
    );
    assert_eq!(s.blocked_moves, 2 * 17 + 1);
}

#[test]
fn the_stall_window_is_configurable() {
    let map = map_from_rows(&["......"], &[(0, 2), (0, 3)], &[(0, 5), (0, 0)]);
    let cfg = EnvConfig {
        stall_window: 3,
        ..common::fixed_cfg(2, 100)
    };
    let mut env = GridEnv::new(map, cfg).unwrap();
    step(&mut env, &[2, 4]);
    step(&mut env, &[2, 4]);
    assert_eq!(env.monitor().deadlocked(), 0);
    step(&mut env, &[2, 4]);
    assert_eq!(env.monitor().deadlocked(), 2);
}

#[test]
fn an_agent_bouncing_back_and_forth_beside_another_is_livelocked() {
    // Agent 0 at col 1 (goal col 5) bounces left/right between cols 0 and 1;
    // agent 1 waits at col 2 (it never requests a move, so it is not stalled).
    let mut env = env_on(&["......"], &[(0, 1), (0, 2)], &[(0, 5), (0, 0)], 100);
    for t in 1..=8u32 {
        let a = if t % 2 == 1 { 4 } else { 2 };
        let (_, out) = step(&mut env, &[a, 0]);
        assert_eq!(out.blocked_moves, 0);
        let expect = if t < 8 { 0 } else { 1 };
        assert_eq!(env.monitor().livelocked(), expect, "step {t}");
        assert_eq!(env.monitor().deadlocked(), 0);
    }
    assert_eq!(pos(&env), [(0, 1), (0, 2)]);
    step(&mut env, &[4, 0]);
    assert_eq!(env.monitor().livelocked(), 1);
    let s = env.stats();
    assert_eq!(
        (s.livelock_steps, s.deadlock_steps, s.deadlock_events),
        (2, 0, 0)
    );
}

#[test]
fn pushing_into_a_wall_alone_is_neither_deadlock_nor_livelock() {
    // Nobody within Manhattan distance 2: a stalled agent, but not a deadlock.
    let mut env = env_on(
        &["..@.....", "........"],
        &[(0, 1), (1, 7)],
        &[(0, 4), (0, 7)],
        100,
    );
    for _ in 0..20 {
        step(&mut env, &[2, 0]);
    }
    let s = env.stats();
    assert_eq!(
        (s.deadlock_steps, s.livelock_steps, s.deadlock_events),
        (0, 0, 0)
    );
    assert_eq!(s.blocked_moves, 20);
}

#[test]
fn progress_or_arrival_resets_the_window() {
    // Agent 0 walks to its goal and keeps "pushing" against the edge there: at
    // its goal it is never stalled; agent 1 waits next to it.
    let mut env = env_on(&["....."], &[(0, 2), (0, 0)], &[(0, 4), (0, 1)], 100);
    for _ in 0..20 {
        let (_, out) = step(&mut env, &[2, 0]);
        assert!(!out.done());
    }
    assert_eq!(pos(&env), [(0, 4), (0, 0)]);
    let s = env.stats();
    assert_eq!((s.deadlock_steps, s.livelock_steps), (0, 0));
}

#[test]
fn monitor_restarts_with_each_episode() {
    let mut env = env_on(&["......"], &[(0, 2), (0, 3)], &[(0, 5), (0, 0)], 100);
    for _ in 0..10 {
        step(&mut env, &[2, 4]);
    }
    assert_eq!(env.stats().deadlock_events, 2);
    env.reset_to(1).unwrap();
    assert_eq!(env.monitor().deadlocked(), 0);
    assert_eq!(env.stats().deadlock_events, 0);
    assert_eq!(env.stats().deadlock_steps, 0);
}
