//! Behavioural tests of the policy crate: masking, joint heads, LSTM resets,
//! gradients, checkpoints.

use buridan_policy::dist::{self, MASK_LOGIT};
use buridan_policy::{
    ActMode, Inference, LstmSpec, Mode, ModelSpec, Policy, PolicyError, RecurrentInput, ValueHead,
    NO_ACTION,
};
use candle_core::{DType, Device, Tensor};
use rand::SeedableRng;

fn obs_batch(rows: usize, dim: usize, salt: f32) -> Vec<f32> {
    (0..rows * dim)
        .map(|i| (i as f32 * 0.37 + salt).sin() * 0.8)
        .collect()
}

fn lstm_spec(mode: Mode, agents: usize, obs_dim: usize) -> ModelSpec {
    ModelSpec {
        hidden: vec![8, 8],
        lstm: Some(LstmSpec {
            cells: 6,
            ..LstmSpec::default()
        }),
        ..ModelSpec::new(mode, agents, obs_dim)
    }
}

#[test]
fn masked_actions_are_never_sampled_and_have_zero_probability() {
    // Logits strongly favour the masked action 1; it must never come out.
    let logits = [0.0f32, 50.0, 0.0, 1.0, 0.0];
    let mask = [1u8, 0, 1, 1, 0];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut counts = [0usize; 5];
    for _ in 0..20_000 {
        let (a, lp) = dist::sample_head(&logits, &mask, &mut rng).unwrap();
        counts[a as usize] += 1;
        assert!(lp <= 0.0);
    }
    assert_eq!(counts[1], 0);
    assert_eq!(counts[4], 0);
    // Legal probabilities: e^0, e^0, e^1 over (2 + e) → 0.2119, 0.2119, 0.5761.
    let p3 = counts[3] as f64 / 20_000.0;
    assert!((p3 - std::f64::consts::E / (2.0 + std::f64::consts::E)).abs() < 0.02);
    assert_eq!(dist::greedy_head(&logits, &mask).unwrap().0, 3);

    // The tensor path gives masked entries probability exactly 0.
    let dev = Device::Cpu;
    let l = Tensor::from_slice(&logits, (1, 5), &dev).unwrap();
    let bias = dist::mask_bias(&mask, 1, 5, &dev).unwrap();
    let lp = dist::masked_log_probs(&l, &bias, 1).unwrap();
    let p: Vec<f32> = lp.exp().unwrap().flatten_all().unwrap().to_vec1().unwrap();
    assert_eq!(p[1], 0.0);
    assert_eq!(p[4], 0.0);
    assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    // Entropy stays finite with masked entries: −Σ p log p over the 3 legal ones.
    let h = dist::entropy(&lp).unwrap().to_vec1::<f32>().unwrap()[0];
    let z = 2.0 + 1f32.exp();
    let expected = -(2.0 * (1.0 / z) * (1.0 / z).ln() + (1f32.exp() / z) * (1f32.exp() / z).ln());
    assert!((h - expected).abs() < 1e-5, "{h} vs {expected}");
    const { assert!(MASK_LOGIT < -1e8) };
}

#[test]
fn inference_respects_masks_for_every_row() {
    let spec = ModelSpec::new(Mode::Ctde, 2, 12);
    let mut inf = Inference::new(Policy::new(spec, 5).unwrap(), 64, 9);
    let obs = obs_batch(64, 12, 0.3);
    // Row r allows only actions {0, r % 5}.
    let mut masks = vec![0u8; 64 * 5];
    for r in 0..64 {
        masks[r * 5] = 1;
        masks[r * 5 + r % 5] = 1;
    }
    let (mut a, mut lp) = (vec![0u8; 64], vec![0f32; 64]);
    for _ in 0..50 {
        inf.act(&obs, &masks, ActMode::Sample, &mut a, &mut lp)
            .unwrap();
        for (r, &ar) in a.iter().enumerate() {
            assert!(ar == 0 || ar as usize == r % 5, "row {r} took {ar}");
        }
    }
    masks[7 * 5] = 0;
    masks[7 * 5 + 2] = 0;
    assert!(matches!(
        inf.act(&obs, &masks, ActMode::Sample, &mut a, &mut lp),
        Err(PolicyError::EmptyMask { row: 7, head: 0 })
    ));
}

