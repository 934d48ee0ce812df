//! Parity of the `pogema` rules with POGEMA 1.4.0 itself.
//!
//! `tests/data/pogema/traces.json.gz` holds episodes recorded in the `pogema`
//! package (`collision_system: soft`, `on_target: nothing`) by
//! `scripts/pogema/record_traces.py` (the exact command is in
//! `tests/data/pogema/README.md`): the benchmark's warehouse (33×46) with 8
//! to 192 agents of its instances, and small maps from pogema's generator;
//! uniform random actions, goal-directed ones and crowds pushing towards one
//! hub. Each episode is replayed through [`GridEnv`] under [`Rules::Pogema`]
//! with the same map, starts, goals, `T_max` and actions, and compared:
//!
//! - every agent's cell after every step;
//! - the episode ends exactly at the recorded last step, terminated (all on
//!   their goals) iff pogema's did, and successful iff pogema's `CSR` is 1;
//! - each agent's cost, SoC, makespan, the episode length and `ISR` equal
//!   pogema's `SumOfCostsAndMakespanMetric` and its other metrics.
//!
//! Mismatches are collected over all episodes (the first wrong position ends
//! that episode's replay) and reported together.

use std::io::Read;
use std::path::PathBuf;
use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, Grid, GridEnv, Map, Rules, Scenario, Starts};

/// Our action index of each of pogema's (`GridConfig.MOVES`: stay, up, down,
/// left, right); ours are stay, up, right, down, left.
const FROM_POGEMA: [u8; 5] = [0, 1, 3, 4, 2];

#[derive(Debug, serde::Deserialize)]
struct Traces {
    pogema: String,
    collision_system: String,
    on_target: String,
    episodes: Vec<Episode>,
}

/// One recorded episode (see `scripts/pogema/record_traces.py`).
#[derive(Debug, serde::Deserialize)]
struct Episode {
    name: String,
    /// MovingAI rows, `.` free and `@` wall.
    map: Vec<String>,
    t_max: u32,
    /// `[row, col]` per agent.
    starts: Vec<[usize; 2]>,
    goals: Vec<[usize; 2]>,
    /// One string per step, a pogema action digit per agent.
    actions: Vec<String>,
    /// Per step, each agent's cell `row * width + col` after it.
    positions: Vec<Vec<usize>>,
    terminated: bool,
    truncated: bool,
    success: bool,
    costs: Vec<u32>,
    soc: u64,
    makespan: u32,
    isr: f64,
    ep_length: u32,
}

fn load() -> Traces {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/pogema/traces.json.gz");
    let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut text = String::new();
    flate2::read::GzDecoder::new(file)
        .read_to_string(&mut text)
        .unwrap();
    serde_json::from_str(&text).unwrap()
}

fn cells(list: &[[usize; 2]]) -> Vec<Cell> {
    list.iter().map(|&[r, c]| Cell::new(r, c)).collect()
}

fn env_for(ep: &Episode) -> GridEnv {
    let rows: Vec<&str> = ep.map.iter().map(String::as_str).collect();
    let grid = Grid::from_rows(&rows).unwrap();
    // Fixed starts: crowded small maps have too few cells for the random
    // generator `GridEnv::new` would otherwise start with.
    let map = Map {
        name: ep.name.clone(),
        grid,
        scenario: Some(Scenario {
            starts: cells(&ep.starts),
            goals: cells(&ep.goals),
        }),
    };
    let cfg = EnvConfig {
        agents: ep.starts.len(),
        t_max: ep.t_max,
        starts: Starts::Fixed,
        ..EnvConfig::for_rules(Rules::Pogema)
    };
    GridEnv::new(Arc::new(map), cfg).unwrap()
}

