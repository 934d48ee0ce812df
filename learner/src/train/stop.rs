//! When a run stops: at its step budget, or earlier once it has learned.
//!
//! A budget alone makes a newcomer wait for steps the policy no longer
//! needs: the recipe's imitation phase often leaves a policy that already
//! solves its layout, and PPO then only has to keep it there. The rule
//! `[stop]` ends the run once the training success (the last
//! [`EPISODE_WINDOW`](super::metrics::EPISODE_WINDOW) episodes) has stayed
//! at or above `success` for `hold` env steps in a row; `steps` stays the
//! cap. The summary says which of these ended the run ([`StopReason`]).

use serde::{Deserialize, Serialize};

use super::target::{Mark, TimeToTarget};

/// Stop once the training success has held a level for a stretch of env
/// steps, TOML `[stop]`.
///
/// ```
/// let rule: buridan_learner::train::StopRule = toml::from_str("success = 0.98\nhold = 50000").unwrap();
/// assert_eq!((rule.success, rule.hold), (0.98, 50_000));
/// rule.validate().unwrap();
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopRule {
    /// The training success level (0..=1) over the last 100 episodes.
    pub success: f64,
    /// Env steps the level must hold, every update at or above it, before
    /// the run stops.
    pub hold: u64,
}

impl StopRule {
    /// Checks the level and the stretch; the message names the bad key.
    pub fn validate(&self) -> Result<(), &'static str> {
        if !(self.success > 0.0 && self.success <= 1.0) {
            return Err("stop.success must lie in (0, 1]");
        }
        if self.hold == 0 {
            return Err("stop.hold must be at least 1 env step");
        }
        Ok(())
    }
}

/// Why a run ended.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// It used its step budget (`steps`).
    #[default]
    Budget,
    /// The training success held `[stop]`'s level for its stretch.
    Learned,
    /// The mean return reached `stop_return` (and the length `stop_len`).
    ReturnGoal,
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StopReason::Budget => "the step budget was used",
            StopReason::Learned => "the training success held its target",
            StopReason::ReturnGoal => "the return goal was reached",
        })
    }
}

/// Follows a [`StopRule`] update by update: the stretch at or above its
/// level is a [`TimeToTarget`]'s `held` mark.
///
/// ```
/// use buridan_learner::train::{StopRule, stop::Holding};
/// use buridan_learner::train::target::Mark;
/// let at = |k: u64| Mark { update: k, env_steps: 1000 * k, wall_seconds: k as f64 };
/// let mut h = Holding::new(StopRule { success: 0.9, hold: 2000 });
/// assert!(!h.observe(0.95, true, at(1))); // held from 1000 steps on
/// assert!(!h.observe(0.85, true, at(2))); // fell: starts over
/// assert!(!h.observe(0.92, true, at(3)));
/// assert!(!h.observe(0.93, false, at(4))); // not a full window: starts over
/// assert!(!h.observe(0.93, true, at(5)));
/// assert!(!h.observe(0.91, true, at(6)));
/// assert!(h.observe(0.99, true, at(7))); // 5000 → 7000: held 2000 steps
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Holding {
    hold: u64,
    level: TimeToTarget,
}

impl Holding {
    /// Nothing held yet.
    pub fn new(rule: StopRule) -> Self {
        Self {
            hold: rule.hold,
            level: TimeToTarget::new(rule.success),
        }
    }

    /// Books one update's training success (`full_window`: over a full
    /// episode window); `true` once the level has held for the stretch.
    pub fn observe(&mut self, success: f64, full_window: bool, at: Mark) -> bool {
        self.level.observe(success, full_window, at);
        self.level
            .held
            .is_some_and(|since| at.env_steps.saturating_sub(since.env_steps) >= self.hold)
    }
}
