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
use buridan_learner::algo::impala::{Impala, ImpalaSettings};
use buridan_learner::algo::ppo::{Ppo, PpoSettings};
use buridan_learner::train::{env_config, Algorithm, ImpalaConfig, PpoConfig, Task, TrainConfig};
use buridan_policy::{DeviceSpec, Fragment, Inference, Mode, ModelSpec, Policy};
use candle_core::Device;
use rand::SeedableRng;

/// The first GPU; a `cuda` build without one fails the test here.
fn gpu() -> Device {
    DeviceSpec::Cuda(0)
        .open()
        .unwrap_or_else(|e| panic!("parity test on a `cuda` build: {e}"))
}

/// The recipe's policy shape (64-cell LSTM) on rm-2.1, 4 agents: the
/// config, the spec, and `count` fragments collected by it on the CPU.
fn setup(algorithm: Algorithm, count: usize) -> (TrainConfig, ModelSpec, Vec<Fragment>) {
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
        inference: Inference::new(Policy::new(spec.clone(), 3).unwrap(), rows, 1),
        behaviour: cfg.behaviour(),
        venv,
        fragment_len: cfg.run.fragment_len,
        version: 0,
        shield: None,
    };
    let frags = (0..count).map(|_| actor.collect().unwrap()).collect();
    (cfg, spec, frags)
}

/// The seed of the weights every compared update starts from.
const WEIGHTS: u64 = 11;

/// The weights every compared update starts from, flat.
fn initial(spec: &ModelSpec) -> Vec<f32> {
    flat(&Policy::new(spec.clone(), WEIGHTS).unwrap())
}

/// One PPO update of `frags` (one epoch, one thread, fixed shuffling) from
/// the initial weights on `device`: the weights after it, flat.
fn ppo_update(
    cfg: &TrainConfig,
    spec: &ModelSpec,
    frags: &[Fragment],
    device: &Device,
) -> Vec<f32> {
    let policy = Policy::new_on(spec.clone(), WEIGHTS, device).unwrap();
    let settings = PpoSettings {
        epochs: 1,
        update_threads: 1,
        ..cfg.ppo_settings(cfg.algorithm.ppo().unwrap())
    };
    let mut ppo = Ppo::new(&policy, settings);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    ppo.update(&policy, frags, &mut rng).unwrap();
    flat(&policy)
}

/// One IMPALA gradient step of `frags` (one thread) from the initial
/// weights on `device`: the weights after it, flat.
fn impala_step(
    cfg: &TrainConfig,
    spec: &ModelSpec,
    frags: &[Fragment],
    device: &Device,
) -> Vec<f32> {
    let policy = Policy::new_on(spec.clone(), WEIGHTS, device).unwrap();
    let settings = ImpalaSettings {
        update_threads: 1,
        ..cfg.impala_settings(cfg.algorithm.impala().unwrap())
    };
    let mut impala = Impala::new(&policy, settings);
    impala.update(&policy, frags).unwrap();
    flat(&policy)
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
    let (cfg, spec, frags) = setup(Algorithm::Ppo(PpoConfig::default()), 2);
    let cpu = ppo_update(&cfg, &spec, &frags, &Device::Cpu);
    let gpu = ppo_update(&cfg, &spec, &frags, &gpu());
    assert_agree("PPO", &initial(&spec), &cpu, &gpu);
}

#[test]
#[cfg_attr(
    not(feature = "cuda"),
    ignore = "needs a `cuda` build (scripts/build-cuda.sh) on a machine with a GPU"
)]
fn an_impala_step_on_the_gpu_moves_the_weights_as_on_the_cpu() {
    let (cfg, spec, frags) = setup(Algorithm::Impala(ImpalaConfig::default()), 1);
    let cpu = impala_step(&cfg, &spec, &frags, &Device::Cpu);
    let gpu = impala_step(&cfg, &spec, &frags, &gpu());
    assert_agree("IMPALA", &initial(&spec), &cpu, &gpu);
}

/// What the GPU tests compare, checked where every machine can: the same
/// update twice on the CPU agrees with itself exactly, and an update on
/// other data (the same actor's third fragment: other episodes) fails the
/// agreement test.
#[test]
fn the_agreement_test_tells_the_same_update_from_another() {
    let (cfg, spec, frags) = setup(Algorithm::Ppo(PpoConfig::default()), 3);
    let (batch, other) = (&frags[..2], &frags[2..]);
    let before = initial(&spec);
    let a = ppo_update(&cfg, &spec, batch, &Device::Cpu);
    let b = ppo_update(&cfg, &spec, batch, &Device::Cpu);
    assert_eq!(a, b, "one update, twice");
    let (cosine, ratio) = agreement(&before, &a, &b);
    assert!(cosine > 0.999_999 && (ratio - 1.0).abs() < 1e-9);
    let c = ppo_update(&cfg, &spec, other, &Device::Cpu);
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
