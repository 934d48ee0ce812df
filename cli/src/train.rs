//! `learner train`: the embedded default — learner and actors in one process.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use buridan_env::{Rules, Starts};
use buridan_eval::plot::{line_chart, Series};
use buridan_experiment::resolve::RunArgs;
use buridan_policy::Mode;

use crate::dashboard::{DashboardProgress, Live};
use crate::signals::{stop_when_stdin_closes, watch_signals};
use indicatif::{ProgressBar, ProgressStyle};

use buridan_learner::train::{Algo, MetricsRow, Progress, StopReason, Summary, TrainConfig};

/// Arguments of `learner train`.
#[derive(Debug, Clone, clap::Args)]
pub struct TrainArgs {
    /// Reference model id (`rm-2.1`), path to a MovingAI `.map` file or a
    /// generated map's spec (`maze/19x19/seed=0`; `learner maps` lists the
    /// families); replaces a config's `maps` or `plant`.
    #[arg(long, conflicts_with_all = ["maps", "plant"])]
    pub map: Option<String>,
    /// Train on an AGV plant instead of a grid map: a bundled plant id
    /// (`dissertation`, `hall`) or a plant file (TOML); replaces a
    /// config's `map`/`maps`. T_max is the plant file's unless the config
    /// or `--set t_max=N` gives one. Without --config the recipe's grid
    /// features, shaping and imitation are left out.
    #[arg(long, value_name = "ID|FILE", conflicts_with = "maps")]
    pub plant: Option<String>,
    /// Several layouts with weights, `NAME:WEIGHT,…` (weight 1 if left
    /// out), e.g. `rm-2.2:1,rm-3.1:1`: each env draws every episode's layout.
    /// A generated map's spec may name a seed range, one layout per seed
    /// sharing the weight: `maze/19x19/seed=0..100`.
    #[arg(long, value_name = "NAME[:WEIGHT],...")]
    pub maps: Option<String>,
    /// Agents per env.
    #[arg(long)]
    pub agents: Option<usize>,
    /// `ppo` or `impala`.
    #[arg(long)]
    pub algo: Option<Algo>,
    /// `ctde` (one shared policy), `dte` (one policy per agent) or `cte` (joint policy).
    #[arg(long)]
    pub mode: Option<Mode>,
    /// `random` starts and goals, or `fixed` (the map's `.scen`).
    #[arg(long)]
    pub starts: Option<Starts>,
    /// The rule set: `thesis` (sequential moves) or `pogema` (POGEMA's
    /// simultaneous moves); also sets T_max to the rule set's (100 / 128;
    /// `--set t_max=N` overrides).
    #[arg(long)]
    pub rules: Option<Rules>,
    /// A TOML run configuration (`TrainConfig`; examples in `learner/configs/`); flags override it. Without one: the default recipe (PPO with the 64-cell LSTM, warm-started by imitating LaCAM and OD-A*, the path and intent features and shaping, until the greedy policy solves 99 % of 200 held-out episodes (and of 1,000 more) or its training success has held 99 % for 100k env steps, at most 1M; then polished by its shield; the book's recipe chapter)
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Env-step budget: the most a run trains (the recipe's `[stop]` rule
    /// may end it sooner, once the policy has learned; --no-stop keeps it
    /// to the budget).
    #[arg(long)]
    pub steps: Option<u64>,
    /// Seed of envs, weights and sampling.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Where the learner's gradient steps run: `cpu` (the default) or
    /// `cuda[:N]`, a GPU, in a binary built by `scripts/build-cuda.sh`;
    /// actors and evaluations act on the CPU either way (TOML `device`).
    #[arg(long, value_name = "cpu|cuda[:N]")]
    pub device: Option<buridan_policy::DeviceSpec>,
    /// Continue from a checkpoint directory or a previous `--out` (its
    /// newest checkpoint); `auto`: from `--out`'s newest checkpoint if it
    /// has one, else start fresh (for restarts by a supervisor).
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// Serve Prometheus metrics on this address (e.g. 0.0.0.0:9000).
    #[arg(long, value_name = "ADDR")]
    pub metrics: Option<std::net::SocketAddr>,
    /// Override any configuration key, e.g. `--set ppo.lr=5e-4 --set hidden=[256,256]`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Skip the imitation phases the recipe or the config asks for (the
    /// planners' lesson before learning from rewards, the shield's polish
    /// after it): learn from rewards alone.
    #[arg(long)]
    pub no_imitation: bool,
    /// Ignore the `[stop]` rule of the recipe or the config: train for the
    /// whole step budget even once the policy has learned.
    #[arg(long)]
    pub no_stop: bool,
    /// Output directory: metrics.csv, checkpoints/, summary.json, curves.
    #[arg(long)]
    pub out: PathBuf,
    /// No progress bar (logs only).
    #[arg(long)]
    pub quiet: bool,
    /// Stop with a checkpoint when stdin reaches its end: how a supervising
    /// process (`learner tune --runner process`) stops the run, and how the
    /// run notices that its supervisor died.
    #[arg(long)]
    pub stop_when_stdin_closes: bool,
    /// The live dashboard.
    #[command(flatten)]
    pub dashboard: crate::dashboard::DashboardArgs,
}

/// Sets the dotted `key` of a TOML table to `value` (parsed as TOML, else a
/// string): [`buridan_experiment::resolve::set_key`].
///
/// ```
/// let mut t: toml::Table = toml::from_str("[ppo]\nlr = 0.001").unwrap();
/// buridan_cli::train::set_key(&mut t, "ppo.lr=5e-4").unwrap();
/// assert_eq!(t["ppo"]["lr"].as_float(), Some(5e-4));
/// assert!(buridan_cli::train::set_key(&mut t, "no_equals_sign").is_err());
/// ```
pub fn set_key(table: &mut toml::Table, assignment: &str) -> Result<()> {
    Ok(buridan_experiment::resolve::set_key(table, assignment)?)
}

impl TrainArgs {
    /// The arguments that decide the run's configuration.
    pub fn run_args(&self) -> RunArgs {
        RunArgs {
            map: self.map.clone(),
            plant: self.plant.clone(),
            maps: self.maps.clone(),
            agents: self.agents,
            algo: self.algo,
            mode: self.mode,
            starts: self.starts,
            rules: self.rules,
            config: self.config.clone(),
            steps: self.steps,
            seed: self.seed,
            device: self.device,
            resume: self.resume.clone(),
            overrides: self.overrides.clone(),
            no_imitation: self.no_imitation,
            no_stop: self.no_stop,
            out: self.out.clone(),
        }
    }
}

/// The configuration of a run: defaults, then `--config`, then flags, then
/// `--set` ([`buridan_experiment::resolve::resolve`]).
pub fn resolve_config(args: &TrainArgs) -> Result<TrainConfig> {
    Ok(buridan_experiment::resolve::resolve(&args.run_args())?)
}

/// Live terminal progress: a bar with steps/s, return, success, length.
pub struct TerminalProgress {
    bar: ProgressBar,
}

impl TerminalProgress {
    /// A bar for a run of `steps` env steps (hidden if `quiet`).
    pub fn new(steps: u64, quiet: bool) -> Self {
        let bar = if quiet {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(steps)
        };
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix} [{bar:25}] {human_pos}/{human_len} {msg} ({elapsed})",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        crate::heartbeat::watch(&bar);
        Self { bar }
    }
}

