//! The [`Planner`] trait every baseline implements, and its result types.

use crate::Problem;
use std::time::Duration;

use crate::limits::{Limits, SolveError};
use crate::plan::Plan;
use crate::rules::ConflictModel;

/// Search effort of one solve call.
///
/// ```
/// let s = buridan_mapf::Stats::default();
/// assert_eq!((s.expanded, s.generated, s.low_level_expanded), (0, 0, 0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    /// Expanded nodes: joint states (MA-A*), constraint-tree nodes (CBS),
    /// steps (PIBT), search iterations, one constraint set each (LaCAM), or
    /// priority orders tried (prioritized planning).
    pub expanded: u64,
    /// Generated nodes: joint successor states (MA-A*, before duplicate
    /// detection), constraint-tree children with a low-level path (CBS),
    /// configurations produced by PIBT (PIBT, LaCAM) or single-agent paths
    /// planned (prioritized planning).
    pub generated: u64,
    /// Low-level space-time A* expansions (CBS, prioritized planning),
    /// constraint sets created (LaCAM); 0 for MA-A*, OD-A* and PIBT.
    pub low_level_expanded: u64,
    /// Wall-clock time of the call.
    pub wall_time: Duration,
}

/// A plan and what it cost to find.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{Cbs, Limits, Planner, Problem};
/// let map = Map::load("rm-1.1").unwrap();
/// let scen = map.scenario.unwrap();
/// let sol = Cbs::default().solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// assert_eq!(sol.plan.sum_of_costs(), 18);
/// assert!(sol.stats.expanded >= 1);
/// ```
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Solution {
    /// The conflict-free plan (paths trimmed after each agent's arrival).
    pub plan: Plan,
    /// Search effort.
    pub stats: Stats,
}

/// A classical MAPF solver: one-shot planning from starts to goals.
/// `Send + Sync`, so one planner can serve several evaluation threads.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{planner_by_name, Limits, Planner, Problem};
/// let map = Map::load("rm-1.3").unwrap();
/// let scen = map.scenario.unwrap();
/// let mut makespans = Vec::new();
/// for name in ["ma-astar", "cbs"] {
///     let planner: Box<dyn Planner> = planner_by_name(name).unwrap();
///     let sol = planner.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
///     makespans.push(sol.plan.makespan());
/// }
/// // SPEC's MA-A* heuristic is inadmissible: 8 steps; CBS's plan needs 7.
/// assert_eq!(makespans, [8, 7]);
/// ```
pub trait Planner: Send + Sync {
    /// Short name for tables and logs (`"ma-astar"`, `"cbs"`, ...).
    fn name(&self) -> &str;

    /// Plans conflict-free paths from `starts[i]` to `goals[i]` on `grid`
    /// within `limits`.
    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError>;

    /// The conflict model its plans satisfy; [`ConflictModel::rule_set`] names the
    /// env rule set that executes them exactly. The default is the thesis
    /// env's ([`ConflictModel::ENV_EXECUTABLE`]), which planners without a rules
    /// option (OD-A*, searching the sequential step itself) plan for.
    ///
    /// ```
    /// use buridan_mapf::{planner_for_rules, Planner, ConflictModel};
    /// let lacam = planner_for_rules("lacam", buridan_env::Rules::Pogema).unwrap();
    /// assert_eq!(lacam.rules(), ConflictModel::SIMULTANEOUS);
    /// assert_eq!(buridan_mapf::OdAstar::default().rules(), ConflictModel::ENV_EXECUTABLE);
    /// ```
    fn rules(&self) -> ConflictModel {
        ConflictModel::ENV_EXECUTABLE
    }
}

/// Why [`planner_for_rules`] cannot make a planner.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlannerLookupError {
    /// No planner has this name.
    #[error("unknown planner '{name}' (expected pibt, lacam, lacam-star, lacam-star-makespan, cbs, ma-astar, pp, od-astar, od-astar-soc, or several joined by '+')")]
    Unknown {
        /// The name asked for (one part of a portfolio).
        name: String,
    },
    /// The planner exists but cannot plan under the env's rule set.
    #[error("planner '{planner}' cannot plan under {rules} rules: {why}")]
    UnsupportedRules {
        /// The planner's name.
        planner: String,
        /// The rule set asked for.
        rules: buridan_env::Rules,
        /// Why not, in words.
        why: &'static str,
    },
}

