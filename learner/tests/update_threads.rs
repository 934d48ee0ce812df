//! The update's gradient shared across threads (PPO's minibatches, IMPALA's
//! train batch): the same update as on one thread, up to float rounding,
//! for feed-forward and recurrent nets and for several weight sets.

use buridan_env::Starts;
use buridan_learner::algo::impala::{Impala, ImpalaSettings};
use buridan_learner::algo::ppo::{Ppo, PpoSettings};
use buridan_learner::train::{ImpalaConfig, ModelConfig, Run, RunConfig, Task, TrainConfig};
use buridan_policy::{Fragment, Mode, ModelSpec, Policy};
use rand::SeedableRng;

/// `count` fragments collected by actor 0 of a run of `cfg`, and the run's
/// model spec.
fn fragments(cfg: &TrainConfig, count: usize) -> (ModelSpec, Vec<Fragment>) {
    let dir = tempfile::tempdir().unwrap();
    let run = Run::prepare(cfg, dir.path()).unwrap();
    let mut actor = run.collector(0).unwrap();
    let frags = (0..count).map(|_| actor.collect().unwrap()).collect();
    (run.spec().clone(), frags)
}

fn flat_weights(policy: &Policy) -> Vec<f32> {
    let mut w = Vec::new();
    for k in 0..policy.spec().nets() {
        for (_, var) in policy.net_vars(k) {
            w.extend(
                var.as_tensor()
                    .flatten_all()
                    .unwrap()
                    .to_vec1::<f32>()
                    .unwrap(),
            );
        }
    }
    w
}

#[derive(Clone, Copy)]
enum Algo {
    Ppo,
    Impala,
}

/// All weights of a fresh policy before and after one update with
/// `threads` threads (PPO: two epochs), and the update's mean loss, KL and
/// gradient norm.
fn update_with(algo: Algo, cfg: &TrainConfig, threads: usize) -> (Vec<f32>, Vec<f32>, [f64; 4]) {
    let (spec, frags) = fragments(cfg, 2);
    let policy = Policy::new(spec, 11).unwrap();
    let before = flat_weights(&policy);
    let stats = match algo {
        Algo::Ppo => {
            let settings = PpoSettings {
                epochs: 2,
                update_threads: threads,
                ..cfg.ppo_settings(cfg.algorithm.ppo().unwrap())
            };
            let mut ppo = Ppo::new(&policy, settings);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
            ppo.update(&policy, &frags, &mut rng).unwrap()
        }
        Algo::Impala => {
            let settings = ImpalaSettings {
                update_threads: threads,
                ..cfg.impala_settings(&ImpalaConfig::default())
            };
            Impala::new(&policy, settings)
                .update(&policy, &frags)
                .unwrap()
        }
    };
    let means = [stats.total_loss, stats.kl, stats.grad_norm, stats.mean_rho];
    (before, flat_weights(&policy), means)
}

fn assert_same_update(algo: Algo, cfg: TrainConfig) {
    let (before, one, means1) = update_with(algo, &cfg, 1);
    let (_, three, means3) = update_with(algo, &cfg, 3);
    assert_eq!(one.len(), three.len());
    let worst = one
        .iter()
        .zip(&three)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-5, "weights differ by {worst}");
    // The update moved the weights: the comparison is not between two
    // untouched copies.
    let moved = before.iter().zip(&one).filter(|(a, b)| a != b).count();
    assert!(
        moved > one.len() / 2,
        "only {moved} of {} weights moved",
        one.len()
    );
    // Adam is blind to a gradient's scale; the norm is not (a share
    // weighted twice would show here, not in the weights).
    for (name, a, b) in ["loss", "kl", "grad norm", "mean rho"]
        .iter()
        .zip(means1.iter().zip(&means3))
        .map(|(n, (a, b))| (n, a, b))
    {
        assert!((a - b).abs() < 1e-6 + 1e-4 * a.abs(), "{name}: {a} vs {b}");
    }
}

fn cfg(mode: Mode, lstm: bool) -> TrainConfig {
    let mut c = TrainConfig {
        mode,
        task: Task::Grid("rm-2.1".into()),
        agents: 4,
        starts: Starts::Random,
        model: ModelConfig {
            lstm,
            ..ModelConfig::default()
        },
        run: RunConfig {
            envs_per_actor: 16,
            fragment_len: 40,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    };
    // One minibatch of the whole batch per weight set: 2 × 640 × 4 samples.
    c.algorithm.ppo_mut().unwrap().minibatch = 100_000;
    c
}

#[test]
fn three_threads_update_a_shared_net_as_one_does() {
    assert_same_update(Algo::Ppo, cfg(Mode::Ctde, false));
}

#[test]
fn three_threads_update_one_net_per_agent_as_one_does() {
    assert_same_update(Algo::Ppo, cfg(Mode::Dte, false));
}

#[test]
fn three_threads_update_a_recurrent_net_as_one_does() {
    assert_same_update(Algo::Ppo, cfg(Mode::Ctde, true));
}

// IMPALA: 2 fragments × 16 envs × 40 steps × 4 agents = 5,120 samples, three
// shares of whole trajectories (rows), V-trace per share.

#[test]
fn three_threads_take_impalas_step_on_a_shared_net_as_one_does() {
    assert_same_update(Algo::Impala, cfg(Mode::Ctde, false));
}

#[test]
fn three_threads_take_impalas_step_on_one_net_per_agent_as_one_does() {
    assert_same_update(Algo::Impala, cfg(Mode::Dte, false));
}

#[test]
fn three_threads_take_impalas_step_on_a_recurrent_net_as_one_does() {
    assert_same_update(Algo::Impala, cfg(Mode::Ctde, true));
}
