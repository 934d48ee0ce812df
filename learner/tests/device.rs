//! The learner's updates on a GPU against the CPU's: one PPO update and
//! one IMPALA gradient step from the same weights and the same batch, the
//! LSTM policy of the recipe, must move the weights alike.
//!
//! They need a binary built with the `cuda` feature (`scripts/build-cuda.sh`)
//! and a machine with a GPU. A default build marks them ignored, with the
//! reason (CI lists them as such); a `cuda` build on a machine without a
//! GPU runs them and fails, naming what is missing, so that a parity check
//! is never passed by a machine that could not make it.
//!
//! Agreement is judged on the updates `Δ = w_after − w_before`, not on the
//! weights: the GPU runs candle's exact `σ`/`tanh` and an unfused LSTM
//! where the CPU runs fast approximations and a fused recurrence, so the
//! gradients differ in their last digits, and Adam's first step (≈ lr ·
//! sign g) turns a near-zero gradient's rounding into a full-size step. So:
//! the two updates agree in direction (cosine ≥ 0.99) and size (norms
//! within 2 %), which an update on garbage gradients cannot meet.

use std::sync::Arc;

use buridan_actor::Collector;
use buridan_env::{Map, ObsKind, Starts, VecEnv};
use buridan_learner::algo::impala::Impala;
use buridan_learner::algo::ppo::Ppo;
use buridan_learner::train::{env_config, Algorithm, ImpalaConfig, PpoConfig, Task, TrainConfig};
use buridan_policy::{DeviceSpec, Fragment, Inference, Mode, Policy};
use candle_core::Device;
use rand::SeedableRng;

/// The first GPU; a `cuda` build without one fails the test here.
fn gpu() -> Device {
    DeviceSpec::Cuda(0)
        .open()
        .unwrap_or_else(|e| panic!("parity test on a `cuda` build: {e}"))
}

/// The recipe's policy shape (64-cell LSTM) on rm-2.1, 4 agents, and
/// `count` fragments collected by it on the CPU.
fn setup(algorithm: Algorithm, count: usize) -> (TrainConfig, Vec<Fragment>) {
    let cfg = TrainConfig {
        task: Task::Grid("rm-2.1".into()),
        agents: 4,
        starts: Starts::Random,
        mode: Mode::Ctde,
        algorithm,
        ..TrainConfig::recipe()
    };
    let map = Arc::new(Map::load(&cfg.map_label()).unwrap());
    let venv = VecEnv::new(map, env_config(&cfg, 0), 8, ObsKind::Local, 1).unwrap();
    let spec = cfg.model_spec(venv.obs_dim());
    let rows = venv.obs().len() / venv.obs_dim();
    let mut actor = Collector {
        id: 0,
        inference: Inference::new(Policy::new(spec, 3).unwrap(), rows, 1),
        behaviour: cfg.behaviour(),
        venv,
        fragment_len: cfg.run.fragment_len,
        version: 0,
        shield: None,
    };
    let frags = (0..count).map(|_| actor.collect().unwrap()).collect();
    (cfg, frags)
}

fn flat(policy: &Policy) -> Vec<f32> {
    let w = policy.weights(0).unwrap();
    w.tensors.into_iter().flat_map(|t| t.data).collect()
}

/// Cosine and norm ratio of the GPU's update against the CPU's.
fn agreement(before: &[f32], cpu: &[f32], gpu: &[f32]) -> (f64, f64) {
    let (mut dot, mut nc, mut ng) = (0.0f64, 0.0f64, 0.0f64);
    for ((&w, &c), &g) in before.iter().zip(cpu).zip(gpu) {
        let (dc, dg) = ((c - w) as f64, (g - w) as f64);
        dot += dc * dg;
        nc += dc * dc;
        ng += dg * dg;
    }
    assert!(nc > 0.0, "the CPU update moved no weight");
    (dot / (nc.sqrt() * ng.sqrt()), ng.sqrt() / nc.sqrt())
}

fn assert_agree(what: &str, before: &[f32], cpu: &[f32], gpu: &[f32]) {
    let (cosine, ratio) = agreement(before, cpu, gpu);
    eprintln!("{what}: cosine {cosine:.5}, norm ratio {ratio:.4}");
    assert!(
        cosine >= 0.99,
        "{what}: updates point apart (cosine {cosine})"
    );
    assert!(
        (ratio - 1.0).abs() <= 0.02,
        "{what}: update sizes differ (ratio {ratio})"
    );
}

