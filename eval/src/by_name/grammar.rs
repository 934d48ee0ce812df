//! The [`Controller`] value and its text form: parsing, the canonical
//! display, serde as that text, and the one error of the grammar.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use buridan_policy::ActMode;

pub use crate::shield::Fallback;
use crate::shield::{Ranking, ShieldOptions};

/// One planner of `buridan-mapf`, by its canonical name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PlannerKind {
    /// `ma-astar` (also `maastar`, `ma-a*`, `ma_astar`).
    MaAstar,
    /// `od-astar` (also `odastar`, `od-a*`, `od_astar`).
    OdAstar,
    /// `od-astar-soc`.
    OdAstarSoc,
    /// `cbs`.
    Cbs,
    /// `pibt`.
    Pibt,
    /// `lacam`.
    Lacam,
    /// `lacam-star` (also `lacam*`, `lacam_star`, `lacamstar`).
    LacamStar,
    /// `lacam-star-makespan`.
    LacamStarMakespan,
    /// `pp` (also `prioritized`).
    Pp,
}

impl PlannerKind {
    /// Every planner, in the order error messages list them.
    pub const ALL: [PlannerKind; 9] = [
        PlannerKind::MaAstar,
        PlannerKind::OdAstar,
        PlannerKind::OdAstarSoc,
        PlannerKind::Cbs,
        PlannerKind::Pibt,
        PlannerKind::Lacam,
        PlannerKind::LacamStar,
        PlannerKind::LacamStarMakespan,
        PlannerKind::Pp,
    ];

    /// The canonical name, as `buridan_mapf::planner_by_name` takes it.
    pub fn name(self) -> &'static str {
        match self {
            PlannerKind::MaAstar => "ma-astar",
            PlannerKind::OdAstar => "od-astar",
            PlannerKind::OdAstarSoc => "od-astar-soc",
            PlannerKind::Cbs => "cbs",
            PlannerKind::Pibt => "pibt",
            PlannerKind::Lacam => "lacam",
            PlannerKind::LacamStar => "lacam-star",
            PlannerKind::LacamStarMakespan => "lacam-star-makespan",
            PlannerKind::Pp => "pp",
        }
    }

    /// The planner of a name or one of its aliases (any case), as
    /// `buridan_mapf::planner_by_name` reads it.
    pub fn from_name(name: &str) -> Option<PlannerKind> {
        Some(match name.to_ascii_lowercase().as_str() {
            "ma-astar" | "maastar" | "ma-a*" | "ma_astar" => PlannerKind::MaAstar,
            "od-astar" | "odastar" | "od-a*" | "od_astar" => PlannerKind::OdAstar,
            "od-astar-soc" => PlannerKind::OdAstarSoc,
            "cbs" => PlannerKind::Cbs,
            "pibt" => PlannerKind::Pibt,
            "lacam" => PlannerKind::Lacam,
            "lacam-star" | "lacam*" | "lacam_star" | "lacamstar" => PlannerKind::LacamStar,
            "lacam-star-makespan" => PlannerKind::LacamStarMakespan,
            "pp" | "prioritized" => PlannerKind::Pp,
            _ => return None,
        })
    }
}

/// Planners tried in turn (`lacam+od-astar`): one or more.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Portfolio(Vec<PlannerKind>);

impl Portfolio {
    /// A portfolio of `planners`, tried in that order; `None` when empty.
    pub fn new(planners: Vec<PlannerKind>) -> Option<Portfolio> {
        (!planners.is_empty()).then_some(Portfolio(planners))
    }

    /// The planners, in the order they are tried.
    pub fn planners(&self) -> &[PlannerKind] {
        &self.0
    }

    /// Parses `P` or `P1+P2+…`; `Err` holds the first unknown name.
    fn parse(text: &str) -> Result<Portfolio, String> {
        text.split('+')
            .map(|part| PlannerKind::from_name(part.trim()).ok_or_else(|| part.to_string()))
            .collect::<Result<Vec<_>, _>>()
            .map(Portfolio)
    }
}

impl fmt::Display for Portfolio {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, p) in self.0.iter().enumerate() {
            if k > 0 {
                f.write_str("+")?;
            }
            f.write_str(p.name())?;
        }
        Ok(())
    }
}

impl FromStr for Portfolio {
    type Err = ControllerParseError;

