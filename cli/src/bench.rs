//! `learner bench pogema`: the field's benchmark in one command. Our
//! controllers on POGEMA's warehouse instances under POGEMA's rules, one
//! evaluation per controller and agent count (resumable), then the table
//! and charts beside the published results of the same instances. With
//! `--lifelong`: POGEMA's lifelong warehouse, throughput on the goal files
//! of `--goals` ([`buridan_eval::lifelong_bench`]).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use buridan_env::Rules;
use buridan_eval::benchmark::{
    check_published_methods, markdown, pool_seeds, published_rows, read_measured, read_published,
    write_table, LowerBounds, Row, DEFAULT_PUBLISHED,
};
use buridan_eval::by_name::{ControllerParseError, Labelled};
use buridan_eval::instances::{is_pattern, load_instance_set, map_names};
use buridan_eval::lifelong_bench::{self, BenchPlan, ThroughputRow};
use buridan_eval::output::write_report;
use buridan_eval::runner::soc_lower_bound;
use buridan_eval::throughput::LifelongSpec;
use buridan_eval::{evaluate_instances, EvalReport, EvalSpec};

use crate::eval::{parse_agent_counts, planner_limits, summary_line, EpisodeProgress};

/// The benchmarks of `learner bench`.
#[derive(Debug, clap::Subcommand)]
pub enum BenchCommand {
    /// POGEMA's warehouse (32–192 agents × 128 seeds, pogema rules, T_max
    /// 128): our controllers beside the published LaCAM, MAPF-GPT, SCRIMP,
    /// DCC, … on the same instances. With `--lifelong`, POGEMA's lifelong
    /// warehouse: throughput (goals per step) on given goal sequences beside
    /// the published Follower and RHCR.
    Pogema(PogemaArgs),
    /// Training throughput of configuration variants side by side (e.g.
    /// PPO's update on one thread against every core): env steps/s, their
    /// ratio to the first variant, time to 96 % training success.
    Train(crate::bench_train::TrainBenchArgs),
    /// A soak run: `learner serve` and actor processes on loopback for N
    /// minutes, a misbehaving client mixed in, actors killed and
    /// restarted at random; memory over time, the fragment books, the
    /// training target.
    #[cfg(feature = "soak")]
    Soak(buridan_soak::SoakArgs),
}

