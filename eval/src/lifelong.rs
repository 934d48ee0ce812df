//! Lifelong PIBT as a controller: one PIBT step from wherever the agents
//! stand, towards whatever their goals are now ([`buridan_mapf::lifelong`]).
//!
//! A planner (`pibt`, `lacam`) solves the episode from its start and is
//! followed step by step; it fails when no plan brings every agent home
//! within the step limit, and it must plan again whenever a goal changes
//! or a robot lags. `lifelong-pibt` plans nothing: each step is computed
//! from the current positions and goals, with priorities that grow while
//! an agent is away from its goal, so it serves fleets whose goals keep
//! changing and whose robots do not always move (a fleet session,
//! [`crate::fleet`]), and one-shot episodes alike.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::{EnvConfig, Map};
//! use buridan_eval::lifelong::LifelongPibtController;
//! use buridan_eval::{evaluate, EvalSpec};
//! let map = Arc::new(Map::load("rm-2.1").unwrap());
//! let spec = EvalSpec { agents: 4, episodes: 5, ..EvalSpec::default() };
//! let report = evaluate(&map, &spec, &|| Box::new(LifelongPibtController::new(0)), &|_| {}).unwrap();
//! assert_eq!(report.summary.controller, "lifelong-pibt");
//! assert!(report.summary.success_rate >= 0.6);
//! ```

use buridan_env::GridEnv;
use buridan_mapf::lifelong::LifelongPibt;
use buridan_mapf::ConflictModel;

use crate::controller::{Controller, GiveUp};

/// PIBT one step at a time (see the [module docs](self)).
pub struct LifelongPibtController {
    seed: u64,
    pibt: Option<LifelongPibt>,
}

impl LifelongPibtController {
    /// A controller whose tie-breaking in episode `e` depends only on
    /// `(seed, e)`.
    pub fn new(seed: u64) -> Self {
        Self { seed, pibt: None }
    }

    /// The seed PIBT gets in episode `episode` of a controller seeded
    /// `seed`.
    pub fn episode_seed(seed: u64, episode: u64) -> u64 {
        seed ^ episode.wrapping_mul(0x9e37_79b9_7f4a_7c15)
    }

    /// A fresh PIBT for `env`'s map, rules and episode.
    fn pibt_for(&self, env: &GridEnv) -> LifelongPibt {
        let rules = ConflictModel::from(env.config().rules);
        let seed = Self::episode_seed(self.seed, env.episode());
        LifelongPibt::new(&env.map().grid, rules, seed)
    }
}

impl Controller for LifelongPibtController {
    fn name(&self) -> String {
        "lifelong-pibt".into()
    }

    fn begin_episode(&mut self, env: &GridEnv) -> Result<(), GiveUp> {
        self.pibt = Some(self.pibt_for(env));
        Ok(())
    }

    fn act(&mut self, env: &GridEnv, actions: &mut [u8]) {
        // Every caller begins an episode first; a controller asked to act
        // before that starts one on the spot.
        if self.pibt.is_none() {
            self.pibt = Some(self.pibt_for(env));
        }
        let Some(pibt) = self.pibt.as_mut() else {
            return actions.fill(0);
        };
        match pibt.actions(&env.positions(), &env.goals()) {
            Ok(moves) => actions.copy_from_slice(&moves),
            // Positions PIBT cannot take (two agents on one cell, an
            // agent on a wall): every agent waits this step.
            Err(_) => actions.fill(0),
        }
    }
}
