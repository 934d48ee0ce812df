//! Generalized advantage estimation, GAE(λ) (Schulman et al. 2016), with
//! correct handling of truncation: the value of the state after a truncated
//! step is bootstrapped from `V(final_obs)`, after a terminated step it is 0,
//! and in both cases the advantage trace does not flow across the boundary.
//!
//! With `δ_t = r_t + γ·V(s_{t+1})·(1 − term_t) − V(s_t)`:
//! `Â_t = δ_t + γλ·(1 − done_t)·Â_{t+1}`, value target `R_t = Â_t + V(s_t)`.
//!
//! `next_values[t]` is `V(s_{t+1})`, the value of the state that step `t`
//! led to: `V(final_obs)` where step `t` truncated, `values[t+1]` inside an
//! episode, the bootstrap value of the fragment's last observation at
//! `t = T−1`, anything where step `t` terminated (it is multiplied by 0).

/// Advantages and value targets of one time-major batch.
#[derive(Debug, Clone, PartialEq)]
pub struct Gae {
    /// `Â_t`, `[T, B]`.
    pub advantages: Vec<f32>,
    /// `R_t = Â_t + V(s_t)`, `[T, B]`.
    pub targets: Vec<f32>,
}

/// GAE(λ) over `t_len` steps of `rows` independent rows, all buffers
/// time-major `[T, B]`.
///
/// ```
/// use buridan_learner::algo::gae::gae;
/// // One row, two steps, terminated at the end: r = [0, 1], V = [0.5, 0.5].
/// let g = gae(&[0.0, 1.0], &[0.5, 0.5], &[0.5, 9.9], &[false, true], &[false, false], 2, 1, 0.9, 1.0);
/// // δ1 = 1 − 0.5 = 0.5; δ0 = 0 + 0.9·0.5 − 0.5 = −0.05; Â0 = −0.05 + 0.9·0.5 = 0.4.
/// assert!((g.advantages[1] - 0.5).abs() < 1e-6 && (g.advantages[0] - 0.4).abs() < 1e-6);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn gae(
    rewards: &[f32],
    values: &[f32],
    next_values: &[f32],
    terminated: &[bool],
    truncated: &[bool],
    t_len: usize,
    rows: usize,
    gamma: f32,
    lambda: f32,
) -> Gae {
    let n = t_len * rows;
    assert!(
        rewards.len() == n
            && values.len() == n
            && next_values.len() == n
            && terminated.len() == n
            && truncated.len() == n,
        "gae: every buffer must hold T·B = {n} values"
    );
    let mut advantages = vec![0.0f32; n];
    let mut targets = vec![0.0f32; n];
    for r in 0..rows {
        let mut next_adv = 0.0f32;
        for t in (0..t_len).rev() {
            let k = t * rows + r;
            let not_term = if terminated[k] { 0.0 } else { 1.0 };
            let not_done = if terminated[k] || truncated[k] {
                0.0
            } else {
                1.0
            };
            let delta = rewards[k] + gamma * next_values[k] * not_term - values[k];
            let adv = delta + gamma * lambda * not_done * next_adv;
            advantages[k] = adv;
            targets[k] = adv + values[k];
            next_adv = adv;
        }
    }
    Gae {
        advantages,
        targets,
    }
}

/// Standardises `x` in place to mean 0 and standard deviation 1 (RLlib's
/// `standardize_fields=["advantages"]`); leaves constant input at 0.
pub fn standardize(x: &mut [f32]) {
    if x.is_empty() {
        return;
    }
    let n = x.len() as f64;
    let mean = x.iter().map(|&v| v as f64).sum::<f64>() / n;
    let var = x.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / n;
    let std = var.sqrt().max(1e-4);
    for v in x.iter_mut() {
        *v = ((*v as f64 - mean) / std) as f32;
    }
}
