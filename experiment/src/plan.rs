//! `learner study`: a declarative experiment — layouts × methods (training
//! configurations) × seeds, plus classical planners on the same seeded
//! episodes; every trained policy evaluated with sampled and greedy
//! actions, optionally over a sweep of agent counts. Each cell is a normal
//! `learner train --out` run directory and a normal `learner eval --out`
//! directory; finished runs and evaluations are skipped on the next
//! invocation. [`crate::report`] aggregates the cells over seeds.
//!
//! A layout may be several maps with weights, `"rm-3.1:1,rm-2.2:1"` (as
//! `learner train --maps` takes them): its runs train on the mixture, and
//! `[experiment.eval] layouts` names the layouts every policy is evaluated
//! on (by default, its training layout).
//!
//! ```toml
//! [experiment]
//! name = "comparison"
//! layouts = ["rm-2.1", "rm-2.2"]
//! seeds = 10                        # seeds 0..10, or a list [0, 1, 5] (none: planners only)
//! steps = 2_000_000                 # per run (default: each config's steps)
//! planners = ["cbs", "ma-astar"]    # any name `learner eval --controller` knows
//! parallel = 1                      # cells at once
//!
//! [experiment.eval]
//! episodes = 100                    # 1000 for generalization
//! seed = 42
//! actions = ["sampled", "greedy"]  # and/or "shielded": greedy through the PIBT shield,
//!                                   # "fallback": shielded, an agent without progress for 16 steps
//!                                   #   follows its shortest path (PIBT with swap)
//!                                   # "ordered": the fallback, and dead-end aisles filled from the
//!                                   #   back (an agent bound nearer the mouth waits outside)
//!                                   # "lanes": ordered, and one-lane corridors kept one-way (an
//!                                   #   agent waits outside while another comes out towards it)
//!                                   # "evict": lanes, and an agent in a dead end's way backs out
//!                                   #   of it (an aisle entered in the wrong order is refilled)
//!                                   # "rescued": shielded, a planner plans whenever an agent is stuck
//!                                   # "lookahead": rescued, with foresight (a twin plays the episode ahead;
//!                                   #   if it would get stuck, the planner plans from the start)
//!                                   # "backstop": the same twin; the planner plans from the start only
//!                                   #   if the twin would fail, else the policy drives untouched
//!                                   # "pace": the backstop; the plan also drives the episodes the twin
//!                                   #   would finish more than 10 % after the plan
//!                                   # or any controller over the run's policy, LABEL@CONTROLLER with
//!                                   #   `checkpoint:` left without DIR (`learner eval --controller`):
//!                                   #   "bss@backstop:sampled:shield[patience=16,settle,lanes]:checkpoint:"
//! rescue_time = 1.0                 # seconds per rescue plan
//! rescue_planner = "od-astar+lacam" # default: as `--controller rescue:…` (LaCAM, then OD-A*;
//!                                   #   beyond 8 agents prioritized planning, then LaCAM)
//! agents = "4..20"                  # default: the agents each policy trained with
//! time_limit = 60.0                 # planners, seconds per instance
//! layouts = ["rm-2.1", "maps/comb.map"]  # evaluate on these (default: the training layout);
//!                                   # map files relative to the working dir or this file
//!
//! [[method]]
//! name = "ppo-ctde"
//! config = "../configs/ppo-ctde-rm-2.1.toml"        # relative to this file (or the working dir);
//!                                                   # no config: the default recipe (`learner train` without --config)
//! configs = { "rm-2.2" = "../configs/ppo-ctde-rm-2.2.toml" }  # per-layout configs
//! set = ["ppo.lr=5e-4"]             # `learner train --set` overrides
//! stop = false                      # train the whole step budget, no stop rule
//!                                   #   (`learner train --no-stop`; default true)
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use buridan_env::Starts;
use buridan_eval::by_name::{Controller, Portfolio};
use buridan_learner::train::WeightedMap;
use serde::{Deserialize, Serialize};

use crate::trial::chain;

mod actions;
mod commands;
#[cfg(test)]
mod tests;

pub use actions::{Actions, NAMED_ACTIONS};
pub use commands::shell_join;

