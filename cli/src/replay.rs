//! `learner replay`: one episode of an evaluation drawn as an animated GIF
//! (or written as its step-by-step trace in JSON), and the failed episodes'
//! replays of `learner eval --replays`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use buridan_env::{Map, Rules, Starts};
use buridan_eval::replay::{record_episode, Trace, Warmup};
use buridan_eval::{EvalReport, EvalSpec};
use buridan_policy::ActMode;
use buridan_render::{write_gif, GifOptions};

use crate::eval::{planner_limits, ControllerFactory};

/// Arguments of `learner replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// Reference model id (`rm-2.1`) or path to a MovingAI `.map` file.
    #[arg(long)]
    pub map: String,
    /// Agents.
    #[arg(long, default_value_t = 4)]
    pub agents: usize,
    /// Seed of the episode generator (as `learner eval --seed`).
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// The episode: `learner eval --seed S` plays it as its K-th (from 0).
    #[arg(long)]
    pub episode: u64,
    /// Episodes of the evaluation the episode belongs to (`learner eval --episodes`).
    #[arg(long, default_value_t = 100)]
    pub episodes: usize,
    /// Any controller `learner eval --controller` accepts.
    #[arg(long)]
    pub controller: String,
    /// `random` starts and goals, or `fixed` (the map's `.scen`).
    #[arg(long, default_value = "random")]
    pub starts: Starts,
    /// The rule set the env moves agents by (`thesis` or `pogema`, as
    /// `learner eval --rules`); planners plan for it.
    #[arg(long, default_value = "thesis")]
    pub rules: Rules,
    /// Truncation step count T_max (default: the rule set's, 100 for
    /// thesis, 128 for pogema).
    #[arg(long)]
    pub t_max: Option<u32>,
    /// Execution delays: the probability in [0, 1) that a robot fails to
    /// carry out its move in a step and stays put (`learner eval --delay`;
    /// here `--delay` is the GIF's frame time; 0: none).
    #[arg(long, default_value_t = 0.0, value_name = "P")]
    pub exec_delay: f32,
    /// Per-instance planning time limit in seconds (planners).
    #[arg(long, default_value_t = 60.0)]
    pub time_limit: f64,
    /// Per-instance memory cap of a planner's search, in MiB.
    #[arg(long, default_value_t = 2048)]
    pub memory_limit: usize,
    /// Trained policies: sample actions (the episodes before K are played
    /// first, as the evaluation plays them).
    #[arg(long)]
    pub sample: bool,
    /// Side of a cell in pixels (0: chosen from the layout's size).
    #[arg(long, default_value_t = 0)]
    pub cell_px: u32,
    /// Time per step in hundredths of a second.
    #[arg(long, default_value_t = 15)]
    pub delay: u16,
    /// The file to write: `*.gif` draws the episode, `*.json` writes its
    /// trace (every agent's cell and stall mark per step, the goals, the
    /// harness's record).
    #[arg(long)]
    pub out: PathBuf,
}

/// What `learner replay --out` writes, from the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ReplayFormat {
    Gif,
    Json,
}

impl ReplayFormat {
    fn of(path: &Path) -> Result<Self> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("gif") => Ok(Self::Gif),
            Some("json") => Ok(Self::Json),
            _ => bail!(
                "--out {}: name the replay *.gif (a drawing) or *.json (the step-by-step trace)",
                path.display()
            ),
        }
    }
}