/// The default-configured planner of a name: `"ma-astar"` (also `"maastar"`,
/// `"ma-a*"`), `"od-astar"` (also `"od-a*"`), `"od-astar-soc"`, `"cbs"`, `"pibt"`, `"lacam"`
/// `"lacam-star"` (also `"lacam*"`), `"lacam-star-makespan"` or `"pp"` (also
/// `"prioritized"`); names joined by `+` make a
/// [`Portfolio`] of them, tried in that order.
///
/// ```
/// assert_eq!(buridan_mapf::planner_by_name("cbs").unwrap().name(), "cbs");
/// assert_eq!(buridan_mapf::planner_by_name("LaCAM*").unwrap().name(), "lacam-star");
/// assert_eq!(buridan_mapf::planner_by_name("lacam-star-makespan").unwrap().name(), "lacam-star-makespan");
/// assert_eq!(buridan_mapf::planner_by_name("lacam+od-astar").unwrap().name(), "lacam+od-astar");
/// assert_eq!(buridan_mapf::planner_by_name("prioritized").unwrap().name(), "pp");
/// assert!(buridan_mapf::planner_by_name("dijkstra").is_none());
/// assert!(buridan_mapf::planner_by_name("lacam+dijkstra").is_none());
/// ```
pub fn planner_by_name(name: &str) -> Option<Box<dyn Planner>> {
    build(name, ConflictModel::ENV_EXECUTABLE, false).ok()
}

/// The planner of a name (as [`planner_by_name`]) configured to plan for
/// the env's rule set `rules`: under [`buridan_env::Rules::Thesis`] exactly
/// [`planner_by_name`]'s planner; under [`buridan_env::Rules::Pogema`] with
/// [`ConflictModel::SIMULTANEOUS`] (vertex and swap conflicts forbidden, following
/// and rotations allowed), whose plans POGEMA's rules execute exactly.
/// OD-A* (`od-astar`, `od-astar-soc`) searches the thesis env's sequential
/// step itself, so it cannot plan under pogema rules and says so, as does a
/// portfolio containing it. LaCAM returns its first plan whatever
/// [`Limits::max_makespan`] says; [`planner_within_cap`] makes the same
/// planners planning within it.
///
/// ```
/// use buridan_env::Rules as RuleSet;
/// use buridan_mapf::{planner_for_rules, PlannerLookupError, ConflictModel};
/// let lacam = planner_for_rules("lacam", RuleSet::Pogema).unwrap();
/// assert_eq!((lacam.name(), lacam.rules()), ("lacam-simultaneous", ConflictModel::SIMULTANEOUS));
/// assert_eq!(planner_for_rules("lacam", RuleSet::Thesis).unwrap().name(), "lacam");
/// let err = planner_for_rules("lacam+od-astar", RuleSet::Pogema).err().unwrap();
/// assert!(matches!(err, PlannerLookupError::UnsupportedRules { rules: RuleSet::Pogema, .. }));
/// let err = planner_for_rules("dijkstra", RuleSet::Thesis).err().unwrap();
/// assert_eq!(err, PlannerLookupError::Unknown { name: "dijkstra".into() });
/// ```
pub fn planner_for_rules(
    name: &str,
    rules: buridan_env::Rules,
) -> Result<Box<dyn Planner>, PlannerLookupError> {
    build(name, ConflictModel::from(rules), false)
}

