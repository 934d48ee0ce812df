//! Hand-checked numbers for GAE, V-trace and the PPO/IMPALA losses.

use buridan_learner::algo::batch::BatchTensors;
use buridan_learner::algo::gae::{gae, standardize, GaeParams};
use buridan_learner::algo::impala::{impala_loss, ImpalaLossParams};
use buridan_learner::algo::ppo::{ppo_loss, update_kl_coeff, PpoLossParams};
use buridan_learner::algo::trajectory::Trajectory;
use buridan_learner::algo::vtrace::{vtrace, VTraceParams};
use buridan_policy::dist;
use candle_core::{Device, Tensor};

fn close(a: &[f32], b: &[f32], tol: f32) {
    assert_eq!(a.len(), b.len());
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() < tol,
            "index {i}: {x} vs {y} (all: {a:?} vs {b:?})"
        );
    }
}

#[test]
fn gae_by_hand_with_truncation_and_termination() {
    // γ = 0.9, λ = 0.8, so γλ = 0.72. Two rows, T = 4, time-major [t·2 + row].
    // Row A: r = [0, 0, 1, 0], V = [1, 2, 3, 4]; step 1 truncated with
    //   V(final_obs) = 5; fragment ends with V(last_obs) = 6.
    //   δ3 = 0 + 0.9·6 − 4 = 1.4            Â3 = 1.4
    //   δ2 = 1 + 0.9·4 − 3 = 1.6            Â2 = 1.6 + 0.72·1.4 = 2.608
    //   δ1 = 0 + 0.9·5 − 2 = 2.5 (bootstrap) Â1 = 2.5 (trace cut)
    //   δ0 = 0 + 0.9·2 − 1 = 0.8            Â0 = 0.8 + 0.72·2.5 = 2.6
    // Row B: r = [0.5, 0, 2, 0], V = [1, 1, 1, 1]; step 2 terminated (its
    //   next value 999 must be ignored); V(last_obs) = 0.5.
    //   δ3 = 0.45 − 1 = −0.55               Â3 = −0.55
    //   δ2 = 2 − 1 = 1                      Â2 = 1 (trace cut)
    //   δ1 = 0.9 − 1 = −0.1                 Â1 = −0.1 + 0.72·1 = 0.62
    //   δ0 = 0.5 + 0.9 − 1 = 0.4            Â0 = 0.4 + 0.72·0.62 = 0.8464
    let rewards = [0.0, 0.5, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0];
    let values = [1.0, 1.0, 2.0, 1.0, 3.0, 1.0, 4.0, 1.0];
    let next_values = [2.0, 1.0, 5.0, 1.0, 4.0, 999.0, 6.0, 0.5];
    let terminated = [false, false, false, false, false, true, false, false];
    let truncated = [false, false, true, false, false, false, false, false];
    let g = gae(
        &Trajectory {
            t_len: 4,
            rows: 2,
            rewards: &rewards,
            values: &values,
            next_values: &next_values,
            terminated: &terminated,
            truncated: &truncated,
        },
        GaeParams {
            gamma: 0.9,
            lambda: 0.8,
        },
    );
    close(
        &g.advantages,
        &[2.6, 0.8464, 2.5, 0.62, 2.608, 1.0, 1.4, -0.55],
        1e-5,
    );
    // Targets = Â + V.
    close(
        &g.targets,
        &[3.6, 1.8464, 4.5, 1.62, 5.608, 2.0, 5.4, 0.45],
        1e-5,
    );
    // Standardisation: mean 0, std 1.
    let mut a = g.advantages.clone();
    standardize(&mut a);
    let mean: f32 = a.iter().sum::<f32>() / 8.0;
    let var: f32 = a.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / 8.0;
    assert!(mean.abs() < 1e-6 && (var - 1.0).abs() < 1e-4);
}