    /// ```
    /// use buridan_eval::by_name::Portfolio;
    /// assert_eq!("LaCAM*+pp".parse::<Portfolio>().unwrap().to_string(), "lacam-star+pp");
    /// assert!("lacam+dijkstra".parse::<Portfolio>().is_err());
    /// ```
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Portfolio::parse(text)
            .map_err(|name| ControllerParseError::new(text, Problem::UnknownPlanner { name }))
    }
}

/// How a trained policy picks its actions.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Act {
    /// The most probable action (the shield: preferences by probability).
    #[default]
    Greedy,
    /// Sampled from the policy's distribution (`sampled:`).
    Sampled,
}

impl From<Act> for ActMode {
    fn from(act: Act) -> ActMode {
        match act {
            Act::Greedy => ActMode::Greedy,
            Act::Sampled => ActMode::Sample,
        }
    }
}

/// A trained policy: its checkpoint and how it acts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Policy {
    /// A `learner train` run directory or checkpoint directory.
    pub checkpoint: PathBuf,
    /// Greedy or sampled.
    pub act: Act,
}

/// A trained policy through the PIBT collision shield, with the shield's
/// options ([`crate::shield::ShieldController`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Shield {
    /// The policy that states the preferences.
    pub policy: Policy,
    /// What the shield does beyond PIBT's one step.
    pub options: ShieldOptions,
}

impl Shield {
    /// The plain shield over `policy`: walls ranking, no options.
    pub fn over(policy: Policy) -> Shield {
        Shield {
            policy,
            options: ShieldOptions::default(),
        }
    }

    /// The name of these options among the named forms (`shield`,
    /// `shield-env`, `shield-ordered`, `shield-lanes`, `shield-settle`),
    /// when one has them.
    fn named_form(&self) -> Option<&'static str> {
        let o = &self.options;
        if o.dead_end_eviction || o.stepping_aside {
            return None;
        }
        let settle = o.fallback.is_some_and(|f| f.goal_settling);
        let these = (o.ranking, o.dead_end_order, o.one_way_lanes, settle);
        SHIELD_FORMS
            .iter()
            .find(|&&(_, ranking, ordered, lanes, settle)| {
                (ranking, ordered, lanes, settle) == these
            })
            .map(|&(form, ..)| form)
    }
}

/// The planner nets around a controller ([`crate::rescue`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NetKind {
    /// `rescue`: the planner plans from the current state whenever an
    /// agent is stuck.
    Rescue,
    /// `lookahead`: a twin plays each episode ahead; if it would get
    /// stuck, the planner plans from the start.
    Lookahead,
    /// `backstop`: the planner drives only the episodes the twin would fail.
    Backstop,
    /// `pace`: the backstop, and the planner's plan also drives the
    /// episodes the twin would finish more than 10 % after it.
    Pace,
}

impl NetKind {
    /// Every kind.
    pub const ALL: [NetKind; 4] = [
        NetKind::Rescue,
        NetKind::Lookahead,
        NetKind::Backstop,
        NetKind::Pace,
    ];

    /// `rescue`, `lookahead`, `backstop` or `pace`.
    pub fn name(self) -> &'static str {
        match self {
            NetKind::Rescue => "rescue",
            NetKind::Lookahead => "lookahead",
            NetKind::Backstop => "backstop",
            NetKind::Pace => "pace",
        }
    }
}

/// A planner net around any controller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Net {
    /// When the planner takes over.
    pub kind: NetKind,
    /// The planner; `None`: the default for the fleet and the rules
    /// ([`super::DEFAULT_RESCUE_PLANNER`], [`super::CROWD_RESCUE_PLANNER`]).
    pub planner: Option<Portfolio>,
    /// The controller inside the net.
    pub inner: Box<Controller>,
}

