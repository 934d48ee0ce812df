//! CBS on rm-2.1 with 4 and 8 random agents (seed 42, fixed episode sets).
//!
//! `cargo bench -p buridan-mapf --bench cbs -- --warm-up-time 1 --measurement-time 3`
//!
//! One iteration solves the whole episode set. 4 agents: episodes 0..16.
//! 8 agents: episodes 0..8 without episode 2, which plain CBS does not solve
//! within 5 s (it would only measure the time limit).

use buridan_mapf::Problem;
use std::time::Duration;

use buridan_env::{episode_instance, Map, Scenario, Starts};
use buridan_mapf::{Cbs, Limits, Planner};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};

fn instances(map: &Map, agents: usize, episodes: &[u64]) -> Vec<Scenario> {
    episodes
        .iter()
        .map(|&e| episode_instance(map, agents, Starts::Random, 42, e).unwrap())
        .collect()
}

fn solve_all(planner: &dyn Planner, map: &Map, set: &[Scenario]) -> usize {
    let limits = Limits::with_time(Duration::from_secs(30));
    set.iter()
        .map(|s| {
            planner
                .solve(Problem::new(&map.grid, &s.starts, &s.goals), &limits)
                .expect("benchmark instances are solvable")
                .plan
                .sum_of_costs()
        })
        .sum()
}

fn bench(c: &mut Criterion) {
    let map = Map::load("rm-2.1").unwrap();
    let four: Vec<u64> = (0..16).collect();
    let eight: Vec<u64> = vec![0, 1, 3, 4, 5, 6, 7];
    let sets = [
        (4, instances(&map, 4, &four)),
        (8, instances(&map, 8, &eight)),
    ];
    let mut group = c.benchmark_group("cbs/rm-2.1");
    group.sampling_mode(SamplingMode::Flat).sample_size(10);
    for (agents, set) in &sets {
        for planner in [Cbs::default(), Cbs::improved()] {
            let id = BenchmarkId::new(
                planner.name().to_string(),
                format!("{agents} agents x {} episodes", set.len()),
            );
            group.bench_with_input(id, set, |b, set| b.iter(|| solve_all(&planner, &map, set)));
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
