//! Controllers by name: the `--controller` language of `learner eval`,
//! `learner bench`, studies and the Python package, resolved in one place.
//!
//! [`Controller`] is the value (its doc comment has the grammar's table):
//! text parses into it ([`ControllerParseError`] lists the forms when it
//! does not), it displays as its canonical text and serialises as that
//! text, and [`Controller::factory`] makes controllers of it for an
//! evaluation. [`Labelled`] adds the row label of `learner bench` and of
//! study actions (`LABEL@CONTROLLER`).

mod build;
mod grammar;
mod label;

pub use crate::shield::ShieldOptions;
pub use grammar::{
    Act, Controller, ControllerParseError, Fallback, Net, NetKind, PlannerKind, Policy, Portfolio,
    Problem, Shield, FORMS,
};
pub use label::Labelled;

use buridan_env::Rules;
use buridan_mapf::{Limits, PlannerLookupError};
use buridan_policy::ActMode;

use crate::policy::PolicyLoadError;

/// A factory of fresh controllers, one per evaluation thread.
pub type ControllerFactory = Box<dyn Fn() -> Box<dyn crate::Controller> + Sync>;

/// The planner of `rescue:CONTROLLER` for small fleets: LaCAM answers in
/// milliseconds where it answers at all; OD-A* takes over the dead-end
/// orderings LaCAM does not finish (README, "Planners").
pub const DEFAULT_RESCUE_PLANNER: &str = "lacam+od-astar";

/// Fleets larger than this are rescued by [`CROWD_RESCUE_PLANNER`]: OD-A*'s
/// state space grows as cellsⁿ, and at 16 agents it spends its whole share
/// of every call without a plan (measured: rm-3.1, 16 agents, 30 episodes:
/// the same 53 % success with LaCAM alone, 3 s against 0.14 s of compute per
/// episode).
pub const RESCUE_OD_ASTAR_MAX_AGENTS: usize = 8;

/// The planner of `rescue:CONTROLLER` beyond [`RESCUE_OD_ASTAR_MAX_AGENTS`]
/// agents, and at every fleet size under pogema rules (where OD-A* does not
/// plan): prioritized planning answers crowds in milliseconds (seed-42, 16
/// agents, 1 s: rm-3.1 100 % and rm-2.1 100 % planned, where LaCAM plans 32 %
/// and 50 % within T_max); LaCAM, complete, takes the instances where every
/// order PP tries fails.
pub const CROWD_RESCUE_PLANNER: &str = "pp+lacam";

