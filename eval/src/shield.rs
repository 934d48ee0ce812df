//! A trained policy executed through the PIBT collision shield
//! (`--controller shield:checkpoint:DIR`; CS-PIBT, Veerapaneni et al.,
//! ICAPS 2024).
//!
//! Each step the policy's action probabilities become each agent's
//! preference order over its five actions ([`preference_orders`]), and
//! [`buridan_mapf::shield::Shield`] turns the preferences into one joint
//! move that the env executes exactly: no blocked move, symmetric waits
//! broken by PIBT's priorities (a fixed random order per episode among
//! agents equally long off their goals).
//!
//! - **Greedy** (default): preferences are the actions sorted by
//!   probability, most probable first. Deterministic.
//! - **Sampled** (`--sample`): the first choice is sampled from the
//!   policy's distribution, the rest follow by probability.
//!
//! Which distribution ([`Ranking`]): by default only walls are masked, so
//! a move into a cell another agent holds keeps its place among the
//! agent's preferences (it ranks by the policy's logit) and PIBT can push
//! that agent away — under the env's mask such moves have probability 0,
//! and two agents facing each other would both prefer to wait.
//! [`Ranking::Env`] keeps the env's mask: moves into occupied cells come
//! after every legal action.

use std::path::Path;

use buridan_env::{seed, GridEnv};
use buridan_mapf::shield::{preference_orders, ActionOrder, Shield};
use buridan_policy::{ActMode, Device};

use crate::policy::{MaskKind, PolicyController, PolicyLoadError};

/// The steps without progress after which the shield lets an agent follow
/// its shortest path ([`ShieldController::with_progress_fallback`]) in the
/// studies' `fallback` evaluations. Chosen on validation episodes, not on
/// the reported ones: seed 7, 300 episodes, the ten intent-recipe policies
/// of each reference layout; mean success over the four layouts for
/// patience 4, 8, 12, 16, 24: 98.6, 99.0, 99.2, 99.2, 99.2 % (plain shield
/// 97.9; `docs/results/recipe-shield-fallback/RESULTS.md`).
pub const DEFAULT_PATIENCE: u32 = 16;
use crate::{Controller, GiveUp};

/// Which of the policy's distributions ranks the actions.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Ranking {
    /// Softmax over the moves that do not hit a wall: moves into cells
    /// other agents hold rank by their logits like free ones.
    #[default]
    Walls,
    /// The policy's own masked distribution, as in training: moves into
    /// occupied cells (probability 0) come after every legal action,
    /// ordered by their logits among themselves.
    Env,
}

impl std::str::FromStr for Ranking {
    type Err = String;

    /// `walls` or `env`.
    ///
    /// ```
    /// use buridan_eval::shield::Ranking;
    /// assert_eq!("env".parse::<Ranking>().unwrap(), Ranking::Env);
    /// assert!("x".parse::<Ranking>().is_err());
    /// ```
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "walls" => Ok(Ranking::Walls),
            "env" => Ok(Ranking::Env),
            other => Err(format!("unknown ranking '{other}': expected walls or env")),
        }
    }
}

/// The shield's progress fallback: an agent that has not come closer to
/// its goal for `patience` steps follows its shortest path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Fallback {
    /// Steps without progress before the fallback takes an agent over.
    pub patience: u32,
    /// Only an agent's first arrival on its goal counts as progress, so
    /// that one stepping on and off its goal settles on it.
    pub goal_settling: bool,
}

/// What the shield does beyond PIBT's one step: one value for the
/// controller grammar's `shield[…]` options and [`ShieldController`].
///
/// ```
/// use buridan_eval::shield::{Fallback, ShieldOptions};
/// let lanes = ShieldOptions {
///     fallback: Some(Fallback { patience: 16, goal_settling: false }),
///     dead_end_order: true,
///     one_way_lanes: true,
///     ..ShieldOptions::default()
/// };
/// assert_eq!(lanes.label(), "shield-lanes=16");
/// assert_eq!(ShieldOptions { stepping_aside: true, ..lanes }.label(), "shield-lanes-aside=16");
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShieldOptions {
    /// Which of the policy's distributions ranks the moves.
    pub ranking: Ranking,
    /// The progress fallback, if any ([`Shield::with_progress_fallback`],
    /// [`Shield::with_goal_settling`]).
    pub fallback: Option<Fallback>,
    /// Dead-end aisles are filled from the back
    /// ([`Shield::with_dead_end_order`]).
    pub dead_end_order: bool,
    /// Agents in a dead end's way back out of it
    /// ([`Shield::with_dead_end_eviction`]).
    pub dead_end_eviction: bool,
    /// One-lane corridors are kept one-way ([`Shield::with_one_way_lanes`]).
    pub one_way_lanes: bool,
    /// Pushed agents step out of their pusher's way
    /// ([`Shield::with_stepping_aside`]).
    pub stepping_aside: bool,
}