#[test]
fn cte_joint_log_prob_is_the_sum_over_heads() {
    let spec = ModelSpec::new(Mode::Cte, 3, 20);
    let policy = Policy::new(spec, 11).unwrap();
    let dev = Device::Cpu;
    let rows = 4;
    let obs = Tensor::from_vec(obs_batch(rows, 20, 1.0), (rows, 20), &dev).unwrap();
    let out = policy.forward(&obs).unwrap();
    assert_eq!(out.logits.dims(), &[rows, 15]);
    let mut masks = vec![1u8; rows * 15];
    masks[2] = 0; // row 0, head 0, action 2
    masks[5 + 4] = 0; // row 0, head 1, action 4
    let bias = dist::mask_bias(&masks, rows, 15, &dev).unwrap();
    let lp = dist::masked_log_probs(&out.logits, &bias, 3).unwrap();
    let actions: Vec<u32> = vec![0, 1, 3, 4, 4, 0, 2, 2, 1, 3, 3, 3];
    let at = Tensor::from_vec(actions.clone(), (rows, 3), &dev).unwrap();
    let joint = dist::joint_log_prob(&lp, &at)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let lp3: Vec<Vec<Vec<f32>>> = lp.to_vec3().unwrap();
    for r in 0..rows {
        let sum: f32 = (0..3).map(|h| lp3[r][h][actions[r * 3 + h] as usize]).sum();
        assert!((joint[r] - sum).abs() < 1e-5);
    }
    // Entropy and KL are sums over heads too.
    let ent = dist::entropy(&lp).unwrap().to_vec1::<f32>().unwrap();
    for r in 0..rows {
        let sum: f32 = (0..3)
            .map(|h| -lp3[r][h].iter().map(|l| l.exp() * l).sum::<f32>())
            .sum();
        assert!((ent[r] - sum).abs() < 1e-5);
    }
    let kl_self = dist::kl(&lp, &lp).unwrap().to_vec1::<f32>().unwrap();
    assert!(kl_self.iter().all(|k| k.abs() < 1e-6));

    // The actor's slice path agrees with the tensor path.
    let mut inf = Inference::new(policy, rows, 1);
    let (mut a, mut logp) = (vec![0u8; rows * 3], vec![0f32; rows]);
    inf.act(
        &obs.flatten_all().unwrap().to_vec1::<f32>().unwrap(),
        &masks,
        ActMode::Sample,
        &mut a,
        &mut logp,
    )
    .unwrap();
    let at = Tensor::from_vec(
        a.iter().map(|&x| x as u32).collect::<Vec<_>>(),
        (rows, 3),
        &dev,
    )
    .unwrap();
    let joint = dist::joint_log_prob(&lp, &at)
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    for r in 0..rows {
        assert!((joint[r] - logp[r]).abs() < 1e-5);
    }
    // Row 0: head 0 never takes the masked action 2, head 1 never 4.
    assert!(a[0] != 2 && a[1] != 4);
}

#[test]
fn lstm_state_resets_at_episode_boundaries() {
    let spec = lstm_spec(Mode::Ctde, 2, 7);
    let policy = Policy::new(spec.clone(), 21).unwrap();
    let rows = 2;
    let masks = vec![1u8; rows * 5];
    let mut inf = Inference::new(policy.clone(), rows, 0);
    let (mut a, mut lp) = (vec![0u8; rows], vec![0f32; rows]);
    let obs0 = obs_batch(rows, 7, 0.0);
    let first = inf
        .act(&obs0, &masks, ActMode::Greedy, &mut a, &mut lp)
        .unwrap()
        .to_vec();
    // Advance a few steps: the state and so the logits move away.
    for k in 0..3 {
        inf.state_mut()
            .unwrap()
            .observe(&a.clone(), &[0.5, -1.0], &[0, 0]);
        inf.act(
            &obs_batch(rows, 7, k as f32),
            &masks,
            ActMode::Greedy,
            &mut a,
            &mut lp,
        )
        .unwrap();
    }
    let st = inf.state().unwrap();
    assert!(st.h.iter().any(|&x| x != 0.0));
    assert!(st.prev_actions.iter().all(|&x| x != NO_ACTION));
    // Row 1's episode ends: only row 1 is reset.
    inf.state_mut()
        .unwrap()
        .observe(&a.clone(), &[0.5, -1.0], &[0, 1]);
    let st = inf.state().unwrap();
    assert!(st.h[6..].iter().all(|&x| x == 0.0) && st.c[6..].iter().all(|&x| x == 0.0));
    assert_eq!(st.prev_actions[1], NO_ACTION);
    assert_eq!(st.prev_rewards[1], 0.0);
    assert!(st.h[..6].iter().any(|&x| x != 0.0));
    let again = inf
        .act(&obs0, &masks, ActMode::Greedy, &mut a, &mut lp)
        .unwrap()
        .to_vec();
    // Row 1 behaves exactly like at the start of an episode; row 0 does not.
    for j in 5..10 {
        assert!((again[j] - first[j]).abs() < 1e-6);
    }
    assert!((0..5).any(|j| (again[j] - first[j]).abs() > 1e-6));
}

