//! Policies through the collision shield: no move the shield sends is ever
//! blocked in the env, whatever the policy (CTDE rows or CTE heads, greedy
//! or sampled, either ranking), greedy shielded evaluation is
//! deterministic, and it frees a trained policy from its greedy jams.

mod common;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use buridan_env::{central_obs_dim, local_obs_dim, EnvConfig, Map};
use buridan_eval::shield::{Ranking, ShieldController};
use buridan_eval::{evaluate, run_episode, Controller, EpisodeRecord, EvalSpec};
use buridan_policy::{ActMode, Mode, ModelSpec, Policy};

/// An untrained policy saved as a checkpoint: its preferences are
/// arbitrary, which is what the shield must cope with.
fn untrained(mode: Mode, agents: usize, obs_dim: usize, tag: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("buridan-eval-shield-{tag}-{}", std::process::id()));
    Policy::new(ModelSpec::new(mode, agents, obs_dim), 3)
        .unwrap()
        .save(&dir)
        .unwrap();
    dir
}

fn run(
    map: &Arc<Map>,
    dir: &Path,
    spec: &EvalSpec,
    act_mode: ActMode,
    ranking: Ranking,
) -> Vec<EpisodeRecord> {
    let make = || -> Box<dyn Controller> {
        Box::new(ShieldController::load(dir, spec.agents, act_mode, spec.seed, ranking).unwrap())
    };
    evaluate(map, spec, &make, &|_| {}).unwrap().records
}

#[test]
fn no_shielded_move_is_ever_blocked() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let (h, w) = (map.grid.height(), map.grid.width());
    let ctde = untrained(
        Mode::Ctde,
        4,
        local_obs_dim(EnvConfig::default().sensor_range),
        "ctde",
    );
    let cte = untrained(Mode::Cte, 4, central_obs_dim(h, w, 4), "cte");
    let mut steps = 0;
    for (dir, agents) in [(&ctde, 4), (&ctde, 12), (&cte, 4)] {
        for act_mode in [ActMode::Greedy, ActMode::Sample] {
            for ranking in [Ranking::Walls, Ranking::Env] {
                let spec = EvalSpec {
                    agents,
                    episodes: 4,
                    t_max: 60,
                    ..EvalSpec::default()
                };
                for r in run(&map, dir, &spec, act_mode, ranking) {
                    assert_eq!(
                        r.blocked_moves, 0,
                        "{dir:?} {agents} {act_mode:?} {ranking:?}: {r:?}"
                    );
                    steps += r.timesteps;
                }
            }
        }
    }
    assert!(steps > 1000, "{steps}");
    for dir in [ctde, cte] {
        let _ = std::fs::remove_dir_all(dir);
    }
}

#[test]
fn shielded_greedy_evaluation_is_deterministic() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let dir = untrained(
        Mode::Ctde,
        4,
        local_obs_dim(EnvConfig::default().sensor_range),
        "det",
    );
    let spec = EvalSpec {
        agents: 8,
        episodes: 4,
        t_max: 50,
        ..EvalSpec::default()
    };
    // One thread, then two: each episode's outcome depends on nothing else.
    let a = run(&map, &dir, &spec, ActMode::Greedy, Ranking::Walls);
    let b = run(
        &map,
        &dir,
        &EvalSpec { jobs: 2, ..spec },
        ActMode::Greedy,
        Ranking::Walls,
    );
    let strip = |r: &EpisodeRecord| EpisodeRecord {
        compute_ms: 0.0,
        ..r.clone()
    };
    assert_eq!(
        a.iter().map(strip).collect::<Vec<_>>(),
        b.iter().map(strip).collect::<Vec<_>>()
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_shield_unjams_the_trained_ppo_policy() {
    // The committed PPO checkpoint (rm-2.1, 4 agents; README "Learning"):
    // in these seed-42 episodes its greedy actions end in a jam (agents
    // waiting on each other until T_max); shielded greedy solves them.
    let dir = common::committed_ppo_checkpoint();
    let mut env = common::committed_ppo_env();
    let mut raw = common::committed_greedy_policy();
    let mut shielded =
        ShieldController::load(&dir, 4, ActMode::Greedy, 42, Ranking::Walls).unwrap();
    for episode in common::JAMMED_EPISODES {
        let r = run_episode(&mut env, raw.as_mut(), episode).unwrap();
        assert!(
            !r.success && r.jammed_at_end > 0,
            "raw, episode {episode}: {r:?}"
        );
        let s = run_episode(&mut env, &mut shielded, episode).unwrap();
        assert!(
            s.success && s.blocked_moves == 0,
            "shielded, episode {episode}: {s:?}"
        );
        // The raw policy's moves are all its own; the shield changed some
        // of them (where the raw run jammed), never more than every move.
        assert_eq!(r.overridden, None);
        let changed = s.overridden.expect("the shield counts its changes");
        assert!(
            changed > 0 && changed <= 4 * s.timesteps,
            "episode {episode}: {changed} of {} agent-steps",
            4 * s.timesteps
        );
    }
}