/// A controller of grid episodes, as `--controller`, study files, `learner
/// bench` and the Python package name it. The text form:
///
/// | form | controller |
/// |---|---|
/// | `PLANNER`, `P1+P2+…` | a planner (`ma-astar`, `od-astar`, `od-astar-soc`, `cbs`, `pibt`, `lacam`, `lacam-star`, `lacam-star-makespan`, `pp`); several joined by `+` are tried in turn |
/// | `random` | uniformly random legal actions |
/// | `lifelong-pibt` | one PIBT step at a time from the current positions and goals, no plan ([`crate::lifelong`]) |
/// | `checkpoint:DIR` | a trained policy (a run or checkpoint directory), greedy |
/// | `sampled:CONTROLLER` | every policy inside samples its actions instead |
/// | `shield:checkpoint:DIR` | the policy through the PIBT collision shield |
/// | `shield[OPTION,…]:checkpoint:DIR` | the shield with options: `env` (moves into occupied cells ranked last), `patience=K` (an agent without progress for K steps follows its shortest path), `settle` (with `patience`: only the first arrival on the goal counts as progress), `ordered` (dead-end aisles filled from the back), `evict` (the dead-end order, and an agent in the way of one bound deeper or bound out backs out of the aisle, agents outside wait while one inside is bound out, and nobody passes through a dead end others are bound for), `lanes` (one-lane corridors kept one-way) |
/// | `shield=K:…` | `shield[patience=K]:…` |
/// | `shield-env[=K]:…` | `shield[env(,patience=K)]:…` |
/// | `shield-ordered[=K]:…` | `shield[(patience=K,)ordered]:…` |
/// | `shield-lanes[=K]:…` | `shield[(patience=K,)ordered,lanes]:…` |
/// | `shield-settle=K:…` | `shield[patience=K,settle]:…` |
/// | `rescue:CONTROLLER` | a planner plans from the current state whenever an agent is stuck |
/// | `lookahead:CONTROLLER` | a twin plays each episode ahead; if it would get stuck, the planner plans from the start |
/// | `backstop:CONTROLLER` | the planner drives only the episodes the twin would fail |
/// | `pace:CONTROLLER` | the backstop, and the plan also drives the episodes the twin would finish > 10 % after it |
/// | `KIND=PLANNER:CONTROLLER` | a net (`rescue`, `lookahead`, `backstop`, `pace`) with a named planner; without one, `lacam+od-astar` (beyond 8 agents or under pogema rules `pp+lacam`) |
///
/// Display prints the shortest of these forms, and it parses back to the
/// same value:
///
/// ```
/// use buridan_eval::by_name::Controller;
/// let c: Controller = "backstop:sampled:shield[lanes,settle,patience=16]:checkpoint:runs/a".parse().unwrap();
/// assert_eq!(c.to_string(), "backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:runs/a");
/// assert_eq!(c.to_string().parse::<Controller>().unwrap(), c);
/// let legacy: Controller = "shield-lanes=16:checkpoint:runs/a".parse().unwrap();
/// assert_eq!(legacy, "shield[ordered,lanes,patience=16]:checkpoint:runs/a".parse().unwrap());
/// assert_eq!(legacy.to_string(), "shield-lanes=16:checkpoint:runs/a");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Controller {
    /// A planner portfolio.
    Planner(Portfolio),
    /// Random legal actions.
    Random,
    /// PIBT one step at a time, no plan.
    LifelongPibt,
    /// A trained policy.
    Policy(Policy),
    /// A trained policy through the collision shield.
    Shield(Shield),
    /// A planner net around a controller.
    Net(Net),
}

impl Controller {
    /// The same controller with every policy inside acting by `act`.
    ///
    /// ```
    /// use buridan_eval::by_name::{Act, Controller};
    /// let c: Controller = "rescue:shield:checkpoint:runs/a".parse().unwrap();
    /// assert_eq!(c.with_act(Act::Sampled).to_string(), "rescue:sampled:shield:checkpoint:runs/a");
    /// ```
    pub fn with_act(mut self, act: Act) -> Controller {
        self.visit_policies(&mut |p| p.act = act);
        self
    }

    /// The same controller with every policy inside loaded from `dir`.
    pub fn with_checkpoint(mut self, dir: &std::path::Path) -> Controller {
        self.visit_policies(&mut |p| p.checkpoint = dir.to_path_buf());
        self
    }

    /// The same controller with `planner` in every net that names none.
    pub fn with_default_planner(mut self, planner: &Portfolio) -> Controller {
        let mut node = &mut self;
        while let Controller::Net(net) = node {
            net.planner.get_or_insert_with(|| planner.clone());
            node = &mut net.inner;
        }
        self
    }

    /// The policies inside, outermost first.
    pub fn policies(&self) -> Vec<&Policy> {
        match self {
            Controller::Planner(_) | Controller::Random | Controller::LifelongPibt => Vec::new(),
            Controller::Policy(p) => vec![p],
            Controller::Shield(s) => vec![&s.policy],
            Controller::Net(net) => net.inner.policies(),
        }
    }

