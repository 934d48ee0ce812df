//! LaCAM on rm-2.1 with 4, 16 and 32 random agents (seed 42, episodes 0..8),
//! and on one of POGEMA's maze instances with 64 agents under pogema rules
//! (`benches/data/`, a copy of `../shared/pogema/mazes/validation-mazes-seed-058.map` and its
//! 64-agent `.scen`): LaCAM returning its first plan, and LaCAM within the
//! instance's T_max of 128 steps (`Lacam::within_cap`).
//!
//! `cargo bench -p buridan-mapf --bench lacam -- --warm-up-time 1 --measurement-time 3`
//!
//! One rm-2.1 iteration solves the whole episode set of one agent count:
//! those of episodes 0..8 that LaCAM solves within 5 s (checked once at
//! setup; the others would only measure the time limit). One maze
//! iteration solves the instance once.

use buridan_mapf::Problem;
use std::time::Duration;

use buridan_env::{episode_instance, Map, Scenario, Starts};
use buridan_mapf::{ConflictModel, Lacam, Limits, Planner};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};

fn instances(map: &Map, agents: usize) -> Vec<Scenario> {
    let quick = Limits::with_time(Duration::from_secs(5));
    (0..8)
        .map(|e| episode_instance(map, agents, Starts::Random, 42, e).unwrap())
        .filter(|s| {
            Lacam::default()
                .solve(Problem::new(&map.grid, &s.starts, &s.goals), &quick)
                .is_ok()
        })
        .collect()
}

fn solve_all(map: &Map, set: &[Scenario]) -> usize {
    let limits = Limits::with_time(Duration::from_secs(30));
    set.iter()
        .map(|s| {
            Lacam::default()
                .solve(Problem::new(&map.grid, &s.starts, &s.goals), &limits)
                .expect("benchmark instances are solvable")
                .plan
                .sum_of_costs()
        })
        .sum()
}

fn bench(c: &mut Criterion) {
    let map = Map::load("rm-2.1").unwrap();
    let mut group = c.benchmark_group("lacam/rm-2.1");
    group.sampling_mode(SamplingMode::Flat).sample_size(10);
    for agents in [4, 16, 32] {
        let set = instances(&map, agents);
        let id = BenchmarkId::new("lacam", format!("{agents} agents x {} episodes", set.len()));
        group.bench_with_input(id, &set, |b, set| b.iter(|| solve_all(&map, set)));
    }
    group.finish();
}

/// The maze instance of the module docs.
const MAZE: &str = "validation-mazes-seed-058";

fn bench_maze(c: &mut Criterion) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/data");
    let map = Map::from_file(&dir.join(format!("{MAZE}.map"))).unwrap();
    let path = dir.join(format!("{MAZE}-64-0.scen"));
    let text = std::fs::read_to_string(&path).unwrap();
    let scen = buridan_env::map::parse_scen(&path.display().to_string(), &text, &map.grid).unwrap();
    let (s, g) = (&scen.starts, &scen.goals);
    assert_eq!(s.len(), 64);
    let limits = Limits {
        max_makespan: Some(128),
        ..Limits::with_time(Duration::from_secs(10))
    };
    let mut group = c.benchmark_group(format!("lacam/{MAZE}"));
    group.sampling_mode(SamplingMode::Flat).sample_size(10);
    for within_cap in [false, true] {
        let lacam = Lacam {
            rules: ConflictModel::SIMULTANEOUS,
            within_cap,
            ..Lacam::default()
        };
        let makespan = lacam
            .solve(Problem::new(&map.grid, s, g), &limits)
            .expect("the benchmark instance is solved")
            .plan
            .makespan();
        let name = if within_cap {
            "within T_max"
        } else {
            "first plan"
        };
        let id = BenchmarkId::new(name, format!("64 agents, makespan {makespan}"));
        group.bench_function(id, |b| {
            b.iter(|| lacam.solve(Problem::new(&map.grid, s, g), &limits).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench, bench_maze);
criterion_main!(benches);
