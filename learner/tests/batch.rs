//! The actor → fragment → learner batch path: truncation bootstrap
//! observations, per-weight-set row routing and the value pass's
//! `V(s_{t+1})` convention.

use std::sync::Arc;

use buridan_actor::Collector;
use buridan_env::{Map, ObsKind, Starts, VecEnv};
use buridan_learner::algo::batch::{build_net_batches, evaluate, BatchTensors};
use buridan_learner::train::{env_config, RunConfig, Task, TrainConfig};
use buridan_policy::{Inference, Mode, Policy};
use candle_core::{Device, Tensor};

fn actor(cfg: &TrainConfig, kind: ObsKind) -> (Collector, Policy) {
    let map = Arc::new(Map::load(&cfg.map_label()).unwrap());
    let venv = VecEnv::new(map, env_config(cfg, 3), cfg.run.envs_per_actor, kind, 1).unwrap();
    let spec = cfg.model_spec(venv.obs_dim());
    let policy = Policy::new(spec.clone(), 5).unwrap();
    let rows = venv.obs().len() / venv.obs_dim();
    let a = Collector {
        id: 0,
        inference: Inference::new(policy.clone(), rows, 9),
        behaviour: cfg.behaviour(),
        venv,
        fragment_len: cfg.run.fragment_len,
        version: 0,
        shield: None,
    };
    (a, policy)
}