/// The resolved plan inside an experiment directory (what `report` reads).
pub const PLAN_FILE: &str = "plan.json";

/// The most training plus evaluation runs an experiment may plan.
pub const MAX_CELLS: usize = 100_000;

/// An experiment file that cannot be used: the file and the problem.
///
/// ```
/// let e = buridan_experiment::plan::Experiment::from_str("[experiment]\nname = 1", "x.toml".as_ref()).unwrap_err();
/// assert!(e.to_string().starts_with("x.toml: "), "{e}");
/// ```
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", file.display())]
pub struct ExperimentError {
    /// The experiment file.
    pub file: PathBuf,
    /// What is wrong with it.
    pub problem: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileToml {
    experiment: ExperimentToml,
    #[serde(default)]
    method: Vec<MethodToml>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum SeedsToml {
    Count(u64),
    List(Vec<u64>),
}

/// No seeds: enough for a study of planners alone.
impl Default for SeedsToml {
    fn default() -> Self {
        SeedsToml::List(Vec::new())
    }
}

#[derive(Deserialize)]
#[serde(untagged)]
enum AgentsToml {
    One(usize),
    List(Vec<usize>),
    Text(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentToml {
    name: String,
    layouts: Vec<String>,
    #[serde(default)]
    seeds: SeedsToml,
    steps: Option<u64>,
    #[serde(default)]
    planners: Vec<String>,
    #[serde(default = "one")]
    parallel: usize,
    #[serde(default)]
    eval: EvalToml,
}

fn one() -> usize {
    1
}

fn default_rescue_time() -> f64 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct EvalToml {
    episodes: usize,
    seed: u64,
    actions: Vec<Actions>,
    agents: Option<AgentsToml>,
    starts: Starts,
    t_max: u32,
    time_limit: f64,
    rescue_time: f64,
    rescue_planner: Option<String>,
    memory_limit: usize,
    layouts: Option<Vec<String>>,
}

impl Default for EvalToml {
    fn default() -> Self {
        EvalToml {
            episodes: 100,
            seed: 42,
            actions: ["sampled", "greedy"]
                .map(|a| a.parse().expect("named actions parse"))
                .to_vec(),
            agents: None,
            starts: Starts::Random,
            t_max: 100,
            time_limit: 60.0,
            rescue_time: 1.0,
            rescue_planner: None,
            memory_limit: 2048,
            layouts: None,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MethodToml {
    name: String,
    config: Option<String>,
    #[serde(default)]
    configs: BTreeMap<String, String>,
    #[serde(default)]
    set: Vec<String>,
    #[serde(default = "yes")]
    stop: bool,
}

fn yes() -> bool {
    true
}

/// The evaluation protocol of an experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalProtocol {
    /// Episodes per evaluation.
    pub episodes: usize,
    /// Seed of the episode generator.
    pub seed: u64,
    /// How the policies are evaluated.
    pub actions: Vec<Actions>,
    /// Agent counts (`None`: each policy's training count).
    pub agents: Option<Vec<usize>>,
    /// Random or fixed starts.
    pub starts: Starts,
    /// Truncation step count.
    pub t_max: u32,
    /// Planner time limit per instance, seconds.
    pub time_limit: f64,
    /// Time limit of each rescue plan (`rescued` actions), seconds.
    #[serde(default = "default_rescue_time")]
    pub rescue_time: f64,
    /// The rescue's planner (`rescued` actions; any `learner eval
    /// --controller` planner name, `+` joins a portfolio); `None`: the
    /// default of `--controller rescue:…`.
    #[serde(default)]
    pub rescue_planner: Option<String>,
    /// Planner memory cap, MiB.
    pub memory_limit: usize,
    /// Layouts every policy (and planner) is evaluated on; `None`: each
    /// policy on its training layout.
    #[serde(default)]
    pub layouts: Option<Vec<String>>,
}

impl EvalProtocol {
    /// Where reports list the action named `name`: the named actions in
    /// their order ([`NAMED_ACTIONS`]), then the others in the study's.
    pub fn action_order(&self, name: &str) -> Option<usize> {
        Actions::named_rank(name).or_else(|| {
            let k = self.actions.iter().position(|a| a.name() == name)?;
            Some(NAMED_ACTIONS.len() + k)
        })
    }
}

/// One training cell: a layout, a method and a seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainCell {
    /// Layout (reference model id or map path).
    pub layout: String,
    /// Method name.
    pub method: String,
    /// Seed.
    pub seed: u64,
    /// Run directory, relative to the experiment directory.
    pub run_dir: PathBuf,
    /// The configuration file (`None`: the default recipe, as `learner
    /// train` without `--config`).
    #[serde(default)]
    pub config: Option<PathBuf>,
    /// Step budget (`None`: the config's).
    pub steps: Option<u64>,
    /// `--set` overrides.
    pub set: Vec<String>,
    /// Whether the run trains its whole step budget, its configuration's
    /// stop rules off (`learner train --no-stop`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub no_stop: bool,
    /// Agents it trains with.
    pub agents: usize,
}

/// What an evaluation cell evaluates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Evaluated {
    /// The policy of training cell `train` (index into the plan's train cells).
    Policy {
        /// The training cell.
        train: usize,
        /// Sampled or greedy.
        actions: Actions,
    },
    /// A planner (deterministic: one evaluation, no seeds).
    Planner,
}

/// One evaluation cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalCell {
    /// Layout evaluated on.
    pub layout: String,
    /// The policy's training layout, when the experiment evaluates on
    /// `[experiment.eval] layouts` (`None`: the same as `layout`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trained_on: Option<String>,
    /// Method or planner name.
    pub method: String,
    /// What is evaluated.
    pub evaluated: Evaluated,
    /// Agents per episode.
    pub agents: usize,
    /// The evaluation directory, relative to the experiment directory.
    pub dir: PathBuf,
}

/// A resolved experiment: every cell, in order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Experiment {
    /// Name.
    pub name: String,
    /// Layouts, in file order.
    pub layouts: Vec<String>,
    /// Methods, in file order.
    pub methods: Vec<String>,
    /// Planners, in file order.
    pub planners: Vec<String>,
    /// Seeds.
    pub seeds: Vec<u64>,
    /// Cells at once.
    pub parallel: usize,
    /// The evaluation protocol.
    pub eval: EvalProtocol,
    /// Training cells.
    pub train: Vec<TrainCell>,
    /// Evaluation cells.
    pub evals: Vec<EvalCell>,
}

fn safe_name(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// A layout's directory (and file) name: its id, or a map path's file
/// stem; for a mixture, each map's name and weight joined by `+`.
///
/// ```
/// use buridan_experiment::plan::layout_dir;
/// assert_eq!(layout_dir("rm-2.1"), "rm-2.1");
/// assert_eq!(layout_dir("maps/my warehouse.map"), "my_warehouse");
/// assert_eq!(layout_dir("rm-3.1:1,maps/x.map:2"), "rm-3.1_1+x_2");
/// ```
pub fn layout_dir(layout: &str) -> String {
    if is_mixture(layout) {
        return layout
            .split(',')
            .map(|entry| {
                let (name, weight) = entry.trim().rsplit_once(':').unwrap_or((entry, "1"));
                format!("{}_{}", layout_dir(name.trim()), safe_name(weight.trim()))
            })
            .collect::<Vec<_>>()
            .join("+");
    }
    let path = Path::new(layout);
    let stem = if layout.ends_with(".map") || path.components().count() > 1 {
        path.file_stem().and_then(|s| s.to_str()).unwrap_or(layout)
    } else {
        layout
    };
    safe_name(stem)
}

/// Whether a layout entry names several maps (`NAME:WEIGHT,…`).
///
/// ```
/// use buridan_experiment::plan::is_mixture;
/// assert!(is_mixture("rm-3.1:1,rm-2.2:1"));
/// assert!(!is_mixture("rm-2.1"));
/// ```
pub fn is_mixture(layout: &str) -> bool {
    layout.contains(',')
}

/// Checks that a layout entry (one map, or a mixture) loads.
fn check_layout(layout: &str) -> Result<(), String> {
    let names = if is_mixture(layout) {
        WeightedMap::parse_list(layout)
            .map_err(|e| e.to_string())?
            .into_iter()
            .map(|m| m.name)
            .collect()
    } else {
        vec![layout.to_string()]
    };
    for name in names {
        buridan_env::Map::load(&name).map_err(|err| chain(&err))?;
    }
    Ok(())
}

impl Experiment {
    /// The layouts evaluations run on: `[experiment.eval] layouts`, else
    /// the training layouts.
    pub fn eval_layouts(&self) -> &[String] {
        self.eval.layouts.as_deref().unwrap_or(&self.layouts)
    }

    /// Reads and resolves an experiment file.
    pub fn from_file(path: &Path) -> Result<Experiment, ExperimentError> {
        let text = std::fs::read_to_string(path).map_err(|e| ExperimentError {
            file: path.to_path_buf(),
            problem: format!("cannot read: {e}"),
        })?;
        Experiment::from_str(&text, path)
    }

    /// Parses and resolves an experiment file's text; `file` names it in
    /// errors and anchors its relative paths.
    #[allow(clippy::should_implement_trait)]
    pub fn from_str(text: &str, file: &Path) -> Result<Experiment, ExperimentError> {
        let bad = |problem: String| ExperimentError {
            file: file.to_path_buf(),
            problem,
        };
        let parsed: FileToml = toml::from_str(text).map_err(|e| {
            bad(e
                .to_string()
                .lines()
                .filter(|l| !l.trim().is_empty())
                .collect::<Vec<_>>()
                .join(" "))
        })?;
        let mut x = parsed.experiment;
        // Map files are named relative to the working directory or, failing
        // that, to this file (as configs are).
        let locate = |layout: &mut String| {
            if !is_mixture(layout) && layout.ends_with(".map") {
                *layout = crate::tune::resolve_relative(file, layout)
                    .display()
                    .to_string();
            }
        };
        x.layouts.iter_mut().for_each(locate);
        x.eval.layouts.iter_mut().flatten().for_each(locate);
        if x.name.trim().is_empty() {
            return Err(bad("[experiment] name is empty".into()));
        }
        if x.layouts.is_empty() {
            return Err(bad("[experiment] layouts: name at least one layout".into()));
        }
        let seeds: Vec<u64> = match x.seeds {
            // Checked before collecting: `seeds = 1e18` asked for exabytes
            // (found by cli/tests/fuzz_experiment.rs).
            SeedsToml::Count(n) if n > MAX_CELLS as u64 => {
                return Err(bad(format!(
                    "[experiment] seeds = {n}: at most {MAX_CELLS} runs per method and layout"
                )))
            }
            SeedsToml::Count(n) => (0..n).collect(),
            SeedsToml::List(v) => v,
        };
        if seeds.is_empty() && !parsed.method.is_empty() {
            return Err(bad("[experiment] seeds: at least one seed".into()));
        }
        if parsed.method.is_empty() && x.planners.is_empty() {
            return Err(bad(
                "nothing to run: add a [[method]] table or [experiment] planners".into(),
            ));
        }
        if x.parallel == 0 {
            return Err(bad("[experiment] parallel must be at least 1".into()));
        }
        if x.steps == Some(0) {
            return Err(bad("[experiment] steps must be at least 1".into()));
        }
        let e = x.eval;
        if e.episodes == 0 {
            return Err(bad("[experiment.eval] episodes must be at least 1".into()));
        }
        if e.actions.is_empty() && !parsed.method.is_empty() {
            let names: Vec<_> = NAMED_ACTIONS.iter().map(|(n, _)| *n).collect();
            return Err(bad(format!(
                "[experiment.eval] actions: name one or more of {}",
                names.join(", ")
            )));
        }
        if !(e.rescue_time > 0.0 && e.rescue_time.is_finite()) {
            return Err(bad(
                "[experiment.eval] rescue_time must be a positive number of seconds".into(),
            ));
        }
        if let Some(planner) = &e.rescue_planner {
            planner.parse::<Portfolio>().map_err(|_| {
                bad(format!(
                    "[experiment.eval] rescue_planner: unknown planner '{planner}' (expected pibt, lacam, lacam-star, od-astar, pp, cbs, ma-astar, or several joined by '+')"
                ))
            })?;
        }
        if !(e.time_limit > 0.0 && e.time_limit.is_finite()) {
            return Err(bad(
                "[experiment.eval] time_limit must be a positive number of seconds".into(),
            ));
        }
        let agents = match e.agents {
            None => None,
            Some(AgentsToml::One(n)) => Some(vec![n]),
            Some(AgentsToml::List(v)) => Some(v),
            Some(AgentsToml::Text(t)) => Some(
                crate::agents::parse_agent_counts(&t)
                    .map_err(|err| bad(format!("[experiment.eval] agents: {err}")))?,
            ),
        };
        if agents
            .as_ref()
            .is_some_and(|a| a.is_empty() || a.contains(&0))
        {
            return Err(bad(
                "[experiment.eval] agents: counts must be at least 1".into()
            ));
        }
        if let Some(layouts) = &e.layouts {
            if layouts.is_empty() {
                return Err(bad(
                    "[experiment.eval] layouts: name at least one layout (or leave it out)".into(),
                ));
            }
            for l in layouts {
                if is_mixture(l) {
                    return Err(bad(format!(
                        "[experiment.eval] layouts: '{l}' is a mixture; evaluations run on one map each"
                    )));
                }
                check_layout(l)
                    .map_err(|err| bad(format!("[experiment.eval] layout '{l}': {err}")))?;
            }
        }
        let mut actions = e.actions.clone();
        actions.dedup();
        for (k, a) in actions.iter().enumerate() {
            if actions[..k].iter().any(|b| b.name() == a.name()) {
                return Err(bad(format!(
                    "[experiment.eval] actions: two actions are named '{}'",
                    a.name()
                )));
            }
        }
        let eval = EvalProtocol {
            episodes: e.episodes,
            seed: e.seed,
            actions,
            agents,
            starts: e.starts,
            t_max: e.t_max,
            time_limit: e.time_limit,
            rescue_time: e.rescue_time,
            rescue_planner: e.rescue_planner,
            memory_limit: e.memory_limit,
            layouts: e.layouts,
        };
        for layout in &x.layouts {
            check_layout(layout).map_err(|err| bad(format!("layout '{layout}': {err}")))?;
            if is_mixture(layout) && eval.layouts.is_none() {
                return Err(bad(format!(
                    "layout '{layout}' trains on several maps: name the maps to evaluate on in [experiment.eval] layouts"
                )));
            }
        }
        for p in &x.planners {
            let planner = p.parse::<Controller>();
            if !matches!(
                planner,
                Ok(Controller::Planner(_) | Controller::Random | Controller::LifelongPibt)
            ) {
                return Err(bad(format!(
                    "planner '{p}' is unknown: expected ma-astar, cbs, pibt, lacam, lacam-star, random or lifelong-pibt"
                )));
            }
        }
        let mut names = BTreeSet::new();
        for m in &parsed.method {
            if m.name.is_empty() || safe_name(&m.name) != m.name {
                return Err(bad(format!(
                    "[[method]] name '{}': use letters, digits, '-', '_' or '.'",
                    m.name
                )));
            }
            if !names.insert(m.name.clone()) || x.planners.contains(&m.name) {
                return Err(bad(format!("[[method]] name '{}' is used twice", m.name)));
            }
            if let Some(l) = m.configs.keys().find(|l| !x.layouts.contains(l)) {
                return Err(bad(format!(
                    "[[method]] '{}': configs names layout '{l}', which is not in layouts",
                    m.name
                )));
            }
        }
        let mut train = Vec::new();
        let mut evals = Vec::new();
        // The plan's size before building it: a few short lists multiply
        // into billions of cells (found by cli/tests/fuzz_experiment.rs).
        let counts = eval.agents.as_ref().map_or(1, Vec::len);
        let targets = eval.layouts.as_ref().map_or(1, Vec::len);
        let cells = [
            parsed.method.len(),
            x.layouts.len(),
            seeds.len(),
            1 + targets
                .saturating_mul(eval.actions.len())
                .saturating_mul(counts),
        ]
        .iter()
        .fold(1usize, |n, &k| n.saturating_mul(k));
        if cells > MAX_CELLS {
            return Err(bad(format!(
                "the plan has {cells} training and evaluation runs; at most {MAX_CELLS}"
            )));
        }
        // Planners run on the evaluation layouts, with every agent count a
        // policy there is evaluated with.
        let mut planner_agents: BTreeMap<String, BTreeSet<usize>> = BTreeMap::new();
        for layout in &x.layouts {
            let ldir = PathBuf::from(layout_dir(layout));
            for m in &parsed.method {
                if m.config.is_none() && !m.configs.is_empty() && !m.configs.contains_key(layout) {
                    return Err(bad(format!(
                        "[[method]] '{}': no config for layout '{layout}' (set config, or leave out configs for the default recipe)",
                        m.name
                    )));
                }
                let config = m
                    .configs
                    .get(layout)
                    .or(m.config.as_ref())
                    .map(|c| crate::tune::resolve_relative(file, c));
                for &seed in &seeds {
                    let cell = TrainCell {
                        layout: layout.clone(),
                        method: m.name.clone(),
                        seed,
                        run_dir: PathBuf::from("runs")
                            .join(&ldir)
                            .join(&m.name)
                            .join(format!("seed-{seed}")),
                        config: config.clone(),
                        steps: x.steps,
                        set: m.set.clone(),
                        no_stop: !m.stop,
                        agents: 0,
                    };
                    let cfg = cell.config_in(Path::new(".")).map_err(|err| {
                        bad(format!(
                            "[[method]] '{}' on '{layout}': {}",
                            m.name,
                            chain(&err)
                        ))
                    })?;
                    let trained = cfg.agents;
                    let counts = eval.agents.clone().unwrap_or_else(|| vec![trained]);
                    let index = train.len();
                    train.push(TrainCell {
                        agents: trained,
                        ..cell
                    });
                    let seed_dir = PathBuf::from("evals")
                        .join(&ldir)
                        .join(&m.name)
                        .join(format!("seed-{seed}"));
                    let targets: Vec<(&String, PathBuf, Option<String>)> = match &eval.layouts {
                        None => vec![(layout, seed_dir, None)],
                        Some(on) => on
                            .iter()
                            .map(|l| (l, seed_dir.join(layout_dir(l)), Some(layout.clone())))
                            .collect(),
                    };
                    for (on, dir, trained_on) in targets {
                        planner_agents
                            .entry(on.clone())
                            .or_default()
                            .extend(counts.iter().copied());
                        for actions in &eval.actions {
                            for &agents in &counts {
                                evals.push(EvalCell {
                                    layout: on.clone(),
                                    trained_on: trained_on.clone(),
                                    method: m.name.clone(),
                                    evaluated: Evaluated::Policy {
                                        train: index,
                                        actions: actions.clone(),
                                    },
                                    agents,
                                    dir: dir.join(actions.name()).join(format!("agents-{agents}")),
                                });
                            }
                        }
                    }
                }
            }
        }
        let planner_layouts = eval.layouts.clone().unwrap_or_else(|| x.layouts.clone());
        for layout in &planner_layouts {
            let counts = match planner_agents.get(layout) {
                Some(counts) if !counts.is_empty() => counts.clone(),
                _ => eval
                    .agents
                    .clone()
                    .unwrap_or_else(|| vec![4])
                    .into_iter()
                    .collect(),
            };
            for p in &x.planners {
                for &agents in &counts {
                    evals.push(EvalCell {
                        layout: layout.clone(),
                        trained_on: None,
                        method: p.clone(),
                        evaluated: Evaluated::Planner,
                        agents,
                        dir: PathBuf::from("evals")
                            .join(layout_dir(layout))
                            .join(safe_name(p))
                            .join(format!("agents-{agents}")),
                    });
                }
            }
        }
        Ok(Experiment {
            name: x.name,
            layouts: x.layouts,
            methods: parsed.method.into_iter().map(|m| m.name).collect(),
            planners: x.planners,
            seeds,
            parallel: x.parallel,
            eval,
            train,
            evals,
        })
    }
}
