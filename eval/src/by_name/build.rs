//! A [`Controller`] value made into controllers, one per evaluation thread.

use std::sync::Arc;

use buridan_env::Rules;
use buridan_mapf::{planner_within_cap, Limits, Planner, PlannerLookupError};
use buridan_policy::Device;

use super::grammar::{Controller, NetKind, Portfolio};
use super::{
    ControllerFactory, ControllerNameError, CROWD_RESCUE_PLANNER, DEFAULT_RESCUE_PLANNER,
    RESCUE_OD_ASTAR_MAX_AGENTS,
};
use crate::lifelong::LifelongPibtController;
use crate::planner::PlannerController;
use crate::policy::{PolicyController, PolicyLoadError};
use crate::rescue::RescueController;
use crate::shield::ShieldController;
use crate::RandomController;

/// The planner of a net that names none, for `agents` agents under `rules`.
fn default_rescue_planner(agents: usize, rules: Rules) -> &'static str {
    if rules == Rules::Pogema || agents > RESCUE_OD_ASTAR_MAX_AGENTS {
        CROWD_RESCUE_PLANNER
    } else {
        DEFAULT_RESCUE_PLANNER
    }
}

impl Controller {
    /// A factory of this controller for episodes with `agents` agents
    /// under `rules`: planners (also the nets') plan for that rule set, and
    /// one that cannot (OD-A* under pogema) is an error; a planner plans
    /// within the episode's T_max, a net's within the steps left (their
    /// LaCAM and LaCAM\* refine a plan that is too long, see
    /// `buridan_mapf::planner_within_cap`); policies sample
    /// with `seed`; the shield keeps the thesis conflict model, whose joint
    /// moves POGEMA's rules execute too. A checkpoint is loaded once here,
    /// so that a bad one fails with its reason.
    ///
    /// ```
    /// use buridan_eval::by_name::Controller;
    /// use buridan_env::Rules;
    /// let c: Controller = "rescue=lacam:random".parse().unwrap();
    /// let make = c.factory(4, 42, Default::default(), Rules::Thesis).unwrap();
    /// assert_eq!(make().name(), "random+rescue-lacam");
    /// ```
    pub fn factory(
        &self,
        agents: usize,
        seed: u64,
        limits: Limits,
        rules: Rules,
    ) -> Result<ControllerFactory, ControllerNameError> {
        self.factory_on(agents, seed, limits, rules, &Device::Cpu)
    }

    /// [`Self::factory`] whose trained policies act on `device` (`learner
    /// eval --device`): each controller it makes loads its checkpoint's
    /// weights there. Planners, shields and the env stay on the CPU.
    pub fn factory_on(
        &self,
        agents: usize,
        seed: u64,
        limits: Limits,
        rules: Rules,
        device: &Device,
    ) -> Result<ControllerFactory, ControllerNameError> {
        let name = || self.to_string();
        match self {
            Controller::Net(net) => {
                let planner = match &net.planner {
                    Some(p) => p.to_string(),
                    None => default_rescue_planner(agents, rules).to_string(),
                };
                // Within the cap: measured with 1 s per call, seed 42, 100
                // episodes, `rescue:shield-lanes=16:checkpoint:model:M`:
                // rm-2.1b 16 agents 55 -> 94 % success (mean compute per
                // episode 2.1 -> 2.5 s), 8 agents 98 -> 99 %, rm-3.1 16
                // agents 100 % either way.
                let planner: Arc<dyn Planner> = planner_within_cap(&planner, rules)
                    .map_err(|source| ControllerNameError::RescueRules {
                        name: name(),
                        source,
                    })?
                    .into();
                let inner = net.inner.factory_on(agents, seed, limits, rules, device)?;
                let kind = net.kind;
                Ok(Box::new(move || {
                    let rescue = RescueController::new(inner(), planner.clone(), limits);
                    Box::new(match kind {
                        NetKind::Lookahead => rescue.with_foresight(inner()),
                        NetKind::Backstop => rescue.with_backstop(inner()),
                        NetKind::Pace => rescue.with_pace(inner()),
                        NetKind::Rescue => rescue,
                    })
                }))
            }
            Controller::Shield(s) => {
                let (s, device) = (s.clone(), device.clone());
                let load = move || {
                    let p = &s.policy;
                    let shield = ShieldController::load_on(
                        &p.checkpoint,
                        agents,
                        p.act.into(),
                        seed,
                        s.options.ranking,
                        &device,
                    )?
                    .with_options(s.options);
                    Ok::<_, PolicyLoadError>(shield)
                };
                load()?;
                Ok(Box::new(move || {
                    Box::new(load().expect("loaded once already"))
                }))
            }
            Controller::Policy(p) => {
                let (dir, act, device) = (p.checkpoint.clone(), p.act.into(), device.clone());
                PolicyController::load_on(&dir, agents, act, seed, &device)?;
                Ok(Box::new(move || {
                    Box::new(
                        PolicyController::load_on(&dir, agents, act, seed, &device)
                            .expect("loaded once already"),
                    )
                }))
            }
            Controller::Random => Ok(Box::new(move || Box::new(RandomController::new(seed)))),
            Controller::LifelongPibt => Ok(Box::new(move || {
                Box::new(LifelongPibtController::new(seed))
            })),
            Controller::Planner(p) => {
                let planner: Arc<dyn Planner> = planner_of(p, rules)
                    .map_err(|source| ControllerNameError::Rules {
                        name: name(),
                        source,
                    })?
                    .into();
                Ok(Box::new(move || {
                    Box::new(PlannerController::new(planner.clone(), limits))
                }))
            }
        }
    }
}

/// The portfolio's planner for `rules`, planning within the episode's
/// T_max (LaCAM and LaCAM\* refine a plan that is too long, see
/// [`planner_within_cap`]).
fn planner_of(p: &Portfolio, rules: Rules) -> Result<Box<dyn Planner>, PlannerLookupError> {
    planner_within_cap(&p.to_string(), rules)
}