    /// Whether a planner net is around it (its planner plans within the
    /// rescue's time).
    pub fn has_net(&self) -> bool {
        matches!(self, Controller::Net(_))
    }

    fn visit_policies(&mut self, f: &mut dyn FnMut(&mut Policy)) {
        match self {
            Controller::Planner(_) | Controller::Random | Controller::LifelongPibt => {}
            Controller::Policy(p) => f(p),
            Controller::Shield(s) => f(&mut s.policy),
            Controller::Net(net) => net.inner.visit_policies(f),
        }
    }
}

fn fmt_policy(p: &Policy, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    if p.act == Act::Sampled {
        f.write_str("sampled:")?;
    }
    Ok(())
}

impl fmt::Display for Controller {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Controller::Planner(p) => write!(f, "{p}"),
            Controller::Random => f.write_str("random"),
            Controller::LifelongPibt => f.write_str("lifelong-pibt"),
            Controller::Policy(p) => {
                fmt_policy(p, f)?;
                write!(f, "checkpoint:{}", p.checkpoint.display())
            }
            Controller::Shield(s) => {
                fmt_policy(&s.policy, f)?;
                let o = &s.options;
                match s.named_form() {
                    Some(name) => {
                        f.write_str(name)?;
                        if let Some(fb) = o.fallback {
                            write!(f, "={}", fb.patience)?;
                        }
                    }
                    None => {
                        let mut options = Vec::new();
                        if o.ranking == Ranking::Env {
                            options.push("env".to_string());
                        }
                        if let Some(fb) = o.fallback {
                            options.push(format!("patience={}", fb.patience));
                            if fb.goal_settling {
                                options.push("settle".into());
                            }
                        }
                        for (set, name) in [
                            (o.dead_end_order, "ordered"),
                            (o.dead_end_eviction, "evict"),
                            (o.one_way_lanes, "lanes"),
                            (o.stepping_aside, "aside"),
                        ] {
                            if set {
                                options.push(name.into());
                            }
                        }
                        write!(f, "shield[{}]", options.join(","))?;
                    }
                }
                write!(f, ":checkpoint:{}", s.policy.checkpoint.display())
            }
            Controller::Net(net) => {
                f.write_str(net.kind.name())?;
                if let Some(p) = &net.planner {
                    write!(f, "={p}")?;
                }
                write!(f, ":{}", net.inner)
            }
        }
    }
}

/// The forms of the grammar, as the error lists them.
pub const FORMS: &str = "PLANNER (ma-astar, od-astar, od-astar-soc, cbs, pibt, lacam, lacam-star, lacam-star-makespan, pp, or several joined by '+'), random, lifelong-pibt, checkpoint:DIR, shield:checkpoint:DIR, shield[OPTION,...]:checkpoint:DIR (options env, patience=K, settle, ordered, evict, lanes, aside), shield=K:, shield-env[=K]:, shield-ordered[=K]:, shield-lanes[=K]:, shield-settle=K:, sampled:CONTROLLER, rescue[=PLANNER]:CONTROLLER, lookahead[=PLANNER]:CONTROLLER, backstop[=PLANNER]:CONTROLLER or pace[=PLANNER]:CONTROLLER";

