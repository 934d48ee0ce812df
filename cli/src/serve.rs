//! `learner serve`: the learner as a gRPC server for `actor` processes.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Result};

use crate::signals::{stop_when_stdin_closes, watch_signals};
use crate::train::{
    check_out, install_metrics, report, resolve_config, TerminalProgress, TrainArgs,
};
use buridan_learner::serve::{
    serve, Listener, ServeOptions, SessionLimits, DEFAULT_IDLE_TIMEOUT, DEFAULT_MAX_MESSAGE_BYTES,
    DEFAULT_MAX_SESSIONS,
};
use buridan_learner::train::Summary;

use crate::dashboard::{DashboardProgress, Live};

/// Arguments of `learner serve`: the run options of `learner train` plus
/// the server's.
#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// Run options, as for `learner train`.
    #[command(flatten)]
    pub run: TrainArgs,
    /// Address to accept actors on.
    #[arg(long, default_value = "127.0.0.1:50051")]
    pub listen: SocketAddr,
    /// Require this shared token from actors (`actor --token`).
    #[arg(long, env = "BURIDAN_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// PEM certificate for TLS (with --tls-key); actors then use https:// and --tls-ca.
    #[arg(long, requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// PEM private key for TLS.
    #[arg(long, requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// Largest message accepted, in bytes.
    #[arg(long, default_value_t = DEFAULT_MAX_MESSAGE_BYTES)]
    pub max_message_bytes: usize,
    /// Fragments the learner queue holds (0: impala.queue_capacity if set, else one train batch).
    #[arg(long, default_value_t = 0)]
    pub queue: usize,
    /// Seconds a session without a parameter stream may go without a
    /// fragment before it expires (a watching actor never expires).
    #[arg(long, value_name = "SECS", default_value_t = DEFAULT_IDLE_TIMEOUT.as_secs_f64())]
    pub session_idle_timeout: f64,
    /// Sessions open at once; a join beyond gets RESOURCE_EXHAUSTED.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_SESSIONS)]
    pub max_sessions: usize,
}

/// The session limits of `args`, refused with a clear error when zero,
/// negative or absurd.
fn session_limits(args: &ServeArgs) -> Result<SessionLimits> {
    let Ok(idle_timeout) = Duration::try_from_secs_f64(args.session_idle_timeout) else {
        bail!(
            "--session-idle-timeout {} is not a number of seconds",
            args.session_idle_timeout
        );
    };
    let limits = SessionLimits {
        idle_timeout,
        max_sessions: args.max_sessions,
    };
    limits.check()?;
    Ok(limits)
}

/// Runs `learner serve`.
pub fn run(args: &ServeArgs) -> Result<Summary> {
    let sessions = session_limits(args)?;
    let cfg = resolve_config(&args.run)?;
    check_out(&args.run, &cfg)?;
    if !args.listen.ip().is_loopback() && args.token.is_none() && args.tls_cert.is_none() {
        tracing::warn!(
            listen = %args.listen,
            "serving beyond loopback without --token or TLS: anyone who can reach this port can join"
        );
    }
    if args.max_message_bytes < 1024 {
        bail!(
            "--max-message-bytes {} is too small for any fragment",
            args.max_message_bytes
        );
    }
    if let Some(addr) = args.run.metrics {
        install_metrics(addr)?;
    }
    let interrupt = Arc::new(AtomicBool::new(false));
    watch_signals(interrupt.clone());
    if args.run.stop_when_stdin_closes {
        stop_when_stdin_closes(interrupt.clone());
    }
    let opts = ServeOptions {
        token: args.token.clone(),
        tls: args.tls_cert.clone().zip(args.tls_key.clone()),
        max_message_bytes: args.max_message_bytes,
        queue_capacity: args.queue,
        linger: Duration::from_secs(1),
        interrupt: Some(interrupt.clone()),
        sessions,
        ..ServeOptions::default()
    };
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let quiet = args.run.quiet;
    std::thread::spawn(move || {
        if let Ok(Some(addr)) = ready_rx.recv() {
            if !quiet {
                eprintln!(
                    "learner listening on {addr}; start actors with: actor --connect http://{addr}"
                );
            }
        }
    });
    let live = Live::start(&args.run.dashboard)?;
    let mut terminal = TerminalProgress::new(cfg.run.steps, args.run.quiet);
    let listener = Listener::Tcp(args.listen);
    let summary = match &live {
        Some(live) => {
            let mut progress =
                DashboardProgress::new(&mut terminal, live, args.run.dashboard.dashboard_eval);
            serve(
                &cfg,
                &args.run.out,
                &opts,
                listener,
                Some(ready_tx),
                &mut progress,
            )?
        }
        None => serve(
            &cfg,
            &args.run.out,
            &opts,
            listener,
            Some(ready_tx),
            &mut terminal,
        )?,
    };
    report(&args.run, &cfg, &summary)?;
    if let Some(live) = live {
        // Ctrl-C or SIGTERM (watch_signals) ends the lingering too.
        live.finish(Some(&interrupt));
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        serve: ServeArgs,
    }

    /// The session limits of `learner serve --out run FLAGS`.
    fn limits(flags: &[&str]) -> Result<SessionLimits> {
        let argv = ["serve", "--out", "run"]
            .into_iter()
            .chain(flags.iter().copied());
        let cli = Cli::try_parse_from(argv)?;
        session_limits(&cli.serve)
    }

    #[test]
    fn session_flags_have_defaults_and_refuse_nonsense() {
        assert_eq!(limits(&[]).unwrap(), SessionLimits::default());
        let l = limits(&["--session-idle-timeout", "2.5", "--max-sessions", "8"]).unwrap();
        assert_eq!(
            (l.idle_timeout, l.max_sessions),
            (Duration::from_millis(2500), 8)
        );
        for (bad, flag) in [
            ("--session-idle-timeout=0", "--session-idle-timeout"),
            ("--session-idle-timeout=-1", "--session-idle-timeout"),
            ("--session-idle-timeout=1e12", "--session-idle-timeout"),
            ("--max-sessions=0", "--max-sessions"),
            ("--max-sessions=99999999", "--max-sessions"),
        ] {
            let err = limits(&[bad]).unwrap_err().to_string();
            assert!(err.contains(flag), "{bad}: {err}");
        }
    }
}
