//! Replays the recorded reference trace `tests/data/reference_trace.txt` and
//! compares positions, rewards, blocked moves and episode ends step by step.
//!
//! The file was generated once by the ignored test
//! `regenerate_reference_trace` (run it with
//! `cargo test -p buridan-env --test reference_trace -- --ignored`), then
//! checked by hand (see the file header). The replay test only reads the
//! file; it never regenerates what it checks.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, GridEnv, Map, Starts};

fn trace_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/reference_trace.txt")
}

fn fmt_cells(cells: &[Cell]) -> String {
    cells
        .iter()
        .map(|c| format!("{},{}", c.row, c.col))
        .collect::<Vec<_>>()
        .join(" ")
}

fn parse_cells(text: &str) -> Vec<Cell> {
    text.split_whitespace()
        .map(|rc| {
            let (r, c) = rc.split_once(',').expect("cell as row,col");
            Cell::new(r.parse().unwrap(), c.parse().unwrap())
        })
        .collect()
}

/// One trace header: `trace <map> agents=<n> starts=<fixed|random> seed=<s> episode=<e> t_max=<T>`.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    map: String,
    agents: usize,
    starts: Starts,
    seed: u64,
    episode: u64,
    t_max: u32,
}

impl Header {
    fn parse(line: &str) -> Header {
        let mut parts = line.split_whitespace();
        assert_eq!(parts.next(), Some("trace"));
        let map = parts.next().unwrap().to_string();
        let mut h = Header {
            map,
            agents: 0,
            starts: Starts::Fixed,
            seed: 0,
            episode: 0,
            t_max: 0,
        };
        for kv in parts {
            let (k, v) = kv.split_once('=').unwrap();
            match k {
                "agents" => h.agents = v.parse().unwrap(),
                "starts" => h.starts = v.parse().unwrap(),
                "seed" => h.seed = v.parse().unwrap(),
                "episode" => h.episode = v.parse().unwrap(),
                "t_max" => h.t_max = v.parse().unwrap(),
                other => panic!("unknown trace key {other}"),
            }
        }
        h
    }

    fn line(&self) -> String {
        let starts = match self.starts {
            Starts::Fixed => "fixed",
            Starts::Random => "random",
        };
        format!(
            "trace {} agents={} starts={} seed={} episode={} t_max={}",
            self.map, self.agents, starts, self.seed, self.episode, self.t_max
        )
    }

    fn env(&self) -> GridEnv {
        let map = Arc::new(Map::load(&self.map).unwrap());
        let cfg = EnvConfig {
            agents: self.agents,
            starts: self.starts,
            seed: self.seed,
            t_max: self.t_max,
            ..EnvConfig::default()
        };
        GridEnv::with_episode(map, cfg, self.episode).unwrap()
    }
}

fn status(out: &buridan_env::StepOutcome) -> &'static str {
    if out.terminated {
        "terminated"
    } else if out.truncated {
        "truncated"
    } else {
        "running"
    }
}

// ------------------------------------------------------------------ replay

