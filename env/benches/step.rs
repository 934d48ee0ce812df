//! Throughput of the vectorized env in agent-steps per second.
//!
//! `cargo bench -p buridan-env --bench step -- --warm-up-time 1 --measurement-time 3`
//!
//! One iteration = one `VecEnv::step` of `ENVS` envs on rm-2.1 with random
//! starts (auto-reset at T_max = 100), including the observation encoding
//! and masks, on one thread; criterion's element throughput is
//! `ENVS × agents` agent-steps per iteration. The actions are uniform over
//! 0..5 and drawn before the timed loop (about a fifth are stays, most of
//! the rest legal moves). `grid_env_step` times the bare rule step of one
//! env, without observations, for comparison. `grid_env_step_warehouse`
//! times the same bare step on the POGEMA benchmark's warehouse
//! (`benches/data/warehouse.map`, and `warehouse.scen` =
//! `../shared/pogema/warehouse-192-0.scen`: its first 64 or all 192 agents)
//! under both rule sets, `T_max` 128, reset to the same instance when an
//! episode ends.

use std::hint::black_box;
use std::sync::Arc;

use buridan_env::{EnvConfig, GridEnv, Map, ObsKind, Rules, Starts, VecEnv};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Envs per VecEnv.
const ENVS: usize = 64;
/// Pre-generated action batches, cycled through.
const BATCHES: usize = 512;

fn action_batches(len: usize, seed: u64) -> Vec<Vec<u8>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..BATCHES)
        .map(|_| (0..len).map(|_| rng.random_range(0..5u8)).collect())
        .collect()
}

fn vec_env(c: &mut Criterion) {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let mut group = c.benchmark_group("vec_env_step_rm-2.1");
    for (kind, agents) in [
        (ObsKind::Local, 4),
        (ObsKind::Local, 16),
        (ObsKind::Central, 4),
        (ObsKind::Central, 16),
    ] {
        let cfg = EnvConfig {
            agents,
            seed: 1,
            ..EnvConfig::default()
        };
        let mut venv = VecEnv::new(map.clone(), cfg, ENVS, kind, 1).unwrap();
        let batches = action_batches(ENVS * agents, agents as u64);
        group.throughput(Throughput::Elements((ENVS * agents) as u64));
        let name = match kind {
            ObsKind::Local => "local",
            ObsKind::Central => "central",
        };
        let mut k = 0;
        group.bench_function(BenchmarkId::new(name, format!("{agents}_agents")), |b| {
            b.iter(|| {
                venv.step(&batches[k % BATCHES]).unwrap();
                k += 1;
                black_box(venv.obs().first());
            })
        });
    }
    group.finish();
}

fn grid_env(c: &mut Criterion) {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let mut group = c.benchmark_group("grid_env_step_rm-2.1");
    for agents in [4, 16] {
        let cfg = EnvConfig {
            agents,
            seed: 1,
            ..EnvConfig::default()
        };
        let mut env = GridEnv::new(map.clone(), cfg).unwrap();
        let batches = action_batches(agents, 100 + agents as u64);
        let mut rewards = vec![0.0; agents];
        group.throughput(Throughput::Elements(agents as u64));
        let mut k = 0;
        group.bench_function(
            BenchmarkId::new("rules_only", format!("{agents}_agents")),
            |b| {
                b.iter(|| {
                    let out = env.step(&batches[k % BATCHES], &mut rewards).unwrap();
                    k += 1;
                    if out.done() {
                        env.reset_next(1).unwrap();
                    }
                    black_box(&rewards);
                })
            },
        );
    }
    group.finish();
}

fn warehouse(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/data/warehouse.map");
    let map = Arc::new(Map::load(path).unwrap());
    let mut group = c.benchmark_group("grid_env_step_warehouse");
    for rules in Rules::ALL {
        for agents in [64, 192] {
            let cfg = EnvConfig {
                agents,
                starts: Starts::Fixed,
                t_max: Rules::Pogema.default_t_max(),
                ..EnvConfig::for_rules(rules)
            };
            let mut env = GridEnv::new(map.clone(), cfg).unwrap();
            let batches = action_batches(agents, 200 + agents as u64);
            let mut rewards = vec![0.0; agents];
            group.throughput(Throughput::Elements(agents as u64));
            let mut k = 0;
            group.bench_function(
                BenchmarkId::new(rules.name(), format!("{agents}_agents")),
                |b| {
                    b.iter(|| {
                        let out = env.step(&batches[k % BATCHES], &mut rewards).unwrap();
                        k += 1;
                        if out.done() {
                            env.reset_to(0).unwrap();
                        }
                        black_box(&rewards);
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, vec_env, grid_env, warehouse);
criterion_main!(benches);
