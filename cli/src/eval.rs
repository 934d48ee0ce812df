//! `learner eval`: one harness for every controller on identical episodes.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use buridan_env::{Map, Rules, Starts};
use buridan_eval::instances::load_instance_set;
use buridan_eval::output::{write_report, write_sweep};
use buridan_eval::plant::{
    evaluate_plant, load_plant, summary_line as plant_summary_line, write_plant_report,
    PlantController, PlantEpisodeRecord, PlantEvalSpec, PlantEvalSummary,
};
use buridan_eval::replay::Warmup;
use buridan_eval::{evaluate, evaluate_instances, EvalReport, EvalSpec, EvalSummary};
use buridan_policy::ActMode;

use crate::replay::write_failed;

use buridan_mapf::Limits;
use indicatif::{ProgressBar, ProgressStyle};

/// Arguments of `learner eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Reference model id (`rm-2.1`), path to a MovingAI `.map` file or a
    /// generated map's spec (`maze/19x19/seed=0`); with --scen, the map
    /// the `.scen` files name (beside them) unless given.
    #[arg(long, required_unless_present_any = ["scen", "plant"])]
    pub map: Option<String>,
    /// Evaluate on an AGV plant instead: a bundled plant id
    /// (`dissertation`, `hall`) or a plant file; --controller is then
    /// `reservation`, `random` or `checkpoint:DIR` (a `learner train
    /// --plant` run), --agents one count (default 4), --t-max overrides
    /// the plant file's T_max; --rules, --starts, --jobs and the planner
    /// limits do not apply and are refused. Writes episodes.csv (KPIs per
    /// episode) and summary.json.
    #[arg(long, value_name = "ID|FILE", conflicts_with_all = ["map", "scen", "replays"])]
    pub plant: Option<String>,
    /// Agents: a number (`4`), an inclusive range (`4..20`, `4..20:2`) or a
    /// list (`4,8,12`); default 4, or with --scen every line of each file
    /// (a number N takes the first N lines).
    #[arg(long)]
    pub agents: Option<String>,
    /// Instance sets: MovingAI `.scen` files, each one episode with its own
    /// starts and goals; a directory means every `.scen` file in it, in
    /// natural order (repeatable). Replaces the seeded episodes (--episodes,
    /// --starts, --seed are not used).
    #[arg(long, value_name = "PATH")]
    pub scen: Vec<PathBuf>,
    /// The rule set the env moves agents by: `thesis` (sequential moves in
    /// index order) or `pogema` (POGEMA's simultaneous moves); planners plan
    /// for it.
    #[arg(long, default_value = "thesis", conflicts_with = "plant")]
    pub rules: Rules,
    /// Episodes per agent count: indices 0..N of the seeded generator.
    #[arg(long, default_value_t = 100)]
    pub episodes: usize,
    /// Seed of the episode generator (42 as in the dissertation).
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// The controller: a planner (`lacam`, `cbs`, `lacam+od-astar`, …),
    /// `random`, `checkpoint:DIR`, `shield[OPTIONS]:checkpoint:DIR`, or a
    /// planner net around any of these (`rescue:…`, `lookahead:…`,
    /// `backstop:…`, `pace:…`); the grammar's table is the doc comment of
    /// `buridan_eval::by_name::Controller` (`cargo doc -p buridan-eval`). With
    /// --plant: `reservation`, `random` or `checkpoint:DIR`.
    #[arg(long)]
    pub controller: String,
    /// `random` starts and goals, or `fixed` (the map's `.scen`).
    #[arg(long, default_value = "random", conflicts_with = "plant")]
    pub starts: Starts,
    /// Truncation step count T_max (default: the rule set's, 100 for
    /// thesis, 128 for pogema).
    #[arg(long, alias = "max-steps")]
    pub t_max: Option<u32>,
    /// Execution delays: the probability in [0, 1) that a robot fails to
    /// carry out its move in a step and stays put, each robot and step
    /// independently, seeded by --seed (0: none). Controllers see the
    /// positions that resulted, not the moves they commanded.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "P",
        conflicts_with = "plant"
    )]
    pub delay: f32,
    /// Per-instance planning time limit in seconds (planners).
    #[arg(long, default_value_t = 60.0, conflicts_with = "plant")]
    pub time_limit: f64,
    /// Per-instance memory cap of a planner's search, in MiB.
    #[arg(long, default_value_t = 2048, conflicts_with = "plant")]
    pub memory_limit: usize,
    /// Episodes run in parallel (1 keeps compute times comparable).
    #[arg(long, default_value_t = 1, conflicts_with = "plant")]
    pub jobs: usize,
    /// Where trained policies infer: `cpu` (the default) or `cuda[:N]`, a
    /// GPU, in a binary built by `scripts/build-cuda.sh`; planners, shields
    /// and the env run on the CPU either way.
    #[arg(
        long,
        value_name = "cpu|cuda[:N]",
        default_value = "cpu",
        conflicts_with = "plant"
    )]
    pub device: buridan_policy::DeviceSpec,
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