#[test]
fn reference_trace_replays_exactly() {
    let text = std::fs::read_to_string(trace_path()).expect("reference trace file");
    let mut lines = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'));
    let mut traces = 0;
    let mut steps = 0;
    while let Some(line) = lines.next() {
        let header = Header::parse(line);
        traces += 1;
        let mut env = header.env();
        let starts = lines.next().unwrap().strip_prefix("starts ").unwrap();
        let goals = lines.next().unwrap().strip_prefix("goals ").unwrap();
        assert_eq!(env.positions(), parse_cells(starts), "{}", header.map);
        assert_eq!(env.goals(), parse_cells(goals), "{}", header.map);
        let n = header.agents;
        let mut rewards = vec![0.0f32; n];
        loop {
            let line = lines.next().expect("trace ends with an 'end' line");
            if let Some(total) = line.strip_prefix("end reward ") {
                assert_eq!(
                    env.stats().reward,
                    total.parse::<f32>().unwrap(),
                    "{}",
                    header.map
                );
                break;
            }
            // t | actions | positions | rewards | blocked | status
            let f: Vec<&str> = line.split('|').map(str::trim).collect();
            assert_eq!(f.len(), 6, "{line}");
            let t: u32 = f[0].parse().unwrap();
            let actions: Vec<u8> = f[1]
                .split_whitespace()
                .map(|a| a.parse().unwrap())
                .collect();
            let want_rewards: Vec<f32> = f[3]
                .split_whitespace()
                .map(|r| r.parse().unwrap())
                .collect();
            let out = env.step(&actions, &mut rewards).unwrap();
            let ctx = format!("{} step {t}", header.map);
            assert_eq!(env.t(), t, "{ctx}");
            assert_eq!(env.positions(), parse_cells(f[2]), "{ctx}");
            assert_eq!(rewards, want_rewards, "{ctx}");
            assert_eq!(out.blocked_moves, f[4].parse::<u32>().unwrap(), "{ctx}");
            assert_eq!(status(&out), f[5], "{ctx}");
            steps += 1;
        }
    }
    assert_eq!(traces, 4);
    assert!(steps >= 4 * 12, "{steps} steps replayed");
}

// -------------------------------------------------------------- generation

/// The traces: header and the action sequence.
fn specs() -> Vec<(Header, Vec<Vec<u8>>)> {
    let header = |map: &str, agents, starts, t_max| Header {
        map: map.into(),
        agents,
        starts,
        seed: 7,
        episode: 0,
        t_max,
    };
    // rm-1.1: hand-written, exercising a wall, both orders of a vacated
    // cell, the evasion aisle, and leaving and re-entering a goal.
    let rm11 = [
        [4, 4],
        [2, 4],
        [2, 1],
        [2, 4],
        [2, 1],
        [2, 3],
        [2, 3],
        [2, 4],
        [2, 4],
        [2, 4],
        [4, 4],
        [2, 0],
    ]
    .iter()
    .map(|a| a.to_vec())
    .collect();
    let mut out = vec![(header("rm-1.1", 2, Starts::Fixed, 100), rm11)];
    for h in [
        header("rm-2.1", 4, Starts::Fixed, 100),
        header("rm-3.1", 4, Starts::Fixed, 12),
        header("rm-2.1", 4, Starts::Random, 100),
    ] {
        let actions = greedy_with_detours(&h, 12);
        out.push((h, actions));
    }
    out
}

/// A deterministic action stream: shortest-path moves on the static layout
/// (ties by action order), with a fixed pseudo-random action every fourth
/// step per agent so that blocked moves and detours appear.
fn greedy_with_detours(h: &Header, steps: usize) -> Vec<Vec<u8>> {
    let mut env = h.env();
    let mut rewards = vec![0.0; h.agents];
    let mut all = Vec::new();
    for t in 0..steps {
        let actions: Vec<u8> = (0..h.agents)
            .map(|i| {
                if (t + i) % 4 == 3 {
                    return ((t * 7 + i * 3) % 5) as u8;
                }
                let grid = &env.map().grid;
                let d = grid.distances_to(env.goal(i));
                let here = env.position(i);
                (0..5u8)
                    .filter_map(|a| grid.neighbour(here, a).map(|n| (a, n)))
                    .filter(|&(_, n)| !grid.is_wall(n))
                    .min_by_key(|&(_, n)| d[grid.index(n)])
                    .map_or(0, |(a, _)| a)
            })
            .collect();
        let out = env.step(&actions, &mut rewards).unwrap();
        all.push(actions);
        if out.done() {
            break;
        }
    }
    all
}