/// What is wrong with a controller's text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Problem {
    /// Nothing names a controller.
    Empty,
    /// A name that is none of the forms.
    UnknownController {
        /// The part that did not parse.
        name: String,
    },
    /// A planner name that no planner has (in a portfolio or a net).
    UnknownPlanner {
        /// The name.
        name: String,
    },
    /// A net's planner that no planner has.
    UnknownRescuePlanner {
        /// The name.
        name: String,
    },
    /// The shield over something other than a checkpoint.
    ShieldNeedsPolicy {
        /// The shield's form (`shield`, `shield-lanes`, …).
        form: String,
    },
    /// A patience that is no number of steps.
    Patience {
        /// What stood for K.
        value: String,
    },
    /// Goal settling without the fallback's patience.
    SettleNeedsPatience,
    /// A shield option that is none of the options, or one given twice.
    ShieldOption {
        /// The option.
        option: String,
    },
    /// A bench or study label that is not letters, digits and `-_.+#`.
    Label {
        /// The label.
        label: String,
    },
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::Empty => f.write_str("no controller"),
            Problem::UnknownController { name } => write!(f, "unknown controller '{name}'"),
            Problem::UnknownPlanner { name } => write!(f, "unknown planner '{name}'"),
            Problem::UnknownRescuePlanner { name } => {
                write!(f, "unknown rescue planner '{name}'")
            }
            Problem::ShieldNeedsPolicy { form } => write!(
                f,
                "the shield drives trained policies only ({form}:checkpoint:DIR)"
            ),
            Problem::Patience { value } => write!(
                f,
                "the shield's patience '{value}' is not a number of steps (shield=K:checkpoint:DIR)"
            ),
            Problem::SettleNeedsPatience => f.write_str(
                "shield-settle needs the fallback's patience (shield-settle=K:checkpoint:DIR, e.g. K = 16)",
            ),
            Problem::ShieldOption { option } => write!(
                f,
                "shield option '{option}' is unknown or given twice (expected env, patience=K, settle, ordered, evict, lanes, aside)"
            ),
            Problem::Label { label } => write!(
                f,
                "label '{label}' is not letters, digits and - _ . + # (LABEL@CONTROLLER)"
            ),
        }
    }
}

/// A controller's text that is none of the grammar's forms: the text, the
/// problem, and the forms ([`FORMS`]).
///
/// ```
/// use buridan_eval::by_name::Controller;
/// let err = "dijkstra".parse::<Controller>().unwrap_err();
/// assert!(err.to_string().starts_with("unknown controller 'dijkstra'; a controller is PLANNER (ma-astar,"), "{err}");
/// let err = "rescue:shield:cbs".parse::<Controller>().unwrap_err();
/// assert!(err.to_string().starts_with("'rescue:shield:cbs': the shield drives trained policies only"), "{err}");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}{problem}; a controller is {FORMS}", context(.text, .problem))]
pub struct ControllerParseError {
    /// The whole text.
    pub text: String,
    /// What is wrong with it.
    pub problem: Problem,
}

/// The text before the problem, unless the problem already names it.
fn context(text: &str, problem: &Problem) -> String {
    match problem {
        Problem::UnknownController { name } if name == text => String::new(),
        _ => format!("'{text}': "),
    }
}

impl ControllerParseError {
    pub(crate) fn new(text: &str, problem: Problem) -> Self {
        ControllerParseError {
            text: text.to_string(),
            problem,
        }
    }
}

/// The shield forms by name: (form, ranking, ordered, lanes, settle).
const SHIELD_FORMS: [(&str, Ranking, bool, bool, bool); 5] = [
    ("shield-env", Ranking::Env, false, false, false),
    ("shield-ordered", Ranking::Walls, true, false, false),
    ("shield-lanes", Ranking::Walls, true, true, false),
    ("shield-settle", Ranking::Walls, false, false, true),
    ("shield", Ranking::Walls, false, false, false),
];

impl FromStr for Controller {
    type Err = ControllerParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        parse(text).map_err(|problem| ControllerParseError::new(text, problem))
    }
}

fn parse(text: &str) -> Result<Controller, Problem> {
    if text.is_empty() {
        return Err(Problem::Empty);
    }
    if let Some(inner) = text.strip_prefix("sampled:") {
        return Ok(parse(inner)?.with_act(Act::Sampled));
    }
    for kind in NetKind::ALL {
        let Some(rest) = text.strip_prefix(kind.name()) else {
            continue;
        };
        let (planner, inner) = if let Some(inner) = rest.strip_prefix(':') {
            (None, inner)
        } else if let Some(named) = rest.strip_prefix('=') {
            let (planner, inner) = named.split_once(':').unwrap_or((named, ""));
            let planner = Portfolio::parse(planner).map_err(|_| Problem::UnknownRescuePlanner {
                name: planner.to_string(),
            })?;
            (Some(planner), inner)
        } else {
            continue;
        };
        return Ok(Controller::Net(Net {
            kind,
            planner,
            inner: Box::new(parse(inner)?),
        }));
    }
    if let Some(shield) = parse_shield(text)? {
        return Ok(Controller::Shield(shield));
    }
    if let Some(dir) = text.strip_prefix("checkpoint:") {
        return Ok(Controller::Policy(Policy {
            checkpoint: PathBuf::from(dir),
            act: Act::Greedy,
        }));
    }
    if text == "random" {
        return Ok(Controller::Random);
    }
    if text == "lifelong-pibt" {
        return Ok(Controller::LifelongPibt);
    }
    Portfolio::parse(text)
        .map(Controller::Planner)
        .map_err(|_| Problem::UnknownController {
            name: text.to_string(),
        })
}

