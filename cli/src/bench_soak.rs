//! `learner bench soak`: `learner serve` and `actor` processes on loopback
//! for N minutes, with a misbehaving client mixed in
//! ([`buridan_actor::misbehave`]) and actors killed (SIGKILL) and restarted
//! at random. Every few seconds it samples the learner's resident memory
//! (`VmRSS`) and scrapes its Prometheus endpoint; at the end it stops the
//! actors, lets the learner drain its queue, stops the learner with
//! SIGTERM (it checkpoints) and balances the fragment books:
//!
//! - every consumed fragment was whole: steps consumed = fragments
//!   consumed × fragment length × envs, and the learner's env-step counter
//!   is a whole number of fragments;
//! - none was used twice: fragments consumed + dropped as stale at the
//!   learner ≤ fragments taken from the queue ≤ fragments accepted;
//! - lost = accepted − consumed, split into dropped as stale at the
//!   learner and held at the end (queue and partial batch, dropped by the
//!   stop).
//!
//! Outputs in `--out`: `soak.csv` (one row per sample), `soak.json`,
//! `soak.png` (memory and training success over time), `soak.md`, and the
//! processes' logs. Fails (non-zero exit) if the learner died, a book does
//! not balance, the misbehaving client got anything but the refusals it
//! expected, or training success never reached `--target`.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use buridan_actor::misbehave::{MisbehaveOptions, MisbehaveTally, Misbehaver};
use buridan_learner::train::TrainConfig;
use buridan_study::figures::clock;
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::heartbeat::TARGET;

mod processes;
use processes::{ActorCommand, Actors, KillSchedule, Learner};

/// Arguments of `learner bench soak`.
#[derive(Debug, Clone, clap::Args)]
pub struct SoakArgs {
    /// How long to run, in minutes (fractions allowed).
    #[arg(long, default_value_t = 30.0)]
    pub minutes: f64,
    /// The learner's TrainConfig.
    #[arg(long, default_value = "learner/configs/impala-ctde-rm-2.1.toml")]
    pub config: PathBuf,
    /// `KEY=VALUE` overrides of the config (as `learner serve --set`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Actor processes.
    #[arg(long, default_value_t = 2)]
    pub actors: usize,
    /// Mean seconds between random actor kills (exponentially distributed).
    #[arg(long, default_value_t = 60.0)]
    pub kill_every: f64,
    /// Longest wait before a killed actor is restarted, in seconds
    /// (uniform from a tenth of it).
    #[arg(long, default_value_t = 5.0)]
    pub restart_within: f64,
    /// Training success over the last 100 episodes the run must reach.
    #[arg(long, default_value_t = 0.8)]
    pub target: f64,
    /// Seed of the run, the kills and the misbehaving client.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seconds between samples of memory and metrics.
    #[arg(long, default_value_t = 5.0)]
    pub sample_every: f64,
    /// The learner's `--session-idle-timeout` (the misbehaving client
    /// checks its idle sessions expire).
    #[arg(long, default_value_t = 5.0)]
    pub session_idle_timeout: f64,
    /// The learner's `--max-sessions` (default: actors + 8); the
    /// misbehaving client probes it.
    #[arg(long)]
    pub max_sessions: Option<usize>,
    /// The `actor` executable (default: `actor` beside this one).
    #[arg(long)]
    pub actor_exe: Option<PathBuf>,
    /// Leave the misbehaving client out.
    #[arg(long)]
    pub no_misbehave: bool,
    /// Output directory (must not hold an earlier soak).
    #[arg(long)]
    pub out: PathBuf,
}

/// One sample of the learner: memory and metrics.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Sample {
    /// Seconds since the learner was started.
    pub seconds: f64,
    /// The learner's resident memory (KiB).
    pub rss_kib: u64,
    /// Fragments accepted (queued).
    pub accepted: u64,
    /// Fragments refused (stale, surplus, invalid, duplicate).
    pub refused: u64,
    /// … of which invalid (malformed, implausible, unknown session).
    pub invalid: u64,
    /// … of which duplicates.
    pub duplicate: u64,
    /// Fragments consumed by updates.
    pub consumed: u64,
    /// Env steps of the consumed fragments.
    pub consumed_steps: u64,
    /// Accepted fragments the learner dropped as too old when it took them.
    pub stale_at_learner: u64,
    /// Env steps taken from the queue.
    pub env_steps: u64,
    /// Policy version (updates).
    pub policy_version: u64,
    /// Training success over the last 100 episodes (empty before any).
    pub success: Option<f64>,
    /// Episodes finished.
    pub episodes: u64,
    /// Sessions open.
    pub sessions: u64,
    /// Actor processes running.
    pub actors_running: usize,
    /// Actors killed so far.
    pub kills: u64,
}

