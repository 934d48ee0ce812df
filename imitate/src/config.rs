//! The settings of an imitation run (`[imitation]` in a training config).

use buridan_mapf::shield::rollout::RolloutShield;
use serde::{Deserialize, Serialize};

use crate::error::ImitationError;

/// How the policy acts in the rollouts of DAgger's later rounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rollout {
    /// The most probable legal action: the states greedy execution meets.
    #[default]
    Greedy,
    /// Actions sampled from the policy.
    Sampled,
    /// The policy's preferences through the collision shield with goal
    /// settling ([`SHIELD_PATIENCE`]), as `shield-settle=16` executes a
    /// policy: the states a shielded policy meets. The policy ranks its
    /// moves under the wall mask (a move into a neighbour's cell asks it
    /// to make way); its labels stay those of the env's mask. Grid envs
    /// only.
    Shielded,
}

/// Who labels the states a rollout reaches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Teacher {
    /// The planners of `expert`: their next joint step from the state.
    #[default]
    Planner,
    /// The policy itself through the deployment shield: its preferences
    /// (its logits under the wall mask) through `shield-lanes=16`
    /// ([`TEACHER_PATIENCE`]), whose joint move labels each agent, a move
    /// into a cell occupied at the start of the step labelled "stay" (as
    /// [`LabelStyle::Wait`]). Where the shield overrides the policy's own
    /// move in the rollout (a yield, a push, the dead-end order, the lane
    /// rule, the progress fallback) the label is the shield's move: the raw
    /// policy learns what the shield does for it; where it keeps it, the
    /// label is a draw from the policy's own distribution, which anchors
    /// the policy without sharpening it. A polish after learning from rewards
    /// (`expert_first = false`); `expert` and `expert_time` are unused.
    Shield,
}

/// The progress fallback's patience of the [`Teacher::Shield`]'s shield:
/// the evaluation's `shield-lanes=16`.
pub const TEACHER_PATIENCE: u32 = 16;

/// The deployment shield, as the [`Teacher::Shield`] and a `[polish]`'s
/// judge play through it: `shield-lanes=16` ([`TEACHER_PATIENCE`]), and
/// with `stepping_aside` (the setting of that name)
/// `shield[patience=16,ordered,lanes,aside]`; per-episode tie-breaks from
/// `seed`.
pub fn deployment_shield(seed: u64, stepping_aside: bool) -> RolloutShield {
    let shield = RolloutShield::new(seed).with_one_way_lanes(TEACHER_PATIENCE);
    if stepping_aside {
        shield.with_stepping_aside()
    } else {
        shield
    }
}

/// The patience of the shield's goal settling in
/// [`Rollout::Shielded`] rollouts: the evaluation's `shield-settle=16`.
pub const SHIELD_PATIENCE: u32 = 16;

/// How a plan step in which one agent follows another into the cell it
/// leaves becomes labels: the policy's action mask forbids entering a cell
/// occupied at the start of the step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LabelStyle {
    /// The step split into steps the policy can take: the leaders move and
    /// the followers wait, then the followers enter. Following the expert,
    /// the env executes the split steps, so the labels are exactly the
    /// moves between the configurations a rollout passes through.
    #[default]
    Split,
    /// The follower labelled "stay" in the plan's own configuration, and
    /// the env, following the expert, executes the plan's joint move
    /// (follows included, in the env's index order).
    Wait,
}

