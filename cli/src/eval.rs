//! `learner eval`: one harness for every controller on identical episodes.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use buridan_env::{Map, Starts};
use buridan_eval::output::{write_report, write_sweep};
use buridan_eval::planner::PlannerController;
use buridan_eval::replay::Warmup;
use buridan_eval::{evaluate, Controller, EvalSpec, EvalSummary, RandomController};
use buridan_policy::ActMode;

use crate::replay::write_failed;

use buridan_eval::policy::PolicyController;
use buridan_eval::rescue::RescueController;
use buridan_eval::shield::{Ranking, ShieldController};
use buridan_mapf::{planner_by_name, Limits, Planner};
use indicatif::{ProgressBar, ProgressStyle};

/// Arguments of `learner eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Reference model id (`rm-2.1`) or path to a MovingAI `.map` file.
    #[arg(long)]
    pub map: String,
    /// Agents: a number (`4`), an inclusive range (`4..20`, `4..20:2`) or a list (`4,8,12`).
    #[arg(long, default_value = "4")]
    pub agents: String,
    /// Episodes per agent count: indices 0..N of the seeded generator.
    #[arg(long, default_value_t = 100)]
    pub episodes: usize,
    /// Seed of the episode generator (42 as in the dissertation).
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// `ma-astar`, `od-astar`, `cbs`, `pibt`, `lacam`, `lacam-star`, `pp`
    /// (prioritized planning; planners joined by `+` are tried in turn), `random`,
    /// `checkpoint:DIR`, or a checkpoint through the PIBT collision shield:
    /// `shield:checkpoint:DIR` (preferences over every move but walls) or
    /// `shield-env:checkpoint:DIR` (moves into occupied cells ranked last);
    /// `rescue:CONTROLLER` adds a planner as a safety net: it plans from the
    /// current state whenever an agent is stuck (within --time-limit), by
    /// default LaCAM then OD-A* (`lacam+od-astar`; beyond 8 agents
    /// prioritized planning then LaCAM, `pp+lacam`); `rescue=PLANNER:CONTROLLER`
    /// names another (e.g. `rescue=lacam:shield:checkpoint:DIR`);
    /// `lookahead:CONTROLLER` (and `lookahead=PLANNER:CONTROLLER`) adds
    /// foresight: a twin of the (deterministic) controller plays each
    /// episode ahead in a copy of the env, and if it would get stuck the
    /// planner plans from the start.
    #[arg(long)]
    pub controller: String,
    /// `random` starts and goals, or `fixed` (the map's `.scen`).
    #[arg(long, default_value = "random")]
    pub starts: Starts,
    /// Truncation step count T_max.
    #[arg(long, default_value_t = 100)]
    pub t_max: u32,
    /// Per-instance planning time limit in seconds (planners).
    #[arg(long, default_value_t = 60.0)]
    pub time_limit: f64,
    /// Per-instance memory cap of a planner's search, in MiB.
    #[arg(long, default_value_t = 2048)]
    pub memory_limit: usize,
    /// Episodes run in parallel (1 keeps compute times comparable).
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// Output directory (CSV, JSON, PNG).
    #[arg(long)]
    pub out: PathBuf,
    /// Print the JSON summary (an array for a sweep) to stdout.
    #[arg(long)]
    pub json: bool,
    /// Trained policies: sample actions instead of taking the most probable
    /// (shielded: the sampled action is the first preference).
    #[arg(long)]
    pub sample: bool,
    /// Write the replays of failed episodes (animated GIFs) into this
    /// directory (per agent count in a sweep).
    #[arg(long, value_name = "DIR")]
    pub replays: Option<PathBuf>,
    /// At most this many replays per agent count (--replays).
    #[arg(long, default_value_t = 20)]
    pub replays_max: usize,
}

/// Parses `4`, `4..20`, `4..20:2` or `4,8,12` into agent counts.
///
/// ```
/// use buridan_cli::eval::parse_agent_counts;
/// assert_eq!(parse_agent_counts("4").unwrap(), vec![4]);
/// assert_eq!(parse_agent_counts("4..8:2").unwrap(), vec![4, 6, 8]);
/// assert_eq!(parse_agent_counts("2,5").unwrap(), vec![2, 5]);
/// assert!(parse_agent_counts("8..4").is_err());
/// ```
pub fn parse_agent_counts(text: &str) -> Result<Vec<usize>> {
    let num = |s: &str| -> Result<usize> {
        let n: usize = s
            .trim()
            .parse()
            .with_context(|| format!("'{s}' is not an agent count"))?;
        if n == 0 {
            bail!("agent counts must be at least 1");
        }
        Ok(n)
    };
    if let Some((lo, rest)) = text.split_once("..") {
        let (hi, step) = rest.split_once(':').unwrap_or((rest, "1"));
        let (lo, hi, step) = (num(lo)?, num(hi)?, num(step)?);
        if lo > hi {
            bail!("empty agent range {text}: {lo} > {hi}");
        }
        return Ok((lo..=hi).step_by(step).collect());
    }
    text.split(',').map(num).collect()
}

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
/// agents: prioritized planning answers crowds in milliseconds (seed-42,
/// 16 agents, 1 s: rm-3.1 100 % and rm-2.1 100 % planned, where LaCAM plans
/// 32 % and 50 % within T_max); LaCAM, complete, takes the instances where
/// every order PP tries fails.
pub const CROWD_RESCUE_PLANNER: &str = "pp+lacam";