/// `shield[OPTIONS]:checkpoint:DIR` and the named shield forms; `None`
/// when `text` is no shield.
fn parse_shield(text: &str) -> Result<Option<Shield>, Problem> {
    let (form, options, inner) = if let Some(rest) = text.strip_prefix("shield[") {
        let Some((options, inner)) = rest.split_once(']') else {
            return Err(Problem::ShieldOption {
                option: rest.to_string(),
            });
        };
        let inner = inner.strip_prefix(':').unwrap_or("");
        ("shield[…]", shield_options(options)?, inner)
    } else {
        let Some((form, ranking, ordered, lanes, settle, patience, inner)) = named_shield(text)?
        else {
            return Ok(None);
        };
        if settle && patience.is_none() {
            return Err(Problem::SettleNeedsPatience);
        }
        let options = ShieldOptions {
            ranking,
            fallback: patience.map(|patience| Fallback {
                patience,
                goal_settling: settle,
            }),
            dead_end_order: ordered,
            one_way_lanes: lanes,
            ..ShieldOptions::default()
        };
        (form, options, inner)
    };
    let Some(dir) = inner.strip_prefix("checkpoint:") else {
        return Err(Problem::ShieldNeedsPolicy {
            form: form.to_string(),
        });
    };
    Ok(Some(Shield {
        policy: Policy {
            checkpoint: PathBuf::from(dir),
            act: Act::Greedy,
        },
        options,
    }))
}

type NamedShield<'a> = (
    &'static str,
    Ranking,
    bool,
    bool,
    bool,
    Option<u32>,
    &'a str,
);

/// `FORM:INNER` or `FORM=K:INNER` for a named shield form.
fn named_shield(text: &str) -> Result<Option<NamedShield<'_>>, Problem> {
    for (form, ranking, ordered, lanes, settle) in SHIELD_FORMS {
        let Some(rest) = text.strip_prefix(form) else {
            continue;
        };
        if let Some(inner) = rest.strip_prefix(':') {
            return Ok(Some((form, ranking, ordered, lanes, settle, None, inner)));
        }
        let Some(named) = rest.strip_prefix('=') else {
            continue;
        };
        let (value, inner) = named.split_once(':').unwrap_or((named, ""));
        let patience = value.parse().map_err(|_| Problem::Patience {
            value: value.to_string(),
        })?;
        return Ok(Some((
            form,
            ranking,
            ordered,
            lanes,
            settle,
            Some(patience),
            inner,
        )));
    }
    Ok(None)
}

/// The options between `shield[` and `]`.
fn shield_options(options: &str) -> Result<ShieldOptions, Problem> {
    let mut shield = ShieldOptions::default();
    let (mut env, mut patience, mut settle) = (false, None, false);
    for option in options.split(',').map(str::trim).filter(|o| !o.is_empty()) {
        let twice = || Problem::ShieldOption {
            option: option.to_string(),
        };
        let flag = match option {
            "env" => &mut env,
            "settle" => &mut settle,
            "ordered" => &mut shield.dead_end_order,
            "evict" => &mut shield.dead_end_eviction,
            "lanes" => &mut shield.one_way_lanes,
            "aside" => &mut shield.stepping_aside,
            _ => {
                let Some(value) = option.strip_prefix("patience=") else {
                    return Err(twice());
                };
                let k: u32 = value.parse().map_err(|_| Problem::Patience {
                    value: value.to_string(),
                })?;
                if patience.replace(k).is_some() {
                    return Err(twice());
                }
                continue;
            }
        };
        if std::mem::replace(flag, true) {
            return Err(twice());
        }
    }
    if env {
        shield.ranking = Ranking::Env;
    }
    if settle && patience.is_none() {
        return Err(Problem::SettleNeedsPatience);
    }
    shield.fallback = patience.map(|patience| Fallback {
        patience,
        goal_settling: settle,
    });
    Ok(shield)
}

crate::serde_as_text!(Controller);
