//! Learner update throughput on one thread: a PPO epoch over a 4000
//! env-step train batch (rm-1.1, CTDE, 2 agents → 8000 samples, one
//! minibatch) and an IMPALA gradient step on the same batch; then one
//! IMPALA step of the tuned rm-2.1 config (`learner/configs/impala-ctde-rm-2.1.toml`:
//! 10 envs × 50 steps × 4 agents = 2000 samples) with the [64, 64] MLP
//! and with the 64-cell LSTM after it, side by side — the learner's half
//! of the end-to-end LSTM / MLP training-speed ratio, apart from the actors.
//!
//! A third group times one PPO epoch of the general-policy probes' shape
//! (issue 56's `p2`: feed-forward [512, 512], the 9 × 9 window with the
//! path, priority, intent and order features; 16 agents on rm-2.1).
//!
//! Each group runs on the CPU and, in a `cuda` build on a machine with a
//! GPU, again on the GPU (`…/cuda`), from the same weights and batch: the
//! side-by-side figures of the book's GPU chapter. Elsewhere it says that
//! it ran on the CPU alone.
//!
//! `cargo bench -p buridan-learner --bench update`
//! (GPU: `scripts/build-cuda.sh`, then the bench binary it lists)

use std::sync::Arc;

use buridan_actor::Collector;
use buridan_env::ObsFeatures;
use buridan_env::{Map, ObsKind, Starts, VecEnv};
use buridan_learner::algo::impala::Impala;
use buridan_learner::algo::ppo::{Ppo, PpoSettings};
use buridan_learner::train::{env_config, Algorithm, ImpalaConfig, PpoConfig, Task, TrainConfig};
use buridan_policy::{DeviceSpec, Fragment, Inference, Mode, ModelSpec, Policy};
use candle_core::Device;
use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion, Throughput};
use rand::SeedableRng;

/// The devices to time on: the CPU, and the first GPU where there is one.
fn devices() -> Vec<(&'static str, Device)> {
    let mut devices = vec![("", Device::Cpu)];
    match DeviceSpec::first_gpu() {
        Some(gpu) => devices.push(("/cuda", gpu)),
        None => eprintln!(
            "update bench: CPU only (GPU: {})",
            if buridan_policy::device::CUDA_BUILT {
                "none found"
            } else {
                "not a `cuda` build"
            }
        ),
    }
    devices
}

/// `count` fragments collected on `cfg`'s task by a fresh policy, and that
/// policy's spec.
fn fragments(cfg: &TrainConfig, count: usize) -> (ModelSpec, Vec<Fragment>) {
    let map = Arc::new(Map::load(&cfg.map_label()).unwrap());
    let venv = VecEnv::new(
        map,
        env_config(cfg, 0),
        cfg.run.envs_per_actor,
        ObsKind::Local,
        1,
    )
    .unwrap();
    let spec = cfg.model_spec(venv.obs_dim());
    let rows = venv.obs().len() / venv.obs_dim();
    let mut actor = Collector {
        id: 0,
        inference: Inference::new(Policy::new(spec.clone(), 0).unwrap(), rows, 1),
        behaviour: cfg.behaviour(),
        venv,
        fragment_len: cfg.run.fragment_len,
        version: 0,
        shield: None,
    };
    let frags = (0..count).map(|_| actor.collect().unwrap()).collect();
    (spec, frags)
}

/// Samples (agent-steps) in a batch of fragments.
fn samples(frags: &[Fragment]) -> usize {
    frags.iter().map(|f| f.len * f.rows).sum()
}