impl ShieldOptions {
    /// The shield with these options, for `grid`.
    pub fn shield(&self, grid: &buridan_env::Grid) -> Shield {
        let mut shield = Shield::new(grid);
        match self.fallback {
            Some(f) if f.goal_settling => shield = shield.with_goal_settling(f.patience),
            Some(f) => shield = shield.with_progress_fallback(f.patience),
            None => {}
        }
        if self.dead_end_order {
            shield = shield.with_dead_end_order();
        }
        if self.dead_end_eviction {
            shield = shield.with_dead_end_eviction();
        }
        if self.one_way_lanes {
            shield = shield.with_one_way_lanes();
        }
        if self.stepping_aside {
            shield = shield.with_stepping_aside();
        }
        shield
    }

    /// The short label of these options in a controller's name
    /// (`shield-lanes=16`, `shield-settle-evict-aside=16`): the strongest
    /// of lanes, order and settling, then each further option.
    pub fn label(&self) -> String {
        let settle = self.fallback.is_some_and(|f| f.goal_settling);
        let base = if self.one_way_lanes {
            "shield-lanes"
        } else if self.dead_end_order {
            "shield-ordered"
        } else if settle {
            "shield-settle"
        } else {
            "shield"
        };
        let evict = if self.dead_end_eviction { "-evict" } else { "" };
        let aside = if self.stepping_aside { "-aside" } else { "" };
        match self.fallback {
            None => format!("{base}{evict}{aside}"),
            Some(f) => format!("{base}{evict}{aside}={}", f.patience),
        }
    }
}

/// A trained policy whose actions pass through the collision shield (see
/// the [module docs](self)).
pub struct ShieldController {
    policy: PolicyController,
    seed: u64,
    options: ShieldOptions,
    shield: Option<Shield>,
    prefs: Vec<ActionOrder>,
    /// Agent-steps of this episode whose action was not the policy's
    /// first choice.
    overridden: u32,
    /// Per agent, whether the last step's action was not the policy's
    /// first choice.
    last_overridden: Vec<bool>,
}

impl ShieldController {
    /// Loads the policy at `checkpoint` for episodes with `agents` agents;
    /// `seed` drives sampling and the per-episode priority tie-breaks.
    ///
    /// ```no_run
    /// use buridan_eval::shield::{Ranking, ShieldController};
    /// use buridan_policy::ActMode;
    /// let dir = std::path::Path::new("docs/results/ppo-ctde-rm-2.1");
    /// let c = ShieldController::load(dir, 4, ActMode::Greedy, 42, Ranking::Walls).unwrap();
    /// ```
    pub fn load(
        checkpoint: &Path,
        agents: usize,
        act_mode: ActMode,
        seed: u64,
        ranking: Ranking,
    ) -> Result<Self, PolicyLoadError> {
        Self::load_on(checkpoint, agents, act_mode, seed, ranking, &Device::Cpu)
    }

    /// [`Self::load`] with the policy's weights on `device`.
    pub fn load_on(
        checkpoint: &Path,
        agents: usize,
        act_mode: ActMode,
        seed: u64,
        ranking: Ranking,
        device: &Device,
    ) -> Result<Self, PolicyLoadError> {
        Ok(Self {
            policy: PolicyController::load_on(checkpoint, agents, act_mode, seed, device)?,
            seed,
            options: ShieldOptions {
                ranking,
                ..ShieldOptions::default()
            },
            shield: None,
            prefs: Vec::with_capacity(agents),
            overridden: 0,
            last_overridden: Vec::with_capacity(agents),
        })
    }

    /// The same controller with every option of `options` (its ranking
    /// included).
    pub fn with_options(mut self, options: ShieldOptions) -> Self {
        self.options = options;
        self
    }

