//! Generalized advantage estimation, GAE(λ) (Schulman et al. 2016), with
//! correct handling of truncation: the value of the state after a truncated
//! step is bootstrapped from `V(final_obs)`, after a terminated step it is 0,
//! and in both cases the advantage trace does not flow across the boundary.
//!
//! With `δ_t = r_t + γ·V(s_{t+1})·(1 − term_t) − V(s_t)`:
//! `Â_t = δ_t + γλ·(1 − done_t)·Â_{t+1}`, value target `R_t = Â_t + V(s_t)`.
//!
//! Inputs as in [`crate::algo::trajectory`].

use crate::algo::trajectory::Trajectory;

/// Advantages and value targets of one time-major batch.
#[derive(Debug, Clone, PartialEq)]
pub struct Gae {
    /// `Â_t`, `[T, B]`.
    pub advantages: Vec<f32>,
    /// `R_t = Â_t + V(s_t)`, `[T, B]`.
    pub targets: Vec<f32>,
}

/// Discount and trace decay of GAE.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaeParams {
    /// Discount γ.
    pub gamma: f32,
    /// Trace decay λ.
    pub lambda: f32,
}

/// GAE(λ) over a time-major trajectory.
///
/// ```
/// use buridan_learner::algo::gae::{gae, GaeParams};
/// use buridan_learner::algo::trajectory::Trajectory;
/// // One row, two steps, terminated at the end: r = [0, 1], V = [0.5, 0.5].
/// let traj = Trajectory {
///     t_len: 2, rows: 1,
///     rewards: &[0.0, 1.0], values: &[0.5, 0.5], next_values: &[0.5, 9.9],
///     terminated: &[false, true], truncated: &[false, false],
/// };
/// let g = gae(&traj, GaeParams { gamma: 0.9, lambda: 1.0 });
/// // δ1 = 1 − 0.5 = 0.5; δ0 = 0 + 0.9·0.5 − 0.5 = −0.05; Â0 = −0.05 + 0.9·0.5 = 0.4.
/// assert!((g.advantages[1] - 0.5).abs() < 1e-6 && (g.advantages[0] - 0.4).abs() < 1e-6);
/// ```
pub fn gae(traj: &Trajectory, p: GaeParams) -> Gae {
    traj.assert_shapes("gae");
    let (gamma, lambda) = (p.gamma, p.lambda);
    let n = traj.len();
    let mut advantages = vec![0.0f32; n];
    let mut targets = vec![0.0f32; n];
    for r in 0..traj.rows {
        let mut next_adv = 0.0f32;
        for t in (0..traj.t_len).rev() {
            let k = t * traj.rows + r;
            let not_term = if traj.terminated[k] { 0.0 } else { 1.0 };
            let not_done = if traj.terminated[k] || traj.truncated[k] {
                0.0
            } else {
                1.0
            };
            let delta = traj.rewards[k] + gamma * traj.next_values[k] * not_term - traj.values[k];
            let adv = delta + gamma * lambda * not_done * next_adv;
            advantages[k] = adv;
            targets[k] = adv + traj.values[k];
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