/// Times one PPO epoch over the whole batch as one minibatch (the cost of
/// one pass), `cfg`'s PPO settings, fresh weights on `device`.
fn bench_ppo_epoch(
    g: &mut BenchmarkGroup<'_, WallTime>,
    name: String,
    cfg: &TrainConfig,
    spec: &ModelSpec,
    frags: &[Fragment],
    device: &Device,
) {
    let policy = Policy::new_on(spec.clone(), 0, device).unwrap();
    let mut ppo = Ppo::new(
        &policy,
        PpoSettings {
            epochs: 1,
            minibatch_size: samples(frags),
            ..cfg.ppo_settings(&PpoConfig::default())
        },
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    g.bench_function(name, |b| {
        b.iter(|| ppo.update(&policy, frags, &mut rng).unwrap())
    });
}

fn bench(c: &mut Criterion) {
    buridan_policy::threads::pin_threads(1);
    let cfg = TrainConfig {
        task: Task::Grid("rm-1.1".into()),
        agents: 2,
        starts: Starts::Fixed,
        mode: Mode::Ctde,
        ..TrainConfig::default()
    };
    let devices = devices();
    // 5 fragments × 50 steps × 16 envs = 4000 env steps = 8000 samples.
    let (spec, frags) = fragments(&cfg, 5);
    let mut g = c.benchmark_group("learner");
    g.sample_size(10);
    g.throughput(Throughput::Elements(samples(&frags) as u64));
    for (suffix, device) in &devices {
        let name = format!("ppo_update_1_epoch_{}_samples{suffix}", samples(&frags));
        bench_ppo_epoch(&mut g, name, &cfg, &spec, &frags, device);
        let icfg = TrainConfig {
            algorithm: Algorithm::Impala(ImpalaConfig::default()),
            ..cfg.clone()
        };
        let ipolicy = Policy::new_on(icfg.model_spec(spec.obs_dim), 0, device).unwrap();
        let mut impala = Impala::new(&ipolicy, icfg.impala_settings(&ImpalaConfig::default()));
        g.bench_function(format!("impala_update_8000_samples{suffix}"), |b| {
            b.iter(|| impala.update(&ipolicy, &frags).unwrap())
        });
    }
    g.finish();

    // Where it was built, or (a bench binary carried to another machine,
    // scripts/gpu-check.sh) beside the working directory.
    let built_here = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/configs/impala-ctde-rm-2.1.toml"
    );
    let config = [built_here, "configs/impala-ctde-rm-2.1.toml"]
        .into_iter()
        .map(std::path::Path::new)
        .find(|p| p.exists())
        .expect("learner/configs/impala-ctde-rm-2.1.toml, run from learner/");
    let tuned = TrainConfig::from_toml_file(config).expect("the tuned IMPALA config parses");
    let mut g = c.benchmark_group("impala-rm-2.1");
    g.sample_size(20);
    for (name, lstm) in [("mlp", false), ("lstm", true)] {
        let mut cfg = tuned.clone();
        cfg.model.lstm = lstm;
        // One train batch: 10 envs × 50 steps = 500 env steps.
        let (spec, frags) = fragments(&cfg, 1);
        let n = samples(&frags);
        g.throughput(Throughput::Elements(n as u64));
        let tuned_impala = cfg.algorithm.impala().expect("an IMPALA config");
        for (suffix, device) in &devices {
            let policy = Policy::new_on(spec.clone(), 0, device).unwrap();
            let mut impala = Impala::new(&policy, cfg.impala_settings(tuned_impala));
            g.bench_function(format!("update_{name}_{n}_samples{suffix}"), |b| {
                b.iter(|| impala.update(&policy, &frags).unwrap())
            });
        }
    }
    g.finish();

    // The general-policy probe's shape (issue 56's p2), one PPO epoch.
    let mut general = TrainConfig {
        task: Task::Grid("rm-2.1".into()),
        agents: 16,
        sensor_range: 4,
        features: ObsFeatures {
            path: true,
            priority: true,
            intent: true,
            order: true,
            ..ObsFeatures::default()
        },
        ..TrainConfig::default()
    };
    general.model.lstm = false;
    general.model.hidden = vec![512, 512];
    general.run.envs_per_actor = 8;
    let (spec, frags) = fragments(&general, 1);
    let mut g = c.benchmark_group("general-policy");
    g.sample_size(10);
    g.throughput(Throughput::Elements(samples(&frags) as u64));
    for (suffix, device) in &devices {
        let name = format!(
            "ppo_update_1_epoch_ff512x2_{}_samples{suffix}",
            samples(&frags)
        );
        bench_ppo_epoch(&mut g, name, &general, &spec, &frags, device);
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
