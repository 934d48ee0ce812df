//! The planner rescue: a jammed policy is freed by LaCAM's plan from the
//! jammed state, an unjammed one never calls the planner.

mod common;

use buridan_mapf::Problem;
use std::sync::Arc;

use buridan_eval::rescue::RescueController;
use buridan_eval::{run_episode, Controller};
use buridan_mapf::{planner_by_name, Limits, Planner};

/// A planner by name, shareable between a rescue net and a reference.
fn planner(name: &str) -> Arc<dyn Planner> {
    planner_by_name(name).unwrap().into()
}

#[test]
fn lacam_frees_the_jammed_greedy_ppo_policy_and_stays_out_of_solved_episodes() {
    // The committed PPO checkpoint (rm-2.1, 4 agents): its greedy actions
    // end these seed-42 episodes in a jam (tests/shield.rs) ...
    let mut env = common::committed_ppo_env();
    let policy = common::committed_greedy_policy;
    let lacam = planner("lacam");
    let mut rescued = RescueController::new(policy(), lacam, Limits::default());
    let mut raw = policy();
    for episode in common::JAMMED_EPISODES {
        let r = run_episode(&mut env, &mut rescued, episode).unwrap();
        assert!(r.success, "episode {episode}: {r:?}");
        assert!(r.rescues.unwrap() >= 1, "episode {episode}: {r:?}");
    }
    // ... and solves these alone: the rescue never steps in, and the
    // episode is played exactly as without it.
    let mut untouched = 0;
    for episode in 0..15 {
        let plain = run_episode(&mut env, raw.as_mut(), episode).unwrap();
        let r = run_episode(&mut env, &mut rescued, episode).unwrap();
        if plain.success && plain.deadlock_steps == 0 && r.rescues == Some(0) {
            assert_eq!((r.success, r.timesteps), (true, plain.timesteps));
            untouched += 1;
        }
        assert!(r.success || !plain.success, "episode {episode}: {r:?}");
    }
    assert!(untouched >= 5, "{untouched}");
}

#[test]
fn foresight_plans_jammed_episodes_from_the_start_and_leaves_solved_ones_alone() {
    // The same committed greedy PPO policy and its jammed episodes. With
    // foresight a twin of the policy plays each episode ahead; where it
    // gets stuck, OD-A* plans from the start: the episode takes the optimal
    // makespan (no steps lost walking into the jam and waiting for the
    // stall detector), and never more steps than the late rescue needs.
    let mut env = common::committed_ppo_env();
    let policy = common::committed_greedy_policy;
    let od = planner("od-astar");
    let mut late = RescueController::new(policy(), od.clone(), Limits::default());
    let mut ahead =
        RescueController::new(policy(), od.clone(), Limits::default()).with_foresight(policy());
    assert_eq!(ahead.name(), "ctde-policy+lookahead-od-astar");
    let mut raw = policy();
    for episode in common::JAMMED_EPISODES {
        let r = run_episode(&mut env, &mut ahead, episode).unwrap();
        let l = run_episode(&mut env, &mut late, episode).unwrap();
        env.reset_to(episode).unwrap();
        let optimal = od
            .solve(
                Problem::new(&env.map().grid, &env.positions(), &env.goals()),
                &Limits::default(),
            )
            .unwrap()
            .plan
            .makespan() as u32;
        assert!(
            r.success && r.rescues == Some(1),
            "episode {episode}: {r:?}"
        );
        assert_eq!(r.timesteps, optimal, "episode {episode}: {r:?}");
        assert!(r.timesteps <= l.timesteps, "episode {episode}: {r:?} {l:?}");
    }
    // Episodes the policy solves alone are played exactly as without the net.
    let mut untouched = 0;
    for episode in 0..15 {
        let plain = run_episode(&mut env, raw.as_mut(), episode).unwrap();
        let r = run_episode(&mut env, &mut ahead, episode).unwrap();
        if r.rescues == Some(0) {
            assert_eq!((r.success, r.timesteps), (plain.success, plain.timesteps));
            assert!(plain.success, "episode {episode}: {r:?}");
            untouched += 1;
        }
        assert!(r.success, "episode {episode}: {r:?}");
    }
    assert!(untouched >= 5, "{untouched}");
}