/// Installs the Prometheus exporter on `addr` (a `/metrics` endpoint).
pub fn install_metrics(addr: std::net::SocketAddr) -> Result<()> {
    metrics_exporter_prometheus::PrometheusBuilder::new()
        .with_http_listener(addr)
        .set_buckets_for_metric(
            metrics_exporter_prometheus::Matcher::Full("buridan_policy_lag".into()),
            &[0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0],
        )
        .context("invalid histogram buckets")?
        .install()
        .with_context(|| format!("cannot serve metrics on {addr}"))?;
    tracing::info!(%addr, "Prometheus metrics at http://{addr}/metrics");
    Ok(())
}

impl Progress for TerminalProgress {
    fn on_start(&mut self, cfg: &TrainConfig, total_steps: u64, env_steps: u64) {
        crate::heartbeat::start_at(&self.bar, total_steps, env_steps);
        self.bar.set_prefix(format!(
            "{} {} {} n={}",
            cfg.algorithm.algo(),
            format!("{:?}", cfg.mode).to_lowercase(),
            cfg.map_label(),
            cfg.agents
        ));
    }

    fn on_update(&mut self, row: &MetricsRow) {
        self.bar.set_position(row.env_steps);
        self.bar.set_message(format!(
            "{:>7.0} steps/s  return {:>6.2}  success {:>5.1}%  len {:>5.1}",
            row.steps_per_s,
            row.episode_return_mean,
            100.0 * row.success_rate,
            row.episode_len_mean
        ));
        tracing::info!(
            update = row.update,
            env_steps = row.env_steps,
            steps_per_s = row.steps_per_s,
            episode_return_mean = row.episode_return_mean,
            success_rate = row.success_rate,
            episode_len_mean = row.episode_len_mean,
            "update"
        );
    }