const HEADER: &str = r"# Reference trace of the thesis ruleset (SPEC §2), replayed by
# tests/reference_trace.rs. Generated once by the ignored test
# `regenerate_reference_trace`; never regenerated by the test that checks it.
#
# Format: a `trace` line (map, agents, starts, seed, episode index, T_max),
# the starts and goals as row,col per agent, then one line per step:
#   t | actions | positions after the step | rewards | blocked moves | status
# and `end reward <EpisodeStats.reward>` (summed over agents).
# Actions: 0 stay, 1 up (row-1), 2 right (col+1), 3 down (row+1), 4 left (col-1).
#
# Checked by hand against the rules (maps in env/maps/):
# rm-1.1 (row 0 is wall except the aisle (0,4); row 1 is open; agent 0
# (1,1)->(1,8), agent 1 (1,7)->(1,0)), every step:
#   1  both left: 0 to (1,0) (agent 1's goal: no reward for 0), 1 to (1,6).
#   2  0 right to (1,1), 1 left to (1,5).
#   3  1 up into the wall (0,5): blocked (1).
#   4  0 to (1,3), 1 to (1,4).
#   5  0 right into (1,4): still occupied when 0 moves (1 moves later):
#      blocked (1); then 1 goes up into the aisle (0,4).
#   6  0 enters (1,4); 1 down into (1,4), occupied by 0: blocked (1).
#   7  0 leaves (1,4) first, so 1 (higher index) may enter it in the same
#      step: both move, no move blocked.
#   8, 9  both walk on; 10  0 reaches its goal (1,8): +0.5.
#   11 0 steps off its goal to (1,7); 1 reaches (1,0): +0.5 for 1.
#   12 0 comes back to (1,8): no second +0.5; all home: +1 each,
#      terminated. Episode reward 0.5 + 0.5 + 1 + 1 = 3; 3 blocked moves.
# rm-2.1 fixed, steps 1-5 checked: step 2 agent 2 down into the shelf wall
#   (7,4): blocked; step 4 agent 0 up into the wall (5,2) and agent 2 left
#   into agent 0: 2 blocked; step 5 agents 0 and 2 push head-on at (6,2)/(6,3)
#   and both stay (no swap); from step 7 agents 1/3 push head-on too.
#   No goal reached, no rewards.
# rm-3.1 fixed with T_max 12, step 1 checked (agent 3 left into the wall
#   (16,27): blocked); nobody home at step 12: truncated, -1 each, total -4.
# rm-2.1 random (seed 7, episode 0), steps 1, 8, 9 checked: step 1 agents 1
#   and 3 push head-on at (0,17)/(0,18): both blocked; agent 2 reaches (0,4)
#   at step 8 and agent 0 (2,18) at step 9: +0.5 each, total 1. This trace
#   also pins the seeded start/goal generator.
";

#[test]
#[ignore = "writes tests/data/reference_trace.txt; run by hand, then check the file by hand"]
fn regenerate_reference_trace() {
    let mut text = String::from(HEADER);
    for (header, actions) in specs() {
        let mut env = header.env();
        let n = header.agents;
        writeln!(text, "\n{}", header.line()).unwrap();
        writeln!(text, "starts {}", fmt_cells(&env.positions())).unwrap();
        writeln!(text, "goals {}", fmt_cells(&env.goals())).unwrap();
        let mut rewards = vec![0.0f32; n];
        for a in &actions {
            let out = env.step(a, &mut rewards).unwrap();
            let acts = a.iter().map(u8::to_string).collect::<Vec<_>>().join(" ");
            let rews = rewards
                .iter()
                .map(f32::to_string)
                .collect::<Vec<_>>()
                .join(" ");
            writeln!(
                text,
                "{:>2} | {acts} | {} | {rews} | {} | {}",
                env.t(),
                fmt_cells(&env.positions()),
                out.blocked_moves,
                status(&out)
            )
            .unwrap();
            if out.done() {
                break;
            }
        }
        writeln!(text, "end reward {}", env.stats().reward).unwrap();
    }
    std::fs::write(trace_path(), text).unwrap();
}
