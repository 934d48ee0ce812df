//! Controllers by name: the `--controller` language of `learner eval`,
//! studies and the Python package, resolved in one place.
//!
//! A name is a planner (`cbs`, `lacam`, `pp`, …, `planner_by_name`),
//! `random`, `checkpoint:DIR` (a trained policy), `shield:checkpoint:DIR` /
//! `shield-env:checkpoint:DIR` (the policy through the PIBT collision
//! shield, ranked by walls or by the env's order; `shield=K:…` lets an
//! agent that has not come closer to its goal for K steps follow its
//! shortest path; `shield-ordered:…` and `shield-ordered=K:…` also fill
//! dead-end aisles from the back; `shield-lanes:…` and `shield-lanes=K:…`
//! also keep one-lane corridors one-way; `shield-settle=K:…` counts only
//! an agent's first arrival on its goal as progress, so that one stepping
//! on and off its goal settles on it), or a rescue around any of
//! these: `rescue:INNER`, `rescue=PLANNER:INNER`, `lookahead:INNER`,
//! `lookahead=PLANNER:INNER` (a planner takes over when an agent is stuck,
//! or before it jams), `backstop:INNER`, `backstop=PLANNER:INNER` (a
//! planner drives only the episodes the controller would fail), `pace:INNER`,
//! `pace=PLANNER:INNER` (and those it would finish more than 10 % after the
//! planner's plan).

use std::path::PathBuf;
use std::sync::Arc;

use buridan_env::Rules;
use buridan_mapf::{planner_for_rules, Limits, Planner, PlannerLookupError};
use buridan_policy::ActMode;

use crate::planner::PlannerController;
use crate::policy::{PolicyController, PolicyLoadError};
use crate::rescue::RescueController;
use crate::shield::{Ranking, ShieldController};
use crate::{Controller, RandomController};

/// A factory of fresh controllers, one per evaluation thread.
pub type ControllerFactory = Box<dyn Fn() -> Box<dyn Controller> + Sync>;

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

/// A controller name that does not resolve.
///
/// ```
/// use buridan_eval::by_name::{controller_factory, ControllerNameError};
/// use buridan_env::Rules;
/// use buridan_policy::ActMode;
/// let err = controller_factory("dijkstra", 4, 0, Default::default(), ActMode::Greedy, Rules::Thesis).err().unwrap();
/// assert!(matches!(err, ControllerNameError::Unknown { .. }));
/// assert!(err.to_string().starts_with("unknown controller 'dijkstra': expected ma-astar"));
/// ```
#[derive(Debug, thiserror::Error)]
pub enum ControllerNameError {
    /// Neither a planner nor one of the other forms.
    #[error("unknown controller '{name}': expected ma-astar, od-astar, cbs, pibt, lacam, lacam-star, pp, random, checkpoint:DIR, shield:checkpoint:DIR or rescue:CONTROLLER")]
    Unknown {
        /// The name given.
        name: String,
    },
    /// A planner that cannot plan under the env's rules.
    #[error("controller '{name}'")]
    Rules {
        /// The name given.
        name: String,
        /// Why the planner cannot plan there.
        source: PlannerLookupError,
    },
    /// The planner of a rescue is unknown.
    #[error("'{name}': unknown rescue planner '{planner}' (expected pibt, lacam, lacam-star, od-astar, pp, cbs, ma-astar, or several joined by '+')")]
    UnknownRescuePlanner {
        /// The name given.
        name: String,
        /// The planner named in it.
        planner: String,
    },
    /// The planner of a rescue cannot plan under the env's rules.
    #[error("'{name}': rescue planner")]
    RescueRules {
        /// The name given.
        name: String,
        /// Why the planner cannot plan there.
        source: PlannerLookupError,
    },
    /// The shield was asked to drive something other than a checkpoint.
    #[error("'{name}': the shield drives trained policies only ({prefix}:checkpoint:DIR)")]
    ShieldNeedsPolicy {
        /// The name given.
        name: String,
        /// `shield`, `shield-env`, `shield-ordered`, `shield-lanes` or
        /// `shield-settle`.
        prefix: &'static str,
    },
    /// `shield=K:` with a K that is no step count.
    #[error("'{name}': the shield's patience '{value}' is not a number of steps (shield=K:checkpoint:DIR)")]
    ShieldPatience {
        /// The name given.
        name: String,
        /// What stood for K.
        value: String,
    },
    /// `shield-settle:` without its patience: settling is a rule of the
    /// progress fallback, which needs one.
    #[error("'{name}': shield-settle needs the fallback's patience (shield-settle=K:checkpoint:DIR, e.g. K = 16)")]
    SettleNeedsPatience {
        /// The name given.
        name: String,
    },
    /// A checkpoint that cannot drive these episodes.
    #[error(transparent)]
    Checkpoint(#[from] PolicyLoadError),
}

/// The kinds of planner nets around a controller, as names begin:
/// `KIND:INNER` or `KIND=PLANNER:INNER` ([`crate::rescue`]).
pub const RESCUE_KINDS: [&str; 4] = ["rescue", "lookahead", "backstop", "pace"];

/// Splits `KIND:INNER` and `KIND=PLANNER:INNER` ([`RESCUE_KINDS`]) into
/// (kind, planner, inner); the default planner depends on the fleet size
/// and the rules.
fn rescue_parts(name: &str, agents: usize, rules: Rules) -> Option<(&'static str, &str, &str)> {
    RESCUE_KINDS.into_iter().find_map(|kind| {
        let rest = name.strip_prefix(kind)?;
        if let Some(inner) = rest.strip_prefix(':') {
            let planner = if rules == Rules::Pogema || agents > RESCUE_OD_ASTAR_MAX_AGENTS {
                CROWD_RESCUE_PLANNER
            } else {
                DEFAULT_RESCUE_PLANNER
            };
            return Some((kind, planner, inner));
        }
        let named = rest.strip_prefix('=')?;
        let (planner, inner) = named.split_once(':').unwrap_or((named, ""));
        Some((kind, planner, inner))
    })
}

/// Splits `PREFIX:INNER` and `PREFIX=K:INNER` (a shield with the progress
/// fallback after K steps) into (patience, inner); `None` when `name` is
/// neither.
fn shield_parts<'a>(
    name: &'a str,
    prefix: &'static str,
) -> Result<Option<(Option<u32>, &'a str)>, ControllerNameError> {
    let Some(rest) = name.strip_prefix(prefix) else {
        return Ok(None);
    };
    if let Some(inner) = rest.strip_prefix(':') {
        return Ok(Some((None, inner)));
    }
    let Some(named) = rest.strip_prefix('=') else {
        return Ok(None);
    };
    let (value, inner) = named.split_once(':').unwrap_or((named, ""));
    let patience = value
        .parse()
        .map_err(|_| ControllerNameError::ShieldPatience {
            name: name.to_string(),
            value: value.to_string(),
        })?;
    Ok(Some((Some(patience), inner)))
}