#[test]
#[cfg_attr(
    not(feature = "cuda"),
    ignore = "needs a `cuda` build (scripts/build-cuda.sh) on a machine with a GPU"
)]
fn a_ppo_update_on_the_gpu_moves_the_weights_as_on_the_cpu() {
    let (cfg, frags) = setup(Algorithm::Ppo(PpoConfig::default()), 2);
    let spec = cfg.model_spec(frags[0].obs_dim);
    let settings = || buridan_learner::algo::ppo::PpoSettings {
        epochs: 1,
        update_threads: 1,
        ..cfg.ppo_settings(cfg.algorithm.ppo().unwrap())
    };
    let on = |device: &Device| {
        let policy = Policy::new_on(spec.clone(), 11, device).unwrap();
        let mut ppo = Ppo::new(&policy, settings());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        ppo.update(&policy, &frags, &mut rng).unwrap();
        flat(&policy)
    };
    let before = flat(&Policy::new(spec.clone(), 11).unwrap());
    let (cpu, gpu) = (on(&Device::Cpu), on(&gpu()));
    assert_agree("PPO", &before, &cpu, &gpu);
}

#[test]
#[cfg_attr(
    not(feature = "cuda"),
    ignore = "needs a `cuda` build (scripts/build-cuda.sh) on a machine with a GPU"
)]
fn an_impala_step_on_the_gpu_moves_the_weights_as_on_the_cpu() {
    let (cfg, frags) = setup(Algorithm::Impala(ImpalaConfig::default()), 1);
    let spec = cfg.model_spec(frags[0].obs_dim);
    let on = |device: &Device| {
        let policy = Policy::new_on(spec.clone(), 11, device).unwrap();
        let settings = buridan_learner::algo::impala::ImpalaSettings {
            update_threads: 1,
            ..cfg.impala_settings(cfg.algorithm.impala().unwrap())
        };
        let mut impala = Impala::new(&policy, settings);
        impala.update(&policy, &frags).unwrap();
        flat(&policy)
    };
    let before = flat(&Policy::new(spec.clone(), 11).unwrap());
    let (cpu, gpu) = (on(&Device::Cpu), on(&gpu()));
    assert_agree("IMPALA", &before, &cpu, &gpu);
}

/// What the GPU tests compare, checked where every machine can: the same
/// update twice on the CPU agrees with itself exactly, and an update on
/// other data (another seed's batch) fails the agreement test.
#[test]
fn the_agreement_test_tells_the_same_update_from_another() {
    let (cfg, frags) = setup(Algorithm::Ppo(PpoConfig::default()), 2);
    // The same actor's third fragment: other episodes.
    let (_, more) = setup(Algorithm::Ppo(PpoConfig::default()), 3);
    let spec = cfg.model_spec(frags[0].obs_dim);
    let run = |batch: &[Fragment]| {
        let policy = Policy::new(spec.clone(), 11).unwrap();
        let mut ppo = Ppo::new(
            &policy,
            buridan_learner::algo::ppo::PpoSettings {
                epochs: 1,
                update_threads: 1,
                ..cfg.ppo_settings(cfg.algorithm.ppo().unwrap())
            },
        );
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        ppo.update(&policy, batch, &mut rng).unwrap();
        flat(&policy)
    };
    let before = flat(&Policy::new(spec.clone(), 11).unwrap());
    let (a, b) = (run(&frags), run(&frags));
    assert_eq!(a, b, "one update, twice");
    let (cosine, ratio) = agreement(&before, &a, &b);
    assert!(cosine > 0.999_999 && (ratio - 1.0).abs() < 1e-9);
    let c = run(&more[2..]);
    let (cosine, _) = agreement(&before, &a, &c);
    assert!(
        cosine < 0.99,
        "another batch's update agrees (cosine {cosine})"
    );
}

/// A default build asked for a GPU stops before it writes anything, and
/// says how to get a build that has one.
#[test]
#[cfg(not(feature = "cuda"))]
fn a_default_build_refuses_cuda_and_names_the_build_script() {
    let out = tempfile::tempdir().unwrap();
    let mut cfg = TrainConfig {
        task: Task::Grid("rm-1.1".into()),
        agents: 2,
        ..TrainConfig::default()
    };
    cfg.run.device = DeviceSpec::Cuda(0);
    let run_dir = out.path().join("run");
    let err = buridan_learner::train::Run::prepare(&cfg, &run_dir)
        .err()
        .expect("a default build has no CUDA");
    // The whole chain, as the binary reports it.
    let mut message = err.to_string();
    let mut source = std::error::Error::source(&err);
    while let Some(e) = source {
        message = format!("{message}: {e}");
        source = e.source();
    }
    assert!(message.contains("cuda:0"), "{message}");
    assert!(message.contains("scripts/build-cuda.sh"), "{message}");
    assert!(!run_dir.exists(), "nothing written");
}