/// The fragment books at the end.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Books {
    /// Env steps per fragment (length × envs per actor).
    pub steps_per_fragment: u64,
    /// Fragments accepted.
    pub accepted: u64,
    /// Fragments the learner took from its queue.
    pub dequeued: u64,
    /// Fragments consumed by updates.
    pub consumed: u64,
    /// Their env steps.
    pub consumed_steps: u64,
    /// Dropped as stale by the learner.
    pub stale_at_learner: u64,
    /// Still in the queue at the end.
    pub queued_at_end: u64,
    /// Taken, in the learner's unfinished batch at the end.
    pub partial_batch_at_end: u64,
    /// Accepted but not consumed (stale at learner + held at the end).
    pub lost: u64,
    /// Consumed fragments not whole (steps not matching).
    pub consumed_in_part: u64,
    /// Fragments used more than once (by the balance).
    pub used_twice: u64,
}

/// What a soak run found.
#[derive(Debug, Clone, Serialize)]
pub struct SoakSummary {
    /// Seconds run (from the learner's start to the stop).
    pub seconds: f64,
    /// The learner's config file and overrides.
    pub config: String,
    /// Actor processes.
    pub actors: usize,
    /// Resident memory at the first and the last sample, and the most (KiB).
    pub rss_start_kib: u64,
    /// See `rss_start_kib`.
    pub rss_end_kib: u64,
    /// See `rss_start_kib`.
    pub rss_max_kib: u64,
    /// Env steps, updates.
    pub env_steps: u64,
    /// Policy version at the end.
    pub updates: u64,
    /// Training success over the last 100 episodes at the end.
    pub final_success: Option<f64>,
    /// The best sampled.
    pub best_success: Option<f64>,
    /// The target.
    pub target: f64,
    /// Seconds until the target was first reached.
    pub target_reached_s: Option<f64>,
    /// Fragments refused by outcome.
    pub refused: Vec<(String, u64)>,
    /// The books.
    pub books: Books,
    /// Actors killed, restarted, and exited on their own.
    pub kills: u64,
    /// See `kills`.
    pub restarts: u64,
    /// See `kills`.
    pub actor_exits: u64,
    /// The misbehaving client.
    pub misbehave: Option<MisbehaveJson>,
    /// RPC errors by code, undecodable messages, implausible fragments,
    /// refused joins, expired sessions (the learner's counters).
    pub learner_counters: Vec<(String, u64)>,
    /// The checkpoint the learner wrote on SIGTERM.
    pub checkpoint: Option<String>,
    /// Why the soak failed (empty: it passed).
    pub failures: Vec<String>,
}

/// [`MisbehaveTally`] as JSON.
#[derive(Debug, Clone, Serialize)]
pub struct MisbehaveJson {
    /// Rounds.
    pub rounds: u64,
    /// Undecodable sent / refused.
    pub undecodable: (u64, u64),
    /// Implausible sent / refused.
    pub implausible: (u64, u64),
    /// Stale replays sent / refused.
    pub stale: (u64, u64),
    /// Repeated sequence numbers sent / refused.
    pub replays: (u64, u64),
    /// Idle sessions opened / found expired.
    pub idle_sessions: (u64, u64),
    /// Joins refused at the cap.
    pub joins_refused_at_cap: u64,
    /// Taken when they should have been refused.
    pub wrongly_accepted: u64,
    /// Other statuses than expected.
    pub unexpected: u64,
    /// Connection failures.
    pub transport_errors: u64,
    /// The last problem.
    pub last_problem: String,
}

impl From<&MisbehaveTally> for MisbehaveJson {
    fn from(t: &MisbehaveTally) -> Self {
        Self {
            rounds: t.rounds,
            undecodable: (t.undecodable_sent, t.undecodable_refused),
            implausible: (t.implausible_sent, t.implausible_refused),
            stale: (t.stale_sent, t.stale_refused),
            replays: (t.replays_sent, t.replays_refused),
            idle_sessions: (t.idle_sessions, t.idle_sessions_expired),
            joins_refused_at_cap: t.joins_refused_at_cap,
            wrongly_accepted: t.wrongly_accepted,
            unexpected: t.unexpected,
            transport_errors: t.transport_errors,
            last_problem: t.last_problem.clone(),
        }
    }
}

/// A Prometheus text exposition, `name{labels}` → value.
#[derive(Debug, Clone, Default)]
pub struct Scrape(Vec<(String, f64)>);

impl Scrape {
    /// Parses the text format (comments skipped).
    ///
    /// ```
    /// use buridan_cli::bench_soak::Scrape;
    /// let s = Scrape::parse("# TYPE x counter\nx{outcome=\"accepted\"} 3\nx{outcome=\"stale\"} 2\ny 0.5\n");
    /// assert_eq!(s.total("x"), 5.0);
    /// assert_eq!(s.labelled("x", "outcome", "stale"), 2.0);
    /// assert_eq!(s.get("y"), Some(0.5));
    /// assert_eq!(s.get("z"), None);
    /// ```
    pub fn parse(text: &str) -> Scrape {
        Scrape(
            text.lines()
                .map(str::trim)
                .filter(|l| !l.is_empty() && !l.starts_with('#'))
                .filter_map(|l| {
                    let (key, value) = l.rsplit_once(' ')?;
                    Some((key.trim().to_string(), value.trim().parse().ok()?))
                })
                .collect(),
        )
    }

