//! The `learner serve` under test: its start on free loopback ports, its
//! readiness, samples of its memory and metrics, and its stop.

use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use crate::child::{free_loopback_addr, kill_and_reap, log_file};
use crate::sample::Sample;
use crate::scrape::{scrape, Scrape};
use crate::{SoakArgs, SoakError, TARGET};

/// The `learner serve` under test.
pub(crate) struct Learner {
    pub(crate) child: Child,
    pub(crate) pid: u32,
    /// The samples' clock starts here.
    pub(crate) started: Instant,
    /// Where it serves actors (gRPC) …
    pub(crate) listen: SocketAddr,
    /// … the same as a URL …
    pub(crate) url: String,
    /// … and its Prometheus metrics.
    pub(crate) metrics: SocketAddr,
    /// Its output, which also names the checkpoint it writes on SIGTERM.
    pub(crate) log: PathBuf,
}

impl Learner {
    /// Starts `learner serve` (the executable `exe`) with the soak's
    /// options on free loopback ports, its output in `learner.log`.
    pub(crate) fn start(
        args: &SoakArgs,
        exe: &Path,
        run_dir: &Path,
        max_sessions: usize,
    ) -> Result<Self, SoakError> {
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
            .args(args.set_flags());
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
            .map_err(SoakError::io(format!("starting {} serve", exe.display())))?;
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
    pub(crate) fn wait_until_serving(&mut self) -> Result<(), SoakError> {
        let ready_by = Instant::now() + Duration::from_secs(300);
        loop {
            if let Some(status) = self.exit_status()? {
                return Err(SoakError::LearnerEnded {
                    status,
                    log: self.log.clone(),
                });
            }
            if TcpStream::connect_timeout(&self.listen, Duration::from_secs(1)).is_ok()
                && scrape(self.metrics).is_ok()
            {
                return Ok(());
            }
            if Instant::now() > ready_by {
                let _ = self.child.kill();
                return Err(SoakError::LearnerSilent);
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// How it ended, if it has.
    pub(crate) fn exit_status(&mut self) -> Result<Option<ExitStatus>, SoakError> {
        self.child
            .try_wait()
            .map_err(SoakError::io("watching the learner"))
    }

    /// Seconds since it was started.
    pub(crate) fn seconds(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// A sample: the metrics of `scrape` with the learner's memory now.
    pub(crate) fn sample(&self, scrape: &Scrape, actors_running: usize, kills: u64) -> Sample {
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
    pub(crate) fn wait_until_still(&self, last: &mut Scrape) {
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
    pub(crate) fn terminate(&mut self, failures: &mut Vec<String>) -> Result<(), SoakError> {
        let term = Command::new("kill")
            .arg("-TERM")
            .arg(self.pid.to_string())
            .status();
        if !term.is_ok_and(|s| s.success()) {
            failures.push("could not send SIGTERM to the learner".into());
        }
        let stop_by = Instant::now() + Duration::from_secs(120);
        loop {
            if self.exit_status()?.is_some() {
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
    pub(crate) fn checkpoint(&self) -> Option<String> {
        let log_text = std::fs::read_to_string(&self.log).unwrap_or_default();
        log_text.lines().rev().find_map(|l| {
            l.split_once("resume with --resume ")
                .map(|(_, p)| p.trim().to_string())
        })
    }
}

/// The resident memory of process `pid` in KiB (`VmRSS`), if readable.
pub(crate) fn rss_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_process_has_resident_memory() {
        if cfg!(target_os = "linux") {
            assert!(rss_kib(std::process::id()).is_some_and(|k| k > 0));
        }
        assert_eq!(rss_kib(u32::MAX), None);
    }
}
