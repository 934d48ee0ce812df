//! V-trace off-policy targets (Espeholt et al. 2018, IMPALA, eq. 1 and §4.2).
//!
//! With importance ratios `π(a_t|x_t) / μ(a_t|x_t)`, truncated weights
//! `ρ_t = min(ρ̄, ratio)` and `c_t = λ·min(c̄, ratio)`, and
//! `δ_t = ρ_t·(r_t + γ·V(x_{t+1})·(1 − term_t) − V(x_t))`:
//!
//! `v_t = V(x_t) + δ_t + γ·c_t·(1 − done_t)·(v_{t+1} − V(x_{t+1}))`
//!
//! and the policy-gradient advantage
//! `A_t = min(ρ̄_pg, ratio)·(r_t + γ·v'_{t+1} − V(x_t))`, where `v'_{t+1}` is
//! `v_{t+1}` inside an episode and the fragment, the bootstrap value
//! `next_values[t]` at the fragment end or after a truncation, and 0 after a
//! termination. Inputs as in
//! [`crate::algo::trajectory`].

use crate::algo::trajectory::Trajectory;

/// V-trace targets and advantages of one time-major batch.
#[derive(Debug, Clone, PartialEq)]
pub struct VTrace {
    /// Value targets `v_t`, `[T, B]`.
    pub vs: Vec<f32>,
    /// Policy-gradient advantages, `[T, B]`.
    pub pg_advantages: Vec<f32>,
    /// Clipped importance weights `ρ_t`, `[T, B]` (diagnostics).
    pub rhos: Vec<f32>,
}

/// Clipping thresholds and discounting of V-trace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VTraceParams {
    /// Discount γ.
    pub gamma: f32,
    /// Trace decay λ (1 in the paper's experiments and RLlib).
    pub lambda: f32,
    /// ρ̄, truncation of the TD weights.
    pub rho_bar: f32,
    /// c̄, truncation of the trace weights.
    pub c_bar: f32,
    /// Truncation of the policy-gradient weights (RLlib `vtrace_clip_pg_rho_threshold`).
    pub pg_rho_bar: f32,
}

impl Default for VTraceParams {
    fn default() -> Self {
        Self {
            gamma: 0.99,
            lambda: 1.0,
            rho_bar: 1.0,
            c_bar: 1.0,
            pg_rho_bar: 1.0,
        }
    }
}

/// V-trace over a time-major trajectory; `log_rhos = log π(a_t|x_t) −
/// log μ(a_t|x_t)`, `[T, B]` like the trajectory.
///
/// ```
/// use buridan_learner::algo::trajectory::Trajectory;
/// use buridan_learner::algo::vtrace::{vtrace, VTraceParams};
/// // On-policy, one step, terminated: v = r, A = r − V.
/// let traj = Trajectory {
///     t_len: 1, rows: 1,
///     rewards: &[1.0], values: &[0.25], next_values: &[0.0],
///     terminated: &[true], truncated: &[false],
/// };
/// let v = vtrace(&traj, &[0.0], VTraceParams { gamma: 0.9, ..VTraceParams::default() });
/// assert_eq!(v.vs, vec![1.0]);
/// assert_eq!(v.pg_advantages, vec![0.75]);
/// ```
pub fn vtrace(traj: &Trajectory, log_rhos: &[f32], p: VTraceParams) -> VTrace {
    traj.assert_shapes("vtrace");
    let n = traj.len();
    assert_eq!(
        log_rhos.len(),
        n,
        "vtrace: log_rhos must hold T·B = {n} traj.values"
    );
    let mut vs = vec![0.0f32; n];
    let mut pg = vec![0.0f32; n];
    let mut rhos = vec![0.0f32; n];
    for r in 0..traj.rows {
        // v_{t+1} − V(x_{t+1}) of the step after t, 0 beyond the fragment.
        let mut next_acc = 0.0f32;
        // v_{t+1} (V-trace target of the next step), for the pg advantage.
        let mut next_vs = 0.0f32;
        for t in (0..traj.t_len).rev() {
            let k = t * traj.rows + r;
            let ratio = log_rhos[k].exp();
            let rho = ratio.min(p.rho_bar);
            let c = p.lambda * ratio.min(p.c_bar);
            let term = traj.terminated[k];
            let done = term || traj.truncated[k];
            let not_term = if term { 0.0 } else { 1.0 };
            let boot = traj.next_values[k] * not_term;
            let delta = rho * (traj.rewards[k] + p.gamma * boot - traj.values[k]);
            let carry = if done { 0.0 } else { next_acc };
            let acc = delta + p.gamma * c * carry;
            vs[k] = traj.values[k] + acc;
            let v_next = if done || t + 1 == traj.t_len {
                boot
            } else {
                next_vs
            };
            pg[k] = ratio.min(p.pg_rho_bar) * (traj.rewards[k] + p.gamma * v_next - traj.values[k]);
            rhos[k] = rho;
            next_acc = acc;
            next_vs = vs[k];
        }
    }
    VTrace {
        vs,
        pg_advantages: pg,
        rhos,
    }
}