    /// The value of the unlabelled series `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }

    /// The sum over every series of `name` (0 if none).
    pub fn total(&self, name: &str) -> f64 {
        self.0
            .iter()
            .filter(|(k, _)| k == name || k.strip_prefix(name).is_some_and(|r| r.starts_with('{')))
            .map(|(_, v)| v)
            .sum()
    }

    /// The series of `name` with the single label `label="value"` (0 if none).
    pub fn labelled(&self, name: &str, label: &str, value: &str) -> f64 {
        let key = format!("{name}{{{label}=\"{value}\"}}");
        self.get(&key).unwrap_or(0.0)
    }

    /// Every series of `name` by the value of its one label.
    pub fn by_label(&self, name: &str) -> Vec<(String, u64)> {
        self.0
            .iter()
            .filter_map(|(k, v)| {
                let rest = k.strip_prefix(name)?.strip_prefix('{')?;
                let (_, value) = rest.trim_end_matches('}').split_once('=')?;
                Some((value.trim_matches('"').to_string(), *v as u64))
            })
            .collect()
    }
}

/// GETs `http://addr/metrics`.
pub fn scrape(addr: SocketAddr) -> Result<Scrape> {
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
    s.set_read_timeout(Some(Duration::from_secs(5)))?;
    s.write_all(b"GET /metrics HTTP/1.0\r\nHost: localhost\r\n\r\n")?;
    let mut text = String::new();
    s.read_to_string(&mut text)?;
    let (head, body) = text
        .split_once("\r\n\r\n")
        .context("no HTTP header in the metrics reply")?;
    let ok = head.starts_with("HTTP/1.") && head.split(' ').nth(1) == Some("200");
    if !ok {
        bail!(
            "metrics endpoint answered {}",
            head.lines().next().unwrap_or("")
        );
    }
    Ok(Scrape::parse(body))
}

/// The resident memory of process `pid` in KiB (`VmRSS`), if readable.
pub fn rss_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// `--set KEY=VALUE` for each override, as `learner serve` takes them.
fn set_flags(args: &SoakArgs) -> impl Iterator<Item = &str> {
    args.overrides.iter().flat_map(|s| ["--set", s.as_str()])
}

/// The learner's run options as `learner serve` resolves them.
fn soak_config(args: &SoakArgs, run_dir: &Path) -> Result<TrainConfig> {
    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        run: crate::train::TrainArgs,
    }
    let config = args.config.display().to_string();
    let run_dir = run_dir.display().to_string();
    let argv = ["serve", "--config", &config, "--out", &run_dir]
        .into_iter()
        .chain(set_flags(args));
    let wrap = Wrap::try_parse_from(argv).context("the soak's learner options")?;
    crate::train::resolve_config(&wrap.run)
}

/// Refuses flags the soak cannot run with.
fn validate(args: &SoakArgs) -> Result<()> {
    if !(args.minutes > 0.0 && args.minutes.is_finite()) {
        bail!("--minutes must be positive");
    }
    if args.actors == 0 {
        bail!("--actors must be at least 1");
    }
    if !(args.kill_every > 0.0 && args.sample_every > 0.0 && args.restart_within >= 0.0) {
        bail!("--kill-every and --sample-every must be positive");
    }
    if !(0.0..=1.0).contains(&args.target) {
        bail!("--target is a success rate in [0, 1]");
    }
    Ok(())
}

/// Creates `out`, unless an earlier soak is there (its CSV and run would be
/// appended to).
fn create_out_dir(out: &Path) -> Result<()> {
    if out.join("soak.csv").exists() || out.join("run").exists() {
        bail!(
            "{} already holds a soak run; choose another --out",
            out.display()
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))
}

/// The `actor` executable: `--actor-exe`, or `actor` beside `learner_exe`.
fn find_actor_exe(args: &SoakArgs, learner_exe: &Path) -> Result<PathBuf> {
    let actor_exe = args
        .actor_exe
        .clone()
        .unwrap_or_else(|| learner_exe.with_file_name("actor"));
    if !actor_exe.is_file() {
        bail!(
            "no actor executable at {} (build it: cargo build --release -p buridan-actor, or pass --actor-exe)",
            actor_exe.display()
        );
    }
    Ok(actor_exe)
}

/// The outcomes of `buridan_fragments_total` that refuse a fragment.
const REFUSALS: [&str; 4] = ["stale", "surplus", "invalid", "duplicate"];

/// Fragments with `outcome` in `scrape` (see [`REFUSALS`]; also
/// `accepted` and `stale_at_learner`).
fn fragments(scrape: &Scrape, outcome: &str) -> u64 {
    scrape.labelled("buridan_fragments_total", "outcome", outcome) as u64
}