#[test]
fn lstm_unroll_matches_step_by_step_inference_with_resets() {
    // The learner's unroll (resets via `keep`) reproduces what the actor saw.
    let spec = lstm_spec(Mode::Cte, 2, 9);
    let policy = Policy::new(spec.clone(), 4).unwrap();
    let (t_len, rows, w) = (6, 3, 10);
    let mut inf = Inference::new(policy.clone(), rows, 0);
    let masks = vec![1u8; rows * w];
    let done_at = |t: usize, r: usize| (t == 1 && r == 0) || (t == 3 && r == 2);
    let mut all_obs = Vec::new();
    let mut logits_seen = Vec::new();
    let mut prev_a = Vec::new();
    let mut prev_r = Vec::new();
    let mut keep = Vec::new();
    let (mut a, mut lp) = (vec![0u8; rows * 2], vec![0f32; rows]);
    for t in 0..t_len {
        let obs = obs_batch(rows, 9, t as f32 * 0.7);
        let st = inf.state().unwrap().clone();
        let mut onehot = Vec::new();
        buridan_policy::infer::one_hot_prev(&st.prev_actions, 5, &mut onehot);
        prev_a.extend(onehot);
        prev_r.extend(st.prev_rewards.iter().copied());
        for r in 0..rows {
            keep.push(if t > 0 && done_at(t - 1, r) {
                0.0f32
            } else {
                1.0
            });
        }
        logits_seen.extend_from_slice(
            inf.act(&obs, &masks, ActMode::Sample, &mut a, &mut lp)
                .unwrap(),
        );
        all_obs.extend(obs);
        let rewards: Vec<f32> = (0..rows).map(|r| (t + r) as f32 * 0.1).collect();
        let done: Vec<u8> = (0..rows).map(|r| u8::from(done_at(t, r))).collect();
        inf.state_mut()
            .unwrap()
            .observe(&a.clone(), &rewards, &done);
    }
    let dev = Device::Cpu;
    let n = t_len * rows;
    let out = policy
        .net(0)
        .unroll(
            &Tensor::from_vec(all_obs, (n, 9), &dev).unwrap(),
            &Tensor::from_vec(prev_a, (n, w), &dev).unwrap(),
            &Tensor::from_vec(prev_r, (n, 1), &dev).unwrap(),
            &Tensor::from_vec(keep, (n, 1), &dev).unwrap(),
            &Tensor::zeros((rows, 6), DType::F32, &dev).unwrap(),
            &Tensor::zeros((rows, 6), DType::F32, &dev).unwrap(),
            t_len,
            32,
        )
        .unwrap();
    let got: Vec<f32> = out.logits.flatten_all().unwrap().to_vec1().unwrap();
    assert_eq!(got.len(), logits_seen.len());
    for (g, s) in got.iter().zip(&logits_seen) {
        assert!((g - s).abs() < 1e-5, "{g} vs {s}");
    }
}

