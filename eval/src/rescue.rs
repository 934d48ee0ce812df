//! A controller with a planner as its safety net (`--controller
//! rescue:INNER`, e.g. `rescue:shield:checkpoint:DIR`).
//!
//! The inner controller — a trained policy, usually through the collision
//! shield — drives the robots. When the stall detector
//! ([`buridan_env::monitor`]) reports an agent *stuck* (off its goal, no
//! progress for `k` steps: jammed in a standoff, or dithering alone), a
//! planner (on the command line LaCAM then OD-A* by default: LaCAM answers
//! in milliseconds, OD-A* finds the dead-end orderings LaCAM misses) plans
//! from the current state, and its plan is followed to its end; then
//! the inner controller takes over again. A plan that stops matching the
//! env is dropped. Plans are asked for within the steps left in the episode
//! ([`Limits::max_makespan`]; the planners of `rescue:…` search within it,
//! see `buridan_mapf::planner_within_cap`). If the planner finds nothing within its limit, the inner
//! controller goes on and the planner is asked again after `k` more steps,
//! then after `2k`, `4k`, … (a state the planner cannot solve quickly
//! costs a few calls per episode, not one every `k` steps).
//!
//! **Foresight** ([`RescueController::with_foresight`], `--controller
//! lookahead:INNER`): a deterministic inner controller (greedy, or greedy
//! through the shield) will do in the episode exactly what a twin of it does
//! in a copy of the env. At the start of each episode the twin plays the
//! episode ahead; if it would get stuck, the planner plans from the start
//! at once instead of from the jam `k` steps too late, and the episode
//! runs on the plan (with the makespan-optimal OD-A*, as short as any
//! planner's); if the twin would finish, the inner controller drives. A
//! failed start-plan leaves the ordinary rescue in place.
//!
//! **Backstop** ([`RescueController::with_backstop`], `--controller
//! backstop:INNER`): the same twin, asked a weaker question — does the
//! episode *fail* (time runs out), not does an agent stall on the way. If
//! the twin finishes, however slowly, the inner controller drives the whole
//! episode untouched (no stall rescue either: it would change an episode
//! known to succeed); if it fails, the planner plans from the start, and
//! the ordinary rescue stays behind a failed start-plan. The planner then
//! drives only the episodes the learned controller cannot finish, so the
//! `rescues` column counts exactly those: the net's share, not the stall
//! detector's.
//!
//! **Pace** ([`RescueController::with_pace`], `--controller pace:INNER`):
//! the backstop, and a bound on slowness. The planner also plans every
//! episode from its start; if the twin fails, or finishes more than
//! [`PACE_SLACK`] later than the plan's makespan, the plan drives the
//! episode; otherwise the inner controller drives it untouched and the plan
//! is dropped. A deterministic learned controller then never takes more
//! than 10 % longer than the planner on an episode the planner solves (with
//! the makespan-optimal OD-A* first in the portfolio, than any planner),
//! and `rescues` counts the episodes it handed over.
//!
//! The count of plans followed per episode is reported as `rescues` in the
//! evaluation's CSV: how often the learned controller needed the net.
//! While a plan is followed the inner controller does not act (a recurrent
//! policy misses those steps' actions as inputs).

use buridan_mapf::Problem;
use std::sync::Arc;

use buridan_env::GridEnv;
use buridan_mapf::replay::plan_actions;
use buridan_mapf::{Limits, Plan, Planner};

use crate::controller::{Controller, GiveUp, PlanNotes};

/// How much longer than the planner's plan from the start a `pace:` twin's
/// run may take and still drive the episode: 10 % (the recipe's target
/// against CBS's timesteps: within 10 % of them on the instances both solve).
pub const PACE_SLACK: f64 = 0.10;

/// An inner controller rescued from stalls by a planner (see the
/// [module docs](self)).
///
/// ```
/// use std::sync::Arc;
/// use buridan_eval::{evaluate, rescue::RescueController, EvalSpec, RandomController};
/// use buridan_mapf::{planner_by_name, Limits};
/// let map = Arc::new(buridan_env::Map::load("rm-2.1").unwrap());
/// let spec = EvalSpec { agents: 4, episodes: 10, ..EvalSpec::default() };
/// let make = || -> Box<dyn buridan_eval::Controller> {
///     let lacam: Arc<dyn buridan_mapf::Planner> = planner_by_name("lacam").unwrap().into();
///     Box::new(RescueController::new(Box::new(RandomController::new(42)), lacam, Limits::default()))
/// };
/// let report = evaluate(&map, &spec, &make, &|_| {}).unwrap();
/// // Random walks never finish; rescued by LaCAM once stuck, they do.
/// assert!(report.summary.success_rate >= 0.9, "{}", report.summary.success_rate);
/// assert!(report.records.iter().all(|r| r.rescues.unwrap() >= 1));
/// ```
pub struct RescueController {
    inner: Box<dyn Controller>,
    /// A second instance of the inner controller that plays each episode
    /// ahead in a copy of the env, and what its run must show for the
    /// planner to plan from the start.
    twin: Option<(Box<dyn Controller>, Foresight)>,
    /// This episode is the inner controller's alone (a backstop's twin
    /// finished it).
    hands_off: bool,
    planner: Arc<dyn Planner>,
    limits: Limits,
    /// The plan followed and its joint actions, step by step.
    plan: Option<(Plan, Vec<Vec<u8>>)>,
    /// The plan's step the env is at.
    step: usize,
    /// No planner call before this env step (after a failed one).
    retry_at: u32,
    /// Planner calls of this episode that found nothing.
    failures: u32,
    rescues: u32,
    /// The inner controller chose the last step's actions (not the plan).
    inner_acted: bool,
}