/// Arguments of `learner bench pogema`.
#[derive(Debug, clap::Args)]
pub struct PogemaArgs {
    /// The benchmark's folder: `<map>.map`, `<map>-<agents>-<seed>.scen`
    /// and the published results (`../shared/pogema`).
    #[arg(long, required_unless_present = "lifelong")]
    pub instances: Option<PathBuf>,
    /// Lifelong MAPF (POGEMA's `on_target: restart`): a robot that reaches
    /// its goal gets the next of its sequence; the table is throughput,
    /// goals reached per step, per agent count (mean over seeds, 95 %
    /// bootstrap interval). Needs `--goals`.
    #[arg(long, requires = "goals", conflicts_with = "instances")]
    pub lifelong: bool,
    /// With `--lifelong`: the folder of goal files,
    /// `warehouse-lifelong-<seed>.goals` (`lifelong-goals v1`: starts and
    /// goal sequences, the N-agent tasks the first N agents) and the map
    /// they name (`warehouse.map`), as `scripts/pogema/export_lifelong.py`
    /// writes them.
    #[arg(long, requires = "lifelong")]
    pub goals: Option<PathBuf>,
    /// With `--lifelong`: steps per run.
    #[arg(long, default_value_t = 256, requires = "lifelong")]
    pub steps: u32,
    /// With `--lifelong`: the probability that a robot's move fails and
    /// becomes a wait (seeded per instance).
    #[arg(long, default_value_t = 0.0, requires = "lifelong")]
    pub delay: f32,
    /// The map's name in the file names; with `*` (any run of characters)
    /// every `<name>.map` of the folder that matches, each map with its own
    /// instances, pooled into one row per count: POGEMA's mazes are
    /// `--map-name 'validation-mazes-seed-*' --seeds 0`.
    #[arg(long, default_value = "warehouse")]
    pub map_name: String,
    /// Agent counts: a list (`32,64`) or a range (`32..192:32`).
    #[arg(long, default_value = "32,64,96,128,160,192")]
    pub agents: String,
    /// Instance seeds: a list (`0,5`) or an inclusive range (`0..127`).
    #[arg(long, default_value = "0..127")]
    pub seeds: String,
    /// A controller, `[LABEL@]CONTROLLER` (repeatable; run in the order
    /// given): the grammar of `learner eval --controller`
    /// (`buridan_eval::by_name::Controller`), the label naming its rows
    /// (`learned@sampled:shield:checkpoint:DIR`; without one, the text).
    /// Labels `NAME#K` (one per training seed K) are pooled into one row
    /// `NAME`: mean success over seeds with its 95 % bootstrap interval.
    /// Default: lacam, pibt, lacam-star and cbs; with `--lifelong`,
    /// lifelong-pibt (a planner such as lacam plans again whenever a goal
    /// changes or a robot lags).
    #[arg(long = "controller", value_parser = parse_labelled)]
    pub controllers: Vec<Labelled>,
    /// Published per-instance results (default: `<map>-published.csv` in
    /// the instances folder, or `published.csv` for a `*` pattern).
    #[arg(long)]
    pub published: Option<PathBuf>,
    /// Published methods to show beside ours (comma-separated, as named in
    /// the file).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_PUBLISHED.map(String::from))]
    pub published_methods: Vec<String>,
    /// Per-instance planning time limit in seconds (with `--lifelong`: of
    /// each plan).
    #[arg(long, default_value_t = 10.0)]
    pub time_limit: f64,
    /// Per-instance memory cap of a planner's search, in MiB.
    #[arg(long, default_value_t = 2048)]
    pub memory_limit: usize,
    /// Instances run in parallel (1 keeps compute times comparable).
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// Seed of trained policies' sampling (with `--lifelong`, also of the
    /// delays).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory: `<label>/agents-<N>/` per evaluation (kept and
    /// reused when the command runs again), `table.csv`, `table.md`,
    /// `success.png`, `soc_ratio.png`; with `--lifelong`,
    /// `<label>/agents-<N>.csv` per cell (kept and reused),
    /// `instances.csv`, `table.csv`, `table.md`, `throughput.png`.
    #[arg(long)]
    pub out: PathBuf,
}

/// Parses seeds: `0..127` (inclusive), `0..127:2` or `0,5,9`.
///
/// ```
/// use buridan_cli::bench::parse_seeds;
/// assert_eq!(parse_seeds("0..3").unwrap(), vec![0, 1, 2, 3]);
/// assert_eq!(parse_seeds("4,0").unwrap(), vec![4, 0]);
/// assert!(parse_seeds("3..1").is_err());
/// assert!(parse_seeds("a").is_err());
/// ```
pub fn parse_seeds(text: &str) -> Result<Vec<u64>> {
    let num = |s: &str| -> Result<u64> {
        s.trim()
            .parse()
            .with_context(|| format!("'{s}' is not a seed"))
    };
    if let Some((lo, rest)) = text.split_once("..") {
        let (hi, step) = rest.split_once(':').unwrap_or((rest, "1"));
        let (lo, hi, step) = (num(lo)?, num(hi)?, num(step)?);
        if lo > hi || step == 0 {
            bail!("empty seed range {text}");
        }
        return Ok((lo..=hi).step_by(step as usize).collect());
    }
    text.split(',').map(num).collect()
}

/// Parses a `--controller` value ([`Labelled`]).
///
/// ```
/// use buridan_cli::bench::parse_labelled;
/// let l = parse_labelled("shield-lanes=16:checkpoint:runs/a").unwrap();
/// assert_eq!((l.label.as_str(), l.controller.to_string().as_str()), ("shield-lanes-16-checkpoint-runs-a", "shield-lanes=16:checkpoint:runs/a"));
/// let l = parse_labelled("learned=sampled:shield:checkpoint:runs/a").unwrap();
/// assert_eq!((l.label.as_str(), l.controller.to_string().as_str()), ("learned", "sampled:shield:checkpoint:runs/a"));
/// assert!(parse_labelled("=lacam").is_err());
/// ```
pub fn parse_labelled(text: &str) -> Result<Labelled, ControllerParseError> {
    text.parse()
}

/// Runs `learner bench`.
pub fn run(command: &BenchCommand) -> Result<()> {
    match command {
        BenchCommand::Pogema(args) if args.lifelong => run_lifelong(args).map(|_| ()),
        BenchCommand::Pogema(args) => run_pogema(args).map(|_| ()),
        BenchCommand::Train(args) => crate::bench_train::run(args).map(|_| ()),
        #[cfg(feature = "soak")]
        BenchCommand::Soak(args) => run_soak(args),
    }
}

