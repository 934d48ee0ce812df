//! Deadlock and livelock detection (definitions in `buridan_env::monitor`),
//! driven through real episodes of `GridEnv`: constructed ones, and
//! episodes recorded from the dissertation author's environment.

mod common;

use buridan_env::monitor::{AgentState, StallMonitor, DEFAULT_WINDOW};
use buridan_env::{EnvConfig, GridEnv};
use common::author::{env_for, episodes};
use common::{env_on, map_from_rows, pos, step};

fn states(env: &GridEnv) -> Vec<AgentState> {
    (0..env.agents()).map(|i| env.monitor().state(i)).collect()
}

use AgentState::{Deadlocked, Free, Livelocked};

#[test]
fn two_agents_facing_in_a_corridor_and_staying_are_deadlocked() {
    // 1-wide corridor; agent 0 at col 2 wants col 5, agent 1 at col 3 wants
    // col 0. Under masking neither may move forward, so both "stay": no move
    // is ever requested, none fails — and yet they are deadlocked.
    let mut env = env_on(&["......"], &[(0, 2), (0, 3)], &[(0, 5), (0, 0)], 100);
    assert_eq!(env.config().stall_window, DEFAULT_WINDOW);
    let mut mask = [0u8; 5];
    env.write_action_mask(0, &mut mask).unwrap();
    assert_eq!(mask, [1, 0, 0, 0, 1], "forward is masked for agent 0");
    for t in 1..=7 {
        let (_, out) = step(&mut env, &[0, 0]);
        assert_eq!(out.blocked_moves, 0);
        assert_eq!(env.monitor().stuck(), 0, "step {t}: window not full yet");
        assert_eq!(env.monitor().deadlocked(), 0, "step {t}");
    }
    step(&mut env, &[0, 0]);
    assert_eq!(env.monitor().stuck(), 2);
    assert_eq!(states(&env), [Deadlocked, Deadlocked]);
    assert_eq!(env.monitor().deadlock_events(), 2);
    assert_eq!(env.monitor().deadlock_steps(), 1);
    for _ in 9..=20 {
        step(&mut env, &[0, 0]);
        assert_eq!(states(&env), [Deadlocked, Deadlocked]);
    }
    let m = env.monitor();
    assert_eq!(m.agent_deadlock_steps(), [13, 13]);
    assert_eq!(m.agent_livelock_steps(), [0, 0]);
    assert_eq!((m.deadlocked_agents(), m.deadlock_events()), (2, 2));
    let s = env.stats();
    assert_eq!(
        (
            s.deadlock_steps,
            s.livelock_steps,
            s.deadlock_events,
            s.blocked_moves
        ),
        (13, 0, 2, 0)
    );
}

#[test]
fn pushing_head_on_is_deadlocked_too() {
    // The same corridor with both pushing forward (no mask): same verdict.
    let mut env = env_on(&["......"], &[(0, 2), (0, 3)], &[(0, 5), (0, 0)], 100);
    for _ in 0..10 {
        let (_, out) = step(&mut env, &[2, 4]);
        assert_eq!(out.blocked_moves, 2);
    }
    assert_eq!(env.monitor().agent_deadlock_steps(), [3, 3]);
    assert_eq!(env.stats().deadlock_events, 2);
}

#[test]
fn facing_agents_going_back_and_forth_are_livelocked_then_deadlocked_when_they_stop() {
    // Agent 0 (col 2 -> goal col 7) and agent 1 (col 4 -> goal col 0) step
    // back and forth out of phase, always 2 apart, each in the other's way.
    let mut env = env_on(&["........"], &[(0, 2), (0, 4)], &[(0, 7), (0, 0)], 100);
    for t in 1..=20u32 {
        let a = if t % 2 == 1 { 2 } else { 4 };
        step(&mut env, &[a, a]);
        let p = pos(&env);
        assert_eq!(p[1].1 - p[0].1, 2, "step {t}");
        // Agent 0's first step right is a new low (progress); from then on
        // neither gets closer: agent 1 is stuck from step 8, agent 0 from 9,
        // and agent 1 waits on agent 0, who is still progressing at step 8.
        let expect = if t < 9 {
            [Free, Free]
        } else {
            [Livelocked, Livelocked]
        };
        assert_eq!(states(&env), expect, "step {t}");
    }
    assert_eq!(env.monitor().agent_livelock_steps(), [12, 12]);
    assert_eq!(env.stats().deadlock_steps, 0);
    // They stop: still jammed, livelocked until a full window without a
    // cell change has passed, then deadlocked.
    for t in 1..=8 {
        step(&mut env, &[0, 0]);
        let expect = if t < 8 { Livelocked } else { Deadlocked };
        assert_eq!(states(&env), [expect, expect], "stop step {t}");
    }
    let s = env.stats();
    assert_eq!(
        (s.livelock_steps, s.deadlock_steps, s.deadlock_events),
        (19, 1, 2)
    );
}