#[test]
fn backstop_plans_only_the_episodes_the_policy_would_fail() {
    // The same committed greedy PPO policy. As a backstop, the twin's run
    // ahead decides only whether the episode fails: the jammed episodes are
    // planned from the start (optimal makespan); every episode the policy
    // finishes alone, stalls on the way or not, is played exactly as
    // without the net, and the planner is never called.
    let mut env = common::committed_ppo_env();
    let policy = common::committed_greedy_policy;
    let od = planner("od-astar");
    let mut backstop =
        RescueController::new(policy(), od.clone(), Limits::default()).with_backstop(policy());
    assert_eq!(backstop.name(), "ctde-policy+backstop-od-astar");
    let mut lookahead =
        RescueController::new(policy(), od.clone(), Limits::default()).with_foresight(policy());
    let mut raw = policy();
    for episode in common::JAMMED_EPISODES {
        let plain = run_episode(&mut env, raw.as_mut(), episode).unwrap();
        let r = run_episode(&mut env, &mut backstop, episode).unwrap();
        assert!(!plain.success, "episode {episode}: {plain:?}");
        assert!(
            r.success && r.rescues == Some(1),
            "episode {episode}: {r:?}"
        );
    }
    let (mut solved_alone, mut stalled_but_solved) = (0, 0);
    for episode in 0..30 {
        let plain = run_episode(&mut env, raw.as_mut(), episode).unwrap();
        let r = run_episode(&mut env, &mut backstop, episode).unwrap();
        let ahead = run_episode(&mut env, &mut lookahead, episode).unwrap();
        assert!(r.success, "episode {episode}: {r:?}");
        if plain.success {
            assert_eq!(
                (r.timesteps, r.rescues),
                (plain.timesteps, Some(0)),
                "episode {episode}: {r:?}"
            );
            solved_alone += 1;
            // Where the lookahead plans because an agent stalls on the way,
            // the backstop leaves the finished episode to the policy.
            if ahead.rescues == Some(1) {
                stalled_but_solved += 1;
            }
        } else {
            assert_eq!(r.rescues, Some(1), "episode {episode}: {r:?}");
        }
    }
    assert!(solved_alone >= 10, "{solved_alone}");
    assert!(stalled_but_solved >= 1, "{stalled_but_solved}");
}

#[test]
fn pace_hands_over_the_episodes_the_policy_would_fail_or_finish_slowly() {
    // The same committed greedy PPO policy with a pace: OD-A* (makespan-
    // optimal) plans every episode from the start. Episodes the policy
    // fails, or finishes more than 10 % after the plan, are driven by the
    // plan (its optimal makespan); the others are played exactly as without
    // the net, and the plan is dropped.
    let mut env = common::committed_ppo_env();
    let policy = common::committed_greedy_policy;
    let od = planner("od-astar");
    let mut pace =
        RescueController::new(policy(), od.clone(), Limits::default()).with_pace(policy());
    assert_eq!(pace.name(), "ctde-policy+pace-od-astar");
    let mut optimal = buridan_eval::planner::PlannerController::new(od, Limits::default());
    let mut raw = policy();
    let (mut kept, mut handed_over_slow) = (0, 0);
    for episode in 0..30 {
        let plain = run_episode(&mut env, raw.as_mut(), episode).unwrap();
        let best = run_episode(&mut env, &mut optimal, episode).unwrap();
        let r = run_episode(&mut env, &mut pace, episode).unwrap();
        assert!(best.success, "episode {episode}: {best:?}");
        assert!(r.success, "episode {episode}: {r:?}");
        let keeps_pace =
            plain.success && f64::from(plain.timesteps) <= 1.1 * f64::from(best.timesteps);
        if keeps_pace {
            assert_eq!(
                (r.timesteps, r.rescues),
                (plain.timesteps, Some(0)),
                "episode {episode}: {r:?}"
            );
            kept += 1;
        } else {
            assert_eq!(
                (r.timesteps, r.rescues),
                (best.timesteps, Some(1)),
                "episode {episode}: {r:?}"
            );
            if plain.success {
                handed_over_slow += 1;
            }
        }
    }
    assert!(kept >= 10, "{kept}");
    assert!(handed_over_slow >= 1, "{handed_over_slow}");
}