/// Runs `learner bench soak` on this executable's `serve`.
#[cfg(feature = "soak")]
fn run_soak(args: &buridan_soak::SoakArgs) -> Result<()> {
    let host = buridan_soak::Host {
        learner_exe: std::env::current_exe().context("finding the learner executable")?,
        watch: crate::heartbeat::watch,
    };
    buridan_soak::run(args, &host)?;
    Ok(())
}

impl PogemaArgs {
    /// The controllers to run: those asked for, else the defaults (lacam,
    /// pibt, lacam-star and cbs; with `--lifelong`, lifelong-pibt). Two
    /// with one label are refused.
    pub fn chosen_controllers(&self) -> Result<Vec<Labelled>> {
        let defaults: &[&str] = if self.lifelong {
            &["lifelong-pibt"]
        } else {
            &["lacam", "pibt", "lacam-star", "cbs"]
        };
        controllers(self, defaults)
    }
}

/// The controllers asked for, or `defaults` if none; two with one label
/// are refused.
fn controllers(args: &PogemaArgs, defaults: &[&str]) -> Result<Vec<Labelled>> {
    let specs = if args.controllers.is_empty() {
        defaults
            .iter()
            .map(|d| parse_labelled(d))
            .collect::<Result<Vec<_>, _>>()?
    } else {
        args.controllers.clone()
    };
    for (k, spec) in specs.iter().enumerate() {
        if specs[..k].iter().any(|s| s.label == spec.label) {
            bail!(
                "two controllers are labelled '{}': name them apart with LABEL@CONTROLLER",
                spec.label
            );
        }
    }
    Ok(specs)
}

/// Runs `learner bench pogema --lifelong`; returns the table's rows
/// (measured, then published).
pub fn run_lifelong(args: &PogemaArgs) -> Result<Vec<ThroughputRow>> {
    let Some(goals) = &args.goals else {
        bail!("--lifelong needs --goals DIR");
    };
    if !(0.0..1.0).contains(&args.delay) {
        bail!("--delay must lie in [0, 1), got {}", args.delay);
    }
    if args.steps == 0 {
        bail!("--steps must be at least 1");
    }
    let plan = BenchPlan {
        goals_dir: goals.clone(),
        controllers: args.chosen_controllers()?,
        counts: parse_agent_counts(&args.agents)?,
        seeds: parse_seeds(&args.seeds)?,
        spec: LifelongSpec {
            steps: args.steps,
            delay: args.delay,
            seed: args.seed,
            episode: 0,
            limits: planner_limits(args.time_limit, args.memory_limit)?,
        },
        jobs: args.jobs.max(1),
        keep: Some(args.out.clone()),
    };
    let total = plan.controllers.len() * plan.counts.len() * plan.seeds.len();
    let bar = indicatif::ProgressBar::new(total as u64);
    let runs = lifelong_bench::run_bench(&plan, &|row| {
        bar.inc(1);
        bar.set_message(format!(
            "{} agents={} seed={}: {:.3} goals/step",
            row.controller, row.agents, row.seed, row.throughput
        ));
    })
    .with_context(|| format!("the lifelong benchmark on {}", goals.display()))?;
    bar.finish_and_clear();
    let rows = lifelong_bench::pool(&runs);
    let title = format!(
        "lifelong warehouse, {} steps, delay {}",
        args.steps, args.delay
    );
    let files = lifelong_bench::write_results(&args.out, &runs, &rows, &title)
        .with_context(|| format!("writing the table to {}", args.out.display()))?;
    tracing::info!(files = ?files, "lifelong benchmark table written");
    println!("{}", lifelong_bench::markdown(&rows));
    Ok(rows)
}