    fn on_checkpoint(&mut self, dir: &Path) {
        tracing::info!(dir = %dir.display(), "checkpoint");
    }

    fn on_stopped(&mut self, reason: StopReason) {
        // The bar stops here: its rate and ETA would decay through the
        // final replays and the polish, which log their own lines.
        let message = format!("{}  stopped: {reason}", self.bar.message());
        self.bar.abandon_with_message(message);
        tracing::info!(
            %reason,
            "updates stopped; choosing the kept weights, then the polish if configured"
        );
    }

    fn on_finish(&mut self, _summary: &Summary) {
        if !self.bar.is_finished() {
            self.bar.finish();
        }
    }
}

/// Writes `learning_curve.png` (return and length) and `success_curve.png`
/// from the run's `metrics.csv` (all rows, resumed runs included).
pub fn write_curves(out: &Path, title: &str) -> Result<()> {
    let path = out.join(buridan_learner::train::METRICS_FILE);
    let rows: Vec<MetricsRow> = csv::Reader::from_path(&path)
        .with_context(|| format!("reading {}", path.display()))?
        .deserialize()
        .collect::<Result<_, _>>()
        .with_context(|| format!("parsing {}", path.display()))?;
    let pts = |f: fn(&MetricsRow) -> f64| {
        rows.iter()
            .filter(|r| r.episodes > 0)
            .map(|r| (r.env_steps as f64, f(r)))
            .collect()
    };
    line_chart(
        &out.join("learning_curve.png"),
        &format!("{title}: episode return and length (last 100 episodes)"),
        "env steps",
        "mean over the last 100 episodes",
        &[
            Series {
                label: "episode return".into(),
                points: pts(|r| r.episode_return_mean),
            },
            Series {
                label: "episode length / 10".into(),
                points: pts(|r| r.episode_len_mean / 10.0),
            },
        ],
    )?;
    line_chart(
        &out.join("success_curve.png"),
        &format!("{title}: success rate (last 100 episodes)"),
        "env steps",
        "success rate (%)",
        &[Series {
            label: "success".into(),
            points: pts(|r| 100.0 * r.success_rate),
        }],
    )?;
    Ok(())
}

/// Runs `learner train`.
pub fn run(args: &TrainArgs) -> Result<Summary> {
    let cfg = resolve_config(args)?;
    check_out(args, &cfg)?;
    if let Some(addr) = args.metrics {
        install_metrics(addr)?;
    }
    let live = Live::start(&args.dashboard)?;
    let mut terminal = TerminalProgress::new(cfg.run.steps, args.quiet);
    let interrupt = Arc::new(AtomicBool::new(false));
    watch_signals(interrupt.clone());
    if args.stop_when_stdin_closes {
        stop_when_stdin_closes(interrupt.clone());
    }
    let summary = match &live {
        Some(live) => {
            let mut progress =
                DashboardProgress::new(&mut terminal, live, args.dashboard.dashboard_eval);
            train_interruptible(&cfg, &args.out, &mut progress, interrupt.clone())?
        }
        None => train_interruptible(&cfg, &args.out, &mut terminal, interrupt.clone())?,
    };
    report(args, &cfg, &summary)?;
    if let Some(live) = live {
        live.finish(Some(&interrupt));
    }
    Ok(summary)
}

pub use buridan_experiment::trial::train_interruptible;

/// Refuses to overwrite a finished run.
pub fn check_out(args: &TrainArgs, cfg: &TrainConfig) -> Result<()> {
    if args.out.join(buridan_learner::train::SUMMARY_FILE).exists() && cfg.run.resume.is_none() {
        bail!(
            "{} already holds a finished run; choose another --out or pass --resume {}",
            args.out.display(),
            args.out.display()
        );
    }
    Ok(())
}

