//! Classical planners of `buridan-mapf` as [`Controller`]s: plan once at the
//! start of an episode within the limits, then follow the plan step by step.
//!
//! A plan is asked for within the episode's T_max
//! ([`Limits::max_makespan`], lowered to the steps left): a plan longer
//! than that cannot succeed. The controllers of `learner eval` plan with
//! [`buridan_mapf::planner_within_cap`], whose LaCAM and LaCAM\* refine a
//! plan that is too long until it fits, or prove that none does
//! ([`GiveUp::NoSolutionWithin`]).

use buridan_mapf::Problem;
use std::sync::Arc;

use buridan_env::GridEnv;
use buridan_mapf::replay::action_between;
use buridan_mapf::{Limits, Plan, Planner, SolveError};

use crate::controller::{Controller, GiveUp, PlanNotes};

/// A planner driving the env: `begin_episode` plans, `act` replays the plan.
///
/// ```
/// use buridan_eval::{evaluate, planner::PlannerController, EvalSpec};
/// use buridan_env::Starts;
/// let map = std::sync::Arc::new(buridan_env::Map::load("rm-1.1").unwrap());
/// let spec = EvalSpec { agents: 2, episodes: 1, starts: Starts::Fixed, ..EvalSpec::default() };
/// let make = || -> Box<dyn buridan_eval::Controller> {
///     Box::new(PlannerController::new(buridan_mapf::planner_by_name("cbs").unwrap().into(), Default::default()))
/// };
/// let report = evaluate(&map, &spec, &make, &|_| {}).unwrap();
/// assert_eq!(report.summary.success_rate, 1.0);
/// ```
pub struct PlannerController {
    planner: Arc<dyn Planner>,
    limits: Limits,
    plan: Option<Plan>,
    notes: PlanNotes,
}

impl PlannerController {
    /// Wraps `planner`, which gets `limits` per instance, with
    /// [`Limits::max_makespan`] at most the steps left in the episode.
    pub fn new(planner: Arc<dyn Planner>, limits: Limits) -> Self {
        Self {
            planner,
            limits,
            plan: None,
            notes: PlanNotes::default(),
        }
    }
}

impl Controller for PlannerController {
    fn name(&self) -> String {
        self.planner.name().to_string()
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        self.plan = None;
        self.notes = PlanNotes::default();
        let left = env.config().t_max.saturating_sub(env.t()) as usize;
        let limits = Limits {
            max_makespan: Some(self.limits.max_makespan.map_or(left, |m| m.min(left))),
            ..self.limits
        };
        let solved = self.planner.solve(
            Problem::new(&env.map().grid, &env.positions(), &env.goals()),
            &limits,
        );
        match solved {
            Ok(solution) => {
                self.notes = PlanNotes {
                    plan_makespan: Some(solution.plan.makespan() as u32),
                    plan_sum_of_costs: Some(solution.plan.sum_of_costs() as u32),
                    expanded: Some(solution.stats.expanded),
                    ..PlanNotes::default()
                };
                self.plan = Some(solution.plan);
                Ok(())
            }
            Err(SolveError::TimeLimit { .. }) => Err(GiveUp::TimeLimit),
            Err(SolveError::MemoryLimit { .. }) => Err(GiveUp::MemoryLimit),
            Err(SolveError::NoSolution) => Err(GiveUp::NoSolution),
            Err(SolveError::NoSolutionWithin { max_makespan }) => {
                Err(GiveUp::NoSolutionWithin(max_makespan))
            }
            Err(other) => Err(GiveUp::Other(other.to_string())),
        }
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        let Some(plan) = &self.plan else {
            actions.fill(0);
            return;
        };
        let t = env.t() as usize;
        for (i, a) in actions.iter_mut().enumerate() {
            // Agents stay on their goals once their path ends.
            *a = plan
                .position(i, t + 1)
                .map_or(0, |next| action_between(env.position(i), next).unwrap_or(0));
        }
    }

    fn episode_notes(&self) -> PlanNotes {
        self.notes
    }

    fn follows_plan(&self) -> bool {
        true
    }
}