/// Runs `learner bench pogema`; returns the table's rows.
pub fn run_pogema(args: &PogemaArgs) -> Result<Vec<Row>> {
    if args.lifelong {
        bail!("--lifelong: call run_lifelong");
    }
    let Some(instances) = &args.instances else {
        bail!("--instances DIR is required (or --lifelong --goals DIR)");
    };
    let counts = parse_agent_counts(&args.agents)?;
    let seeds = parse_seeds(&args.seeds)?;
    let specs = &args.chosen_controllers()?;
    let maps = map_names(instances, &args.map_name)?;
    let published_path = args.published.clone().unwrap_or_else(|| {
        if is_pattern(&args.map_name) {
            instances.join("published.csv")
        } else {
            instances.join(format!("{}-published.csv", args.map_name))
        }
    });
    // Read before hours of planning, so that a bad file fails at once.
    let published = read_published(&published_path)?;
    check_published_methods(&published, &args.published_methods)?;
    let limits = planner_limits(args.time_limit, args.memory_limit)?;
    let rules = Rules::Pogema;
    let mut sets = Vec::with_capacity(counts.len());
    let mut bounds = LowerBounds::new();
    for &agents in &counts {
        let mut per_map = Vec::with_capacity(maps.len());
        for map in &maps {
            let files: Vec<PathBuf> = seeds
                .iter()
                .map(|seed| instances.join(format!("{map}-{agents}-{seed}.scen")))
                .collect();
            let set = load_instance_set(&files, None, Some(agents))
                .with_context(|| format!("loading the {agents}-agent instances of {map}"))?;
            for (instance, &seed) in set.instances.iter().zip(&seeds) {
                let bound = soc_lower_bound(&set.map.grid, &instance.starts, &instance.goals);
                bounds.insert((agents, map.clone(), seed), bound);
            }
            per_map.push(set);
        }
        sets.push((agents, per_map));
    }
    let mut rows = Vec::new();
    for spec in specs {
        for (agents, per_map) in &sets {
            let episodes: usize = per_map.iter().map(|set| set.instances.len()).sum();
            let dir = args.out.join(&spec.label).join(format!("agents-{agents}"));
            let summary_path = dir.join("summary.json");
            if summary_path.is_file() {
                let kept = read_measured(&summary_path)?;
                if kept.episodes != episodes {
                    bail!(
                        "{} holds {} instances, not the {} asked for: move it away to run it again",
                        summary_path.display(),
                        kept.episodes,
                        episodes
                    );
                }
                tracing::info!(label = %spec.label, agents, "kept from an earlier run");
                rows.push(Row::measured(&spec.label, &kept));
                continue;
            }
            let make = spec.controller.factory(*agents, args.seed, limits, rules)?;
            let eval_spec = EvalSpec {
                agents: *agents,
                episodes,
                seed: args.seed,
                t_max: rules.default_t_max(),
                jobs: args.jobs.max(1),
                rules,
                ..EvalSpec::default()
            };
            let progress = EpisodeProgress::new(
                &format!("{} {} agents={agents}", spec.label, args.map_name),
                episodes,
            );
            let mut reports = Vec::with_capacity(per_map.len());
            for set in per_map {
                let report =
                    evaluate_instances(&set.map, &eval_spec, &set.instances, &*make, &|r| {
                        progress.record(r)
                    })
                    .with_context(|| {
                        format!(
                            "evaluating {} on {} with {agents} agents",
                            spec.label, set.map.name
                        )
                    })?;
                reports.push(report);
            }
            progress.finish();
            let report = match reports.len() {
                1 => reports.pop().expect("one report"),
                _ => EvalReport::merge(&args.map_name, &eval_spec, reports),
            };
            write_report(&dir, &report, &per_map[0].map.grid)
                .with_context(|| format!("writing results to {}", dir.display()))?;
            eprintln!("{} -> {}", summary_line(&report.summary), dir.display());
            // Read back, not taken from memory: serde_json's float parsing
            // is not bit-exact, and a rerun that keeps this cell must give
            // the same row as this run.
            rows.push(Row::measured(&spec.label, &read_measured(&summary_path)?));
        }
    }
    let mut rows = pool_seeds(&rows);
    rows.extend(published_rows(
        &published,
        &args.published_methods,
        &bounds,
    )?);
    let files = write_table(&args.out, &args.map_name, &rows)
        .with_context(|| format!("writing the table to {}", args.out.display()))?;
    tracing::info!(files = ?files, "benchmark table written");
    println!("{}", markdown(&rows));
    Ok(rows)
}

#[cfg(all(test, feature = "soak"))]
mod tests {
    #[test]
    fn the_soaks_progress_lines_are_shown_as_progress() {
        assert_eq!(buridan_soak::TARGET, crate::heartbeat::TARGET);
    }
}