#[test]
fn an_agent_parked_on_its_goal_jams_the_one_behind_but_not_a_passer_by() {
    // Agent 1 sits on its goal (12,3), right in front of agent 0 at (12,1)
    // (goal (12,9)), which waits. Agent 2 walks down column 0 from (0,0) to
    // its goal (12,0). At steps 10 and 11 agent 0 is in agent 2's way (on a
    // cell closer to agent 2's goal, within the radius), but agent 2 is
    // never in agent 0's way: agent 0 does not wait on the passer-by, so its
    // deadlock goes on while agent 2 passes.
    let rows = [".........."; 13];
    let mut env = env_on(
        &rows,
        &[(12, 1), (12, 3), (0, 0)],
        &[(12, 9), (12, 3), (12, 0)],
        100,
    );
    for t in 1..=14u32 {
        step(&mut env, &[0, 0, if t <= 12 { 3 } else { 0 }]);
        let expect = if t < 8 { Free } else { Deadlocked };
        assert_eq!(states(&env), [expect, Free, Free], "step {t}");
        assert_eq!(env.monitor().stuck(), usize::from(t >= 8));
    }
    assert_eq!(pos(&env)[2], (12, 0));
    assert!(env.at_goal(1) && env.at_goal(2));
    let s = env.stats();
    assert_eq!((s.deadlock_steps, s.deadlock_events), (7, 1));
    assert_eq!(env.monitor().agent_deadlock_steps(), [7, 0, 0]);
}

#[test]
fn waiting_behind_an_agent_that_moves_on_is_not_a_deadlock() {
    // A queue: agent 1 (col 1) waits for no reason, agent 0 (col 0) waits
    // behind it; both want col 9. Agent 1 has nobody in its way (stuck, not
    // jammed); agent 0 waits on a stuck agent: jammed.
    let map = map_from_rows(&[".........."], &[(0, 0), (0, 1)], &[(0, 9), (0, 8)]);
    let cfg = EnvConfig {
        stall_window: 3,
        ..common::fixed_cfg(2, 100)
    };
    let mut env = GridEnv::new(map, cfg).unwrap();
    for _ in 0..3 {
        step(&mut env, &[0, 0]);
    }
    assert_eq!(env.monitor().stuck(), 2);
    assert_eq!(states(&env), [Deadlocked, Free]);
    // Agent 1 moves on: agent 0 is still stuck, but it now waits on an
    // agent that makes progress — a queue, not a deadlock.
    step(&mut env, &[0, 2]);
    assert_eq!(env.monitor().stuck(), 1);
    assert_eq!(states(&env), [Free, Free]);
    assert_eq!(env.stats().deadlock_steps, 1);
}

#[test]
fn the_window_is_configurable() {
    let map = map_from_rows(&["......"], &[(0, 2), (0, 3)], &[(0, 5), (0, 0)]);
    let cfg = EnvConfig {
        stall_window: 3,
        ..common::fixed_cfg(2, 100)
    };
    let mut env = GridEnv::new(map, cfg).unwrap();
    assert_eq!(env.monitor().window(), 3);
    step(&mut env, &[0, 0]);
    step(&mut env, &[0, 0]);
    assert_eq!(env.monitor().deadlocked(), 0);
    step(&mut env, &[0, 0]);
    assert_eq!(env.monitor().deadlocked(), 2);
}

#[test]
fn stuck_alone_is_neither_deadlock_nor_livelock() {
    // Agent 0 pushes into a wall with nobody in its way; agent 1 is two
    // cells away, but behind it (not closer to agent 0's goal) and at home.
    let mut env = env_on(
        &["..@.....", "........"],
        &[(0, 1), (1, 0)],
        &[(0, 4), (1, 0)],
        100,
    );
    for _ in 0..20 {
        step(&mut env, &[2, 0]);
    }
    assert_eq!(env.monitor().stuck(), 1);
    let s = env.stats();
    assert_eq!(
        (s.deadlock_steps, s.livelock_steps, s.deadlock_events),
        (0, 0, 0)
    );
    assert_eq!(s.blocked_moves, 20);
}