/// Replays one episode; returns its mismatches.
fn replay(ep: &Episode) -> Vec<String> {
    let mut env = env_for(ep);
    let n = ep.starts.len();
    let width = ep.map[0].len();
    let mut out = Vec::new();
    assert_eq!(env.positions(), cells(&ep.starts), "{}: starts", ep.name);
    assert_eq!(ep.actions.len(), ep.positions.len(), "{}: steps", ep.name);
    let mut rewards = vec![0.0; n];
    let last = ep.actions.len() - 1;
    for (t, (joint, want)) in ep.actions.iter().zip(&ep.positions).enumerate() {
        let actions: Vec<u8> = joint
            .bytes()
            .map(|d| FROM_POGEMA[usize::from(d - b'0')])
            .collect();
        assert_eq!(actions.len(), n, "{}: step {} actions", ep.name, t + 1);
        let outcome = env.step(&actions, &mut rewards).unwrap();
        let got: Vec<usize> = env
            .positions()
            .iter()
            .map(|c| c.row * width + c.col)
            .collect();
        if &got != want {
            let agents: Vec<usize> = (0..n).filter(|&i| got[i] != want[i]).collect();
            out.push(format!(
                "{}: step {}: agents {agents:?} at {:?}, pogema has them at {:?}",
                ep.name,
                t + 1,
                agents.iter().map(|&i| got[i]).collect::<Vec<_>>(),
                agents.iter().map(|&i| want[i]).collect::<Vec<_>>(),
            ));
            return out;
        }
        if outcome.done() != (t == last) {
            out.push(format!(
                "{}: step {}: done {}, pogema ends at step {}",
                ep.name,
                t + 1,
                outcome.done(),
                last + 1
            ));
            return out;
        }
        if t == last && outcome.terminated != ep.terminated {
            out.push(format!(
                "{}: terminated {}, pogema {} (truncated {})",
                ep.name, outcome.terminated, ep.terminated, ep.truncated
            ));
        }
    }
    let stats = env.stats();
    let costs: Vec<u32> = (0..n).map(|i| env.cost(i)).collect();
    let isr = f64::from(stats.agents_at_goal) / n as f64;
    let ours = (
        stats.success,
        costs,
        env.sum_of_costs(),
        env.makespan(),
        env.t(),
    );
    let theirs = (
        ep.success,
        ep.costs.clone(),
        ep.soc,
        ep.makespan,
        ep.ep_length,
    );
    if ours != theirs || (isr - ep.isr).abs() > 1e-12 {
        out.push(format!(
            "{}: (success, costs, SoC, makespan, length) = {ours:?}, ISR {isr}; pogema {theirs:?}, ISR {}",
            ep.name, ep.isr
        ));
    }
    out
}

#[test]
fn pogema_rules_replay_pogema_traces_step_for_step() {
    let traces = load();
    assert_eq!(
        (
            traces.pogema.as_str(),
            traces.collision_system.as_str(),
            traces.on_target.as_str()
        ),
        ("1.4.0", "soft", "nothing")
    );
    let mismatches: Vec<String> = traces.episodes.iter().flat_map(replay).collect();
    assert!(
        mismatches.is_empty(),
        "{} mismatches, first ones:\n{}",
        mismatches.len(),
        mismatches[..mismatches.len().min(20)].join("\n")
    );
    // The coverage the parity claim rests on.
    let steps: usize = traces.episodes.iter().map(|e| e.actions.len()).sum();
    let crowd_steps: usize = traces
        .episodes
        .iter()
        .filter(|e| e.starts.len() == 192 && e.name.starts_with("warehouse"))
        .map(|e| e.actions.len())
        .sum();
    let successes = traces.episodes.iter().filter(|e| e.success).count();
    let left_goal = traces.episodes.iter().any(|e| {
        // Somebody stood on its goal at some step but arrived later than that.
        let width = e.map[0].len();
        e.positions.iter().enumerate().any(|(t, p)| {
            (0..e.starts.len()).any(|i| {
                let [r, c] = e.goals[i];
                p[i] == r * width + c && e.costs[i] > t as u32 + 1
            })
        })
    });
    // POGEMA's metric keeps an arrival when the agent leaves in the truncating step.
    let left_at_truncation = traces.episodes.iter().any(|e| {
        let width = e.map[0].len();
        let last = e.positions.last().unwrap();
        (0..e.starts.len()).any(|i| {
            let [r, c] = e.goals[i];
            last[i] != r * width + c && e.costs[i] < e.ep_length
        })
    });
    assert!(steps >= 10_000, "only {steps} recorded steps");
    assert!(
        left_at_truncation,
        "no agent left its goal in the truncating step"
    );
    assert!(
        crowd_steps >= 1_000,
        "only {crowd_steps} steps with 192 agents"
    );
    assert!(successes >= 10, "only {successes} successful episodes");
    assert!(left_goal, "no agent ever left its goal and came back");
}