#[test]
fn finite_difference_gradient_check() {
    // Loss = −mean joint log-prob + 0.5·mean value² − 0.1·mean entropy on a
    // tiny separate-value model; candle's backward vs central differences.
    let spec = ModelSpec {
        hidden: vec![4, 3],
        value: ValueHead::Separate,
        ..ModelSpec::new(Mode::Cte, 2, 5)
    };
    let policy = Policy::new(spec, 2).unwrap();
    let dev = Device::Cpu;
    let rows = 3;
    let obs = Tensor::from_vec(obs_batch(rows, 5, 0.5), (rows, 5), &dev).unwrap();
    let mut masks = vec![1u8; rows * 10];
    masks[1] = 0;
    masks[13] = 0;
    let bias = dist::mask_bias(&masks, rows, 10, &dev).unwrap();
    let actions = Tensor::from_vec(vec![0u32, 3, 2, 4, 1, 1], (rows, 2), &dev).unwrap();
    let loss = |p: &Policy| -> Tensor {
        let out = p.forward(&obs).unwrap();
        // Scale logits up so the gradient is not dominated by the 0.01 init.
        let lp = dist::masked_log_probs(&(out.logits * 30.0).unwrap(), &bias, 2).unwrap();
        let logp = dist::joint_log_prob(&lp, &actions).unwrap();
        let ent = dist::entropy(&lp).unwrap();
        let v2 = (out.value * 20.0).unwrap().sqr().unwrap();
        ((logp.mean_all().unwrap().neg().unwrap() + (v2.mean_all().unwrap() * 0.5).unwrap())
            .unwrap()
            - (ent.mean_all().unwrap() * 0.1).unwrap())
        .unwrap()
    };
    let l = loss(&policy);
    let grads = l.backward().unwrap();
    let mut checked = 0;
    for (name, var) in policy.vars() {
        let g: Vec<f32> = grads
            .get(var.as_tensor())
            .unwrap_or_else(|| panic!("no grad for {name}"))
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        let base: Vec<f32> = var.as_tensor().flatten_all().unwrap().to_vec1().unwrap();
        for i in (0..base.len()).step_by(3) {
            let eps = 1e-2f32;
            let mut plus = base.clone();
            plus[i] += eps;
            var.set(&Tensor::from_vec(plus, var.dims(), &dev).unwrap())
                .unwrap();
            let lp = loss(&policy).to_scalar::<f32>().unwrap() as f64;
            let mut minus = base.clone();
            minus[i] -= eps;
            var.set(&Tensor::from_vec(minus, var.dims(), &dev).unwrap())
                .unwrap();
            let lm = loss(&policy).to_scalar::<f32>().unwrap() as f64;
            var.set(&Tensor::from_vec(base.clone(), var.dims(), &dev).unwrap())
                .unwrap();
            let numeric = (lp - lm) / (2.0 * eps as f64);
            let analytic = g[i] as f64;
            let tol = 2e-3 + 3e-2 * numeric.abs().max(analytic.abs());
            assert!(
                (numeric - analytic).abs() < tol,
                "{name}[{i}]: numeric {numeric} vs backward {analytic}"
            );
            checked += 1;
        }
    }
    assert!(checked > 20);
}