/// Runs `learner replay`: records the episode and writes its GIF or its
/// JSON trace.
pub fn run(args: &ReplayArgs) -> Result<Trace> {
    let format = ReplayFormat::of(&args.out)?;
    if args.agents == 0 {
        bail!("--agents must be at least 1");
    }
    let map =
        Arc::new(Map::load(&args.map).with_context(|| format!("loading map '{}'", args.map))?);
    let act_mode = if args.sample {
        ActMode::Sample
    } else {
        ActMode::Greedy
    };
    let limits = planner_limits(args.time_limit, args.memory_limit)?;
    let make = buridan_eval::by_name::controller_factory(
        &args.controller,
        args.agents,
        args.seed,
        limits,
        act_mode,
        args.rules,
    )?;
    let spec = EvalSpec {
        agents: args.agents,
        episodes: args.episodes,
        seed: args.seed,
        starts: args.starts,
        t_max: args.t_max.unwrap_or(args.rules.default_t_max()),
        jobs: 1,
        rules: args.rules,
        delay: args.exec_delay,
    };
    let opts = GifOptions {
        cell_px: args.cell_px,
        delay_cs: args.delay,
        ..GifOptions::default()
    };
    let warmup = if args.sample {
        Warmup::Preceding
    } else {
        Warmup::Fresh
    };
    let trace = record(&map, &spec, &make, args.episode, warmup)?;
    create_parent(&args.out)?;
    match format {
        ReplayFormat::Gif => draw(&args.out, &trace, &opts)?,
        ReplayFormat::Json => {
            let json = serde_json::to_vec_pretty(&trace).context("encoding the trace")?;
            std::fs::write(&args.out, json)
                .with_context(|| format!("writing {}", args.out.display()))?;
        }
    }
    let r = &trace.record;
    eprintln!(
        "{} on {} with {} agents, seed {}, episode {}: {} after {} steps ({} deadlocked agents, {} stuck at the end) -> {}",
        trace.controller,
        trace.map,
        args.agents,
        args.seed,
        args.episode,
        if r.success { "solved" } else { "failed" },
        r.timesteps,
        r.deadlocked_agents,
        r.stuck_at_end,
        args.out.display()
    );
    Ok(trace)
}

/// Records episode `episode` of `spec` and writes its GIF to `path`.
pub fn write_replay(
    map: &Arc<Map>,
    spec: &EvalSpec,
    make: &ControllerFactory,
    episode: u64,
    warmup: Warmup,
    path: &Path,
    opts: &GifOptions,
) -> Result<Trace> {
    let trace = record(map, spec, make, episode, warmup)?;
    create_parent(path)?;
    draw(path, &trace, opts)?;
    Ok(trace)
}

/// Records episode `episode` of `spec`.
fn record(
    map: &Arc<Map>,
    spec: &EvalSpec,
    make: &ControllerFactory,
    episode: u64,
    warmup: Warmup,
) -> Result<Trace> {
    record_episode(map, spec, &**make, episode, warmup)
        .with_context(|| format!("recording episode {episode} on {}", map.name))
}

/// Draws `trace` as a GIF at `path`.
fn draw(path: &Path, trace: &Trace, opts: &GifOptions) -> Result<()> {
    write_gif(path, trace, opts).with_context(|| format!("drawing {}", path.display()))
}

/// Creates the folder `path` goes into.
fn create_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(())
}

/// Writes the replays of `report`'s failed episodes (those the controller
/// played to `T_max`; at most `max`) into `dir` as `episode-K.gif`;
/// returns the files.
pub fn write_failed(
    map: &Arc<Map>,
    spec: &EvalSpec,
    make: &ControllerFactory,
    report: &EvalReport,
    warmup: Warmup,
    dir: &Path,
    max: usize,
) -> Result<Vec<PathBuf>> {
    let failed = report
        .records
        .iter()
        .filter(|r| !r.success && r.gave_up.is_none());
    let mut files = Vec::new();
    for r in failed.take(max) {
        let path = dir.join(format!("episode-{}.gif", r.episode));
        let trace = write_replay(
            map,
            spec,
            make,
            r.episode,
            warmup,
            &path,
            &GifOptions::default(),
        )?;
        if trace.record.success || trace.record.timesteps != r.timesteps {
            tracing::warn!(
                episode = r.episode,
                "the replay differs from the evaluated episode (a controller that is not deterministic per episode, or --jobs > 1 with --sample)"
            );
        }
        files.push(path);
    }
    Ok(files)
}