/// Draws the curves and prints the final line of a run.
pub fn report(args: &TrainArgs, cfg: &TrainConfig, summary: &Summary) -> Result<()> {
    let title = format!(
        "{} {} on {}, {} agents",
        cfg.algorithm.algo(),
        format!("{:?}", cfg.mode).to_lowercase(),
        cfg.map_label(),
        cfg.agents,
    );
    // One run: one seed, named in the figures' titles.
    write_curves(&args.out, &format!("{title}, seed {}", cfg.run.seed))
        .context("drawing the learning curves")?;
    // A run shorter than one episode (imitation only, `--steps` below
    // T_max) has no episode statistics: say so rather than print NaN.
    let episodes = if !summary.episode_len_mean.is_finite() {
        "no episode finished".to_string()
    } else if cfg.task.is_plant() {
        // Plant episodes only end at T_max: there is no success to report.
        format!(
            "last 100 episodes: return {:.2}, length {:.1}",
            summary.episode_return_mean, summary.episode_len_mean,
        )
    } else {
        format!(
            "last 100 episodes: return {:.2}, success {:.1}%, length {:.1}",
            summary.episode_return_mean,
            100.0 * summary.success_rate,
            summary.episode_len_mean,
        )
    };
    eprintln!(
        "{title}: {} env steps in {:.0} s ({:.0} steps/s); {episodes} -> {}",
        summary.env_steps,
        summary.wall_seconds,
        summary.steps_per_s,
        args.out.display()
    );
    eprintln!("  stopped: {}", summary.stop_reason);
    for (map, success) in &summary.success_by_map {
        let episodes = summary.episodes_by_map.get(map).copied().unwrap_or(0);
        if episodes == 0 {
            eprintln!("  {map}: no episode finished");
            continue;
        }
        eprintln!(
            "  {map}: success {:.1}% over its last 100 episodes ({episodes} episodes in all)",
            100.0 * success
        );
    }
    if let Some(g) = &summary.greedy_check {
        eprintln!(
            "  greedy check: {} of {} held-out episodes solved after {} env steps",
            g.solved, g.episodes, g.env_steps
        );
    }
    if let Some(k) = summary.kept_check.filter(|k| k.update != summary.updates) {
        eprintln!(
            "  kept: the weights of update {} ({} of {} held-out episodes solved after {} env steps)",
            k.update, k.solved, k.episodes, k.env_steps
        );
    }
    if let Some(r) = &summary.kept_replay {
        eprintln!(
            "  finalists: the kept weights solved {} of {} final held-out episodes (finalists.csv)",
            r.solved, r.episodes
        );
    }
    if let Some(p) = &summary.polish_replay {
        eprintln!(
            "  polish (polish.csv): the polished weights solved {} of them, {} through shield-lanes=16 (the finalist {}): {}",
            p.solved,
            p.shielded,
            p.kept_shielded,
            if p.polished_kept {
                "kept"
            } else {
                "not more, the finalist kept"
            }
        );
    }
    for t in &summary.time_to_target {
        let mark = |m: Option<buridan_learner::train::target::Mark>| {
            m.map_or("not reached".to_string(), |m| {
                format!("{} env steps, {:.1} s", m.env_steps, m.wall_seconds)
            })
        };
        eprintln!(
            "  training success {:.0}%: first after {}; held from {}",
            100.0 * t.success,
            mark(t.first),
            mark(t.held)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// When the updates stop the bar finishes, its last statistics kept
    /// and the reason added: the final replays and the polish that follow
    /// neither move it nor feed its rate and ETA.
    #[test]
    fn the_bar_finishes_when_the_updates_stop() {
        let mut progress = TerminalProgress::new(1_000, true);
        let row = MetricsRow {
            env_steps: 400,
            success_rate: 0.5,
            ..MetricsRow::default()
        };
        progress.on_update(&row);
        assert!(!progress.bar.is_finished());
        progress.on_stopped(StopReason::Learned);
        assert!(progress.bar.is_finished());
        let message = progress.bar.message();
        assert!(message.contains("success  50.0%"), "{message}");
        assert!(
            message.ends_with("stopped: the training success held its target"),
            "{message}"
        );
        assert_eq!(progress.bar.position(), 400);
    }
}
