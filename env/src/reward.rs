//! The rewards the env's rules can produce: the range a learner checks
//! rewards from remote actors against ([`EnvConfig::step_reward_range`]).

use crate::config::EnvConfig;
use crate::world::{REWARD_ALL_AT_GOAL, REWARD_COLLISION, REWARD_GOAL, REWARD_TRUNCATED_OFF_GOAL};

/// The smallest and largest reward (both inclusive) of one agent in one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardRange {
    /// The smallest reward.
    pub min: f32,
    /// The largest reward.
    pub max: f32,
}

impl RewardRange {
    /// Whether `reward` lies in the range (NaN never does).
    ///
    /// ```
    /// let r = buridan_env::RewardRange { min: -2.0, max: 1.5 };
    /// assert!(r.contains(1.5) && !r.contains(1.6) && !r.contains(f32::NAN));
    /// ```
    pub fn contains(&self, reward: f32) -> bool {
        reward >= self.min && reward <= self.max
    }

    /// The range of a sum of `n` such rewards (`n` agents of a central row,
    /// or `n` steps of an episode).
    ///
    /// ```
    /// let r = buridan_env::RewardRange { min: -2.0, max: 1.5 };
    /// assert_eq!(r.times(4), buridan_env::RewardRange { min: -8.0, max: 6.0 });
    /// ```
    pub fn times(&self, n: u32) -> RewardRange {
        RewardRange {
            min: self.min * n as f32,
            max: self.max * n as f32,
        }
    }
}

impl EnvConfig {
    /// The reward one agent can receive in one step under these rules,
    /// shaping included (the same under `thesis` and `pogema`).
    ///
    /// Episodic: at most +0.5 (first arrival) + 1 (all at their goals), at
    /// least −1 (collision, impossible but checked) − 1 (truncated off its
    /// goal). Lifelong: at most +0.5, at least −1. Shaping adds
    /// `coeff·(γ·Φ(s′) − Φ(s))` with `Φ = −distance`; a step changes an
    /// agent's goal distance by at most one, so the bonus lies in
    /// `[−γ·coeff, coeff·(γ + (1−γ)·max_goal_distance)]`.
    /// `max_goal_distance` is any upper bound on a reachable goal distance
    /// of the map (its free cells − 1 always is one); it only matters with
    /// shaping and γ < 1.
    ///
    /// ```
    /// use buridan_env::{EnvConfig, RewardRange, Shaping};
    /// let episodic = EnvConfig::default();
    /// assert_eq!(episodic.step_reward_range(0), RewardRange { min: -2.0, max: 1.5 });
    /// let lifelong = EnvConfig { lifelong: true, ..EnvConfig::default() };
    /// assert_eq!(lifelong.step_reward_range(0), RewardRange { min: -1.0, max: 0.5 });
    /// let shaped = EnvConfig {
    ///     shaping: Some(Shaping { coeff: 0.1, gamma: 0.5 }),
    ///     ..EnvConfig::default()
    /// };
    /// // Bonus in [−0.05, 0.1·(0.5 + 0.5·10)] = [−0.05, 0.55].
    /// let r = shaped.step_reward_range(10);
    /// assert!((r.min + 2.05).abs() < 1e-6 && (r.max - 2.05).abs() < 1e-6);
    /// ```
    pub fn step_reward_range(&self, max_goal_distance: u32) -> RewardRange {
        let (mut min, mut max) = if self.lifelong {
            (REWARD_COLLISION, REWARD_GOAL)
        } else {
            (
                REWARD_COLLISION + REWARD_TRUNCATED_OFF_GOAL,
                REWARD_GOAL + REWARD_ALL_AT_GOAL,
            )
        };
        if let Some(s) = self.shaping {
            let (coeff, gamma) = (f64::from(s.coeff), f64::from(s.gamma));
            let far = (1.0 - gamma).max(0.0) * f64::from(max_goal_distance);
            min -= (gamma * coeff) as f32;
            max += (coeff * (gamma + far)) as f32;
        }
        RewardRange { min, max }
    }
}
