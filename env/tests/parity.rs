//! Parity with the dissertation author's environment (the public Python env,
//! tag v1.0.0, that produced the dissertation's numbers).
//!
//! `tests/data/author-env-v1.0.0-traces.json.gz` is
//! `../shared/parity/author-env-v1.0.0-traces.json`, gzipped unchanged
//! (sha256 of the uncompressed file:
//! `babfc8a9e238b53c8281994a897f0f6551f46b5f311e210ace71c90fad07cccc`): 48
//! episodes recorded in that env — rm-2.1, rm-2.1b, rm-2.2, rm-3.1 with 4
//! agents, rm-2.1 with 12, rm-1.1 with 2; 8 each; sensor range 2, `T_max`
//! 100; starts and goals from the author's own generator; random or
//! mostly goal-directed actions. Each is replayed through [`GridEnv`] with the
//! same map, agents, starts, goals and actions, and compared at every step:
//!
//! - positions, rewards, `terminated` and `truncated`: exactly, always;
//! - action masks and agent 0's 5×5 window codes: exactly at reset and for
//!   the highest-index agent (the author's README);
//! - the documented difference itself: the author's env observes agent `i`
//!   right after agent `i` moved, before agents `i+1..n` move, so its masks
//!   (and codes) of lower-index agents see agents `0..=i` after the step and
//!   agents `i+1..n` before it. That mid-step view is rebuilt here from our
//!   positions and compared exactly too, so every recorded mask and window is
//!   accounted for — not only those the README promises.
//!
//! Mismatches are collected over all episodes (the first mismatch in
//! positions ends that episode's replay: later steps would only repeat it)
//! and reported together.

mod common;

use std::collections::BTreeMap;

use buridan_env::{Cell, GridEnv, NUM_ACTIONS};

use common::author::{cells, env_for, episodes, Episode, SIDE, T_MAX};

fn mask(env: &GridEnv, agent: usize) -> [u8; NUM_ACTIONS] {
    let mut m = [0; NUM_ACTIONS];
    env.write_action_mask(agent, &mut m).unwrap();
    m
}

fn codes(env: &GridEnv, agent: usize) -> [[u8; SIDE]; SIDE] {
    let mut flat = [0; SIDE * SIDE];
    env.write_local_codes(agent, &mut flat).unwrap();
    let mut out = [[0; SIDE]; SIDE];
    for (row, chunk) in out.iter_mut().zip(flat.chunks_exact(SIDE)) {
        row.copy_from_slice(chunk);
    }
    out
}

fn name(k: usize, ep: &Episode) -> String {
    format!("episode {k} ({} × {})", ep.map, ep.agents)
}

