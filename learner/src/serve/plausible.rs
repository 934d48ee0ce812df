//! Plausibility checks on a submitted fragment: its numbers could have come
//! from the run's env and a policy. They run after the wire checks
//! ([`buridan_proto::check_fragment`]: shapes, NaN, ranges) and the shape
//! checks against the run, and catch what is well-formed but impossible:
//! rewards outside what the env's rules can produce, episode statistics
//! that contradict the fragment or the rules, logits that are not finite
//! where the mask allows the action, log-probabilities above 0.
//!
//! ```
//! use buridan_env::EnvConfig;
//! use buridan_learner::serve::plausible::{Implausible, Plausibility};
//! use buridan_policy::Fragment;
//! let env = EnvConfig { agents: 2, ..EnvConfig::default() };
//! let check = Plausibility::new(&env, 10, 2, 1);
//! let mut f = Fragment::with_capacity(0, 0, 1, 2, 2, 1, 1, 5);
//! f.len = 1;
//! f.rewards = vec![-0.0, 1e30];
//! f.terminated = vec![0, 0];
//! f.truncated = vec![0, 0];
//! f.masks = vec![1; 10];
//! f.behaviour_logits = vec![0.0; 10];
//! f.behaviour_logp = vec![-1.6; 2];
//! let err = check.check(&f).unwrap_err();
//! assert!(matches!(err, Implausible::Reward { index: 1, .. }));
//! assert_eq!(
//!     err.to_string(),
//!     "fragment.rewards[1] = 1e30 is outside the env's reward range [-2, 1.5]"
//! );
//! ```

use std::fmt;

use buridan_env::{EnvConfig, EpisodeStats, RewardRange};
use buridan_policy::Fragment;

/// Slack for f32 rounding in sums of rewards, relative to the bound (at
/// least this much absolute).
const REWARD_SLACK: f32 = 1e-3;

/// Largest accepted log-probability: 0 plus rounding.
const LOGP_SLACK: f32 = 1e-3;

/// A number printed compactly: `1e30` rather than thirty-one digits, and
/// an f32 as its shortest decimal (`1.6`, not `1.600000023841858`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f32);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v != 0.0 && v.is_finite() && !(1e-4..1e9).contains(&v.abs()) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// Why a well-formed fragment cannot have come from the run's env.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Implausible {
    /// A reward outside what the rules can produce for one row in one step.
    #[error(
        "fragment.rewards[{index}] = {value} is outside the env's reward range [{min}, {max}]"
    )]
    Reward {
        /// Position in `rewards` (`t·rows + row`).
        index: usize,
        /// The reward found.
        value: Num,
        /// The smallest possible reward.
        min: Num,
        /// The largest possible reward.
        max: Num,
    },
    /// A logit that is not finite where the mask allows the action (or
    /// `+∞` anywhere; masked actions may have `−∞`).
    #[error(
        "fragment.behaviour_logits[{index}] = {value} is not finite where masks[{index}] = {mask}"
    )]
    Logit {
        /// Position in `behaviour_logits`.
        index: usize,
        /// The logit found.
        value: f32,
        /// The mask there (1: action allowed).
        mask: u8,
    },
    /// A log-probability above 0.
    #[error("fragment.behaviour_logp[{index}] = {value} is a log-probability above 0")]
    LogProb {
        /// Position in `behaviour_logp`.
        index: usize,
        /// The value found.
        value: Num,
    },
    /// More episode statistics than episodes ending in the fragment.
    #[error("fragment.episodes holds {got} episodes, but only {ends} end in the fragment (terminated or truncated)")]
    EpisodeCount {
        /// Episodes reported.
        got: usize,
        /// Env episodes whose end the fragment's flags show.
        ends: usize,
    },
    /// More successful episodes than terminations in the fragment.
    #[error("fragment.episodes holds {got} successes, but only {terminations} episodes terminate in the fragment")]
    SuccessCount {
        /// Successes reported.
        got: usize,
        /// Env episodes the fragment shows terminating.
        terminations: usize,
    },
    /// An episode statistic the rules cannot produce.
    #[error("fragment.episodes[{index}].{field} = {value} is outside [{min}, {max}]")]
    EpisodeField {
        /// Position in `episodes`.
        index: usize,
        /// The statistic.
        field: &'static str,
        /// Its value.
        value: Num,
        /// The smallest possible value.
        min: Num,
        /// The largest possible value.
        max: Num,
    },
    /// A success the rules cannot produce.
    #[error("fragment.episodes[{index}].success is set, but {why}")]
    Success {
        /// Position in `episodes`.
        index: usize,
        /// Why it cannot be.
        why: &'static str,
    },
}