impl Sample {
    /// The learner's metrics in `scrape`; time, memory and actors left at 0.
    fn from_scrape(scrape: &Scrape) -> Self {
        let total = |name: &str| scrape.total(name) as u64;
        let gauge = |name: &str| scrape.get(name).unwrap_or(0.0) as u64;
        let episodes = gauge("buridan_episodes");
        Self {
            accepted: fragments(scrape, "accepted"),
            refused: REFUSALS.iter().map(|o| fragments(scrape, o)).sum(),
            invalid: fragments(scrape, "invalid"),
            duplicate: fragments(scrape, "duplicate"),
            consumed: total("buridan_fragments_consumed_total"),
            consumed_steps: total("buridan_fragment_steps_consumed_total"),
            stale_at_learner: fragments(scrape, "stale_at_learner"),
            env_steps: total("buridan_env_steps_total"),
            policy_version: gauge("buridan_policy_version"),
            // Until there were 100 episodes it is not the rate over the last 100.
            success: scrape
                .get("buridan_success_rate")
                .filter(|_| episodes >= 100),
            episodes,
            sessions: gauge("buridan_sessions"),
            ..Self::default()
        }
    }
}

/// The samples, each written to `soak.csv` as it is taken so a soak cut
/// short still leaves its rows.
struct Samples {
    csv: csv::Writer<std::fs::File>,
    rows: Vec<Sample>,
    /// The last scrape that answered: a failed scrape repeats its numbers.
    last_scrape: Scrape,
}

impl Samples {
    fn create(out: &Path) -> Result<Self> {
        let path = out.join("soak.csv");
        let csv = csv::Writer::from_path(&path)
            .with_context(|| format!("creating {}", path.display()))?;
        Ok(Self {
            csv,
            rows: Vec::new(),
            last_scrape: Scrape::default(),
        })
    }

    /// Writes `s` out and keeps it.
    fn record(&mut self, s: Sample) -> Result<&Sample> {
        self.csv.serialize(&s)?;
        self.csv.flush()?;
        self.rows.push(s);
        Ok(&self.rows[self.rows.len() - 1])
    }

    /// Scrapes the learner and records a sample.
    fn take(&mut self, learner: &Learner, actors: &Actors, bar: &ProgressBar) -> Result<&Sample> {
        match scrape(learner.metrics) {
            Ok(s) => self.last_scrape = s,
            Err(e) => bar.suspend(|| tracing::warn!(target: TARGET, "soak: scrape failed: {e:#}")),
        }
        let s = learner.sample(&self.last_scrape, actors.running().count(), actors.kills);
        self.record(s)
    }
}

/// The soak's progress bar, `total` long.
fn progress_bar(total: Duration) -> ProgressBar {
    let bar = ProgressBar::new(total.as_secs());
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:25}] {elapsed}/{len}s {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_prefix("soak");
    crate::heartbeat::watch(&bar);
    bar
}

/// The misbehaving client, unless `--no-misbehave`.
fn start_misbehaver(args: &SoakArgs, url: &str, max_sessions: usize) -> Result<Option<Misbehaver>> {
    if args.no_misbehave {
        return Ok(None);
    }
    let options = MisbehaveOptions {
        name: "soak-misbehaving".into(),
        max_sessions: Some(max_sessions),
        idle_timeout: Some(Duration::from_secs_f64(args.session_idle_timeout)),
        seed: args.seed,
        ..MisbehaveOptions::default()
    };
    Ok(Some(Misbehaver::spawn(url, options)?))
}

/// The soak proper, for `total`: actors killed and restarted, a sample
/// every `--sample-every` s. Why it ended early if the learner died.
fn soak_for(
    args: &SoakArgs,
    total: Duration,
    learner: &mut Learner,
    actors: &mut Actors,
    misbehaver: Option<&Misbehaver>,
    samples: &mut Samples,
    bar: &ProgressBar,
) -> Result<Option<String>> {
    let end = Instant::now() + total;
    let mut kill_schedule = KillSchedule::new(args);
    let mut next_sample = Instant::now();
    while Instant::now() < end {
        std::thread::sleep(Duration::from_millis(100));
        if let Some(status) = learner.exit_status()? {
            return Ok(Some(format!(
                "the learner died after {} with {status}",
                clock(learner.seconds())
            )));
        }
        let now = Instant::now();
        bar.set_position(learner.started.elapsed().as_secs().min(total.as_secs()));
        actors.supervise(now, bar)?;
        kill_schedule.strike(now, actors, bar);
        if now >= next_sample {
            next_sample = now + Duration::from_secs_f64(args.sample_every);
            let s = samples.take(learner, actors, bar)?;
            bar.set_message(message(s, args.actors, misbehaver));
        }
    }
    Ok(None)
}

/// What the stop sequence found.
struct Stopped {
    /// Seconds from the learner's start to its stop.
    seconds: f64,
    tally: Option<MisbehaveTally>,
    checkpoint: Option<String>,
    failures: Vec<String>,
}