pub use buridan_experiment::agents::parse_agent_counts;

pub use buridan_eval::by_name::{
    Controller, ControllerFactory, CROWD_RESCUE_PLANNER, DEFAULT_RESCUE_PLANNER,
    RESCUE_OD_ASTAR_MAX_AGENTS,
};

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

/// Runs `learner eval --plant`: `--episodes` seeded plant episodes of
/// `--controller` ([`buridan_eval::plant`]), the files in `--out`.
pub fn run_plant(args: &EvalArgs, plant: &str) -> Result<PlantEvalSummary> {
    let agents = match &args.agents {
        None => 4,
        Some(text) => match parse_agent_counts(text)?.as_slice() {
            [n] => *n,
            _ => bail!("--plant evaluates one agent count at a time, not '{text}'"),
        },
    };
    let plant = Arc::new(load_plant(plant, args.t_max)?);
    let act_mode = if args.sample {
        ActMode::Sample
    } else {
        ActMode::Greedy
    };
    let mut controller =
        PlantController::by_name(&args.controller, &plant, agents, args.seed, act_mode)
            .with_context(|| format!("controller '{}'", args.controller))?;
    let spec = PlantEvalSpec {
        agents,
        episodes: args.episodes,
        seed: args.seed,
    };
    let bar = ProgressBar::new(args.episodes as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed}, eta {eta})",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar.set_prefix(format!(
        "{} plant:{} agents={agents}",
        args.controller, plant.id
    ));
    crate::heartbeat::watch(&bar);
    let on_episode = |r: &PlantEpisodeRecord| {
        bar.set_message(format!(
            "deliveries {} collisions {}",
            r.deliveries, r.collisions
        ));
        bar.inc(1);
    };
    let report = evaluate_plant(&plant, &spec, &mut controller, &on_episode)
        .with_context(|| format!("evaluating {agents} AGVs on plant '{}'", plant.id))?;
    bar.finish();
    let files = write_plant_report(&args.out, &report)
        .with_context(|| format!("writing results to {}", args.out.display()))?;
    let s = report.summary;
    tracing::info!(controller = %s.controller, plant = %s.plant, agents, deliveries_mean = s.deliveries_mean,
        collisions_mean = s.collisions_mean, files = ?files, "plant evaluation done");
    if args.json {
        println!("{}", serde_json::to_string_pretty(&s)?);
    } else {
        eprintln!("{} -> {}", plant_summary_line(&s), args.out.display());
    }
    Ok(s)
}

