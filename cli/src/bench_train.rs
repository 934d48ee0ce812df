//! `learner bench train`: end-to-end training throughput of configuration
//! variants, measured side by side in one invocation. Each variant is the
//! same run (config, flags, seed, step budget) with its own `--set`
//! overrides; the runs alternate (variant A, B, …, then the next repeat) so
//! that a machine's drift touches every variant alike, and the table gives
//! each variant's env steps/s and its ratio to the first variant — machines
//! are noisy, ratios measured in one run are what compare.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use buridan_learner::train::target::Mark;
use buridan_learner::train::Summary;
use serde::Serialize;

use crate::train::{resolve_config, train_interruptible, TerminalProgress, TrainArgs};

/// Arguments of `learner bench train`.
#[derive(Debug, clap::Args)]
pub struct TrainBenchArgs {
    /// The run every variant starts from (config, flags, `--set`, seed,
    /// `--steps`); `--out` is the benchmark's directory.
    #[command(flatten)]
    pub train: TrainArgs,
    /// A variant as `NAME:KEY=VALUE;KEY=VALUE…` (`NAME` alone: the run as
    /// given), e.g. `one-thread:ppo.update_threads=1`. Repeatable; the
    /// first is the reference of the ratios.
    #[arg(long = "variant", value_name = "NAME[:KEY=VALUE;...]", required = true)]
    pub variants: Vec<String>,
    /// Runs per variant.
    #[arg(long, default_value_t = 2)]
    pub repeats: usize,
}

/// One variant: its name and overrides.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Variant {
    /// Its name (a directory name).
    pub name: String,
    /// `KEY=VALUE` overrides on top of the run's.
    pub overrides: Vec<String>,
}

impl Variant {
    /// Parses `NAME[:KEY=VALUE;KEY=VALUE…]`.
    ///
    /// ```
    /// use buridan_cli::bench_train::Variant;
    /// let v = Variant::parse("lstm:lstm=true;ppo.update_threads=1").unwrap();
    /// assert_eq!(v.name, "lstm");
    /// assert_eq!(v.overrides, ["lstm=true", "ppo.update_threads=1"]);
    /// assert!(Variant::parse("base").unwrap().overrides.is_empty());
    /// assert!(Variant::parse("a/b:x=1").is_err());
    /// assert!(Variant::parse("x:no-equals").is_err());
    /// ```
    pub fn parse(text: &str) -> Result<Self> {
        let (name, sets) = text.split_once(':').unwrap_or((text, ""));
        let name = name.trim();
        let ok = |c: char| c.is_ascii_alphanumeric() || "-_.".contains(c);
        if name.is_empty() || !name.chars().all(ok) {
            bail!("variant '{text}': the name must be letters, digits, '-', '_' or '.'");
        }
        let overrides: Vec<String> = sets
            .split(';')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        if let Some(bad) = overrides.iter().find(|o| !o.contains('=')) {
            bail!("variant '{text}': '{bad}' is not KEY=VALUE");
        }
        Ok(Self {
            name: name.to_string(),
            overrides,
        })
    }
}

/// One measured run of a variant.
#[derive(Debug, Clone, Serialize)]
pub struct Measured {
    /// The variant's name.
    pub variant: String,
    /// Repeat index.
    pub repeat: usize,
    /// Env steps sampled.
    pub env_steps: u64,
    /// Wall seconds.
    pub wall_seconds: f64,
    /// Env steps per second, end to end.
    pub steps_per_s: f64,
    /// Training success of the last 100 episodes at the end.
    pub success: f64,
    /// Wall seconds until the training success first reached 90 %.
    pub first_90_s: Option<f64>,
    /// Wall seconds until it first reached 96 %.
    pub first_96_s: Option<f64>,
    /// Wall seconds from which on it stayed at or above 96 %.
    pub held_96_s: Option<f64>,
}

impl Measured {
    fn new(variant: &str, repeat: usize, s: &Summary) -> Self {
        let at = |level: f64, held: bool| {
            let t = s
                .time_to_target
                .iter()
                .find(|t| (t.success - level).abs() < 1e-9)?;
            let mark: Option<Mark> = if held { t.held } else { t.first };
            mark.map(|m| m.wall_seconds)
        };
        Self {
            variant: variant.to_string(),
            repeat,
            env_steps: s.env_steps,
            wall_seconds: s.wall_seconds,
            steps_per_s: s.steps_per_s,
            success: s.success_rate,
            first_90_s: at(0.90, false),
            first_96_s: at(0.96, false),
            held_96_s: at(0.96, true),
        }
    }
}