impl Implausible {
    /// The field named, as the `field` label of
    /// `buridan_implausible_fragments_total`.
    pub fn field(&self) -> &'static str {
        match self {
            Implausible::Reward { .. } => "rewards",
            Implausible::Logit { .. } => "behaviour_logits",
            Implausible::LogProb { .. } => "behaviour_logp",
            Implausible::EpisodeCount { .. } | Implausible::SuccessCount { .. } => "episodes",
            Implausible::EpisodeField { field, .. } => field,
            Implausible::Success { .. } => "success",
        }
    }
}

/// What the run's env can produce, to check fragments against.
#[derive(Debug, Clone, PartialEq)]
pub struct Plausibility {
    /// Reward of one row in one step (an agent, or a central row's agents).
    pub row_reward: RewardRange,
    /// Unshaped reward of one agent in one step (episode returns leave
    /// shaping out).
    pub agent_reward: RewardRange,
    /// Agents per env.
    pub agents: u32,
    /// Steps before truncation.
    pub t_max: u32,
    /// Lifelong mode (no successes, every arrival counted).
    pub lifelong: bool,
    /// Layouts the run trains on.
    pub layouts: u32,
}

impl Plausibility {
    /// The bounds of `env` on a map whose reachable goal distances are at
    /// most `max_goal_distance`, for fragments of `rows_per_env` rows per
    /// env, over `layouts` layouts.
    pub fn new(env: &EnvConfig, max_goal_distance: u32, rows_per_env: u32, layouts: u32) -> Self {
        let agents = env.agents as u32;
        let agents_per_row = if rows_per_env == 1 { agents } else { 1 };
        let unshaped = EnvConfig {
            shaping: None,
            ..env.clone()
        };
        Self {
            row_reward: env
                .step_reward_range(max_goal_distance)
                .times(agents_per_row),
            agent_reward: unshaped.step_reward_range(max_goal_distance),
            agents,
            t_max: env.t_max,
            lifelong: env.lifelong,
            layouts: layouts.max(1),
        }
    }

    /// The bounds of an AGV plant run: `step` is one AGV's reward range
    /// per step (`buridan_plant::env::step_reward_range`), episodes last at
    /// most `t_max` steps and never succeed, and deliveries count as goals
    /// reached, any number per episode (the lifelong rules' bounds).
    ///
    /// ```
    /// use buridan_env::RewardRange;
    /// use buridan_learner::serve::plausible::Plausibility;
    /// let p = Plausibility::plant(RewardRange { min: -1.02, max: 1.0 }, 2, 1000, 1);
    /// assert_eq!(p.row_reward, RewardRange { min: -2.04, max: 2.0 });
    /// assert!(p.lifelong);
    /// ```
    pub fn plant(step: RewardRange, agents: u32, t_max: u32, rows_per_env: u32) -> Self {
        let agents_per_row = if rows_per_env == 1 { agents } else { 1 };
        Self {
            row_reward: step.times(agents_per_row),
            agent_reward: step,
            agents,
            t_max,
            lifelong: true,
            layouts: 1,
        }
    }

    /// Checks `f` (already through the wire and shape checks): the first
    /// implausible value, if any.
    pub fn check(&self, f: &Fragment) -> Result<(), Implausible> {
        let range = slack(self.row_reward);
        if let Some(index) = f.rewards.iter().position(|&r| !range.contains(r)) {
            return Err(Implausible::Reward {
                index,
                value: Num(f.rewards[index]),
                min: Num(self.row_reward.min),
                max: Num(self.row_reward.max),
            });
        }
        let logit_ok = |(&x, &m): (&f32, &u8)| x.is_finite() || (m == 0 && x == f32::NEG_INFINITY);
        if let Some(index) = f
            .behaviour_logits
            .iter()
            .zip(&f.masks)
            .position(|p| !logit_ok(p))
        {
            return Err(Implausible::Logit {
                index,
                value: f.behaviour_logits[index],
                mask: f.masks[index],
            });
        }
        if let Some(index) = f.behaviour_logp.iter().position(|&p| p > LOGP_SLACK) {
            return Err(Implausible::LogProb {
                index,
                value: Num(f.behaviour_logp[index]),
            });
        }
        self.check_episodes(f)
    }