/// Resolves a controller name to a factory for episodes with `agents`
/// agents under `rules`: planners (also the rescue's) plan for that rule
/// set, and one that cannot (OD-A* under pogema) is an error; policies act
/// as trained (`act_mode`, sampling seeded by `seed`); the shield keeps the
/// thesis conflict model, whose joint moves POGEMA's rules execute too. A
/// checkpoint is loaded once here, so that a bad one fails with its reason.
///
/// ```
/// use buridan_eval::by_name::controller_factory;
/// use buridan_env::Rules;
/// use buridan_policy::ActMode;
/// let (g, t, p) = (ActMode::Greedy, Rules::Thesis, Rules::Pogema);
/// let ckpt = "../docs/results/ppo-ctde-rm-2.1/checkpoint";
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
    if let Some((kind, planner, inner)) = rescue_parts(name, agents, rules) {
        let planner: Arc<dyn Planner> = match planner_for_rules(planner, rules) {
            Ok(planner) => planner.into(),
            Err(PlannerLookupError::Unknown { .. }) => {
                return Err(ControllerNameError::UnknownRescuePlanner {
                    name: name.to_string(),
                    planner: planner.to_string(),
                })
            }
            Err(source) => {
                return Err(ControllerNameError::RescueRules {
                    name: name.to_string(),
                    source,
                })
            }
        };
        let inner = controller_factory(inner, agents, seed, limits, act_mode, rules)?;
        return Ok(Box::new(move || {
            let rescue = RescueController::new(inner(), planner.clone(), limits);
            Box::new(match kind {
                "lookahead" => rescue.with_foresight(inner()),
                "backstop" => rescue.with_backstop(inner()),
                "pace" => rescue.with_pace(inner()),
                _ => rescue,
            })
        }));
    }
    for (prefix, ranking, ordered, lanes, settle) in [
        ("shield", Ranking::Walls, false, false, false),
        ("shield-env", Ranking::Env, false, false, false),
        ("shield-ordered", Ranking::Walls, true, false, false),
        ("shield-lanes", Ranking::Walls, true, true, false),
        ("shield-settle", Ranking::Walls, false, false, true),
    ] {
        if let Some((patience, inner)) = shield_parts(name, prefix)? {
            if settle && patience.is_none() {
                return Err(ControllerNameError::SettleNeedsPatience {
                    name: name.to_string(),
                });
            }
            let Some(dir) = inner.strip_prefix("checkpoint:") else {
                return Err(ControllerNameError::ShieldNeedsPolicy {
                    name: name.to_string(),
                    prefix,
                });
            };
            let dir = PathBuf::from(dir);
            let load = move || {
                let mut shield = ShieldController::load(&dir, agents, act_mode, seed, ranking)?;
                match patience {
                    Some(k) if settle => shield = shield.with_goal_settling(k),
                    Some(k) => shield = shield.with_progress_fallback(k),
                    None => {}
                }
                if ordered {
                    shield = shield.with_dead_end_order();
                }
                if lanes {
                    shield = shield.with_one_way_lanes();
                }
                Ok::<_, PolicyLoadError>(shield)
            };
            load()?;
            return Ok(Box::new(move || {
                Box::new(load().expect("loaded once already"))
            }));
        }
    }
    if let Some(dir) = name.strip_prefix("checkpoint:") {
        let dir = PathBuf::from(dir);
        PolicyController::load(&dir, agents, act_mode, seed)?;
        return Ok(Box::new(move || {
            Box::new(
                PolicyController::load(&dir, agents, act_mode, seed).expect("loaded once already"),
            )
        }));
    }
    if name == "random" {
        return Ok(Box::new(move || Box::new(RandomController::new(seed))));
    }
    let planner: Arc<dyn Planner> = match planner_for_rules(name, rules) {
        Ok(planner) => planner.into(),
        Err(PlannerLookupError::Unknown { .. }) => {
            return Err(ControllerNameError::Unknown {
                name: name.to_string(),
            })
        }
        Err(source) => {
            return Err(ControllerNameError::Rules {
                name: name.to_string(),
                source,
            })
        }
    };
    Ok(Box::new(move || {
        Box::new(PlannerController::new(planner.clone(), limits))
    }))
}
