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
//! ([`Limits::max_makespan`]). If the planner finds nothing within its limit, the inner
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
//! The count of plans followed per episode is reported as `rescues` in the
//! evaluation's CSV: how often the learned controller needed the net.
//! While a plan is followed the inner controller does not act (a recurrent
//! policy misses those steps' actions as inputs).

use std::sync::Arc;

use buridan_env::GridEnv;
use buridan_mapf::replay::plan_actions;
use buridan_mapf::{Limits, Plan, Planner};

use crate::controller::{Controller, GiveUp, PlanNotes};

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
    /// ahead in a copy of the env (foresight).
    twin: Option<Box<dyn Controller>>,
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
}

impl RescueController {
    /// `inner` rescued by `planner`, which gets `limits` per call.
    pub fn new(inner: Box<dyn Controller>, planner: Arc<dyn Planner>, limits: Limits) -> Self {
        Self {
            inner,
            twin: None,
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
        self.twin = Some(twin);
        self
    }

    /// Whether the twin, playing the episode ahead from `env`'s state, gets
    /// stuck (or cannot play it).
    fn foresees_a_stall(twin: &mut dyn Controller, env: &GridEnv) -> bool {
        let mut ahead = env.clone();
        if twin.begin_episode(&ahead).is_err() {
            return true;
        }
        let n = ahead.agents();
        let (mut actions, mut rewards) = (vec![0u8; n], vec![0.0f32; n]);
        loop {
            twin.act(&ahead, &mut actions);
            let Ok(out) = ahead.step(&actions, &mut rewards) else {
                return true;
            };
            twin.after_step(&rewards);
            if ahead.monitor().stuck() > 0 || out.truncated {
                return true;
            }
            if out.terminated {
                return false;
            }
        }
    }

    /// Plans from `env`'s state within the steps left in the episode; on
    /// success the plan is followed from the next action on.
    fn plan_from(&mut self, env: &GridEnv) -> bool {
        // A plan that outlasts the episode is no rescue: planners that
        // search within a cap (OD-A*, CBS) prune longer ones, a portfolio
        // passes them on to its next planner.
        let remaining = env.config().t_max.saturating_sub(env.t()) as usize;
        let limits = Limits {
            max_makespan: Some(remaining),
            ..self.limits
        };
        let solved = self
            .planner
            .solve(&env.map().grid, &env.positions(), &env.goals(), &limits);
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

impl Controller for RescueController {
    fn name(&self) -> String {
        let kind = if self.twin.is_some() {
            "lookahead"
        } else {
            "rescue"
        };
        format!("{}+{kind}-{}", self.inner.name(), self.planner.name())
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        self.plan = None;
        self.step = 0;
        self.retry_at = 0;
        self.failures = 0;
        self.rescues = 0;
        self.inner.begin_episode(env)?;
        if let Some(twin) = self.twin.as_mut() {
            if Self::foresees_a_stall(twin.as_mut(), env) {
                self.plan_from(env);
            }
        }
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
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
        self.inner.act(env, actions);
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
