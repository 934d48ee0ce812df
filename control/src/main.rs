//! `fleet-control --listen ADDR`: the fleet controller service
//! (`control.proto`): a fleet manager opens a session with a map, a
//! controller and its robots, then asks every control cycle for each
//! robot's next move.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use buridan_control::{metrics, serve, ControlService, ServeConfig};
use clap::Parser;

/// Serves any controller of the project (planners, trained policies through
/// the shield) to fleets over gRPC (buridan.v1.FleetControl). Runs until
/// Ctrl-C or SIGTERM; calls in flight then get --grace seconds.
#[derive(Debug, Parser)]
#[command(name = "fleet-control", version)]
struct Args {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:50071")]
    listen: SocketAddr,
    /// Serve Prometheus metrics on this address (http://ADDR/metrics).
    #[arg(long, value_name = "ADDR")]
    metrics: Option<SocketAddr>,
    /// Require this shared token from clients (authorization: Bearer TOKEN).
    #[arg(long, env = "BURIDAN_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// PEM certificate for TLS (with --tls-key); clients then use https://.
    #[arg(long, requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// PEM private key for TLS.
    #[arg(long, requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    /// Sessions open at once; an Open beyond gets RESOURCE_EXHAUSTED.
    #[arg(long, value_name = "N", default_value_t = buridan_control::DEFAULT_MAX_SESSIONS)]
    max_sessions: usize,
    /// Robots per session; an Open with more gets RESOURCE_EXHAUSTED.
    #[arg(long, value_name = "N", default_value_t = buridan_control::DEFAULT_MAX_ROBOTS)]
    max_robots: usize,
    /// Seconds a session may go without a call before it expires.
    #[arg(long, value_name = "SECS", default_value_t = buridan_control::DEFAULT_IDLE_TIMEOUT.as_secs_f64())]
    session_idle_timeout: f64,
    /// Seconds a planner gets for one plan (at Open and at each replan).
    #[arg(long, value_name = "SECS", default_value_t = buridan_control::DEFAULT_PLAN_TIME.as_secs_f64())]
    plan_time: f64,
    /// Count robots that stand off their goal for more than K steps
    /// (metric buridan_control_robots_waiting).
    #[arg(long, value_name = "K", default_value_t = buridan_control::DEFAULT_WAIT_ALARM)]
    wait_alarm: u32,
    /// Let controllers load checkpoints from directories on this machine
    /// (checkpoint:DIR); without it only bundled models (checkpoint:model:NAME).
    #[arg(long)]
    allow_checkpoint_dirs: bool,
    /// Largest message accepted or sent, in bytes.
    #[arg(long, default_value_t = buridan_control::DEFAULT_MAX_MESSAGE_BYTES)]
    max_message_bytes: usize,
    /// Seconds calls in flight get after Ctrl-C or SIGTERM.
    #[arg(long, value_name = "SECS", default_value_t = buridan_control::DEFAULT_GRACE.as_secs_f64())]
    grace: f64,
}

/// `secs` as a duration, or an error naming `flag`.
fn seconds(flag: &str, secs: f64) -> Result<Duration> {
    match Duration::try_from_secs_f64(secs) {
        Ok(d) => Ok(d),
        Err(_) => bail!("{flag} {secs} is not a number of seconds"),
    }
}

fn main() -> Result<()> {
    buridan_serving::logging::init("info");
    let args = Args::parse();
    let cfg = ServeConfig {
        max_sessions: args.max_sessions,
        max_robots: args.max_robots,
        idle_timeout: seconds("--session-idle-timeout", args.session_idle_timeout)?,
        plan_time: seconds("--plan-time", args.plan_time)?,
        wait_alarm: args.wait_alarm,
        allow_checkpoint_dirs: args.allow_checkpoint_dirs,
        token: args.token.clone(),
        tls: args.tls_cert.clone().zip(args.tls_key.clone()),
        max_message_bytes: args.max_message_bytes,
        grace: seconds("--grace", args.grace)?,
    };
    if !args.listen.ip().is_loopback() && cfg.token.is_none() && cfg.tls.is_none() {
        tracing::warn!(
            listen = %args.listen,
            "serving beyond loopback without --token or TLS: anyone who can reach this port can drive the fleet"
        );
    }
    let service = ControlService::new(cfg).context("cannot serve as asked")?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    runtime.block_on(async {
        if let Some(addr) = args.metrics {
            metrics::prometheus_builder()
                .context("invalid histogram buckets")?
                .with_http_listener(addr)
                .install()
                .with_context(|| format!("cannot serve metrics on {addr}"))?;
            metrics::describe();
            tracing::info!(%addr, "Prometheus metrics at http://{addr}/metrics");
        }
        let listener = tokio::net::TcpListener::bind(args.listen)
            .await
            .with_context(|| format!("cannot listen on {}", args.listen))?;
        tracing::info!(addr = %listener.local_addr()?, "fleet control service listening");
        serve(service, listener, buridan_serving::shutdown_signal())
            .await
            .context("the fleet control service failed")
    })?;
    tracing::info!("stopped");
    Ok(())
}