/// The planner of a name for `rules` (as [`planner_for_rules`]) that plans
/// within [`Limits::max_makespan`] where one is set: LaCAM searches on
/// until its plan fits ([`crate::Lacam::within_cap`]) and LaCAM\* returns a
/// plan within it ([`crate::Lacam::within_cap`], in [`crate::LacamStar::lacam`]), so a plan that
/// cannot succeed within an episode's T_max is refined or rejected
/// ([`SolveError::NoSolutionWithin`] once the search proves that none
/// fits). The other planners search within the cap anyway (OD-A\*, CBS,
/// MA-A\*, PP) or stop at it (PIBT). The controllers of `learner eval`
/// plan so: a planner with the cap at the episode's T_max, the planner
/// nets (`rescue:…`) at the steps left. [`planner_for_rules`]'s LaCAM
/// returns its first plan whatever its length.
///
/// ```
/// use buridan_env::{Cell, Grid, Rules};
/// use buridan_mapf::{planner_within_cap, Limits, Problem, SolveError};
/// let lacam = planner_within_cap("lacam", Rules::Thesis).unwrap();
/// assert_eq!(lacam.name(), "lacam");
/// // One agent 4 steps from its goal: no plan within 3 steps.
/// let grid = Grid::from_rows(&["....."]).unwrap();
/// let (s, g) = ([Cell::new(0, 0)], [Cell::new(0, 4)]);
/// let capped = Limits { max_makespan: Some(3), ..Limits::default() };
/// let err = lacam.solve(Problem::new(&grid, &s, &g), &capped).unwrap_err();
/// assert_eq!(err, SolveError::NoSolutionWithin { max_makespan: 3 });
/// let sol = lacam.solve(Problem::new(&grid, &s, &g), &Limits { max_makespan: Some(4), ..capped }).unwrap();
/// assert_eq!(sol.plan.makespan(), 4);
/// ```
pub fn planner_within_cap(
    name: &str,
    rules: buridan_env::Rules,
) -> Result<Box<dyn Planner>, PlannerLookupError> {
    build(name, ConflictModel::from(rules), true)
}

/// The name table of [`planner_by_name`], [`planner_for_rules`] and
/// [`planner_within_cap`] (`within_cap`: LaCAM and LaCAM\* plan within
/// [`Limits::max_makespan`]).
fn build(
    name: &str,
    rules: ConflictModel,
    within_cap: bool,
) -> Result<Box<dyn Planner>, PlannerLookupError> {
    if name.contains('+') {
        let planners = name
            .split('+')
            .map(|part| build(part.trim(), rules, within_cap))
            .collect::<Result<Vec<_>, _>>()?;
        return Ok(Box::new(Portfolio::new(planners)));
    }
    let lower = name.to_ascii_lowercase();
    // PIBT's swap operation is on under both rule sets (measured under
    // each, see `Lacam::swap`).
    let lacam = crate::Lacam {
        rules,
        within_cap,
        ..crate::Lacam::default()
    };
    Ok(match lower.as_str() {
        "ma-astar" | "maastar" | "ma-a*" | "ma_astar" => Box::new(crate::MaAstar {
            rules,
            ..crate::MaAstar::default()
        }),
        "od-astar" | "odastar" | "od-a*" | "od_astar" | "od-astar-soc" => {
            if !rules.forbid_following {
                return Err(PlannerLookupError::UnsupportedRules {
                    planner: lower,
                    rules: rules.rule_set(),
                    why: "OD-A* searches the thesis env's sequential step in index order, so its plans, optimality and unsolvability proofs hold under thesis rules only",
                });
            }
            if lower == "od-astar-soc" {
                Box::new(crate::OdAstar::sum_of_loss())
            } else {
                Box::new(crate::OdAstar::default())
            }
        }
        "cbs" => Box::new(crate::Cbs {
            rules,
            ..crate::Cbs::default()
        }),
        "pibt" => Box::new(crate::Pibt {
            rules,
            ..crate::Pibt::default()
        }),
        "pp" | "prioritized" => Box::new(crate::Prioritized {
            rules,
            ..crate::Prioritized::default()
        }),
        "lacam" => Box::new(lacam),
        "lacam-star" | "lacam*" | "lacam_star" | "lacamstar" => Box::new(crate::LacamStar {
            lacam,
            ..crate::LacamStar::default()
        }),
        "lacam-star-makespan" => Box::new(crate::LacamStar {
            lacam,
            objective: crate::Objective::Makespan,
            ..crate::LacamStar::default()
        }),
        _ => {
            return Err(PlannerLookupError::Unknown {
                name: name.to_string(),
            })
        }
    })
}