    /// The same controller whose shield lets an agent that has not come
    /// closer to its goal for `patience` steps follow its shortest path
    /// ([`Shield::with_progress_fallback`]; `shield=K:checkpoint:DIR`).
    pub fn with_progress_fallback(mut self, patience: u32) -> Self {
        self.options.fallback = Some(Fallback {
            patience,
            goal_settling: false,
        });
        self
    }

    /// The same controller with the progress fallback that counts only the
    /// first arrival on a goal as progress, so that an agent stepping on
    /// and off its goal settles on it ([`Shield::with_goal_settling`];
    /// `shield-settle=K:checkpoint:DIR`).
    pub fn with_goal_settling(mut self, patience: u32) -> Self {
        self.options.fallback = Some(Fallback {
            patience,
            goal_settling: true,
        });
        self
    }

    /// The same controller whose shield fills dead-end aisles from the
    /// back ([`Shield::with_dead_end_order`];
    /// `shield-ordered[=K]:checkpoint:DIR`).
    pub fn with_dead_end_order(mut self) -> Self {
        self.options.dead_end_order = true;
        self
    }

    /// The same controller whose shield also backs agents out of a dead
    /// end entered in the wrong order ([`Shield::with_dead_end_eviction`];
    /// the option `evict` of `shield[…]:checkpoint:DIR`).
    pub fn with_dead_end_eviction(mut self) -> Self {
        self.options.dead_end_eviction = true;
        self
    }

    /// The same controller whose shield keeps one-lane corridors one-way
    /// ([`Shield::with_one_way_lanes`]; `shield-lanes[=K]:checkpoint:DIR`,
    /// which also fills dead-end aisles from the back).
    pub fn with_one_way_lanes(mut self) -> Self {
        self.options.one_way_lanes = true;
        self
    }

    /// The same controller whose shield makes pushed agents step out of
    /// their pusher's way ([`Shield::with_stepping_aside`]; the option
    /// `aside` of `shield[…]:checkpoint:DIR`).
    pub fn with_stepping_aside(mut self) -> Self {
        self.options.stepping_aside = true;
        self
    }
}

impl Controller for ShieldController {
    fn name(&self) -> String {
        format!("{}+{}", self.policy.name(), self.options.label())
    }

    fn obs_features(&self) -> buridan_env::ObsFeatures {
        self.policy.obs_features()
    }

    fn obs_sensor_range(&self) -> usize {
        self.policy.obs_sensor_range()
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        self.policy.begin_episode(env)?;
        // A fixed order among equals per episode, independent of which
        // evaluation thread plays it.
        let ties = seed::shield_ties(self.seed, env.episode());
        let mut shield = self.options.shield(&env.map().grid);
        shield.begin_episode(env.agents(), ties);
        self.shield = Some(shield);
        self.overridden = 0;
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        let mask = match self.options.ranking {
            Ranking::Walls => MaskKind::Walls,
            Ranking::Env => MaskKind::Env,
        };
        let Ok(d) = self.policy.decide(env, mask) else {
            // Stay is always legal, so inference cannot fail on masks.
            actions.fill(0);
            return;
        };
        preference_orders(d.actions, d.logits, d.masks, &mut self.prefs);
        let shield = match self.shield.take() {
            Some(shield) => shield,
            None => self.options.shield(&env.map().grid),
        };
        let shield = self.shield.insert(shield);
        if shield
            .step(&env.positions(), &env.goals(), &self.prefs, actions)
            .is_err()
        {
            // The env's own state is always valid; stay rather than panic.
            actions.fill(0);
        }
        self.last_overridden.clear();
        self.last_overridden.extend(
            self.prefs
                .iter()
                .zip(actions.iter())
                .map(|(order, &a)| order[0] != a),
        );
        self.overridden += self.last_overridden.iter().filter(|&&o| o).count() as u32;
        self.policy.record_taken(actions);
    }

    fn after_step(&mut self, rewards: &[f32]) {
        self.policy.after_step(rewards);
    }

    fn overridden(&self) -> Option<&[bool]> {
        Some(&self.last_overridden)
    }

    fn episode_notes(&self) -> crate::PlanNotes {
        crate::PlanNotes {
            overridden: Some(self.overridden),
            ..self.policy.episode_notes()
        }
    }
}