    /// The episode statistics against the fragment's done flags and the rules.
    fn check_episodes(&self, f: &Fragment) -> Result<(), Implausible> {
        let (mut ends, mut terminations) = (0, 0);
        // Done flags are per row; every row of an env carries its env's.
        for t in 0..f.len {
            for row in (0..f.rows).step_by(f.rows_per_env.max(1)) {
                let i = t * f.rows + row;
                let terminated = f.terminated.get(i).is_some_and(|&x| x != 0);
                let truncated = f.truncated.get(i).is_some_and(|&x| x != 0);
                ends += usize::from(terminated || truncated);
                terminations += usize::from(terminated);
            }
        }
        if f.episodes.len() > ends {
            return Err(Implausible::EpisodeCount {
                got: f.episodes.len(),
                ends,
            });
        }
        let successes = f.episodes.iter().filter(|e| e.success).count();
        if successes > terminations {
            return Err(Implausible::SuccessCount {
                got: successes,
                terminations,
            });
        }
        for (index, e) in f.episodes.iter().enumerate() {
            self.check_episode(index, e)?;
        }
        Ok(())
    }

    fn check_episode(&self, index: usize, e: &EpisodeStats) -> Result<(), Implausible> {
        let agents = f64::from(self.agents);
        let length = f64::from(e.length);
        let agent_steps = agents * length;
        let goals = if self.lifelong { agent_steps } else { agents };
        for (field, value, max) in [
            ("length", e.length, f64::from(self.t_max)),
            ("agents_at_goal", e.agents_at_goal, agents),
            ("goals_reached", e.goals_reached, goals),
            ("blocked_moves", e.blocked_moves, agent_steps),
            ("deadlock_steps", e.deadlock_steps, length),
            ("livelock_steps", e.livelock_steps, length),
            ("deadlock_events", e.deadlock_events, agent_steps),
            (
                "layout",
                e.layout,
                f64::from(self.layouts.saturating_sub(1)),
            ),
        ] {
            let min = if field == "length" { 1.0 } else { 0.0 };
            if !(min..=max).contains(&f64::from(value)) {
                return Err(Implausible::EpisodeField {
                    index,
                    field,
                    value: Num(value as f32),
                    min: Num(min as f32),
                    max: Num(max as f32),
                });
            }
        }
        let returns = self
            .agent_reward
            .times(self.agents.saturating_mul(e.length));
        // Written so that NaN is refused too.
        if !slack(returns).contains(e.reward) {
            return Err(Implausible::EpisodeField {
                index,
                field: "reward",
                value: Num(e.reward),
                min: Num(returns.min),
                max: Num(returns.max),
            });
        }
        if e.success {
            if self.lifelong {
                return Err(Implausible::Success {
                    index,
                    why: "lifelong episodes never succeed",
                });
            }
            if e.agents_at_goal != self.agents {
                return Err(Implausible::Success {
                    index,
                    why: "not every agent is at its goal",
                });
            }
        }
        Ok(())
    }
}

