//! `learner serve`: the learner as a gRPC server for `actor` processes.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Result};

use crate::train::{
    check_out, install_metrics, report, resolve_config, stop_when_stdin_closes, TerminalProgress,
    TrainArgs,
};
use buridan_learner::serve::{serve, Listener, ServeOptions, DEFAULT_MAX_MESSAGE_BYTES};
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
}

/// Runs `learner serve`.
pub fn run(args: &ServeArgs) -> Result<Summary> {
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
    let mut terminal = TerminalProgress::new(cfg.steps, args.run.quiet);
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

/// Sets `flag` on Ctrl-C or SIGTERM (a supervisor stopping the learner):
/// the run checkpoints and exits, actors wait for its restart.
fn watch_signals(flag: Arc<AtomicBool>) {
    std::thread::spawn(move || {
        let Ok(rt) = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
        else {
            return;
        };
        rt.block_on(async {
            #[cfg(unix)]
            {
                let mut term =
                    match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
                    {
                        Ok(t) => t,
                        Err(_) => {
                            let _ = tokio::signal::ctrl_c().await;
                            return;
                        }
                    };
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            }
            #[cfg(not(unix))]
            let _ = tokio::signal::ctrl_c().await;
        });
        tracing::warn!("stopping: checkpointing after the current update");
        flag.store(true, Ordering::SeqCst);
    });
}