impl RescueController {
    /// `inner` rescued by `planner`, which gets `limits` per call.
    pub fn new(inner: Box<dyn Controller>, planner: Arc<dyn Planner>, limits: Limits) -> Self {
        Self {
            inner,
            twin: None,
            hands_off: false,
            inner_acted: false,
            planner,
            limits,
            plan: None,
            step: 0,
            retry_at: 0,
            failures: 0,
            rescues: 0,
        }
    }

    /// With foresight: `twin`, a second instance of the inner controller,
    /// plays each episode ahead in a copy of the env; if it gets stuck the
    /// planner plans from the episode's start (see the [module docs](self)).
    /// Only a deterministic inner controller's twin foresees what will
    /// happen.
    pub fn with_foresight(mut self, twin: Box<dyn Controller>) -> Self {
        self.twin = Some((twin, Foresight::Stall));
        self
    }

    /// As a backstop: `twin`, a second instance of the inner controller,
    /// plays each episode ahead; the planner plans from the start only if
    /// the twin fails to finish, and otherwise stays out of the episode
    /// (see the [module docs](self)). Needs a deterministic inner
    /// controller, as [`Self::with_foresight`].
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_eval::{evaluate, rescue::RescueController, EvalSpec, RandomController};
    /// use buridan_mapf::{planner_by_name, Limits};
    /// let map = Arc::new(buridan_env::Map::load("rm-2.1").unwrap());
    /// let spec = EvalSpec { agents: 4, episodes: 5, ..EvalSpec::default() };
    /// let make = || -> Box<dyn buridan_eval::Controller> {
    ///     let od: Arc<dyn buridan_mapf::Planner> = planner_by_name("od-astar").unwrap().into();
    ///     let random = |seed| Box::new(RandomController::new(seed));
    ///     Box::new(RescueController::new(random(7), od, Limits::default()).with_backstop(random(7)))
    /// };
    /// let report = evaluate(&map, &spec, &make, &|_| {}).unwrap();
    /// // The random twin never finishes: OD-A* plans every episode from its start.
    /// assert_eq!(report.summary.success_rate, 1.0);
    /// assert!(report.records.iter().all(|r| r.rescues == Some(1)));
    /// ```
    pub fn with_backstop(mut self, twin: Box<dyn Controller>) -> Self {
        self.twin = Some((twin, Foresight::Failure));
        self
    }

    /// With a pace: the backstop, and the planner also drives the episodes
    /// the twin would finish more than [`PACE_SLACK`] later than the
    /// planner's plan from the start (see the [module docs](self)). Every
    /// episode costs one planner call.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_eval::{evaluate, rescue::RescueController, EvalSpec, RandomController};
    /// use buridan_mapf::{planner_by_name, Limits};
    /// let map = Arc::new(buridan_env::Map::load("rm-2.1").unwrap());
    /// let spec = EvalSpec { agents: 4, episodes: 5, ..EvalSpec::default() };
    /// let make = || -> Box<dyn buridan_eval::Controller> {
    ///     let od: Arc<dyn buridan_mapf::Planner> = planner_by_name("od-astar").unwrap().into();
    ///     let random = |seed| Box::new(RandomController::new(seed));
    ///     Box::new(RescueController::new(random(7), od, Limits::default()).with_pace(random(7)))
    /// };
    /// let report = evaluate(&map, &spec, &make, &|_| {}).unwrap();
    /// // The random twin never finishes: OD-A*'s plan drives every episode.
    /// assert_eq!(report.summary.success_rate, 1.0);
    /// assert!(report.records.iter().all(|r| r.rescues == Some(1)));
    /// ```
    pub fn with_pace(mut self, twin: Box<dyn Controller>) -> Self {
        self.twin = Some((twin, Foresight::Pace));
        self
    }

    /// The steps the twin, playing the episode ahead from `env`'s state,
    /// takes to bring every agent to its goal in time — `None` if it does
    /// not, or stalls on the way where `foresight` asks for no stall (a twin
    /// that cannot play does not finish).
    fn twin_finish_time(
        twin: &mut dyn Controller,
        env: &GridEnv,
        foresight: Foresight,
    ) -> Option<u32> {
        let mut ahead = env.clone();
        twin.begin_episode(&ahead).ok()?;
        let n = ahead.agents();
        let (mut actions, mut rewards) = (vec![0u8; n], vec![0.0f32; n]);
        loop {
            twin.act(&ahead, &mut actions);
            let out = ahead.step(&actions, &mut rewards).ok()?;
            twin.after_step(&rewards);
            let stalled = foresight == Foresight::Stall && ahead.monitor().stuck() > 0;
            if stalled || out.truncated {
                return None;
            }
            if out.terminated {
                return Some(ahead.t() - env.t());
            }
        }
    }