#[test]
fn checkpoint_round_trip_gives_identical_outputs() {
    let dir = tempfile::tempdir().unwrap();
    for (k, spec) in [
        ModelSpec::new(Mode::Ctde, 2, 13),
        ModelSpec {
            value: ValueHead::Separate,
            ..ModelSpec::new(Mode::Dte, 3, 13)
        },
        lstm_spec(Mode::Cte, 2, 13),
    ]
    .into_iter()
    .enumerate()
    {
        let path = dir.path().join(format!("ck{k}"));
        let p = Policy::new(spec.clone(), 100 + k as u64).unwrap();
        p.save(&path).unwrap();
        assert!(path.join("spec.json").is_file() && path.join("model.safetensors").is_file());
        let q = Policy::load_expecting(&path, &spec, &Device::Cpu).unwrap();
        let rows = 6;
        let obs = Tensor::from_vec(obs_batch(rows, 13, 2.0), (rows, 13), &Device::Cpu).unwrap();
        if spec.lstm.is_none() {
            let (a, b) = (p.forward(&obs).unwrap(), q.forward(&obs).unwrap());
            let (la, lb): (Vec<f32>, Vec<f32>) = (
                a.logits.flatten_all().unwrap().to_vec1().unwrap(),
                b.logits.flatten_all().unwrap().to_vec1().unwrap(),
            );
            assert_eq!(la, lb);
            assert_eq!(
                a.value.to_vec1::<f32>().unwrap(),
                b.value.to_vec1::<f32>().unwrap()
            );
        } else {
            let dev = Device::Cpu;
            let input = RecurrentInput {
                prev_action: Tensor::ones((rows, 10), DType::F32, &dev).unwrap(),
                prev_reward: Tensor::ones((rows, 1), DType::F32, &dev).unwrap(),
                h: Tensor::ones((rows, 6), DType::F32, &dev).unwrap(),
                c: Tensor::ones((rows, 6), DType::F32, &dev).unwrap(),
            };
            let a = p.net(0).step(&obs, &input).unwrap().0;
            let b = q.net(0).step(&obs, &input).unwrap().0;
            assert_eq!(
                a.logits.flatten_all().unwrap().to_vec1::<f32>().unwrap(),
                b.logits.flatten_all().unwrap().to_vec1::<f32>().unwrap()
            );
        }
        assert_eq!(p.weights(3).unwrap(), q.weights(3).unwrap());
    }
    // Typed errors: missing files, spec mismatch, shape mismatch.
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    assert!(matches!(
        Policy::load(&empty),
        Err(PolicyError::MissingFile {
            file: "spec.json",
            ..
        })
    ));
    let ck0 = dir.path().join("ck0");
    let other = ModelSpec::new(Mode::Ctde, 2, 14);
    assert!(matches!(
        Policy::load_expecting(&ck0, &other, &Device::Cpu),
        Err(PolicyError::SpecMismatch { .. })
    ));
    // Weights of a 13-dim model under a 14-dim spec.
    std::fs::write(
        ck0.join("spec.json"),
        serde_json::to_string(&other).unwrap(),
    )
    .unwrap();
    match Policy::load(&ck0) {
        Err(PolicyError::ShapeMismatch {
            name,
            expected,
            found,
        }) => {
            assert_eq!(name, "net0.pi.0.weight");
            assert_eq!(expected, vec![64, 14]);
            assert_eq!(found, vec![64, 13]);
        }
        other => panic!("expected a shape mismatch, got {other:?}"),
    }
    std::fs::remove_file(ck0.join("model.safetensors")).unwrap();
    assert!(matches!(
        Policy::load(&ck0),
        Err(PolicyError::MissingFile {
            file: "model.safetensors",
            ..
        })
    ));
    std::fs::write(ck0.join("spec.json"), "{ not json").unwrap();
    assert!(matches!(
        Policy::load(&ck0),
        Err(PolicyError::BadSpecFile { .. })
    ));
}

#[test]
fn dte_uses_one_weight_set_per_agent() {
    let spec = ModelSpec::new(Mode::Dte, 2, 6);
    let policy = Policy::new(spec, 8).unwrap();
    assert_eq!(policy.nets().len(), 2);
    let dev = Device::Cpu;
    // The same observation in both agent slots of an env gives different
    // logits (different weights); routed rows match each net's own forward.
    let one = obs_batch(1, 6, 0.1);
    let obs: Vec<f32> = one.iter().chain(one.iter()).copied().collect();
    let t = Tensor::from_vec(obs, (2, 6), &dev).unwrap();
    let out = policy.forward(&t).unwrap();
    let l: Vec<Vec<f32>> = out.logits.to_vec2().unwrap();
    assert_ne!(l[0], l[1]);
    let single = Tensor::from_vec(one, (1, 6), &dev).unwrap();
    let l1: Vec<Vec<f32>> = policy
        .net(1)
        .forward(&single)
        .unwrap()
        .logits
        .to_vec2()
        .unwrap();
    assert_eq!(l[1], l1[0]);
    // Inference routes the same way.
    let mut inf = Inference::new(policy, 2, 0);
    let (mut a, mut lp) = (vec![0u8; 2], vec![0f32; 2]);
    let logits = inf
        .act(
            &t.flatten_all().unwrap().to_vec1::<f32>().unwrap(),
            &[1; 10],
            ActMode::Greedy,
            &mut a,
            &mut lp,
        )
        .unwrap();
    for j in 0..5 {
        assert!((logits[5 + j] - l1[0][j]).abs() < 1e-6);
    }
}

