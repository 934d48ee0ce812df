//! Observation buffers on the wire: encode and decode one IMPALA fragment's
//! observations (rm-2.1, 10 envs × 4 agents, 50 steps, 129 floats each:
//! 1.03 MB) as raw bytes, LZ4 and 2-bit codes, on one thread. The
//! observations are real: a random policy stepping the env.
//!
//! `cargo bench -p buridan-proto --bench obs_encoding`

use std::sync::Arc;

use buridan_env::{EnvConfig, Map, ObsKind, Starts, VecEnv};
use buridan_proto::obs_encoding::{decode, encode};
use buridan_proto::v1::ObsEncoding;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{Rng, SeedableRng};

/// 50 steps of 10 envs with 4 agents each, random moves.
fn fragment_obs() -> Vec<f32> {
    let map = Arc::new(Map::load("rm-2.1").expect("bundled"));
    let cfg = EnvConfig {
        agents: 4,
        starts: Starts::Random,
        seed: 42,
        ..EnvConfig::default()
    };
    let mut venv = VecEnv::new(map, cfg, 10, ObsKind::Local, 1).expect("env");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut obs = Vec::new();
    for _ in 0..50 {
        obs.extend_from_slice(venv.obs());
        let actions: Vec<u8> = (0..40).map(|_| rng.random_range(0..5)).collect();
        venv.step(&actions).expect("step");
    }
    obs
}

fn bench(c: &mut Criterion) {
    let obs = fragment_obs();
    let mut g = c.benchmark_group("obs_encoding");
    g.throughput(Throughput::Bytes((obs.len() * 4) as u64));
    for (name, encoding) in [
        ("raw", ObsEncoding::Raw),
        ("lz4", ObsEncoding::Lz4),
        ("codes", ObsEncoding::Codes),
    ] {
        let wire = encode(&obs, encoding);
        println!(
            "{name}: {} values, {} bytes on the wire ({:.1}x smaller)",
            obs.len(),
            wire.len(),
            (obs.len() * 4) as f64 / wire.len() as f64
        );
        g.bench_function(format!("encode_{name}"), |b| {
            b.iter(|| encode(std::hint::black_box(&obs), encoding))
        });
        g.bench_function(format!("decode_{name}"), |b| {
            b.iter(|| {
                let wire = std::hint::black_box(&wire);
                decode("obs", wire, encoding, Some(obs.len()), usize::MAX).unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