#[test]
fn coming_back_after_giving_way_is_progress() {
    // Agent 1 (goal col 0) steps into the niche (0,3) and waits there while
    // agent 0 walks past along row 1, then comes back down and home: a
    // solved episode with a long wait and no deadlock.
    let mut env = env_on(
        &["@@@.@@@@@@@@", "............"],
        &[(1, 0), (1, 4)],
        &[(1, 11), (1, 0)],
        100,
    );
    let mut actions = vec![[2, 4], [2, 1]];
    actions.extend([[2, 0]; 9]); // agent 0 to its goal, agent 1 in the niche
    actions.extend([[0, 3], [0, 4], [0, 4], [0, 4]]);
    let mut stuck_seen = false;
    for (t, a) in actions.iter().enumerate() {
        let (_, out) = step(&mut env, a);
        stuck_seen |= env.monitor().is_stuck(1);
        assert_eq!(out.terminated, t + 1 == actions.len(), "step {}", t + 1);
    }
    assert!(stuck_seen, "agent 1 waited a full window");
    let s = env.stats();
    assert!(s.success);
    assert_eq!((s.deadlock_steps, s.livelock_steps), (0, 0));
    // On the way back agent 1 was stuck (it had been closer 9 steps before)
    // only until it got closer than anywhere in the last window.
    assert!(!env.monitor().is_stuck(1));
}

#[test]
fn sliding_window_progress_ignores_oscillation_but_sees_returns() {
    // Agent 0 alone in a corridor, goal at col 20, distances by column.
    let dist = |_: usize, (_, col): (usize, usize)| 20 - col as u16;
    let mut m = StallMonitor::new(1, 4);
    m.reset(&[(0, 10)], dist);
    // Back and forth between cols 10 and 11: the first step is a new low,
    // the rest never are; stuck after 4 steps without one.
    for (t, col) in [11, 10, 11, 10, 11, 10].into_iter().enumerate() {
        m.observe(&[(0, col)], &[false], &[false], dist);
        assert_eq!(m.is_stuck(0), t + 1 >= 5, "step {}", t + 1);
    }
    // Retreat to col 5, wait there, then walk back: from col 6 on every
    // step beats the whole last window (which no longer holds col 11).
    for col in [9, 8, 7, 6, 5, 5, 5, 5, 5] {
        m.observe(&[(0, col)], &[false], &[false], dist);
    }
    assert!(m.is_stuck(0));
    m.observe(&[(0, 6)], &[false], &[false], dist);
    assert!(!m.is_stuck(0));
}

#[test]
fn monitor_restarts_with_each_episode() {
    let mut env = env_on(&["......"], &[(0, 2), (0, 3)], &[(0, 5), (0, 0)], 100);
    for _ in 0..10 {
        step(&mut env, &[0, 0]);
    }
    assert_eq!(env.stats().deadlock_events, 2);
    env.reset_to(1).unwrap();
    assert_eq!(env.monitor().deadlocked(), 0);
    assert_eq!(env.monitor().agent_deadlock_steps(), [0, 0]);
    assert_eq!(env.stats().deadlock_events, 0);
    assert_eq!(env.stats().deadlock_steps, 0);
    for _ in 0..7 {
        step(&mut env, &[0, 0]);
    }
    assert_eq!(env.monitor().deadlocked(), 0, "a fresh window");
}

// ------------------------------------------------ recorded (author's env)

/// Replays recorded episode `k` and returns the env and, per step, the
/// monitor's verdict for every agent.
fn replay(k: usize) -> (GridEnv, Vec<Vec<AgentState>>) {
    let ep = &episodes()[k];
    let mut env = env_for(ep);
    let mut rewards = vec![0.0; ep.agents];
    let mut verdicts = Vec::new();
    for s in &ep.steps {
        env.step(&s.actions, &mut rewards).unwrap();
        verdicts.push(states(&env));
    }
    (env, verdicts)
}

#[test]
fn a_recorded_buridan_corridor_episode_is_flagged() {
    // Episode 41: rm-1.1 (a corridor with one side aisle), goal-directed
    // actions under the mask. Agent 0 (goal (1,7)) gets there first and
    // parks; agent 1 (goal (1,8), behind it) cannot pass. From step 26 on
    // they stand swapped — agent 0 on (1,8), agent 1 on (1,7) — and stay so
    // to the end, agent 1 bouncing between (1,6) and (1,7) for a while.
    let ep = &episodes()[41];
    assert_eq!((ep.map.as_str(), ep.agents), ("rm-1.1", 2));
    let (env, verdicts) = replay(41);
    let s = env.stats();
    assert!(!s.success && s.length == 100);
    // Nothing before agent 1 has been stuck behind the parked agent 0 for
    // a full window (it last got closer at step 11).
    let first = verdicts.iter().position(|v| v.iter().any(|&x| x != Free));
    assert_eq!(first.map(|t| t + 1), Some(19));
    // From the swap on, some agent is jammed at almost every step, and the
    // episode ends in a deadlock of both.
    let jammed_after_swap = verdicts[33..]
        .iter()
        .filter(|v| v.iter().any(|&x| x != Free))
        .count();
    assert!(jammed_after_swap >= 60, "{jammed_after_swap} of 67 steps");
    assert_eq!(verdicts.last().unwrap(), &[Deadlocked, Deadlocked]);
    assert!(s.deadlock_steps >= 40, "{s:?}");
    assert!(s.livelock_steps > 0, "agent 1's bouncing is seen: {s:?}");
    assert_eq!(env.monitor().deadlocked_agents(), 2);
}