#[test]
fn gae_with_lambda_one_is_the_discounted_return_minus_value() {
    // λ = 1, terminated at the last step: Â_t = Σ γ^k r_{t+k} − V_t.
    // r = [1, 1, 1], γ = 0.5: returns [1.75, 1.5, 1]; V = [0.25, 0.5, 0.75].
    let g = gae(
        &Trajectory {
            t_len: 3,
            rows: 1,
            rewards: &[1.0, 1.0, 1.0],
            values: &[0.25, 0.5, 0.75],
            next_values: &[0.5, 0.75, 0.0],
            terminated: &[false, false, true],
            truncated: &[false, false, false],
        },
        GaeParams {
            gamma: 0.5,
            lambda: 1.0,
        },
    );
    close(&g.advantages, &[1.5, 1.0, 0.25], 1e-6);
    close(&g.targets, &[1.75, 1.5, 1.0], 1e-6);
}

#[test]
fn vtrace_by_hand() {
    // γ = 0.9, λ = 1, ρ̄ = c̄ = 1. One row, T = 3, ratios [2, 0.5, 1]:
    // ρ = c = [1, 0.5, 1]. r = [1, 0, 1], V = [0.5, 1, 2], V(last) = 3.
    //   δ2 = 1·(1 + 0.9·3 − 2) = 1.7          v2 = 2 + 1.7 = 3.7
    //   δ1 = 0.5·(0 + 0.9·2 − 1) = 0.4        v1 = 1 + 0.4 + 0.9·0.5·1.7 = 2.165
    //   δ0 = 1·(1 + 0.9·1 − 0.5) = 1.4        v0 = 0.5 + 1.4 + 0.9·1·1.165 = 2.9485
    // pg advantages (ρ_pg = min(1, ratio)):
    //   A2 = 1·(1 + 0.9·3 − 2) = 1.7
    //   A1 = 0.5·(0 + 0.9·3.7 − 1) = 1.165
    //   A0 = 1·(1 + 0.9·2.165 − 0.5) = 2.4485
    let p = VTraceParams {
        gamma: 0.9,
        ..VTraceParams::default()
    };
    let log_rhos = [2f32.ln(), 0.5f32.ln(), 0.0];
    let v = vtrace(
        &Trajectory {
            t_len: 3,
            rows: 1,
            rewards: &[1.0, 0.0, 1.0],
            values: &[0.5, 1.0, 2.0],
            next_values: &[1.0, 2.0, 3.0],
            terminated: &[false; 3],
            truncated: &[false; 3],
        },
        &log_rhos,
        p,
    );
    close(&v.vs, &[2.9485, 2.165, 3.7], 1e-5);
    close(&v.pg_advantages, &[2.4485, 1.165, 1.7], 1e-5);
    close(&v.rhos, &[1.0, 0.5, 1.0], 1e-6);

    // Truncation at step 0 with V(final) = 4: v0 = 0.5 + 1·(1 + 0.9·4 − 0.5) = 4.6,
    // no trace from step 1; A0 = 1 + 0.9·4 − 0.5 = 4.1. Termination at step 1:
    // v1 = 1 + 0.5·(0 − 1) = 0.5 (V(x_2) of the next episode is ignored).
    let v = vtrace(
        &Trajectory {
            t_len: 3,
            rows: 1,
            rewards: &[1.0, 0.0, 1.0],
            values: &[0.5, 1.0, 2.0],
            next_values: &[4.0, 123.0, 3.0],
            terminated: &[false, true, false],
            truncated: &[true, false, false],
        },
        &log_rhos,
        p,
    );
    close(&v.vs, &[4.6, 0.5, 3.7], 1e-5);
    // A1 = 0.5·(0 + 0 − 1) = −0.5.
    close(&v.pg_advantages, &[4.1, -0.5, 1.7], 1e-5);
}