/// Runs `learner eval` (with `--plant`: [`run_plant`], and no grid
/// summaries are returned).
pub fn run(args: &EvalArgs) -> Result<Vec<EvalSummary>> {
    if let Some(plant) = &args.plant {
        run_plant(args, plant)?;
        return Ok(Vec::new());
    }
    let counts: Vec<Option<usize>> = match &args.agents {
        Some(text) => parse_agent_counts(text)?.into_iter().map(Some).collect(),
        // With --scen: every line of each file.
        None if !args.scen.is_empty() => vec![None],
        None => vec![Some(4)],
    };
    let fixed_map = if args.scen.is_empty() {
        let name = args
            .map
            .as_deref()
            .context("--map is required without --scen")?;
        Some(Arc::new(
            Map::load(name).with_context(|| format!("loading map '{name}'"))?,
        ))
    } else {
        if args.replays.is_some() {
            bail!("--replays is not supported with --scen yet: replays redraw seeded episodes");
        }
        None
    };
    let limits = planner_limits(args.time_limit, args.memory_limit)?;
    let device = args
        .device
        .open()
        .with_context(|| format!("--device {}", args.device))?;
    let t_max = args.t_max.unwrap_or(args.rules.default_t_max());
    let sweep = counts.len() > 1;
    let mut controller: Controller = args.controller.parse()?;
    if args.sample {
        controller = controller.with_act(buridan_eval::by_name::Act::Sampled);
    }
    let mut summaries = Vec::new();
    for &count in &counts {
        let set = match &fixed_map {
            Some(_) => None,
            None => Some(
                load_instance_set(&args.scen, args.map.as_deref(), count)
                    .context("loading the --scen instances")?,
            ),
        };
        let map = match (&fixed_map, &set) {
            (Some(map), _) => map.clone(),
            (None, Some(set)) => set.map.clone(),
            (None, None) => unreachable!("either --map or --scen"),
        };
        let agents = match &set {
            Some(set) => set.agents(),
            None => count.expect("a count without --scen"),
        };
        let episodes = set.as_ref().map_or(args.episodes, |s| s.instances.len());
        let make = controller.factory_on(agents, args.seed, limits, args.rules, &device)?;
        let spec = EvalSpec {
            agents,
            episodes,
            seed: args.seed,
            starts: args.starts,
            t_max,
            jobs: args.jobs.max(1),
            rules: args.rules,
            delay: args.delay,
        };
        let progress = EpisodeProgress::new(
            &format!("{} {} agents={agents}", args.controller, map.name),
            episodes,
        );
        let on_episode = |r: &buridan_eval::EpisodeRecord| progress.record(r);
        let report: EvalReport = match &set {
            Some(set) => evaluate_instances(&map, &spec, &set.instances, &*make, &on_episode),
            None => evaluate(&map, &spec, &*make, &on_episode),
        }
        .with_context(|| format!("evaluating {} agents on {}", agents, map.name))?;
        progress.finish();
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
            eprintln!("{} -> {}", summary_line(s), dir.display());
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

/// A progress bar over an evaluation's episodes that shows the success
/// rate so far (and, off a terminal, heartbeat log lines).
pub struct EpisodeProgress {
    bar: ProgressBar,
    solved: AtomicUsize,
    done: AtomicUsize,
}

impl EpisodeProgress {
    /// A bar for `episodes` episodes, labelled `prefix`.
    pub fn new(prefix: &str, episodes: usize) -> Self {
        let bar = ProgressBar::new(episodes as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed}, eta {eta})",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar.set_prefix(prefix.to_string());
        crate::heartbeat::watch(&bar);
        EpisodeProgress {
            bar,
            solved: AtomicUsize::new(0),
            done: AtomicUsize::new(0),
        }
    }

    /// Counts one finished episode (called from evaluation threads).
    pub fn record(&self, r: &buridan_eval::EpisodeRecord) {
        let solved = usize::from(r.success);
        let s = self.solved.fetch_add(solved, Ordering::Relaxed) + solved;
        let d = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        self.bar
            .set_message(format!("success {:.1}%", 100.0 * s as f64 / d as f64));
        self.bar.inc(1);
    }

    /// Leaves the finished bar on screen.
    pub fn finish(&self) {
        self.bar.finish();
    }
}

/// The line `learner eval` prints per evaluation: success, timesteps and
/// compute as before, then the rule set, SoC and makespan (POGEMA's
/// definitions: agents off their goals cost T_max), the median SoC over
/// its single-agent lower bound and the ISR.
pub fn summary_line(s: &EvalSummary) -> String {
    let episodes = if s.instances > 0 {
        format!("{} instances", s.instances)
    } else {
        format!("{} episodes", s.episodes)
    };
    format!(
        "{} on {} with {} agents ({} rules, T_max {}): success {:.1}% ({episodes}), timesteps median {} [q1 {}, q3 {}], compute median {} ms (max {:.1}), SoC mean {:.1}, makespan mean {:.1}, SoC/LB median {}, ISR {:.3}",
        s.controller,
        s.map,
        s.agents,
        s.rules,
        s.t_max,
        100.0 * s.success_rate,
        fmt_opt(s.timesteps_median),
        fmt_opt(s.timesteps_q1),
        fmt_opt(s.timesteps_q3),
        fmt_opt(s.compute_ms_median),
        s.compute_ms_max,
        s.soc_mean,
        s.makespan_mean,
        s.soc_ratio_median.map_or_else(|| "-".into(), |x| format!("{x:.3}")),
        s.isr_mean,
    )
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |x| format!("{x:.1}"))
}