fn cfg(mode: Mode) -> TrainConfig {
    TrainConfig {
        mode,
        task: Task::Grid("rm-2.1".into()),
        agents: 3,
        starts: Starts::Random,
        t_max: 7,
        run: RunConfig {
            // truncations inside every 20-step fragment
            envs_per_actor: 2,
            fragment_len: 20,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    }
}

#[test]
fn fragments_record_truncations_and_bootstrap_observations() {
    let c = cfg(Mode::Ctde);
    let (mut a, _) = actor(&c, ObsKind::Local);
    let f = a.collect().unwrap();
    f.validate().unwrap();
    let (t, b, d) = (f.len, f.rows, f.obs_dim);
    assert_eq!((t, b, f.rows_per_env), (20, 6, 3));
    assert_eq!(f.env_steps, 40);
    // Episodes of 7 steps: truncated at t = 6 and 13, every row.
    for s in 0..t {
        for r in 0..b {
            let k = s * b + r;
            assert_eq!(f.truncated[k] != 0, s == 6 || s == 13, "t={s} r={r}");
            assert_eq!(f.terminated[k], 0);
        }
    }
    assert_eq!(f.final_obs_index.len(), 2 * b);
    assert_eq!(f.episodes.len(), 4); // 2 envs × 2 finished episodes
    for (q, &idx) in f.final_obs_index.iter().enumerate() {
        let (s, r) = (idx as usize / b, idx as usize % b);
        let fin = &f.final_obs[q * d..(q + 1) * d];
        let next = &f.obs[((s + 1) * b + r) * d..((s + 1) * b + r + 1) * d];
        // The final observation is the last state, not the next episode's first.
        assert_ne!(fin, next);
        // Truncation penalties land on the truncated step: −1 off the goal.
        assert!(f.rewards[idx as usize] <= 0.5);
    }
    assert_eq!(&f.last_obs[..], a.venv.obs());
}

#[test]
fn value_pass_bootstraps_from_final_and_last_observations() {
    for mode in [Mode::Ctde, Mode::Dte, Mode::Cte] {
        let c = cfg(mode);
        let kind = if mode == Mode::Cte {
            ObsKind::Central
        } else {
            ObsKind::Local
        };
        let (mut a, policy) = actor(&c, kind);
        let frags = vec![a.collect().unwrap(), a.collect().unwrap()];
        let batches = build_net_batches(&frags, policy.spec()).unwrap();
        assert_eq!(batches.len(), if mode == Mode::Dte { 3 } else { 1 });
        let dev = Device::Cpu;
        for (k, nb) in batches.iter().enumerate() {
            // Rows of weight set k: agent k of every env of every fragment.
            let per_frag = frags[0].rows / policy.spec().nets();
            assert_eq!(nb.rows, 2 * per_frag);
            let bt = BatchTensors::new(nb, &dev).unwrap();
            let ev = evaluate(policy.net(k), nb, &bt, 32, &dev).unwrap();
            let v = |obs: &[f32]| -> f32 {
                let t = Tensor::from_slice(obs, (1, nb.obs_dim), &dev).unwrap();
                policy
                    .net(k)
                    .forward(&t)
                    .unwrap()
                    .value
                    .to_vec1::<f32>()
                    .unwrap()[0]
            };
            let (t, r, d) = (nb.t, nb.rows, nb.obs_dim);
            for s in 0..t {
                for j in 0..r {
                    let i = s * r + j;
                    let expected = if nb.truncated[i] {
                        let q = nb.final_index.iter().position(|&x| x == i).unwrap();
                        v(&nb.final_obs[q * d..(q + 1) * d])
                    } else if s + 1 < t {
                        ev.values_vec[i + r]
                    } else {
                        v(&nb.last_obs[j * d..(j + 1) * d])
                    };
                    assert!(
                        (ev.next_values[i] - expected).abs() < 1e-5,
                        "{mode} net {k} t={s} row {j}: {} vs {expected}",
                        ev.next_values[i]
                    );
                }
            }
            // The behaviour log-probs recomputed from stored logits match the actors'.
            let lp: Vec<f32> = bt.behaviour_logp.to_vec1().unwrap();
            let mut from_actor = Vec::new();
            for s in 0..t {
                for f in &frags {
                    for row in 0..f.rows {
                        if policy.spec().net_of_row(row) == k {
                            from_actor.push(f.behaviour_logp[s * f.rows + row]);
                        }
                    }
                }
            }
            for (x, y) in lp.iter().zip(&from_actor) {
                assert!((x - y).abs() < 1e-4, "{x} vs {y}");
            }
        }
    }
}

#[test]
fn recurrent_value_pass_bootstraps_from_the_actors_state() {
    // With an LSTM the fragment-end bootstrap value V(last_obs) must use the
    // state the actor carried into the next fragment.
    let mut c = cfg(Mode::Ctde);
    c.model.lstm = true;
    c.model.lstm_cells = 8;
    c.model.hidden = vec![16, 16];
    c.t_max = 100; // no episode ends at T−1
    let (mut a, policy) = actor(&c, ObsKind::Local);
    let frags = vec![a.collect().unwrap()];
    let nb = &build_net_batches(&frags, policy.spec()).unwrap()[0];
    let dev = Device::Cpu;
    let bt = BatchTensors::new(nb, &dev).unwrap();
    let ev = evaluate(policy.net(0), nb, &bt, 32, &dev).unwrap();
    let st = a.inference.state().unwrap();
    let (r, cells) = (nb.rows, 8);
    let mut onehot = Vec::new();
    buridan_policy::infer::one_hot_prev(&st.prev_actions, 5, &mut onehot);
    let input = buridan_policy::RecurrentInput {
        prev_action: Tensor::from_vec(onehot, (r, 5), &dev).unwrap(),
        prev_reward: Tensor::from_slice(&st.prev_rewards, (r, 1), &dev).unwrap(),
        h: Tensor::from_slice(&st.h, (r, cells), &dev).unwrap(),
        c: Tensor::from_slice(&st.c, (r, cells), &dev).unwrap(),
    };
    let obs = Tensor::from_slice(&nb.last_obs, (r, nb.obs_dim), &dev).unwrap();
    let (out, _) = policy.net(0).step(&obs, &input).unwrap();
    let v: Vec<f32> = out.value.to_vec1().unwrap();
    for (j, vj) in v.iter().enumerate() {
        let got = ev.next_values[(nb.t - 1) * r + j];
        assert!((got - vj).abs() < 1e-5, "row {j}: {got} vs {vj}");
    }
}