    /// Plans from `env`'s state within the steps left in the episode; on
    /// success the plan is followed from the next action on.
    fn plan_from(&mut self, env: &GridEnv) -> bool {
        // A plan that outlasts the episode is no rescue: planners that
        // search within a cap (OD-A*, CBS, LaCAM made by
        // `planner_within_cap`) prune longer ones, a portfolio passes them
        // on to its next planner.
        let remaining = env.config().t_max.saturating_sub(env.t()) as usize;
        let limits = Limits {
            max_makespan: Some(remaining),
            ..self.limits
        };
        let solved = self.planner.solve(
            Problem::new(&env.map().grid, &env.positions(), &env.goals()),
            &limits,
        );
        let planned = solved.ok().and_then(|solution| {
            let steps = plan_actions(&solution.plan).ok()?;
            Some((solution.plan, steps))
        });
        match planned {
            Some(plan) => {
                self.plan = Some(plan);
                self.step = 0;
                self.rescues += 1;
                true
            }
            None => false,
        }
    }

    /// Writes the plan's next step if the env is where the plan says;
    /// otherwise drops the plan.
    fn follow(&mut self, env: &GridEnv, actions: &mut [u8]) -> bool {
        let Some((plan, steps)) = &self.plan else {
            return false;
        };
        let t = self.step;
        if t < plan.makespan() && plan.positions_at(t) == env.positions() {
            actions.copy_from_slice(&steps[t]);
            self.step += 1;
            return true;
        }
        self.plan = None;
        false
    }
}

/// What a twin's run ahead must show for the planner to plan from the
/// episode's start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Foresight {
    /// An agent gets stuck on the way (`lookahead:`).
    Stall,
    /// The episode fails (`backstop:`).
    Failure,
    /// The episode fails, or takes more than [`PACE_SLACK`] longer than
    /// the planner's plan (`pace:`).
    Pace,
}

impl Controller for RescueController {
    fn name(&self) -> String {
        let kind = match self.twin {
            Some((_, Foresight::Stall)) => "lookahead",
            Some((_, Foresight::Failure)) => "backstop",
            Some((_, Foresight::Pace)) => "pace",
            None => "rescue",
        };
        format!("{}+{kind}-{}", self.inner.name(), self.planner.name())
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        self.plan = None;
        self.step = 0;
        self.retry_at = 0;
        self.failures = 0;
        self.rescues = 0;
        self.hands_off = false;
        self.inner.begin_episode(env)?;
        let Some((twin, foresight)) = self.twin.as_mut() else {
            return Ok(());
        };
        let foresight = *foresight;
        let finish = Self::twin_finish_time(twin.as_mut(), env, foresight);
        match (foresight, finish) {
            (_, None) => {
                self.plan_from(env);
            }
            (Foresight::Stall, Some(_)) => {}
            (Foresight::Failure, Some(_)) => self.hands_off = true,
            (Foresight::Pace, Some(steps)) => {
                let planned = self.plan_from(env);
                let plan_steps = self.plan.as_ref().map_or(0, |(plan, _)| plan.makespan());
                if !planned || f64::from(steps) <= (1.0 + PACE_SLACK) * plan_steps as f64 {
                    // The twin keeps pace with the plan (or nothing plans
                    // faster): the episode is the inner controller's.
                    self.plan = None;
                    self.rescues = 0;
                    self.hands_off = true;
                }
            }
        }
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        self.inner_acted = false;
        if self.hands_off {
            self.inner_acted = true;
            return self.inner.act(env, actions);
        }
        if self.follow(env, actions) {
            return;
        }
        let monitor = env.monitor();
        if monitor.stuck() > 0 && env.t() >= self.retry_at {
            if !self.plan_from(env) {
                self.retry_at = env.t() + (monitor.window() << self.failures.min(8));
                self.failures += 1;
            } else if self.follow(env, actions) {
                return;
            }
        }
        self.inner_acted = true;
        self.inner.act(env, actions);
    }

    /// The inner controller's, on the steps it chose (none while a plan
    /// drives).
    fn overridden(&self) -> Option<&[bool]> {
        if self.inner_acted {
            self.inner.overridden()
        } else {
            None
        }
    }

    fn after_step(&mut self, rewards: &[f32]) {
        self.inner.after_step(rewards);
    }

    fn episode_notes(&self) -> PlanNotes {
        PlanNotes {
            rescues: Some(self.rescues),
            ..self.inner.episode_notes()
        }
    }

    fn obs_features(&self) -> buridan_env::ObsFeatures {
        self.inner.obs_features()
    }

    fn obs_sensor_range(&self) -> usize {
        self.inner.obs_sensor_range()
    }
}