/// Stops the misbehaving client and the actors; unless the learner died
/// (`learner_died`), lets it drain, records a last sample, stops it with
/// SIGTERM and finds its checkpoint.
fn stop_soak(
    learner: &mut Learner,
    actors: &mut Actors,
    misbehaver: Option<Misbehaver>,
    samples: &mut Samples,
    bar: &ProgressBar,
    learner_died: Option<String>,
) -> Result<Stopped> {
    let tally = misbehaver.map(Misbehaver::stop);
    actors.stop();
    bar.finish_and_clear();
    let mut checkpoint = None;
    let mut failures = Vec::new();
    match learner_died {
        Some(why) => failures.push(why),
        None => {
            learner.wait_until_still(&mut samples.last_scrape);
            let s = learner.sample(&samples.last_scrape, 0, actors.kills);
            samples.record(s)?;
            learner.terminate(&mut failures)?;
            checkpoint = learner.checkpoint();
            if checkpoint.is_none() {
                failures
                    .push("the learner wrote no checkpoint on SIGTERM (see learner.log)".into());
            }
        }
    }
    Ok(Stopped {
        seconds: learner.seconds(),
        tally,
        checkpoint,
        failures,
    })
}

/// Balances the fragment books of the last sample (see the module docs);
/// each book that does not balance goes to `failures`.
fn balance(
    last: &Sample,
    steps_per_fragment: u64,
    fragments_per_batch: u64,
    failures: &mut Vec<String>,
) -> Books {
    let mut books = Books {
        steps_per_fragment,
        accepted: last.accepted,
        consumed: last.consumed,
        consumed_steps: last.consumed_steps,
        stale_at_learner: last.stale_at_learner,
        ..Books::default()
    };
    if !last.env_steps.is_multiple_of(steps_per_fragment) {
        failures.push(format!(
            "the learner took {} env steps from its queue, not a whole number of {steps_per_fragment}-step fragments",
            last.env_steps
        ));
    }
    books.dequeued = last.env_steps / steps_per_fragment;
    let whole = last.consumed * steps_per_fragment;
    if last.consumed_steps != whole {
        books.consumed_in_part = last
            .consumed
            .saturating_sub(last.consumed_steps / steps_per_fragment)
            .max(1);
        failures.push(format!(
            "{} fragments consumed with {} env steps, not {whole}: some were used in part",
            last.consumed, last.consumed_steps
        ));
    }
    let used = last.consumed + last.stale_at_learner;
    if used > books.dequeued || books.dequeued > books.accepted {
        books.used_twice =
            used.saturating_sub(books.dequeued) + books.dequeued.saturating_sub(books.accepted);
        failures.push(format!(
            "fragments used twice: consumed {} + stale at learner {} > taken {} or taken > accepted {}",
            last.consumed, last.stale_at_learner, books.dequeued, books.accepted
        ));
    }
    books.queued_at_end = books.accepted.saturating_sub(books.dequeued);
    books.partial_batch_at_end = books.dequeued.saturating_sub(used);
    books.lost = books.accepted.saturating_sub(last.consumed);
    if books.partial_batch_at_end >= fragments_per_batch {
        failures.push(format!(
            "{} fragments taken but neither consumed nor dropped (a batch holds {fragments_per_batch})",
            books.partial_batch_at_end,
        ));
    }
    books
}

/// Training success over the run.
struct SuccessRecord {
    last: Option<f64>,
    best: Option<f64>,
    /// Seconds until it first reached the target.
    target_reached_s: Option<f64>,
}

impl SuccessRecord {
    fn of(samples: &[Sample], target: f64) -> Self {
        Self {
            last: samples.iter().rev().find_map(|s| s.success),
            best: samples.iter().filter_map(|s| s.success).reduce(f64::max),
            target_reached_s: samples
                .iter()
                .find(|s| s.success.is_some_and(|v| v >= target))
                .map(|s| s.seconds),
        }
    }
}

/// What the misbehaving client's tally says went wrong.
fn misbehaver_failures(t: &MisbehaveTally) -> Vec<String> {
    let mut failures = Vec::new();
    if t.wrongly_accepted > 0 || t.unexpected > 0 {
        failures.push(format!(
            "the misbehaving client: {} wrongly accepted, {} unexpected answers (last: {})",
            t.wrongly_accepted, t.unexpected, t.last_problem
        ));
    }
    if t.sent() == 0 {
        failures.push("the misbehaving client sent nothing (never connected)".into());
    }
    failures
}

/// The learner's counters of trouble: RPC errors by code, undecodable
/// messages, implausible fragments, refused joins, expired sessions.
fn learner_counters(scrape: &Scrape) -> Vec<(String, u64)> {
    let mut counters: Vec<(String, u64)> = [
        ("undecodable messages", "buridan_undecodable_messages_total"),
        (
            "implausible fragments",
            "buridan_implausible_fragments_total",
        ),
        ("joins refused (cap)", "buridan_joins_refused_total"),
        ("sessions expired", "buridan_sessions_expired_total"),
    ]
    .into_iter()
    .map(|(name, key)| (name.into(), scrape.total(key) as u64))
    .collect();
    for (code, n) in scrape.by_label("buridan_rpc_errors_total") {
        counters.push((format!("rpc errors {code}"), n));
    }
    counters
}

