//! `learner train`: the embedded default — learner and actors in one process.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use buridan_env::{ObsFeatures, Rules, Starts};
use buridan_eval::plot::{line_chart, Series};
use buridan_policy::Mode;

use crate::dashboard::{DashboardProgress, Live};
use crate::signals::{stop_when_stdin_closes, watch_signals};
use indicatif::{ProgressBar, ProgressStyle};

use buridan_learner::train::{
    Algo, InProcess, MetricsRow, Progress, Run, Summary, TrainConfig, TrainError, WeightedMap,
};

/// Arguments of `learner train`.
#[derive(Debug, Clone, clap::Args)]
pub struct TrainArgs {
    /// Reference model id (`rm-2.1`) or path to a MovingAI `.map` file
    /// (replaces a config's `maps` or `plant`).
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
    /// A TOML run configuration (`TrainConfig`; examples in `learner/configs/`); flags override it. Without one: the default recipe (PPO-CTDE with the 64-cell LSTM, warm-started by imitating LaCAM and OD-A*, the path feature and shaping, 1M steps; README, "The default recipe")
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
    /// Skip the imitation phase the recipe or the config asks for: learn
    /// from rewards alone from the first step.
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

/// Sets the dotted `key` of a TOML table to `value` (parsed as TOML, else a string).
///
/// ```
/// let mut t: toml::Table = toml::from_str("[ppo]\nlr = 0.001").unwrap();
/// buridan_cli::train::set_key(&mut t, "ppo.lr=5e-4").unwrap();
/// assert_eq!(t["ppo"]["lr"].as_float(), Some(5e-4));
/// assert!(buridan_cli::train::set_key(&mut t, "no_equals_sign").is_err());
/// ```
pub fn set_key(table: &mut toml::Table, assignment: &str) -> Result<()> {
    let (key, raw) = assignment
        .split_once('=')
        .with_context(|| format!("--set '{assignment}': expected KEY=VALUE"))?;
    let value: toml::Value = toml::from_str::<toml::Table>(&format!("v = {raw}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(raw.to_string()));
    let mut parts: Vec<&str> = key.trim().split('.').collect();
    let last = parts
        .pop()
        .filter(|k| !k.is_empty())
        .with_context(|| format!("--set '{assignment}': empty key"))?;
    let mut node = table;
    for part in parts {
        node = node
            .entry(part)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            .as_table_mut()
            .with_context(|| format!("--set '{assignment}': '{part}' is not a section"))?;
    }
    node.insert(last.to_string(), value);
    Ok(())
}

/// The configuration of a run: defaults, then `--config`, then flags, then `--set`.
pub fn resolve_config(args: &TrainArgs) -> Result<TrainConfig> {
    let mut cfg = match &args.config {
        Some(path) => TrainConfig::from_toml_file(path)?,
        None => TrainConfig::recipe(),
    };
    // Whether T_max was chosen (else a plant run takes its plant file's).
    let mut t_max_given = match &args.config {
        Some(path) => std::fs::read_to_string(path)
            .ok()
            .and_then(|text| toml::from_str::<toml::Table>(&text).ok())
            .is_some_and(|t| t.contains_key("t_max")),
        None => false,
    };
    if let Some(v) = &args.map {
        cfg.map = v.clone();
        cfg.maps = None;
        cfg.plant = None;
    }
    if let Some(v) = &args.maps {
        cfg.maps = Some(WeightedMap::parse_list(v)?);
        cfg.plant = None;
    }
    if let Some(v) = &args.plant {
        cfg.plant = Some(v.clone());
        cfg.maps = None;
    }
    if let Some(v) = args.agents {
        cfg.agents = v;
    }
    if let Some(v) = args.algo {
        cfg.algo = v;
    }
    if let Some(v) = args.mode {
        cfg.mode = v;
    }
    if let Some(v) = args.starts {
        cfg.starts = v;
    }
    if let Some(v) = args.rules {
        cfg.rules = v;
        cfg.t_max = v.default_t_max();
    }
    if args.config.is_none() && cfg.mode == Mode::Cte {
        // The recipe's features extend local observations; CTE's central
        // observation already shows the whole layout.
        cfg.features = ObsFeatures::default();
    }
    if let Some(v) = args.steps {
        cfg.steps = v;
    }
    if let Some(v) = args.seed {
        cfg.seed = v;
    }
    if let Some(v) = &args.resume {
        cfg.resume = if v.as_os_str() == "auto" {
            buridan_policy::checkpoint::resolve(&args.out).ok()
        } else {
            Some(buridan_policy::checkpoint::resolve(v)?)
        };
    }
    let mut set_keys = Vec::new();
    if !args.overrides.is_empty() {
        let mut table: toml::Table =
            toml::from_str(&cfg.to_toml()).context("configuration round trip")?;
        for o in &args.overrides {
            set_key(&mut table, o)?;
            let key = o.split_once('=').map(|(k, _)| k.trim());
            // Like the flags: naming one map replaces the list or the plant.
            if key == Some("map") {
                table.remove("maps");
                table.remove("plant");
            }
            t_max_given |= key == Some("t_max");
            set_keys.extend(key.map(str::to_string));
        }
        cfg = table.try_into().context("invalid --set override")?;
    }
    if args.no_imitation {
        cfg.imitation = None;
    }
    if args.no_stop {
        cfg.stop = None;
    }
    if cfg.plant.is_some() && args.config.is_none() {
        // The recipe's features and shaping are grid ones (a plant run
        // refuses them): left out unless set explicitly.
        if !set_keys.iter().any(|k| k.starts_with("features")) {
            cfg.features = ObsFeatures::default();
        }
        if !set_keys.iter().any(|k| k == "shaping") {
            cfg.shaping = 0.0;
        }
        // Its imitation asks grid planners for labels.
        if !set_keys.iter().any(|k| k.starts_with("imitation")) {
            cfg.imitation = None;
        }
        // Plant episodes only truncate: no success for `[stop]` to hold.
        if !set_keys.iter().any(|k| k.starts_with("stop")) {
            cfg.stop = None;
        }
    }
    if !t_max_given {
        cfg.use_plant_t_max()
            .with_context(|| format!("loading plant '{}'", cfg.plant.as_deref().unwrap_or("")))?;
    }
    cfg.validate()?;
    Ok(cfg)
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
            cfg.algo,
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

    fn on_finish(&mut self, _summary: &Summary) {
        self.bar.finish();
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
    let mut terminal = TerminalProgress::new(cfg.steps, args.quiet);
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

/// Trains as the learner's `train` does (actor threads in this process),
/// stopping with a checkpoint (`TrainError::Interrupted`) once `interrupt`
/// is set.
pub fn train_interruptible(
    cfg: &TrainConfig,
    out: &Path,
    progress: &mut dyn Progress,
    interrupt: Arc<AtomicBool>,
) -> Result<Summary, Box<TrainError>> {
    let mut run = Run::prepare(cfg, out)?;
    let mut collectors = Vec::with_capacity(cfg.num_actors);
    for i in 0..cfg.num_actors as u32 {
        collectors.push(run.collector(i)?);
    }
    let mut exchange = InProcess::spawn(
        collectors,
        cfg.queue_capacity(),
        cfg.staleness(),
        cfg.actor_nice,
    )
    .map_err(|e| Box::new(e.into()))?;
    run.interrupt_on(interrupt);
    Ok(run.learn(&mut exchange, progress)?)
}

/// Refuses to overwrite a finished run.
pub fn check_out(args: &TrainArgs, cfg: &TrainConfig) -> Result<()> {
    if args.out.join(buridan_learner::train::SUMMARY_FILE).exists() && cfg.resume.is_none() {
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
        cfg.algo,
        format!("{:?}", cfg.mode).to_lowercase(),
        cfg.map_label(),
        cfg.agents,
    );
    // One run: one seed, named in the figures' titles.
    write_curves(&args.out, &format!("{title}, seed {}", cfg.seed))
        .context("drawing the learning curves")?;
    // A run shorter than one episode (imitation only, `--steps` below
    // T_max) has no episode statistics: say so rather than print NaN.
    let episodes = if !summary.episode_len_mean.is_finite() {
        "no episode finished".to_string()
    } else if cfg.plant.is_some() {
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