/// Runs `learner bench train`; returns every run's measurement.
pub fn run(args: &TrainBenchArgs) -> Result<Vec<Measured>> {
    let variants = args
        .variants
        .iter()
        .map(|v| Variant::parse(v))
        .collect::<Result<Vec<_>>>()?;
    for (i, v) in variants.iter().enumerate() {
        if variants[..i].iter().any(|w| w.name == v.name) {
            bail!("variant '{}' is named twice", v.name);
        }
    }
    if args.repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    let t = &args.train;
    if t.resume.is_some() || t.metrics.is_some() || t.stop_when_stdin_closes {
        bail!("--resume, --metrics and --stop-when-stdin-closes do not apply to a benchmark");
    }
    if t.dashboard.dashboard.is_some() {
        bail!("--dashboard does not apply to a benchmark");
    }
    let out = &args.train.out;
    if out.join("runs.csv").exists() {
        bail!(
            "{} already holds a benchmark (runs.csv); choose another --out",
            out.display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut measured = Vec::new();
    for repeat in 0..args.repeats {
        for v in &variants {
            let dir = out.join(&v.name).join(format!("repeat-{repeat}"));
            let cfg = variant_config(&args.train, v, &dir)?;
            tracing::info!(variant = %v.name, repeat, out = %dir.display(), "bench run starts");
            let mut progress = TerminalProgress::new(cfg.run.steps, args.train.quiet);
            let summary =
                train_interruptible(&cfg, &dir, &mut progress, Arc::new(AtomicBool::new(false)))
                    .map_err(|e| anyhow::anyhow!(e))
                    .with_context(|| format!("variant {} repeat {repeat}", v.name))?;
            let m = Measured::new(&v.name, repeat, &summary);
            eprintln!(
                "{} repeat {repeat}: {:.0} env steps/s ({} steps in {:.1} s), success {:.1} %",
                v.name,
                m.steps_per_s,
                m.env_steps,
                m.wall_seconds,
                100.0 * m.success
            );
            measured.push(m);
        }
    }
    write_tables(out, &variants, &measured)?;
    eprint!("{}", std::fs::read_to_string(out.join("table.md"))?);
    Ok(measured)
}

/// The run's configuration with the variant's overrides, into `dir`.
fn variant_config(
    base: &TrainArgs,
    v: &Variant,
    dir: &Path,
) -> Result<buridan_learner::train::TrainConfig> {
    // Through the same resolution as `learner train`, so a variant is
    // exactly `learner train ... --set ...` (and validated the same way).
    let mut args = base.clone();
    args.overrides.extend(v.overrides.iter().cloned());
    args.out = dir.to_path_buf();
    resolve_config(&args).with_context(|| format!("variant {}", v.name))
}

/// Per-variant means of the measurements, with ratios to the first.
#[derive(Debug, Clone, Serialize)]
pub struct VariantRow {
    /// The variant.
    pub variant: String,
    /// Its overrides.
    pub overrides: String,
    /// Runs measured.
    pub runs: usize,
    /// Mean env steps/s.
    pub steps_per_s: f64,
    /// Slowest run's env steps/s.
    pub steps_per_s_min: f64,
    /// Fastest run's env steps/s.
    pub steps_per_s_max: f64,
    /// Mean env steps/s over the first variant's.
    pub ratio: f64,
    /// Mean final training success.
    pub success: f64,
    /// Mean wall seconds until 96 % was first reached (runs that reached it).
    pub first_96_s: Option<f64>,
    /// Mean wall seconds from which on 96 % held (runs where it held).
    pub held_96_s: Option<f64>,
}

/// The per-variant rows of `measured`.
pub fn variant_rows(variants: &[Variant], measured: &[Measured]) -> Vec<VariantRow> {
    let mean = |xs: &[f64]| (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64);
    let mut rows: Vec<VariantRow> = variants
        .iter()
        .map(|v| {
            let runs: Vec<&Measured> = measured.iter().filter(|m| m.variant == v.name).collect();
            let speed: Vec<f64> = runs.iter().map(|m| m.steps_per_s).collect();
            let of = |f: fn(&Measured) -> Option<f64>| {
                mean(&runs.iter().filter_map(|m| f(m)).collect::<Vec<_>>())
            };
            VariantRow {
                variant: v.name.clone(),
                overrides: v.overrides.join(";"),
                runs: runs.len(),
                steps_per_s: mean(&speed).unwrap_or(f64::NAN),
                steps_per_s_min: speed.iter().copied().fold(f64::INFINITY, f64::min),
                steps_per_s_max: speed.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                ratio: f64::NAN,
                success: mean(&runs.iter().map(|m| m.success).collect::<Vec<_>>())
                    .unwrap_or(f64::NAN),
                first_96_s: of(|m| m.first_96_s),
                held_96_s: of(|m| m.held_96_s),
            }
        })
        .collect();
    let reference = rows.first().map_or(f64::NAN, |r| r.steps_per_s);
    for r in &mut rows {
        r.ratio = r.steps_per_s / reference;
    }
    rows
}

/// Writes `runs.csv` (every run), `table.csv`, `table.json` and `table.md`
/// (per variant) into `out`.
fn write_tables(out: &Path, variants: &[Variant], measured: &[Measured]) -> Result<()> {
    let mut w = csv::Writer::from_path(out.join("runs.csv"))?;
    for m in measured {
        w.serialize(m)?;
    }
    w.flush()?;
    let rows = variant_rows(variants, measured);
    let mut w = csv::Writer::from_path(out.join("table.csv"))?;
    for r in &rows {
        w.serialize(r)?;
    }
    w.flush()?;
    std::fs::write(out.join("table.json"), serde_json::to_string_pretty(&rows)?)?;
    let secs = |x: Option<f64>| x.map_or("–".to_string(), |s| format!("{s:.0}"));
    let mut md = String::from(
        "| variant | overrides | runs | env steps/s (min–max) | ratio | training success | 96 % first / held from (s) |\n|---|---|---|---|---|---|---|\n",
    );
    for r in &rows {
        let overrides = match r.overrides.as_str() {
            "" => "(as given)".to_string(),
            o => format!("`{o}`"),
        };
        md.push_str(&format!(
            "| {} | {} | {} | {:.0} ({:.0}–{:.0}) | {:.2} | {:.1} % | {} / {} |\n",
            r.variant,
            overrides,
            r.runs,
            r.steps_per_s,
            r.steps_per_s_min,
            r.steps_per_s_max,
            r.ratio,
            100.0 * r.success,
            secs(r.first_96_s),
            secs(r.held_96_s)
        ));
    }
    std::fs::write(out.join("table.md"), md)?;
    Ok(())
}