/// Fails with every collected mismatch (at most 40 shown).
fn assert_none(what: &str, mismatches: &[String]) {
    assert!(
        mismatches.is_empty(),
        "{} {what} mismatches, first ones:\n{}",
        mismatches.len(),
        mismatches
            .iter()
            .take(40)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn the_trace_file_holds_the_48_documented_episodes() {
    let eps = episodes();
    assert_eq!(eps.len(), 48);
    let mut per_setup = BTreeMap::new();
    for ep in eps {
        *per_setup.entry((ep.map.as_str(), ep.agents)).or_insert(0) += 1;
    }
    let expected: BTreeMap<_, _> = [
        (("rm-1.1", 2), 8),
        (("rm-2.1", 4), 8),
        (("rm-2.1", 12), 8),
        (("rm-2.1b", 4), 8),
        (("rm-2.2", 4), 8),
        (("rm-3.1", 4), 8),
    ]
    .into_iter()
    .collect();
    assert_eq!(per_setup, expected);
    let mut successes = 0;
    for (k, ep) in eps.iter().enumerate() {
        let n = ep.agents;
        assert_eq!((ep.starts.len(), ep.goals.len()), (n, n), "{}", name(k, ep));
        assert!(!ep.steps.is_empty() && ep.steps.len() <= T_MAX as usize);
        for (t, s) in ep.steps.iter().enumerate() {
            let last = t + 1 == ep.steps.len();
            assert_eq!(s.masks_before.len(), n);
            assert_eq!(s.actions.len(), n);
            assert_eq!(s.positions.len(), n);
            assert_eq!(s.rewards.len(), n);
            assert!(s.actions.iter().all(|&a| (a as usize) < NUM_ACTIONS));
            // Episodes are recorded up to and including their last step.
            assert_eq!(s.terminated || s.truncated, last, "{} t={t}", name(k, ep));
        }
        successes += usize::from(ep.steps.last().unwrap().terminated);
    }
    // The goal-directed episodes make sure success (and its +1) is covered.
    assert!(successes >= 3, "{successes} successful episodes");
}

#[test]
fn positions_rewards_and_done_flags_match_the_author_env_at_every_step() {
    let mut mismatches = Vec::new();
    let mut steps = 0;
    for (k, ep) in episodes().iter().enumerate() {
        let mut env = env_for(ep);
        assert_eq!(env.positions(), cells(&ep.starts));
        let mut rewards = vec![0.0f32; ep.agents];
        let mut total = 0.0f32;
        for (t, s) in ep.steps.iter().enumerate() {
            let at = format!("{} step {}", name(k, ep), t + 1);
            let out = env.step(&s.actions, &mut rewards).unwrap();
            steps += 1;
            total += s.rewards.iter().sum::<f32>();
            let want = cells(&s.positions);
            if env.positions() != want {
                mismatches.push(format!(
                    "{at}: actions {:?}: positions {:?}, author {:?}",
                    s.actions,
                    env.positions(),
                    want
                ));
                break;
            }
            if rewards != s.rewards {
                mismatches.push(format!("{at}: rewards {rewards:?}, author {:?}", s.rewards));
            }
            if (out.terminated, out.truncated) != (s.terminated, s.truncated) {
                mismatches.push(format!(
                    "{at}: (terminated, truncated) = {:?}, author {:?}",
                    (out.terminated, out.truncated),
                    (s.terminated, s.truncated)
                ));
            }
        }
        if env.is_over() {
            let stats = env.stats();
            assert_eq!(stats.length as usize, ep.steps.len());
            assert_eq!(stats.success, ep.steps.last().unwrap().terminated);
            assert_eq!(stats.reward, total, "{}", name(k, ep));
        }
    }
    assert_none("dynamics", &mismatches);
    assert!(steps > 4000, "{steps} steps replayed");
}

#[test]
fn masks_and_window_codes_match_at_reset_and_for_the_highest_index_agent() {
    let mut mismatches = Vec::new();
    let mut compared = 0;
    for (k, ep) in episodes().iter().enumerate() {
        let mut env = env_for(ep);
        let last = ep.agents - 1;
        let mut rewards = vec![0.0f32; ep.agents];
        for (t, s) in ep.steps.iter().enumerate() {
            let at = format!("{} before step {}", name(k, ep), t + 1);
            let agents = if t == 0 {
                0..ep.agents
            } else {
                last..ep.agents
            };
            for i in agents {
                compared += 1;
                if mask(&env, i) != s.masks_before[i] {
                    mismatches.push(format!(
                        "{at}: agent {i} mask {:?}, author {:?}",
                        mask(&env, i),
                        s.masks_before[i]
                    ));
                }
            }
            if t == 0 && codes(&env, 0) != s.codes0_before {
                mismatches.push(format!(
                    "{at}: agent 0 window {:?}, author {:?}",
                    codes(&env, 0),
                    s.codes0_before
                ));
            }
            env.step(&s.actions, &mut rewards).unwrap();
            if env.positions() != cells(&s.positions) {
                break; // reported by the dynamics test
            }
        }
    }
    assert_none("mask/window", &mismatches);
    assert!(compared > 4000);
}

/// The author env's view of agent `i` during a step: agents `0..=i` where
/// they are after the step, agents `i+1..` where they were before it.
fn mid_step_view(scratch: &mut GridEnv, before: &[Cell], after: &[Cell], goals: &[Cell], i: usize) {
    let cells: Vec<Cell> = after[..=i]
        .iter()
        .chain(&before[i + 1..])
        .copied()
        .collect();
    // Sequential moves never put a moved agent onto a not-yet-moved one's
    // cell, so these cells are distinct and `reset_with` accepts them.
    scratch.reset_with(0, &cells, goals).unwrap();
}

#[test]
fn every_recorded_mask_and_window_is_our_state_seen_mid_step() {
    let mut mismatches = Vec::new();
    let (mut stale_masks, mut stale_windows, mut compared) = (0, 0, 0);
    for (k, ep) in episodes().iter().enumerate() {
        let mut env = env_for(ep);
        let mut scratch = env_for(ep);
        let goals = cells(&ep.goals);
        let n = ep.agents;
        let mut before = cells(&ep.starts);
        let mut after = before.clone();
        let mut rewards = vec![0.0f32; n];
        for (t, s) in ep.steps.iter().enumerate() {
            let at = format!("{} before step {}", name(k, ep), t + 1);
            for i in 0..n {
                mid_step_view(&mut scratch, &before, &after, &goals, i);
                let (ours, theirs) = (mask(&scratch, i), s.masks_before[i]);
                compared += 1;
                if ours != theirs {
                    mismatches.push(format!(
                        "{at}: agent {i} mid-step mask {ours:?}, author {theirs:?}"
                    ));
                }
                stale_masks += usize::from(mask(&env, i) != theirs);
                if i == 0 {
                    let ours = codes(&scratch, 0);
                    if ours != s.codes0_before {
                        mismatches.push(format!(
                            "{at}: agent 0 mid-step window {ours:?}, author {:?}",
                            s.codes0_before
                        ));
                    }
                    stale_windows += usize::from(codes(&env, 0) != s.codes0_before);
                }
            }
            env.step(&s.actions, &mut rewards).unwrap();
            before = after;
            after = env.positions();
            if after != cells(&s.positions) {
                break; // reported by the dynamics test
            }
        }
    }
    assert_none("mid-step mask/window", &mismatches);
    assert!(compared > 10_000, "{compared} masks compared");
    // The documented difference is real in these traces: without the
    // mid-step view, some lower-index masks and windows would differ.
    assert!(
        stale_masks > 0,
        "no stale mask: the mid-step model is untested"
    );
    assert!(
        stale_windows > 0,
        "no stale window: the mid-step model is untested"
    );
    eprintln!("{compared} masks compared; {stale_masks} masks and {stale_windows} agent-0 windows differ from the end-of-step view");
}