#[test]
fn vtrace_on_policy_equals_n_step_bootstrapped_returns() {
    // π = μ, λ = 1: v_t = Σ_{k=t}^{T−1} γ^{k−t} r_k + γ^{T−t} V(x_T), within
    // each episode (a termination at step 4 restarts the sum, no bootstrap).
    let (t_len, gamma) = (7usize, 0.9f32);
    let rewards: Vec<f32> = (0..t_len)
        .map(|t| ((t * 7 % 5) as f32) * 0.3 - 0.2)
        .collect();
    let values: Vec<f32> = (0..t_len).map(|t| (t as f32 * 1.3).sin()).collect();
    let v_last = 0.7f32;
    let mut next_values: Vec<f32> = values[1..].to_vec();
    next_values.push(v_last);
    let mut terminated = vec![false; t_len];
    terminated[4] = true;
    let v = vtrace(
        &Trajectory {
            t_len,
            rows: 1,
            rewards: &rewards,
            values: &values,
            next_values: &next_values,
            terminated: &terminated,
            truncated: &vec![false; t_len],
        },
        &vec![0.0; t_len],
        VTraceParams {
            gamma,
            ..VTraceParams::default()
        },
    );
    for t in 0..t_len {
        let (end, boot) = if t <= 4 { (5, 0.0) } else { (t_len, v_last) };
        let mut ret = 0.0f32;
        for (k, &r) in rewards.iter().enumerate().take(end).skip(t) {
            ret += gamma.powi((k - t) as i32) * r;
        }
        ret += gamma.powi((end - t) as i32) * boot;
        assert!((v.vs[t] - ret).abs() < 1e-5, "t={t}: {} vs {ret}", v.vs[t]);
    }
    // And on-policy V-trace with λ = 1 equals GAE(λ = 1) targets.
    let g = gae(
        &Trajectory {
            t_len,
            rows: 1,
            rewards: &rewards,
            values: &values,
            next_values: &next_values,
            terminated: &terminated,
            truncated: &vec![false; t_len],
        },
        GaeParams { gamma, lambda: 1.0 },
    );
    close(&v.vs, &g.targets, 1e-5);
}

/// Two samples, one head of two actions, behaviour uniform.
fn tiny_batch() -> (BatchTensors, Tensor) {
    let dev = Device::Cpu;
    let bias = dist::mask_bias(&[1, 1, 1, 1], 2, 2, &dev).unwrap();
    let behaviour_logits = Tensor::zeros((2, 2), candle_core::DType::F32, &dev).unwrap();
    let blp = dist::masked_log_probs(&behaviour_logits, &bias, 1).unwrap();
    let actions = Tensor::from_vec(vec![0u32, 1], (2, 1), &dev).unwrap();
    let blogp = dist::joint_log_prob(&blp, &actions).unwrap();
    let bt = BatchTensors {
        t: 1,
        rows: 2,
        heads: 1,
        obs: Tensor::zeros((2, 1), candle_core::DType::F32, &dev).unwrap(),
        mask_bias: bias,
        actions,
        behaviour_log_probs: blp,
        behaviour_logp: blogp,
        recurrent: None,
    };
    // Current policy: sample 0 π = [0.75, 0.25], sample 1 π = [0.5, 0.5].
    let logits = Tensor::from_vec(vec![3f32.ln(), 0.0, 0.0, 0.0], (2, 2), &dev).unwrap();
    (bt, logits)
}