#[test]
fn a_recorded_rm_2_2_episode_ending_in_a_dead_end_jam_is_flagged() {
    // Episode 19: rm-2.2, goal-directed. Agent 3 parks on its goal (14,19)
    // and agent 1 (goal (10,7)) is left in the dead end (14,20) behind it.
    let (env, verdicts) = replay(19);
    assert!(!env.stats().success);
    let last = verdicts.last().unwrap();
    assert_eq!(pos(&env)[1], (14, 20));
    assert_eq!(pos(&env)[3], (14, 19));
    assert!(env.at_goal(3));
    assert_eq!(last[1], Deadlocked);
    assert_eq!(last[3], Free, "a parked agent is never jammed itself");
    // Agent 1 entered the dead end at step 72, where agent 3 first reached
    // its goal (progress: agent 1 waits on it, but is not jammed yet). From
    // step 74 on agent 1 is jammed: livelocked while its last move is
    // within the window, then deadlocked to the end.
    assert_eq!(verdicts[72][1], Free);
    assert!(verdicts[73..79].iter().all(|v| v[1] == Livelocked));
    assert!(verdicts[79..].iter().all(|v| v[1] == Deadlocked));
}

#[test]
fn recorded_solved_episodes_are_not_flagged() {
    // The recorded episodes that end in success quickly (goal-directed
    // actions, no long wait): nobody is ever deadlocked or livelocked.
    let mut solved = 0;
    for (k, ep) in episodes().iter().enumerate() {
        if !ep.steps.last().unwrap().terminated || ep.steps.len() > 50 {
            continue;
        }
        let (env, verdicts) = replay(k);
        assert!(env.stats().success);
        assert!(
            verdicts.iter().flatten().all(|&v| v == Free),
            "episode {k} ({}) flagged",
            ep.map
        );
        let s = env.stats();
        assert_eq!(
            (s.deadlock_steps, s.livelock_steps, s.deadlock_events),
            (0, 0, 0)
        );
        solved += 1;
    }
    assert_eq!(solved, 4, "episodes 3, 5, 27, 47");
}

#[test]
fn verdicts_are_consistent_over_random_episodes() {
    // Invariants over many random-action steps on rm-2.1 (8 agents, k = 4),
    // in both modes: only stuck agents are jammed, never one on its goal; a
    // deadlocked agent has kept its cell for the whole window; the counters
    // add up.
    use rand::{Rng, SeedableRng};
    let map = std::sync::Arc::new(buridan_env::Map::load("rm-2.1").unwrap());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let mut flagged = 0;
    for lifelong in [false, true] {
        let cfg = EnvConfig {
            agents: 8,
            stall_window: 4,
            lifelong,
            ..EnvConfig::default()
        };
        let mut env = GridEnv::new(map.clone(), cfg).unwrap();
        for episode in 0..20 {
            env.reset_to(episode).unwrap();
            let mut history = vec![env.positions()];
            let (mut dl_steps, mut agent_dl) = (0, vec![0u32; 8]);
            loop {
                let actions: Vec<u8> = (0..8).map(|_| rng.random_range(0..5)).collect();
                let (_, out) = step(&mut env, &actions);
                history.push(env.positions());
                let m = env.monitor();
                let mut stuck = 0;
                for i in 0..8 {
                    stuck += usize::from(m.is_stuck(i));
                    if m.is_stuck(i) {
                        assert!(!env.at_goal(i));
                    }
                    match m.state(i) {
                        Free => {}
                        Livelocked => assert!(m.is_stuck(i)),
                        Deadlocked => {
                            assert!(m.is_stuck(i));
                            let w = history.len() - 5;
                            assert!(history[w..].iter().all(|p| p[i] == history[w][i]));
                            agent_dl[i] += 1;
                        }
                    }
                }
                assert_eq!(m.stuck(), stuck);
                assert!(m.deadlocked() + m.livelocked() <= stuck);
                dl_steps += u32::from(m.deadlocked() > 0);
                flagged += m.deadlocked() + m.livelocked();
                if out.done() {
                    break;
                }
            }
            assert_eq!(env.stats().deadlock_steps, dl_steps);
            assert_eq!(env.monitor().agent_deadlock_steps(), agent_dl);
        }
    }
    assert!(
        flagged > 0,
        "random walks of 8 agents never jam: invariants untested"
    );
}