/// A controller name that does not resolve to controllers.
///
/// ```
/// use buridan_eval::by_name::{controller_factory, ControllerNameError};
/// use buridan_env::Rules;
/// use buridan_policy::ActMode;
/// let err = controller_factory("dijkstra", 4, 0, Default::default(), ActMode::Greedy, Rules::Thesis).err().unwrap();
/// assert!(matches!(err, ControllerNameError::Parse(_)));
/// assert!(err.to_string().starts_with("unknown controller 'dijkstra'; a controller is PLANNER (ma-astar"));
/// ```
#[derive(Debug, thiserror::Error)]
pub enum ControllerNameError {
    /// The text is none of the grammar's forms.
    #[error(transparent)]
    Parse(#[from] ControllerParseError),
    /// A planner that cannot plan under the env's rules.
    #[error("controller '{name}'")]
    Rules {
        /// The controller.
        name: String,
        /// Why the planner cannot plan there.
        source: PlannerLookupError,
    },
    /// The planner of a net cannot plan under the env's rules.
    #[error("'{name}': rescue planner")]
    RescueRules {
        /// The controller.
        name: String,
        /// Why the planner cannot plan there.
        source: PlannerLookupError,
    },
    /// A checkpoint that cannot drive these episodes.
    #[error(transparent)]
    Checkpoint(#[from] PolicyLoadError),
}

/// Parses a controller's text ([`Controller`]) and makes its factory for
/// episodes with `agents` agents under `rules` ([`Controller::factory`]);
/// with `act_mode` sampling, every policy in it samples.
///
/// ```
/// use buridan_eval::by_name::controller_factory;
/// use buridan_env::Rules;
/// use buridan_policy::ActMode;
/// let (g, t, p) = (ActMode::Greedy, Rules::Thesis, Rules::Pogema);
/// let ckpt = "../fixtures/ppo-ctde-rm-2.1/checkpoint";
/// let make = controller_factory(&format!("shield:checkpoint:{ckpt}"), 8, 42, Default::default(), g, t).unwrap();
/// assert_eq!(make().name(), "ctde-policy+shield");
/// let err = controller_factory("shield:cbs", 4, 42, Default::default(), g, t).err().unwrap();
/// assert!(err.to_string().contains("trained policies only"), "{err}");
/// let patient = controller_factory(&format!("shield=8:checkpoint:{ckpt}"), 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(patient().name(), "ctde-policy+shield=8");
/// let ordered = controller_factory(&format!("shield-ordered=16:checkpoint:{ckpt}"), 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(ordered().name(), "ctde-policy+shield-ordered=16");
/// let lanes = controller_factory(&format!("shield-lanes=16:checkpoint:{ckpt}"), 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(lanes().name(), "ctde-policy+shield-lanes=16");
/// let settled = controller_factory(&format!("shield-settle=16:checkpoint:{ckpt}"), 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(settled().name(), "ctde-policy+shield-settle=16");
/// let err = controller_factory(&format!("shield-settle:checkpoint:{ckpt}"), 4, 42, Default::default(), g, t).err().unwrap();
/// assert!(err.to_string().contains("shield-settle needs the fallback's patience"), "{err}");
/// let err = controller_factory(&format!("shield=soon:checkpoint:{ckpt}"), 4, 42, Default::default(), g, t).err().unwrap();
/// assert!(err.to_string().contains("patience 'soon' is not a number of steps"), "{err}");
/// let rescued = controller_factory("rescue:random", 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(rescued().name(), "random+rescue-lacam+od-astar");
/// let crowd = controller_factory("rescue:random", 16, 42, Default::default(), g, t).unwrap();
/// assert_eq!(crowd().name(), "random+rescue-pp+lacam");
/// let by_lacam = controller_factory("rescue=lacam:random", 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(by_lacam().name(), "random+rescue-lacam");
/// let ahead = controller_factory("lookahead=od-astar:random", 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(ahead().name(), "random+lookahead-od-astar");
/// let backstop = controller_factory("backstop:random", 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(backstop().name(), "random+backstop-lacam+od-astar");
/// let pace = controller_factory("pace=od-astar+lacam:random", 4, 42, Default::default(), g, t).unwrap();
/// assert_eq!(pace().name(), "random+pace-od-astar+lacam");
/// let err = controller_factory("rescue=dijkstra:random", 4, 42, Default::default(), g, t).err().unwrap();
/// assert!(err.to_string().contains("unknown rescue planner 'dijkstra'"), "{err}");
/// // Under pogema rules:
/// let lacam = controller_factory("lacam", 32, 0, Default::default(), g, p).unwrap();
/// assert_eq!(lacam().name(), "lacam-simultaneous");
/// let err = controller_factory("od-astar", 4, 0, Default::default(), g, p).err().unwrap();
/// let source = std::error::Error::source(&err).unwrap().to_string();
/// assert!(source.contains("cannot plan under pogema rules"), "{source}");
/// let rescued = controller_factory("rescue:random", 4, 0, Default::default(), g, p).unwrap();
/// assert_eq!(rescued().name(), "random+rescue-pp-simultaneous+lacam-simultaneous");
/// ```
pub fn controller_factory(
    name: &str,
    agents: usize,
    seed: u64,
    limits: Limits,
    act_mode: ActMode,
    rules: Rules,
) -> Result<ControllerFactory, ControllerNameError> {
    let mut controller: Controller = name.parse()?;
    if act_mode == ActMode::Sample {
        controller = controller.with_act(Act::Sampled);
    }
    controller.factory(agents, seed, limits, rules)
}
