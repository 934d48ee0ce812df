//! LaCAM on rm-2.1 with 4, 16 and 32 random agents (seed 42, episodes 0..8).
//!
//! `cargo bench -p buridan-mapf --bench lacam -- --warm-up-time 1 --measurement-time 3`
//!
//! One iteration solves the whole episode set of one agent count: those of
//! episodes 0..8 that LaCAM solves within 5 s (checked once at setup; the
//! others would only measure the time limit).

use buridan_mapf::Problem;
use std::time::Duration;

use buridan_env::{episode_instance, Map, Scenario, Starts};
use buridan_mapf::{Lacam, Limits, Planner};
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

criterion_group!(benches, bench);
criterion_main!(benches);