/// Behaviour cloning of a planner with DAgger's on-policy correction
/// ([`crate::dagger`]). The defaults are the recipe's.
///
/// ```
/// let c: buridan_imitate::ImitationConfig = toml::from_str("rounds = 3\nexpert = [\"cbs\", \"lacam\"]").unwrap();
/// assert_eq!((c.rounds, c.expert.len()), (3, 2));
/// c.validate().unwrap();
/// let bad = buridan_imitate::ImitationConfig { expert: vec!["dijkstra".into()], ..c };
/// assert!(bad.validate().unwrap_err().to_string().contains("dijkstra"));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImitationConfig {
    /// Planners asked for a state's labels, in order, until one solves it
    /// (any name `buridan_mapf::planner_by_name` knows).
    pub expert: Vec<String>,
    /// CPU seconds each planner may spend on one state.
    pub expert_time: f64,
    /// DAgger rounds. Round 0 follows the expert; later rounds follow the
    /// policy being trained (with probability `beta` the expert instead).
    pub rounds: usize,
    /// Env steps collected per round.
    pub steps_per_round: u64,
    /// Envs stepped side by side while collecting.
    pub envs: usize,
    /// Probability that an env follows the expert for one step in rounds
    /// after the first (it unjams the policy, so later states get labels
    /// too).
    pub beta: f64,
    /// How the policy acts in its rollouts: `greedy` (the default),
    /// `sampled`, or `shielded` (its preferences through the collision
    /// shield with goal settling, as `shield-settle=16` executes it).
    pub rollout: Rollout,
    /// Round 0 follows the expert, so a fresh policy's data starts on the
    /// expert's track. Off for a polish after learning from rewards
    /// (`[polish]` in a training config), where every round follows the
    /// trained policy and the expert labels the states it reaches.
    pub expert_first: bool,
    /// Passes over the aggregated data after each round.
    pub epochs: usize,
    /// Rows per gradient step.
    pub minibatch: usize,
    /// Adam step size.
    pub lr: f64,
    /// Most labelled rows kept; beyond it new rows replace random old ones.
    pub max_rows: usize,
    /// Steps per window for a recurrent policy: the windows it is cloned on
    /// replay this many consecutive steps through the LSTM from a stored
    /// state (the learner's `max_seq_len` by default).
    pub window: usize,
    /// How following moves become labels ([`LabelStyle`]).
    pub labels: LabelStyle,
    /// Who labels the states: the planners of `expert` (the default) or
    /// the policy through the deployment shield ([`Teacher`]).
    pub teacher: Teacher,
    /// Under [`Teacher::Shield`], the share of the agreeing data kept for
    /// the fit: a recurrent policy's windows in which the shield overrode
    /// no step, a feed-forward policy's rows it did not override (each
    /// kept with this probability; the others always). The overrides
    /// carry the lesson and the agreeing steps only anchor the policy
    /// where it is, so a share below 1 buys the fit's time back. 1: all.
    pub agreeing_share: f64,
    /// The deployment shield also makes pushed agents step out of their
    /// pusher's way (`shield[patience=16,ordered,lanes,aside]` instead of
    /// `shield-lanes=16`): the [`Teacher::Shield`]'s shield and, in a
    /// `[polish]`, the shield its judge replays the final held-out
    /// episodes through.
    pub stepping_aside: bool,
    /// Threads each gradient step's minibatch is cut across (its windows or
    /// rows in shares, the shares' gradients summed in order: the same step
    /// up to float rounding). 0: the machine's cores; `learner train` gives
    /// it the run's share of the cores, as PPO's `update_threads`.
    pub threads: usize,
}

impl Default for ImitationConfig {
    fn default() -> Self {
        Self {
            expert: vec!["lacam".into()],
            expert_time: 0.02,
            rounds: 5,
            steps_per_round: 20_000,
            envs: 16,
            beta: 0.25,
            rollout: Rollout::Greedy,
            expert_first: true,
            epochs: 3,
            minibatch: 1024,
            lr: 1e-3,
            max_rows: 2_000_000,
            window: 32,
            labels: LabelStyle::Split,
            teacher: Teacher::Planner,
            agreeing_share: 1.0,
            stepping_aside: false,
            threads: 0,
        }
    }
}

impl ImitationConfig {
    /// Checks every setting; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ImitationError> {
        let bad = |field: &'static str, problem: &str| {
            Err(ImitationError::Invalid {
                field,
                problem: problem.to_string(),
            })
        };
        if self.expert.is_empty() {
            return bad("expert", "name at least one planner");
        }
        if let Some(p) = self
            .expert
            .iter()
            .find(|p| buridan_mapf::planner_by_name(p).is_none())
        {
            return bad(
                "expert",
                &format!(
                    "unknown planner '{p}': expected ma-astar, cbs, pibt, lacam or lacam-star"
                ),
            );
        }
        if !(self.expert_time > 0.0 && self.expert_time.is_finite()) {
            return bad("expert_time", "must be a positive number of seconds");
        }
        if self.rounds == 0 {
            return bad("rounds", "must be at least 1");
        }
        if self.steps_per_round == 0 || self.envs == 0 {
            return bad(
                "steps_per_round",
                "steps_per_round and envs must be at least 1",
            );
        }
        if !(0.0..=1.0).contains(&self.beta) {
            return bad("beta", "must lie in [0, 1]");
        }
        if self.window == 0 {
            return bad("window", "must be at least 1 step");
        }
        if self.epochs == 0 || self.minibatch == 0 || self.max_rows == 0 {
            return bad(
                "epochs",
                "epochs, minibatch and max_rows must be at least 1",
            );
        }
        if !(self.lr > 0.0 && self.lr.is_finite()) {
            return bad("lr", "must be positive");
        }
        if !(self.agreeing_share > 0.0 && self.agreeing_share <= 1.0) {
            return bad("agreeing_share", "must lie in (0, 1]");
        }
        if self.teacher == Teacher::Shield {
            if self.expert_first {
                return bad(
                    "teacher",
                    "the shield teaches a trained policy: set expert_first = false",
                );
            }
            if self.rollout == Rollout::Shielded {
                return bad(
                    "teacher",
                    "the shield labels the policy's own moves: rollout must be greedy or sampled",
                );
            }
        }
        Ok(())
    }

    /// The threads a gradient step uses: `threads`, or the machine's cores
    /// when it is 0.
    ///
    /// ```
    /// use buridan_imitate::ImitationConfig;
    /// assert_eq!(ImitationConfig { threads: 3, ..ImitationConfig::default() }.update_threads(), 3);
    /// assert!(ImitationConfig::default().update_threads() >= 1);
    /// ```
    pub fn update_threads(&self) -> usize {
        match self.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        }
    }
}
