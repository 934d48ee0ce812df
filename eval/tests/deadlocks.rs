//! The deadlock metrics of `buridan_env::monitor` in the evaluation's
//! per-episode records, `episodes.csv` and `summary.json`.

use std::sync::Arc;

use buridan_env::{GridEnv, Map, Starts, NUM_ACTIONS};
use buridan_eval::output::write_report;
use buridan_eval::{evaluate, Controller, EvalSpec, GiveUp};

/// Greedy under the action mask: a legal move that shortens the agent's
/// shortest path to its goal, else stay — what a policy that never learnt to
/// give way does.
struct MaskedGreedy;

impl Controller for MaskedGreedy {
    fn name(&self) -> String {
        "masked-greedy".into()
    }

    fn begin_episode(&mut self, _: &GridEnv) -> Result<(), GiveUp> {
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        let grid = &env.map().grid;
        for (i, a) in actions.iter_mut().enumerate() {
            let mut mask = [0; NUM_ACTIONS];
            env.write_action_mask(i, &mut mask).unwrap();
            let here = env.goal_distance(i);
            let dist = grid.distances_to(env.goal(i));
            *a = (1..NUM_ACTIONS as u8)
                .filter(|&k| mask[k as usize] == 1)
                .find(|&k| {
                    grid.neighbour(env.position(i), k)
                        .is_some_and(|n| dist[grid.index(n)] < here)
                })
                .unwrap_or(0);
        }
    }
}

#[test]
fn a_masked_greedy_head_on_episode_is_reported_as_a_deadlock() {
    // rm-1.1 fixed: agent 0 (1,1) -> (1,8), agent 1 (1,7) -> (1,0) in one
    // corridor. They walk into each other (agent 1's move at step 3 is
    // blocked: agent 0 moved into (1,4) first), then the mask leaves them
    // only "stay". Agent 1 last got closer at step 2, agent 0 at step 3:
    // both stuck, each waiting on the other, from step 11 to the end.
    let map = Arc::new(Map::load("rm-1.1").unwrap());
    let spec = EvalSpec {
        agents: 2,
        episodes: 1,
        starts: Starts::Fixed,
        ..EvalSpec::default()
    };
    let report = evaluate(&map, &spec, &|| Box::new(MaskedGreedy), &|_| {}).unwrap();
    let r = &report.records[0];
    assert!(!r.success);
    assert_eq!(r.timesteps, 100);
    assert_eq!(r.blocked_moves, 1);
    assert_eq!((r.deadlock_steps, r.livelock_steps), (90, 0));
    assert_eq!((r.deadlock_events, r.deadlocked_agents), (2, 2));
    assert_eq!(r.deadlock_steps_per_agent, [90, 90]);
    assert_eq!((r.jammed_at_end, r.stuck_at_end), (2, 2));
    let s = &report.summary;
    assert_eq!(s.deadlock_steps_mean, 90.0);
    assert_eq!(s.deadlock_episode_rate, 1.0);
    assert_eq!(
        (s.failures_ending_jammed, s.failures_ending_stuck_alone),
        (1, 0)
    );

    let dir = std::env::temp_dir().join(format!("buridan-eval-deadlocks-{}", std::process::id()));
    write_report(&dir, &report, &map.grid).unwrap();
    let csv = std::fs::read_to_string(dir.join("episodes.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<&str> = lines.next().unwrap().split(',').collect();
    let cell = |name: &str| row[header.iter().position(|&h| h == name).unwrap()];
    assert_eq!(cell("deadlock_steps"), "90");
    assert_eq!(cell("deadlock_events"), "2");
    assert_eq!(cell("deadlocked_agents"), "2");
    assert_eq!(cell("deadlock_steps_per_agent"), "90 90");
    assert_eq!(cell("livelock_steps_per_agent"), "0 0");
    assert_eq!(cell("jammed_at_end"), "2");
    assert_eq!(cell("stuck_at_end"), "2");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["deadlock_steps_mean"], 90.0);
    assert_eq!(json["failures_ending_jammed"], 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn solved_episodes_report_no_deadlock() {
    // The same greedy controller on rm-2.1 with random starts solves about
    // half the episodes; the solved ones carry no deadlock or livelock, the
    // failed ones all end in a jam (greedy agents never give way).
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let spec = EvalSpec {
        agents: 4,
        episodes: 30,
        ..EvalSpec::default()
    };
    let report = evaluate(&map, &spec, &|| Box::new(MaskedGreedy), &|_| {}).unwrap();
    let solved: Vec<_> = report.records.iter().filter(|r| r.success).collect();
    assert!(!solved.is_empty());
    for r in &solved {
        assert_eq!((r.deadlock_steps, r.livelock_steps), (0, 0), "{r:?}");
        assert_eq!((r.jammed_at_end, r.stuck_at_end), (0, 0), "{r:?}");
    }
    let failed = report.records.len() - solved.len();
    let s = &report.summary;
    assert!(failed > 0);
    assert_eq!(s.failures_ending_jammed, failed);
    assert!(report
        .records
        .iter()
        .all(|r| r.success || r.deadlock_steps > 0));
    eprintln!(
        "masked greedy on rm-2.1: {} of 30 solved; failures ending jammed {}, stuck alone {}; \
         deadlock steps per episode {:.1}, livelock {:.1}",
        solved.len(),
        s.failures_ending_jammed,
        s.failures_ending_stuck_alone,
        s.deadlock_steps_mean,
        s.livelock_steps_mean
    );
}
