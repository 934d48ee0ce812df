//! PPO's critic warm-up: an update with `critic_only` set moves the value
//! weights alone (the value bias first by the batch's mean of `R − V`),
//! so the policy a run imitated acts exactly as before.

use buridan_env::Starts;
use buridan_learner::algo::ppo::{is_value_weight, Ppo, PpoSettings};
use buridan_learner::train::{ModelConfig, PpoConfig, Run, RunConfig, Task, TrainConfig};
use buridan_policy::{Fragment, Mode, ModelSpec, Policy};
use rand::SeedableRng;

fn fragments(cfg: &TrainConfig) -> (ModelSpec, Vec<Fragment>) {
    let dir = tempfile::tempdir().unwrap();
    let run = Run::prepare(cfg, dir.path()).unwrap();
    let mut actor = run.collector(0).unwrap();
    let frags = (0..2).map(|_| actor.collect().unwrap()).collect();
    (run.spec().clone(), frags)
}

/// Every weight by name.
fn weights(policy: &Policy) -> Vec<(String, Vec<f32>)> {
    (0..policy.spec().nets())
        .flat_map(|k| policy.net_vars(k))
        .map(|(name, var)| {
            let w = var
                .as_tensor()
                .flatten_all()
                .unwrap()
                .to_vec1::<f32>()
                .unwrap();
            (name, w)
        })
        .collect()
}

fn warm_up(mode: Mode, lstm: bool) {
    let cfg = TrainConfig {
        mode,
        task: Task::Grid("rm-2.1".into()),
        agents: 4,
        starts: Starts::Random,
        model: ModelConfig {
            lstm,
            ..ModelConfig::default()
        },
        run: RunConfig {
            envs_per_actor: 8,
            fragment_len: 40,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    };
    let (spec, frags) = fragments(&cfg);
    let policy = Policy::new(spec, 3).unwrap();
    let before = weights(&policy);
    let mut ppo = Ppo::new(
        &policy,
        PpoSettings {
            epochs: 3,
            ..cfg.ppo_settings(&PpoConfig::default())
        },
    );
    ppo.critic_only = true;
    let kl_coeffs = ppo.kl_coeffs.clone();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let first = ppo.update(&policy, &frags, &mut rng).unwrap();
    let after = weights(&policy);
    let mut value_moved = 0;
    for ((name, a), (_, b)) in before.iter().zip(&after) {
        if is_value_weight(name) {
            value_moved += usize::from(a != b);
        } else {
            assert_eq!(a, b, "{mode:?}: {name} moved during the warm-up");
        }
    }
    assert!(value_moved > 0, "{mode:?}: no value weight moved");
    // The policy did not change: the KL coefficients do not adapt.
    assert_eq!(ppo.kl_coeffs, kl_coeffs);
    // A fresh head predicts about 0 where the returns are several units:
    // the bias shift fits the scale, and a second warm-up update on the
    // same batch starts far closer.
    let second = ppo.update(&policy, &frags, &mut rng).unwrap();
    assert!(
        second.vf_loss < first.vf_loss,
        "{mode:?}: value loss {} then {}",
        first.vf_loss,
        second.vf_loss
    );
    // Off again: the policy learns.
    ppo.critic_only = false;
    ppo.update(&policy, &frags, &mut rng).unwrap();
    let trained = weights(&policy);
    let policy_moved = after
        .iter()
        .zip(&trained)
        .filter(|((name, a), (_, b))| !is_value_weight(name) && a != b)
        .count();
    assert!(policy_moved > 0, "{mode:?}: PPO left the policy alone");
}

#[test]
fn the_warm_up_fits_the_critic_of_a_recurrent_central_policy_alone() {
    warm_up(Mode::Cte, true);
}

#[test]
fn the_warm_up_fits_the_critic_of_a_shared_feed_forward_policy_alone() {
    warm_up(Mode::Ctde, false);
}