#[test]
fn ppo_loss_by_hand() {
    let dev = Device::Cpu;
    let (bt, logits) = tiny_batch();
    // Ratios: 0.75/0.5 = 1.5 (action 0), 0.5/0.5 = 1. Advantages [1, −1], ε = 0.2:
    //   surrogate0 = min(1.5·1, 1.2·1) = 1.2; surrogate1 = −1 → policy loss −0.1.
    // Values [0.5, 2], targets [1, −2]: (0.25, 16) clamped at 10 → mean 5.125.
    // Entropy: H0 = −(0.75 ln 0.75 + 0.25 ln 0.25) = 0.5623351, H1 = ln 2 → 0.6277411.
    // KL(μ‖π): 0.5 ln(0.5/0.75) + 0.5 ln(0.5/0.25) = 0.1438410, and 0 → 0.0719205.
    // Total (c_vf 0.5, c_ent 0.01, β 0.2):
    //   −0.1 + 2.5625 − 0.006277411 + 0.0143841 = 2.4706067.
    let p = PpoLossParams {
        clip: 0.2,
        vf_coeff: 0.5,
        vf_clip: 10.0,
        entropy_coeff: 0.01,
        kl_coeff: 0.2,
    };
    let values = Tensor::from_vec(vec![0.5f32, 2.0], 2, &dev).unwrap();
    let adv = Tensor::from_vec(vec![1f32, -1.0], 2, &dev).unwrap();
    let tgt = Tensor::from_vec(vec![1f32, -2.0], 2, &dev).unwrap();
    let (loss, terms) = ppo_loss(&logits, &values, &bt, &adv, &tgt, &p).unwrap();
    assert!((terms.policy - -0.1).abs() < 1e-6);
    assert!((terms.vf - 5.125).abs() < 1e-6);
    assert!((terms.entropy - 0.6277411).abs() < 1e-6);
    assert!((terms.kl - 0.0719205).abs() < 1e-6);
    assert!((loss.to_scalar::<f32>().unwrap() as f64 - 2.4706067).abs() < 1e-5);

    // Sample 0 is clipped (ratio 1.5 > 1.2 with A > 0): the surrogate gives
    // its logits no gradient. With only the surrogate term (all other
    // coefficients 0) the gradient on sample 0's logits is exactly 0.
    let logits_var = candle_core::Var::from_tensor(&logits).unwrap();
    let p0 = PpoLossParams {
        vf_coeff: 0.0,
        entropy_coeff: 0.0,
        kl_coeff: 0.0,
        ..p
    };
    let (loss, _) = ppo_loss(logits_var.as_tensor(), &values, &bt, &adv, &tgt, &p0).unwrap();
    let g = loss.backward().unwrap();
    let grad: Vec<Vec<f32>> = g.get(logits_var.as_tensor()).unwrap().to_vec2().unwrap();
    assert_eq!(grad[0], vec![0.0, 0.0]);
    // Sample 1 (unclipped): loss term −½·A·π(a1)/μ(a1) with μ(a1) = 0.5, so
    //   d/dlogits = −½·(−1)/0.5 · π(a1)·(onehot − π) = 1 · 0.5·([0, 1] − [0.5, 0.5])
    //   = [−0.25, 0.25].
    close(&grad[1], &[-0.25, 0.25], 1e-6);
}

#[test]
fn adaptive_kl_coefficient_follows_rllib() {
    let mut c = 0.2;
    c = update_kl_coeff(c, 0.05, 0.01); // 0.05 > 0.02 → ×1.5
    assert!((c - 0.3).abs() < 1e-12);
    c = update_kl_coeff(c, 0.015, 0.01); // within [0.005, 0.02] → unchanged
    assert!((c - 0.3).abs() < 1e-12);
    c = update_kl_coeff(c, 0.001, 0.01); // < 0.005 → ×0.5
    assert!((c - 0.15).abs() < 1e-12);
}

#[test]
fn impala_loss_by_hand() {
    let dev = Device::Cpu;
    let (bt, logits) = tiny_batch();
    // log π(a): ln 0.75 = −0.2876821, ln 0.5 = −0.6931472. pg A = [2, −1]:
    //   π loss = −mean(−0.5753641, 0.6931472) = −0.0588916.
    // Values [0.5, 2], v_s [1, 0]: ½·mean(0.25, 4) = 1.0625. Entropy 0.6277411.
    // Total (c_vf 0.5, c_ent 0.01) = −0.0588916 + 0.53125 − 0.0062774 = 0.4660810.
    let values = Tensor::from_vec(vec![0.5f32, 2.0], 2, &dev).unwrap();
    let pg = Tensor::from_vec(vec![2f32, -1.0], 2, &dev).unwrap();
    let vs = Tensor::from_vec(vec![1f32, 0.0], 2, &dev).unwrap();
    let p = ImpalaLossParams {
        vf_coeff: 0.5,
        entropy_coeff: 0.01,
    };
    let (loss, terms) = impala_loss(&logits, &values, &bt, &pg, &vs, &p).unwrap();
    assert!((terms.policy - -0.0588916).abs() < 1e-6);
    assert!((terms.vf - 1.0625).abs() < 1e-6);
    assert!((terms.entropy - 0.6277411).abs() < 1e-6);
    assert!((loss.to_scalar::<f32>().unwrap() as f64 - 0.466081).abs() < 1e-5);
}