/// `range` widened by the rounding slack.
fn slack(range: RewardRange) -> RewardRange {
    let pad = |x: f32| REWARD_SLACK * x.abs().max(1.0);
    RewardRange {
        min: range.min - pad(range.min),
        max: range.max + pad(range.max),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2 steps of 1 env with 2 agents (local rows); the env truncates at
    /// step 1 with one episode reported.
    fn fragment() -> Fragment {
        let mut f = Fragment::with_capacity(0, 0, 2, 2, 2, 1, 1, 5);
        f.len = 2;
        f.obs = vec![0.0; 4];
        f.masks = vec![1; 20];
        f.actions = vec![0; 4];
        f.behaviour_logits = vec![0.0; 20];
        f.behaviour_logp = vec![-1.6; 4];
        f.rewards = vec![0.5, 0.0, -1.0, 1.5];
        f.terminated = vec![0; 4];
        f.truncated = vec![0, 0, 1, 1];
        f.episodes = vec![EpisodeStats {
            reward: -0.5,
            length: 64,
            agents_at_goal: 1,
            goals_reached: 1,
            ..EpisodeStats::default()
        }];
        f
    }

    fn check() -> Plausibility {
        let env = EnvConfig {
            agents: 2,
            t_max: 64,
            ..EnvConfig::default()
        };
        Plausibility::new(&env, 20, 2, 1)
    }

    #[test]
    fn a_real_looking_fragment_passes() {
        check().check(&fragment()).unwrap();
    }

    #[test]
    fn central_rows_sum_their_agents() {
        let env = EnvConfig {
            agents: 4,
            ..EnvConfig::default()
        };
        let c = Plausibility::new(&env, 20, 1, 1);
        assert_eq!(
            c.row_reward,
            RewardRange {
                min: -8.0,
                max: 6.0
            }
        );
    }

    #[test]
    fn each_refusal_names_its_field() {
        let c = check();
        let refused = |edit: &dyn Fn(&mut Fragment)| {
            let mut f = fragment();
            edit(&mut f);
            c.check(&f).unwrap_err()
        };
        let e = refused(&|f: &mut Fragment| f.rewards[3] = 1.6);
        assert_eq!(e.field(), "rewards");
        assert!(e.to_string().contains("rewards[3] = 1.6"), "{e}");
        let e = refused(&|f: &mut Fragment| f.behaviour_logits[7] = f32::NEG_INFINITY);
        assert_eq!(
            e,
            Implausible::Logit {
                index: 7,
                value: f32::NEG_INFINITY,
                mask: 1
            }
        );
        // −∞ where the action is masked is how a policy masks.
        let mut f = fragment();
        f.masks[7] = 0;
        f.behaviour_logits[7] = f32::NEG_INFINITY;
        c.check(&f).unwrap();
        let e = refused(&|f: &mut Fragment| f.behaviour_logits[2] = f32::INFINITY);
        assert_eq!(e.field(), "behaviour_logits");
        let e = refused(&|f: &mut Fragment| f.behaviour_logp[0] = 0.5);
        assert_eq!(e.field(), "behaviour_logp");
        let e = refused(&|f: &mut Fragment| f.episodes.push(f.episodes[0]));
        assert_eq!(e, Implausible::EpisodeCount { got: 2, ends: 1 });
        let e = refused(&|f: &mut Fragment| f.episodes[0].success = true);
        assert!(matches!(
            e,
            Implausible::SuccessCount {
                got: 1,
                terminations: 0
            }
        ));
        let e = refused(&|f: &mut Fragment| f.episodes[0].reward = 1e30);
        assert_eq!(
            e.to_string(),
            "fragment.episodes[0].reward = 1e30 is outside [-256, 192]"
        );
        let e = refused(&|f: &mut Fragment| f.episodes[0].length = 65);
        assert_eq!(e.field(), "length");
        let e = refused(&|f: &mut Fragment| f.episodes[0].agents_at_goal = 3);
        assert_eq!(e.field(), "agents_at_goal");
        let e = refused(&|f: &mut Fragment| f.episodes[0].layout = 1);
        assert_eq!(e.field(), "layout");
        let e = refused(&|f: &mut Fragment| f.episodes[0].reward = f32::NAN);
        assert_eq!(e.field(), "reward");
    }

    #[test]
    fn a_success_needs_every_agent_home() {
        let c = check();
        let mut f = fragment();
        f.terminated = vec![0, 0, 1, 1];
        f.truncated = vec![0; 4];
        f.episodes[0].success = true;
        let e = c.check(&f).unwrap_err();
        assert!(matches!(e, Implausible::Success { index: 0, .. }), "{e}");
        f.episodes[0].agents_at_goal = 2;
        c.check(&f).unwrap();
    }

    #[test]
    fn numbers_print_compactly() {
        assert_eq!(Num(1e30).to_string(), "1e30");
        assert_eq!(Num(-2.0).to_string(), "-2");
        assert_eq!(Num(1.5).to_string(), "1.5");
    }
}