/// The learner's config file and overrides, as on its command line.
fn config_line(args: &SoakArgs) -> String {
    std::iter::once(args.config.display().to_string())
        .chain(set_flags(args).map(String::from))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Balances the books and checks the run against `--target` and the
/// misbehaving client's tally: the summary, with every failure.
fn summarize(
    args: &SoakArgs,
    cfg: &TrainConfig,
    samples: &Samples,
    actors: &Actors,
    stopped: Stopped,
) -> SoakSummary {
    let Stopped {
        seconds,
        tally,
        checkpoint,
        mut failures,
    } = stopped;
    let last = samples.rows.last().cloned().unwrap_or_default();
    let books = balance(
        &last,
        (cfg.fragment_len * cfg.envs_per_actor) as u64,
        cfg.fragments_per_batch() as u64,
        &mut failures,
    );
    let success = SuccessRecord::of(&samples.rows, args.target);
    if success.target_reached_s.is_none() {
        failures.push(format!(
            "training success never reached {:.0} % (best {})",
            100.0 * args.target,
            percent(success.best)
        ));
    }
    if let Some(t) = &tally {
        failures.extend(misbehaver_failures(t));
    }
    // A sample without the learner's memory (it had gone) says nothing of it.
    let rss: Vec<u64> = samples
        .rows
        .iter()
        .map(|s| s.rss_kib)
        .filter(|&r| r > 0)
        .collect();
    SoakSummary {
        seconds,
        config: config_line(args),
        actors: args.actors,
        rss_start_kib: rss.first().copied().unwrap_or(0),
        rss_end_kib: rss.last().copied().unwrap_or(0),
        rss_max_kib: rss.iter().copied().max().unwrap_or(0),
        env_steps: last.env_steps,
        updates: last.policy_version,
        final_success: success.last,
        best_success: success.best,
        target: args.target,
        target_reached_s: success.target_reached_s,
        refused: REFUSALS
            .iter()
            .map(|&o| (o.to_string(), fragments(&samples.last_scrape, o)))
            .collect(),
        books,
        kills: actors.kills,
        restarts: actors.restarts,
        actor_exits: actors.exits,
        misbehave: tally.as_ref().map(MisbehaveJson::from),
        learner_counters: learner_counters(&samples.last_scrape),
        checkpoint,
        failures,
    }
}

/// Writes `soak.json`, `soak.png` and `soak.md` to `out`, and prints the
/// Markdown.
fn report(summary: &SoakSummary, samples: &[Sample], out: &Path) -> Result<()> {
    std::fs::write(
        out.join("soak.json"),
        serde_json::to_string_pretty(summary)?,
    )?;
    if let Err(e) = png::draw(&out.join("soak.png"), samples, summary.target) {
        tracing::warn!("soak.png not drawn: {e}");
    }
    let md = markdown(summary);
    std::fs::write(out.join("soak.md"), &md)?;
    println!("{md}");
    Ok(())
}

/// Runs `learner bench soak`; the summary if every check passed.
pub fn run(args: &SoakArgs) -> Result<SoakSummary> {
    validate(args)?;
    let out = &args.out;
    create_out_dir(out)?;
    let run_dir = out.join("run");
    let cfg = soak_config(args, &run_dir)?;
    let exe = std::env::current_exe().context("finding the learner executable")?;
    let actor_exe = find_actor_exe(args, &exe)?;
    let max_sessions = args.max_sessions.unwrap_or(args.actors + 8);

    let mut learner = Learner::start(args, &exe, &run_dir, max_sessions)?;
    learner.wait_until_serving()?;
    let actor_command = ActorCommand {
        exe: actor_exe,
        url: learner.url.clone(),
        out: out.clone(),
    };
    let mut actors = Actors::start(actor_command, args.actors)?;
    let misbehaver = start_misbehaver(args, &learner.url, max_sessions)?;

    let total = Duration::from_secs_f64(args.minutes * 60.0);
    let bar = progress_bar(total);
    let mut samples = Samples::create(out)?;
    let learner_died = soak_for(
        args,
        total,
        &mut learner,
        &mut actors,
        misbehaver.as_ref(),
        &mut samples,
        &bar,
    )?;
    let stopped = stop_soak(
        &mut learner,
        &mut actors,
        misbehaver,
        &mut samples,
        &bar,
        learner_died,
    )?;

    let summary = summarize(args, &cfg, &samples, &actors, stopped);
    report(&summary, &samples.rows, out)?;
    if !summary.failures.is_empty() {
        bail!(
            "the soak failed: {} (see {})",
            summary.failures.join("; "),
            out.display()
        );
    }
    Ok(summary)
}

/// The progress bar's message for sample `s`.
fn message(s: &Sample, actors: usize, m: Option<&Misbehaver>) -> String {
    let mut text = format!(
        "rss {:.0} MiB, success {}, env steps {}, fragments accepted {} refused {} consumed {}, actors {}/{actors}, kills {}",
        s.rss_kib as f64 / 1024.0,
        s.success.map_or("–".into(), |v| format!("{:.1}%", 100.0 * v)),
        buridan_study::figures::tick(s.env_steps as f64),
        s.accepted,
        s.refused,
        s.consumed,
        s.actors_running,
        s.kills
    );
    if let Some(m) = m {
        let t = m.tally();
        text.push_str(&format!(
            ", misbehaving sent {} refused {} wrongly accepted {}",
            t.sent(),
            t.refused(),
            t.wrongly_accepted
        ));
    }
    text
}

/// A success rate as a percentage, "–" if there is none.
fn percent(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{:.1} %", 100.0 * v))
}

/// The summary as Markdown.
pub fn markdown(s: &SoakSummary) -> String {
    let mib = |k: u64| format!("{:.1} MiB", k as f64 / 1024.0);
    let b = &s.books;
    let mut rows: Vec<(String, String)> = vec![
        (
            "run".into(),
            format!(
                "{} of `learner serve` ({}) with {} actors",
                clock(s.seconds),
                s.config,
                s.actors
            ),
        ),
        (
            "learner resident memory: start → end (max)".into(),
            format!(
                "{} → {} ({})",
                mib(s.rss_start_kib),
                mib(s.rss_end_kib),
                mib(s.rss_max_kib)
            ),
        ),
        (
            "env steps taken, updates".into(),
            format!("{}, {}", s.env_steps, s.updates),
        ),
        (
            "training success (last 100 episodes): final / best".into(),
            format!("{} / {}", percent(s.final_success), percent(s.best_success)),
        ),
        (
            format!("target {:.0} % first reached after", 100.0 * s.target),
            s.target_reached_s.map_or("never".into(), clock),
        ),
        (
            "fragments accepted / refused".into(),
            format!(
                "{} / {} ({})",
                b.accepted,
                s.refused.iter().map(|(_, n)| n).sum::<u64>(),
                s.refused
                    .iter()
                    .map(|(o, n)| format!("{o} {n}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ),
        (
            "fragments consumed by updates (env steps)".into(),
            format!(
                "{} ({} = {} × {} steps)",
                b.consumed, b.consumed_steps, b.consumed, b.steps_per_fragment
            ),
        ),
        (
            "used twice / used in part".into(),
            format!("{} / {}", b.used_twice, b.consumed_in_part),
        ),
        (
            "lost (accepted, not consumed)".into(),
            format!(
                "{}: {} dropped as stale by the learner, {} queued and {} in the unfinished batch at the stop",
                b.lost, b.stale_at_learner, b.queued_at_end, b.partial_batch_at_end
            ),
        ),
        (
            "actors killed (SIGKILL) / restarted / exited on their own".into(),
            format!("{} / {} / {}", s.kills, s.restarts, s.actor_exits),
        ),
    ];
    if let Some(m) = &s.misbehave {
        rows.push((
            "misbehaving client (sent → refused as expected)".into(),
            format!(
                "{} rounds; undecodable {} → {} INVALID_ARGUMENT; implausible {} → {} INVALID_ARGUMENT; old fragments {} → {} stale; repeated sequence numbers {} → {} ALREADY_EXISTS; idle sessions {} ({} found expired); joins refused at the cap {}; wrongly accepted {}, unexpected {}, connection failures {}",
                m.rounds,
                m.undecodable.0,
                m.undecodable.1,
                m.implausible.0,
                m.implausible.1,
                m.stale.0,
                m.stale.1,
                m.replays.0,
                m.replays.1,
                m.idle_sessions.0,
                m.idle_sessions.1,
                m.joins_refused_at_cap,
                m.wrongly_accepted,
                m.unexpected,
                m.transport_errors
            ),
        ));
    }
    rows.push((
        "learner counters".into(),
        s.learner_counters
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", "),
    ));
    rows.push((
        "stop (SIGTERM)".into(),
        s.checkpoint
            .as_ref()
            .map_or("no checkpoint".into(), |c| format!("checkpoint `{c}`")),
    ));
    rows.push((
        "result".into(),
        if s.failures.is_empty() {
            "**passed**".into()
        } else {
            format!("**failed**: {}", s.failures.join("; "))
        },
    ));
    let mut md = String::from("| soak | |\n|---|---|\n");
    for (k, v) in rows {
        md.push_str(&format!("| {k} | {v} |\n"));
    }
    md
}

/// `soak.png`: the learner's resident memory (top) and training success
/// with the target (bottom) over minutes.
mod png {
    use std::path::Path;

    use anyhow::Result;
    use plotters::coord::types::RangedCoordf64;
    use plotters::coord::Shift;
    use plotters::prelude::*;

    use super::Sample;

    /// Draws `samples` and the success `target` to `path`.
    pub(super) fn draw(path: &Path, samples: &[Sample], target: f64) -> Result<()> {
        buridan_study::plot::register_fonts();
        let root = BitMapBackend::new(path, (900, 700)).into_drawing_area();
        plot(&root, samples, target).map_err(|e| anyhow::anyhow!("drawing {}: {e}", path.display()))
    }

    fn plot<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        samples: &[Sample],
        target: f64,
    ) -> DrawResult<(), DB> {
        root.fill(&WHITE)?;
        let (top, bottom) = root.split_vertically(350);
        let minutes = |s: &Sample| s.seconds / 60.0;
        let x1 = samples.last().map_or(1.0, minutes).max(0.1);
        let rss: Vec<(f64, f64)> = samples
            .iter()
            .filter(|s| s.rss_kib > 0)
            .map(|s| (minutes(s), s.rss_kib as f64 / 1024.0))
            .collect();
        let y1 = rss.iter().map(|p| p.1).fold(1.0, f64::max) * 1.1;
        panel(&top, "learner resident memory", (x1, y1), "MiB")?
            .draw_series(LineSeries::new(rss, BLUE.stroke_width(2)))?;
        let mut chart = panel(
            &bottom,
            "training success (last 100 episodes)",
            (x1, 100.0),
            "%",
        )?;
        chart.draw_series(LineSeries::new(
            samples
                .iter()
                .filter_map(|s| Some((minutes(s), 100.0 * s.success?))),
            GREEN.stroke_width(2),
        ))?;
        chart.draw_series(DashedLineSeries::new(
            [(0.0, 100.0 * target), (x1, 100.0 * target)],
            8,
            5,
            RED.stroke_width(1),
        ))?;
        root.present()
    }

    /// One chart: its caption, axes (minutes from 0 to `x1`, `y_desc` from
    /// 0 to `y1`) and mesh.
    fn panel<'a, DB: DrawingBackend>(
        area: &'a DrawingArea<DB, Shift>,
        caption: &str,
        (x1, y1): (f64, f64),
        y_desc: &str,
    ) -> DrawResult<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>, DB> {
        let mut chart = ChartBuilder::on(area)
            .caption(caption, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..x1, 0.0..y1)?;
        chart
            .configure_mesh()
            .x_desc("minutes")
            .y_desc(y_desc)
            .draw()?;
        Ok(chart)
    }
}

#[cfg(test)]
mod tests {
    use super::processes::Dice;
    use super::*;

    #[test]
    fn dice_are_uniform_enough_and_exponential_has_its_mean() {
        let mut d = Dice(3);
        let n = 20_000;
        let mean = (0..n).map(|_| d.exp(60.0)).sum::<f64>() / n as f64;
        assert!((mean - 60.0).abs() < 3.0, "{mean}");
        assert!((0..1000).all(|_| (0.0..1.0).contains(&d.unit())));
    }

    #[test]
    fn labels_are_read_by_value() {
        let s = Scrape::parse(
            "buridan_rpc_errors_total{code=\"InvalidArgument\"} 7\nburidan_rpc_errors_total{code=\"NotFound\"} 2\n",
        );
        assert_eq!(
            s.by_label("buridan_rpc_errors_total"),
            [
                ("InvalidArgument".to_string(), 7),
                ("NotFound".to_string(), 2)
            ]
        );
    }

    #[test]
    fn balanced_books_fail_nothing_and_account_for_the_lost() {
        // 4 steps a fragment: 10 accepted, 8 taken (2 still queued), 6
        // consumed, 1 dropped as stale, 1 in the unfinished batch.
        let last = Sample {
            accepted: 10,
            env_steps: 32,
            consumed: 6,
            consumed_steps: 24,
            stale_at_learner: 1,
            ..Sample::default()
        };
        let mut failures = Vec::new();
        let b = balance(&last, 4, 2, &mut failures);
        assert!(failures.is_empty(), "{failures:?}");
        assert_eq!(
            (b.dequeued, b.queued_at_end, b.partial_batch_at_end, b.lost),
            (8, 2, 1, 4)
        );
        assert_eq!((b.used_twice, b.consumed_in_part), (0, 0));
    }

    #[test]
    fn fragments_used_twice_or_in_part_unbalance_the_books() {
        // 5 taken, 6 consumed; 22 steps consumed where 6 whole are 24.
        let last = Sample {
            accepted: 5,
            env_steps: 20,
            consumed: 6,
            consumed_steps: 22,
            ..Sample::default()
        };
        let mut failures = Vec::new();
        let b = balance(&last, 4, 2, &mut failures);
        assert_eq!((b.used_twice, b.consumed_in_part), (1, 1));
        assert_eq!(failures.len(), 2, "{failures:?}");
    }

    #[test]
    fn success_record_finds_last_best_and_first_at_target() {
        let samples: Vec<Sample> = [None, Some(0.5), Some(0.9), Some(0.7), None]
            .into_iter()
            .enumerate()
            .map(|(k, success)| Sample {
                seconds: k as f64,
                success,
                ..Sample::default()
            })
            .collect();
        let r = SuccessRecord::of(&samples, 0.8);
        assert_eq!(
            (r.last, r.best, r.target_reached_s),
            (Some(0.7), Some(0.9), Some(2.0))
        );
        assert_eq!(SuccessRecord::of(&samples, 0.95).target_reached_s, None);
    }

    #[test]
    fn soak_flags_parse() {
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            soak: SoakArgs,
        }
        let c = Cli::try_parse_from(["soak", "--out", "x", "--minutes", "0.5"]).unwrap();
        assert_eq!(
            (c.soak.minutes, c.soak.actors, c.soak.kill_every),
            (0.5, 2, 60.0)
        );
    }
}