/// Several planners in turn: the first plan any of them finds.
///
/// Planners fail in different places — LaCAM answers in milliseconds or
/// runs to its limit on instances that need agents to make room in a given
/// order, where [`crate::OdAstar`] answers at once, and the other way round
/// for large fleets — so a portfolio is worth more than either. The time
/// budget is shared: planner `k` of `m` may use an equal share of what is
/// left, `remaining / (m - k)`, so time one planner does not need passes to
/// the next. A plan longer than [`Limits::max_makespan`] (LaCAM does not
/// search within a cap unless [`crate::Lacam::within_cap`]) does not end
/// the turn: the next planner tries, and if none does better the shortest
/// plan found is returned. A proof
/// ([`SolveError::NoSolution`], [`SolveError::NoSolutionWithin`]) or a
/// malformed instance ends the call at once; otherwise the error is the
/// last planner's. Stats are the successful planner's, except the wall
/// time, which covers the whole call.
///
/// ```
/// use buridan_env::Map;
/// use buridan_mapf::{Lacam, Limits, OdAstar, Planner, Portfolio, Problem};
/// let map = Map::load("rm-1.1").unwrap();
/// let scen = map.scenario.unwrap();
/// let both = Portfolio::new(vec![Box::new(Lacam::default()), Box::new(OdAstar::default())]);
/// let sol = both.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &Limits::default()).unwrap();
/// assert!(sol.plan.makespan() >= 10);
/// // Within a cap of 10 steps: OD-A*'s optimal plan if LaCAM's is longer.
/// let capped = Limits { max_makespan: Some(10), ..Limits::default() };
/// let sol = both.solve(Problem::new(&map.grid, &scen.starts, &scen.goals), &capped).unwrap();
/// assert_eq!(sol.plan.makespan(), 10);
/// ```
pub struct Portfolio {
    planners: Vec<Box<dyn Planner>>,
    name: String,
}

impl Portfolio {
    /// The planners, tried in this order.
    ///
    /// # Panics
    ///
    /// If `planners` is empty (a portfolio must plan with something).
    pub fn new(planners: Vec<Box<dyn Planner>>) -> Self {
        assert!(
            !planners.is_empty(),
            "a portfolio needs at least one planner"
        );
        let name = planners
            .iter()
            .map(|p| p.name())
            .collect::<Vec<_>>()
            .join("+");
        Self { planners, name }
    }
}

impl Planner for Portfolio {
    fn name(&self) -> &str {
        &self.name
    }

    /// The weakest guarantee of its planners: simultaneous if any plans so.
    fn rules(&self) -> ConflictModel {
        if self.planners.iter().all(|p| p.rules().forbid_following) {
            ConflictModel::ENV_EXECUTABLE
        } else {
            ConflictModel::SIMULTANEOUS
        }
    }

    fn solve(&self, problem: Problem<'_>, limits: &Limits) -> Result<Solution, SolveError> {
        let clock = crate::limits::Budget::new(limits);
        let cap = limits.max_makespan.unwrap_or(usize::MAX);
        let mut last = SolveError::NoSolution;
        let mut too_long: Option<Solution> = None;
        for (k, planner) in self.planners.iter().enumerate() {
            let left = limits.time.saturating_sub(clock.cpu_elapsed());
            let share = Limits {
                time: left / (self.planners.len() - k) as u32,
                ..*limits
            };
            match planner.solve(problem, &share) {
                Ok(mut sol) if sol.plan.makespan() <= cap => {
                    sol.stats.wall_time = clock.elapsed();
                    return Ok(sol);
                }
                Ok(sol) => {
                    if too_long
                        .as_ref()
                        .is_none_or(|best| sol.plan.makespan() < best.plan.makespan())
                    {
                        too_long = Some(sol);
                    }
                }
                // A proof holds for every planner with the same rules.
                Err(
                    err @ (SolveError::NoSolution
                    | SolveError::NoSolutionWithin { .. }
                    | SolveError::Instance(_)),
                ) => return Err(err),
                Err(err) => last = err,
            }
        }
        match too_long {
            Some(mut sol) => {
                sol.stats.wall_time = clock.elapsed();
                Ok(sol)
            }
            None => Err(last),
        }
    }
}