#[test]
fn fast_tanh_matches_libm_and_has_the_right_gradient() {
    use buridan_policy::activation::{fast_tanh, tanh};
    let mut worst = 0.0f64;
    let mut x = -12.0f32;
    while x <= 12.0 {
        let err = (fast_tanh(x) as f64 - (x as f64).tanh()).abs();
        worst = worst.max(err);
        x += 0.001;
    }
    assert!(worst < 2e-6, "max error {worst}");
    assert_eq!(fast_tanh(1e-5), 1e-5);
    let v = candle_core::Var::from_vec(vec![-2.0f32, 0.0, 0.5, 3.0], 4, &Device::Cpu).unwrap();
    let y = tanh(v.as_tensor()).unwrap();
    let g = y.sum_all().unwrap().backward().unwrap();
    let g: Vec<f32> = g.get(v.as_tensor()).unwrap().to_vec1().unwrap();
    for (gi, xi) in g.iter().zip([-2.0f32, 0.0, 0.5, 3.0]) {
        let expected = 1.0 - xi.tanh().powi(2);
        assert!((gi - expected).abs() < 1e-5);
    }
    // Sigmoid through the same approximation: value and gradient σ(1 − σ).
    let y = buridan_policy::activation::sigmoid(v.as_tensor()).unwrap();
    let vals: Vec<f32> = y.to_vec1().unwrap();
    let g = y.sum_all().unwrap().backward().unwrap();
    let g: Vec<f32> = g.get(v.as_tensor()).unwrap().to_vec1().unwrap();
    for ((yi, gi), xi) in vals.iter().zip(&g).zip([-2.0f32, 0.0, 0.5, 3.0]) {
        let s = 1.0 / (1.0 + (-xi).exp());
        assert!((yi - s).abs() < 1e-6);
        assert!((gi - s * (1.0 - s)).abs() < 1e-5);
    }
}

#[test]
fn greedy_mix_draws_from_the_mixture_it_reports() {
    // Legal actions 0, 2, 3 with π ∝ (1, 1, e); action 3 is the greedy one.
    let raw = [0.0f32, 50.0, 0.0, 1.0, 0.0];
    let mask = [1u8, 0, 1, 1, 0];
    let g = 0.6f32;
    let z = 2.0 + 1f32.exp();
    let pi = [1.0 / z, 0.0, 1.0 / z, 1f32.exp() / z, 0.0];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut counts = [0usize; 5];
    let draws = 40_000;
    for _ in 0..draws {
        let mut logits = raw;
        let (a, lp) = dist::greedy_mix_head(&mut logits, &mask, g, &mut rng).unwrap();
        counts[a as usize] += 1;
        assert_eq!(lp, logits[a as usize]);
        // The reported logits are ln μ, μ = (1 − g)·π + g·δ₃.
        for k in [0, 2, 3] {
            let mu = (1.0 - g) * pi[k] + if k == 3 { g } else { 0.0 };
            assert!((logits[k].exp() - mu).abs() < 1e-5, "action {k}");
        }
    }
    assert_eq!(counts[1] + counts[4], 0, "masked actions never come out");
    let freq3 = counts[3] as f32 / draws as f32;
    assert!((freq3 - ((1.0 - g) * pi[3] + g)).abs() < 0.01, "{freq3}");
    // The learner's masked softmax over the reported logits is μ again.
    let mut logits = raw;
    dist::greedy_mix_head(&mut logits, &mask, g, &mut rng).unwrap();
    let dev = Device::Cpu;
    let l = Tensor::from_slice(&logits, (1, 5), &dev).unwrap();
    let bias = dist::mask_bias(&mask, 1, 5, &dev).unwrap();
    let p: Vec<f32> = dist::masked_log_probs(&l, &bias, 1)
        .unwrap()
        .exp()
        .unwrap()
        .flatten_all()
        .unwrap()
        .to_vec1()
        .unwrap();
    assert!((p[3] - ((1.0 - g) * pi[3] + g)).abs() < 1e-5);
    assert!((p[0] - (1.0 - g) * pi[0]).abs() < 1e-5);
}
