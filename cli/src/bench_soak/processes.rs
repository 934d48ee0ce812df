//! The soak's processes: the `learner serve` under test (start, readiness,
//! samples of its memory and metrics, the stop), the actor processes and
//! their supervisor (random SIGKILL, restart), and the kills' schedule.

use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;

use super::*;

/// A loopback port free right now.
pub(super) fn free_port() -> Result<u16> {
    Ok(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// A loopback address on a port free right now.
pub(super) fn free_loopback_addr() -> Result<SocketAddr> {
    Ok(SocketAddr::from(([127, 0, 0, 1], free_port()?)))
}

/// splitmix64: the kills' randomness (no state worth a crate).
pub(super) struct Dice(pub(super) u64);

impl Dice {
    pub(super) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub(super) fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Exponential with mean `mean`.
    pub(super) fn exp(&mut self, mean: f64) -> f64 {
        -mean * (1.0 - self.unit()).ln()
    }
}

/// Stdout and stderr of a process, both appended to `out/name`.
pub(super) fn log_file(out: &Path, name: &str) -> Result<(Stdio, Stdio)> {
    let f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(out.join(name))
        .with_context(|| format!("opening {name}"))?;
    Ok((f.try_clone()?.into(), f.into()))
}

/// SIGKILL, then wait so no zombie is left.
pub(super) fn kill_and_reap(child: &mut Child) {
    let _ = child.kill();
    let _ = child.wait();
}

/// The `learner serve` under test.
pub(super) struct Learner {
    pub(super) child: Child,
    pub(super) pid: u32,
    /// The samples' clock starts here.
    pub(super) started: Instant,
    /// Where it serves actors (gRPC) …
    pub(super) listen: SocketAddr,
    /// … the same as a URL …
    pub(super) url: String,
    /// … and its Prometheus metrics.
    pub(super) metrics: SocketAddr,
    /// Its output, which also names the checkpoint it writes on SIGTERM.
    pub(super) log: PathBuf,
}

impl Learner {
    /// Starts `learner serve` (the executable `exe`) with the soak's
    /// options on free loopback ports, its output in `learner.log`.
    pub(super) fn start(
        args: &SoakArgs,
        exe: &Path,
        run_dir: &Path,
        max_sessions: usize,
    ) -> Result<Self> {
        let listen = free_loopback_addr()?;
        let metrics = free_loopback_addr()?;
        let url = format!("http://{listen}");
        let (stdout, stderr) = log_file(&args.out, "learner.log")?;
        let mut cmd = Command::new(exe);
        cmd.arg("serve")
            .arg("--config")
            .arg(&args.config)
            .arg("--out")
            .arg(run_dir)
            .arg("--listen")
            .arg(listen.to_string())
            .arg("--metrics")
            .arg(metrics.to_string())
            .arg("--steps")
            .arg("1000000000000")
            .arg("--seed")
            .arg(args.seed.to_string())
            .arg("--session-idle-timeout")
            .arg(args.session_idle_timeout.to_string())
            .arg("--max-sessions")
            .arg(max_sessions.to_string())
            .arg("--quiet")
            .args(set_flags(args));
        if std::env::var_os("RUST_LOG").is_none() {
            // Joins, refusals, expiries and checkpoints, not a line per update.
            cmd.env("RUST_LOG", "info,buridan_cli::train=warn");
        }
        let started = Instant::now();
        let child = cmd
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .with_context(|| format!("starting {} serve", exe.display()))?;
        let pid = child.id();
        tracing::info!(target: TARGET, pid, %url, %metrics, "soak: learner started");
        Ok(Self {
            child,
            pid,
            started,
            listen,
            url,
            metrics,
            log: args.out.join("learner.log"),
        })
    }

    /// Waits (up to 300 s) until both its gRPC port and its metrics answer.
    pub(super) fn wait_until_serving(&mut self) -> Result<()> {
        let ready_by = Instant::now() + Duration::from_secs(300);
        loop {
            if let Some(status) = self.child.try_wait()? {
                bail!(
                    "the learner ended with {status} before listening; see {}",
                    self.log.display()
                );
            }
            if TcpStream::connect_timeout(&self.listen, Duration::from_secs(1)).is_ok()
                && scrape(self.metrics).is_ok()
            {
                return Ok(());
            }
            if Instant::now() > ready_by {
                let _ = self.child.kill();
                bail!("the learner did not listen within 300 s");
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// How it ended, if it has.
    pub(super) fn exit_status(&mut self) -> Result<Option<ExitStatus>> {
        Ok(self.child.try_wait()?)
    }

    /// Seconds since it was started.
    pub(super) fn seconds(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// A sample: the metrics of `scrape` with the learner's memory now.
    pub(super) fn sample(&self, scrape: &Scrape, actors_running: usize, kills: u64) -> Sample {
        Sample {
            seconds: self.seconds(),
            rss_kib: rss_kib(self.pid).unwrap_or(0),
            actors_running,
            kills,
            ..Sample::from_scrape(scrape)
        }
    }

    /// Waits (up to 60 s) until the learner has worked off what it was sent:
    /// fragments accepted, env steps and fragments consumed the same two
    /// scrapes running. Leaves the last scrape that answered in `last`.
    pub(super) fn wait_until_still(&self, last: &mut Scrape) {
        let settle_by = Instant::now() + Duration::from_secs(60);
        let mut prev: Option<(u64, u64, u64)> = None;
        while Instant::now() < settle_by {
            std::thread::sleep(Duration::from_secs(1));
            let Ok(s) = scrape(self.metrics) else {
                continue;
            };
            let x = Sample::from_scrape(&s);
            let key = (x.accepted, x.env_steps, x.consumed);
            *last = s;
            if prev == Some(key) {
                break;
            }
            prev = Some(key);
        }
    }

    /// SIGTERM, on which the learner checkpoints and exits; SIGKILL if it is
    /// still there 120 s later. What went wrong goes to `failures`.
    pub(super) fn terminate(&mut self, failures: &mut Vec<String>) -> Result<()> {
        let term = Command::new("kill")
            .arg("-TERM")
            .arg(self.pid.to_string())
            .status();
        if !term.is_ok_and(|s| s.success()) {
            failures.push("could not send SIGTERM to the learner".into());
        }
        let stop_by = Instant::now() + Duration::from_secs(120);
        loop {
            if self.child.try_wait()?.is_some() {
                return Ok(());
            }
            if Instant::now() > stop_by {
                kill_and_reap(&mut self.child);
                failures.push("the learner did not stop within 120 s of SIGTERM".into());
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The checkpoint the learner named in its log on the way out (its last
    /// "resume with --resume PATH").
    pub(super) fn checkpoint(&self) -> Option<String> {
        let log_text = std::fs::read_to_string(&self.log).unwrap_or_default();
        log_text.lines().rev().find_map(|l| {
            l.split_once("resume with --resume ")
                .map(|(_, p)| p.trim().to_string())
        })
    }
}

/// An actor slot: its process, or when it is due to restart.
pub(super) struct Slot {
    pub(super) child: Option<Child>,
    pub(super) restart_at: Option<Instant>,
}

/// How to start an actor.
pub(super) struct ActorCommand {
    pub(super) exe: PathBuf,
    /// The learner's URL.
    pub(super) url: String,
    /// Where the actors' logs go.
    pub(super) out: PathBuf,
}

impl ActorCommand {
    /// Starts actor `k`, appending to its log.
    pub(super) fn spawn(&self, k: usize) -> Result<Child> {
        let (stdout, stderr) = log_file(&self.out, &format!("actor-{k}.log"))?;
        Command::new(&self.exe)
            .arg("--connect")
            .arg(&self.url)
            .arg("--name")
            .arg(format!("soak-actor-{k}"))
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .with_context(|| format!("starting {}", self.exe.display()))
    }
}

/// The actor processes, one per slot, each restarted when it goes; the
/// tally of kills, restarts and exits.
pub(super) struct Actors {
    pub(super) command: ActorCommand,
    pub(super) slots: Vec<Slot>,
    pub(super) kills: u64,
    pub(super) restarts: u64,
    pub(super) exits: u64,
}

impl Actors {
    /// Starts `n` actors.
    pub(super) fn start(command: ActorCommand, n: usize) -> Result<Self> {
        let slots = (0..n)
            .map(|k| {
                Ok(Slot {
                    child: Some(command.spawn(k)?),
                    restart_at: None,
                })
            })
            .collect::<Result<_>>()?;
        Ok(Self {
            command,
            slots,
            kills: 0,
            restarts: 0,
            exits: 0,
        })
    }

    /// The slots with an actor running now.
    pub(super) fn running(&self) -> impl Iterator<Item = usize> + '_ {
        self.slots
            .iter()
            .enumerate()
            .filter(|(_, slot)| slot.child.is_some())
            .map(|(k, _)| k)
    }

    /// Notices actors that exited on their own (restarted a second later)
    /// and restarts those that are due.
    pub(super) fn supervise(&mut self, now: Instant, bar: &ProgressBar) -> Result<()> {
        for (k, slot) in self.slots.iter_mut().enumerate() {
            if let Some(child) = &mut slot.child {
                if let Some(status) = child.try_wait()? {
                    self.exits += 1;
                    bar.suspend(|| tracing::warn!(target: TARGET, actor = k, %status, "soak: actor exited on its own; restarting"));
                    slot.child = None;
                    slot.restart_at = Some(now + Duration::from_secs(1));
                }
            }
            if slot.restart_at.is_some_and(|t| now >= t) {
                slot.child = Some(self.command.spawn(k)?);
                slot.restart_at = None;
                self.restarts += 1;
                let restarts = self.restarts;
                bar.suspend(
                    || tracing::info!(target: TARGET, actor = k, restarts, "soak: actor restarted"),
                );
            }
        }
        Ok(())
    }

    /// SIGKILLs a running actor picked by `dice` and restarts it within
    /// `restart_within` seconds (uniform from a tenth of it).
    pub(super) fn kill_one(
        &mut self,
        dice: &mut Dice,
        restart_within: f64,
        now: Instant,
        bar: &ProgressBar,
    ) {
        let running: Vec<usize> = self.running().collect();
        if running.is_empty() {
            return;
        }
        let k = running[(dice.next() % running.len() as u64) as usize];
        if let Some(mut child) = self.slots[k].child.take() {
            kill_and_reap(&mut child);
        }
        self.kills += 1;
        let wait = restart_within * (0.1 + 0.9 * dice.unit());
        self.slots[k].restart_at = Some(now + Duration::from_secs_f64(wait));
        let kills = self.kills;
        bar.suspend(|| tracing::info!(target: TARGET, actor = k, kills, restart_in_s = format!("{wait:.1}"), "soak: actor killed (SIGKILL)"));
    }

    /// Kills them all, for good.
    pub(super) fn stop(&mut self) {
        for slot in &mut self.slots {
            if let Some(mut child) = slot.child.take() {
                kill_and_reap(&mut child);
            }
        }
    }
}

/// When the next actor is killed: exponential gaps with mean
/// `--kill-every`, drawn from dice seeded by `--seed`.
pub(super) struct KillSchedule {
    pub(super) dice: Dice,
    pub(super) next: Instant,
    pub(super) mean_s: f64,
    pub(super) restart_within: f64,
}

impl KillSchedule {
    pub(super) fn new(args: &SoakArgs) -> Self {
        let mut dice = Dice(args.seed ^ 0x50A4);
        let next = Instant::now() + Duration::from_secs_f64(dice.exp(args.kill_every));
        Self {
            dice,
            next,
            mean_s: args.kill_every,
            restart_within: args.restart_within,
        }
    }

    /// Kills an actor if one is due by `now`.
    pub(super) fn strike(&mut self, now: Instant, actors: &mut Actors, bar: &ProgressBar) {
        if now < self.next {
            return;
        }
        actors.kill_one(&mut self.dice, self.restart_within, now, bar);
        self.next = now + Duration::from_secs_f64(self.dice.exp(self.mean_s));
    }
}