/// Splits `rescue:INNER`, `rescue=PLANNER:INNER`, `lookahead:INNER` and
/// `lookahead=PLANNER:INNER` into (kind, planner, inner); the default
/// planner depends on the fleet size.
fn rescue_parts(name: &str, agents: usize) -> Option<(&'static str, &str, &str)> {
    ["rescue", "lookahead"].into_iter().find_map(|kind| {
        let rest = name.strip_prefix(kind)?;
        if let Some(inner) = rest.strip_prefix(':') {
            let planner = if agents > RESCUE_OD_ASTAR_MAX_AGENTS {
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

/// Planner limits from a time limit in seconds and a memory cap in MiB
/// (`--time-limit`, `--memory-limit`, a study's `time_limit`).
///
/// ```
/// let l = buridan_cli::eval::planner_limits(1.5, 64).unwrap();
/// assert_eq!((l.time.as_millis(), l.memory_bytes), (1500, 64 << 20));
/// assert!(buridan_cli::eval::planner_limits(0.0, 64).is_err());
/// ```
pub fn planner_limits(time_limit: f64, memory_limit_mib: usize) -> Result<Limits> {
    if !(time_limit > 0.0 && time_limit.is_finite()) {
        bail!("--time-limit must be a positive number of seconds");
    }
    Ok(Limits {
        time: std::time::Duration::from_secs_f64(time_limit),
        memory_bytes: memory_limit_mib << 20,
        ..Limits::default()
    })
}

/// A factory of fresh controllers, one per evaluation thread.
pub type ControllerFactory = Box<dyn Fn() -> Box<dyn Controller> + Sync>;

/// Resolves `--controller` (`ma-astar`, `cbs`, `random`, `checkpoint:DIR`,
/// `shield:checkpoint:DIR`, …) to a factory for episodes with `agents` agents.
///
/// ```
/// use buridan_cli::eval::controller_factory;
/// use buridan_policy::ActMode;
/// let ckpt = "../docs/results/ppo-ctde-rm-2.1/checkpoint";
/// let make = controller_factory(&format!("shield:checkpoint:{ckpt}"), 8, 42, Default::default(), ActMode::Greedy).unwrap();
/// assert_eq!(make().name(), "ctde-policy+shield");
/// let err = controller_factory("shield:cbs", 4, 42, Default::default(), ActMode::Greedy).err().unwrap();
/// assert!(err.to_string().contains("trained policies only"), "{err}");
/// let rescued = controller_factory("rescue:random", 4, 42, Default::default(), ActMode::Greedy).unwrap();
/// assert_eq!(rescued().name(), "random+rescue-lacam+od-astar");
/// let crowd = controller_factory("rescue:random", 16, 42, Default::default(), ActMode::Greedy).unwrap();
/// assert_eq!(crowd().name(), "random+rescue-pp+lacam");
/// let by_lacam = controller_factory("rescue=lacam:random", 4, 42, Default::default(), ActMode::Greedy).unwrap();
/// assert_eq!(by_lacam().name(), "random+rescue-lacam");
/// let ahead = controller_factory("lookahead=od-astar:random", 4, 42, Default::default(), ActMode::Greedy).unwrap();
/// assert_eq!(ahead().name(), "random+lookahead-od-astar");
/// let err = controller_factory("rescue=dijkstra:random", 4, 42, Default::default(), ActMode::Greedy).err().unwrap();
/// assert!(err.to_string().contains("unknown rescue planner 'dijkstra'"), "{err}");
/// ```
pub fn controller_factory(
    name: &str,
    agents: usize,
    seed: u64,
    limits: Limits,
    act_mode: ActMode,
) -> Result<ControllerFactory> {
    if let Some((kind, planner, inner)) = rescue_parts(name, agents) {
        let planner: Arc<dyn Planner> = planner_by_name(planner)
            .with_context(|| {
                format!("'{name}': unknown rescue planner '{planner}' (expected pibt, lacam, lacam-star, od-astar, pp, cbs, ma-astar, or several joined by '+')")
            })?
            .into();
        let inner = controller_factory(inner, agents, seed, limits, act_mode)?;
        let foresight = kind == "lookahead";
        return Ok(Box::new(move || {
            let rescue = RescueController::new(inner(), planner.clone(), limits);
            Box::new(if foresight {
                rescue.with_foresight(inner())
            } else {
                rescue
            })
        }));
    }
    for (prefix, ranking) in [("shield:", Ranking::Walls), ("shield-env:", Ranking::Env)] {
        if let Some(inner) = name.strip_prefix(prefix) {
            let Some(dir) = inner.strip_prefix("checkpoint:") else {
                bail!("'{name}': the shield drives trained policies only ({prefix}checkpoint:DIR)");
            };
            let dir = PathBuf::from(dir);
            let load = move || ShieldController::load(&dir, agents, act_mode, seed, ranking);
            // Load once here so that a bad checkpoint fails with its reason.
            load()?;
            return Ok(Box::new(move || {
                Box::new(load().expect("loaded once already"))
            }));
        }
    }
    if let Some(dir) = name.strip_prefix("checkpoint:") {
        let dir = PathBuf::from(dir);
        // Load once here so that a bad checkpoint fails with its reason.
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
    let planner: Arc<dyn Planner> = planner_by_name(name)
        .with_context(|| {
            format!("unknown controller '{name}': expected ma-astar, od-astar, cbs, pibt, lacam, lacam-star, pp, random, checkpoint:DIR, shield:checkpoint:DIR or rescue:CONTROLLER")
        })?
        .into();
    Ok(Box::new(move || {
        Box::new(PlannerController::new(planner.clone(), limits))
    }))
}

/// Runs `learner eval`.
pub fn run(args: &EvalArgs) -> Result<Vec<EvalSummary>> {
    let map =
        Arc::new(Map::load(&args.map).with_context(|| format!("loading map '{}'", args.map))?);
    let counts = parse_agent_counts(&args.agents)?;
    let limits = planner_limits(args.time_limit, args.memory_limit)?;
    let sweep = counts.len() > 1;
    let act_mode = if args.sample {
        ActMode::Sample
    } else {
        ActMode::Greedy
    };
    let mut summaries = Vec::new();
    for &agents in &counts {
        let make = controller_factory(&args.controller, agents, args.seed, limits, act_mode)?;
        let spec = EvalSpec {
            agents,
            episodes: args.episodes,
            seed: args.seed,
            starts: args.starts,
            t_max: args.t_max,
            jobs: args.jobs.max(1),
        };
        let bar = ProgressBar::new(args.episodes as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed}, eta {eta})",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar.set_prefix(format!("{} {} agents={agents}", args.controller, map.name));
        crate::heartbeat::watch(&bar);
        let solved = AtomicUsize::new(0);
        let done = AtomicUsize::new(0);
        let on_episode = |r: &buridan_eval::EpisodeRecord| {
            let s = solved.fetch_add(usize::from(r.success), Ordering::Relaxed)
                + usize::from(r.success);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            bar.set_message(format!("success {:.1}%", 100.0 * s as f64 / d as f64));
            bar.inc(1);
        };
        let report = evaluate(&map, &spec, &*make, &on_episode)
            .with_context(|| format!("evaluating {} agents on {}", agents, map.name))?;
        bar.finish();
        let dir = if sweep {
            args.out.join(format!("agents-{agents}"))
        } else {
            args.out.clone()
        };
        let files = write_report(&dir, &report, &map.grid)
            .with_context(|| format!("writing results to {}", dir.display()))?;
        if let Some(replays) = &args.replays {
            let dir = if sweep {
                replays.join(format!("agents-{agents}"))
            } else {
                replays.clone()
            };
            let warmup = if args.sample && spec.jobs == 1 {
                Warmup::Preceding
            } else {
                Warmup::Fresh
            };
            let files = write_failed(&map, &spec, &make, &report, warmup, &dir, args.replays_max)?;
            if !args.json {
                eprintln!(
                    "{} replays of failed episodes -> {}",
                    files.len(),
                    dir.display()
                );
            }
        }
        let s = &report.summary;
        tracing::info!(
            controller = %s.controller, map = %s.map, agents, success_rate = s.success_rate,
            timesteps_median = ?s.timesteps_median, compute_ms_median = ?s.compute_ms_median,
            files = ?files, "evaluation done"
        );
        if !args.json {
            eprintln!(
                "{} on {} with {} agents: success {:.1}% ({} episodes), timesteps median {} [q1 {}, q3 {}], compute median {} ms -> {}",
                s.controller,
                s.map,
                agents,
                100.0 * s.success_rate,
                s.episodes,
                fmt_opt(s.timesteps_median),
                fmt_opt(s.timesteps_q1),
                fmt_opt(s.timesteps_q3),
                fmt_opt(s.compute_ms_median),
                dir.display()
            );
        }
        summaries.push(report.summary);
    }
    if sweep {
        write_sweep(&args.out, &summaries)
            .with_context(|| format!("writing the sweep to {}", args.out.display()))?;
    }
    if args.json {
        let text = if sweep {
            serde_json::to_string_pretty(&summaries)?
        } else {
            serde_json::to_string_pretty(&summaries[0])?
        };
        println!("{text}");
    }
    Ok(summaries)
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |x| format!("{x:.1}"))
}
