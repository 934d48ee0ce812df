//! The experience both advantage estimators read: `T` steps of `B`
//! independent rows, every buffer time-major `[T, B]` (index `t·B + b`).
//!
//! `next_values[t]` is `V(s_{t+1})`, the value of the state that step `t`
//! led to: `V(final_obs)` where step `t` truncated, `values[t+1]` inside an
//! episode, the bootstrap value of the fragment's last observation at
//! `t = T−1`, anything where step `t` terminated (it is multiplied by 0).

/// One time-major batch, named field by field so that no two buffers can
/// be swapped unnoticed.
///
/// ```
/// use buridan_learner::algo::trajectory::Trajectory;
/// let traj = Trajectory {
///     t_len: 2, rows: 1,
///     rewards: &[0.0, 1.0], values: &[0.5, 0.5], next_values: &[0.5, 0.0],
///     terminated: &[false, true], truncated: &[false, false],
/// };
/// assert_eq!(traj.len(), 2);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Trajectory<'a> {
    /// Steps `T`.
    pub t_len: usize,
    /// Rows `B`.
    pub rows: usize,
    /// `r_t`.
    pub rewards: &'a [f32],
    /// `V(s_t)` under the weights being trained.
    pub values: &'a [f32],
    /// `V(s_{t+1})`, as described in the module documentation.
    pub next_values: &'a [f32],
    /// Step `t` ended its episode at the goal (no bootstrap).
    pub terminated: &'a [bool],
    /// Step `t` ended its episode at the time limit (bootstrap from `next_values`).
    pub truncated: &'a [bool],
}

impl Trajectory<'_> {
    /// Samples `T·B`.
    pub fn len(&self) -> usize {
        self.t_len * self.rows
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Panics unless every buffer holds `T·B` values (a programming error:
    /// batches are built with these shapes).
    pub(crate) fn assert_shapes(&self, who: &str) {
        let n = self.len();
        assert!(
            self.rewards.len() == n
                && self.values.len() == n
                && self.next_values.len() == n
                && self.terminated.len() == n
                && self.truncated.len() == n,
            "{who}: every buffer must hold T·B = {n} values"
        );
    }
}
