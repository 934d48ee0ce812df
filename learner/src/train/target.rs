//! Time to target: when a run's training success (the last
//! [`EPISODE_WINDOW`](super::metrics::EPISODE_WINDOW) episodes) first
//! reached a level, and from when on it stayed there — the figure that says
//! how fast a configuration learns, in env steps and in wall time.

use serde::{Deserialize, Serialize};

/// The training success levels every run reports: 90 % and 96 %.
pub const TARGET_SUCCESS: [f64; 2] = [0.90, 0.96];

/// One moment of a run: after update `update`, at `env_steps` env steps and
/// `wall_seconds` of wall time.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Mark {
    /// Learner updates so far.
    pub update: u64,
    /// Env steps sampled so far.
    pub env_steps: u64,
    /// Wall seconds so far (including resumed runs).
    pub wall_seconds: f64,
}

/// When the training success first reached `success`, and the first update
/// from which on it never fell below it again (so far).
///
/// ```
/// use buridan_learner::train::target::{Mark, TimeToTarget};
/// let mark = |update| Mark { update, env_steps: 1000 * update, wall_seconds: update as f64 };
/// let mut t = TimeToTarget::new(0.9);
/// for (update, success) in [(1, 0.5), (2, 0.92), (3, 0.85), (4, 0.91), (5, 0.95)] {
///     t.observe(success, true, mark(update));
/// }
/// assert_eq!(t.first.map(|m| m.update), Some(2)); // first reached
/// assert_eq!(t.held.map(|m| m.update), Some(4)); // and stayed there from update 4
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TimeToTarget {
    /// The success level (0..1).
    pub success: f64,
    /// The first update whose training success reached the level.
    pub first: Option<Mark>,
    /// The first update of the run's final stretch at or above the level
    /// (`None` if the last update is below it).
    pub held: Option<Mark>,
}

impl TimeToTarget {
    /// A target not reached yet.
    pub fn new(success: f64) -> Self {
        Self {
            success,
            first: None,
            held: None,
        }
    }

    /// Books one update's training success; `full_window` says whether it
    /// is measured over a full episode window (fewer episodes do not count:
    /// the first few successes would "reach" any level). Returns `true` the
    /// first time the level is reached.
    pub fn observe(&mut self, success: f64, full_window: bool, at: Mark) -> bool {
        if !(full_window && success >= self.success) {
            self.held = None;
            return false;
        }
        self.held.get_or_insert(at);
        if self.first.is_some() {
            return false;
        }
        self.first = Some(at);
        true
    }
}

/// The run's targets at [`TARGET_SUCCESS`], none reached.
pub fn targets() -> Vec<TimeToTarget> {
    TARGET_SUCCESS
        .iter()
        .map(|&s| TimeToTarget::new(s))
        .collect()
}
