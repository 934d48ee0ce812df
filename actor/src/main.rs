//! `actor --connect URL [--envs N] [--env URL]`: a stateless actor process.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result};
use buridan_actor::client::{run, url_connector, ActorOptions};
use buridan_proto::v1::ObsEncoding;
use clap::Parser;

/// Runs env instances with the learner's policy and streams trajectory
/// fragments to it. Config and weights come from the learner; on a lost
/// connection the actor reconnects with backoff. Exits 0 when the learner
/// finishes the run.
#[derive(Debug, Parser)]
#[command(name = "actor", version)]
struct Args {
    /// The learner's URL, e.g. http://127.0.0.1:50051 (https://… for TLS).
    #[arg(long, env = "BURIDAN_LEARNER")]
    connect: String,
    /// Envs to run (default: the run's `envs_per_actor`; with --env, the
    /// env server's).
    #[arg(long, conflicts_with = "env")]
    envs: Option<u32>,
    /// Step the envs of an external env server (env.proto, e.g.
    /// `plant-server`) at this URL, e.g. http://127.0.0.1:50061, instead of
    /// building them from the learner's run; required for plant runs.
    #[arg(long, env = "BURIDAN_ENV")]
    env: Option<String>,
    /// Shared token, if the learner was started with one.
    #[arg(long, env = "BURIDAN_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// CA certificate (PEM) to verify a TLS learner.
    #[arg(long)]
    tls_ca: Option<PathBuf>,
    /// Name shown in the learner's logs (default: the host name).
    #[arg(long)]
    name: Option<String>,
    /// Stop after this many seconds without reaching the learner (default: retry forever).
    #[arg(long)]
    give_up_after: Option<f64>,
    /// Longest wait between reconnect attempts, in seconds.
    #[arg(long, default_value_t = 5.0)]
    backoff_max: f64,
    /// How observations travel when the learner accepts it: `codes` (2-bit
    /// codes), `lz4` or `raw`; a learner that lacks it gets the cheapest
    /// packing it lists, else raw.
    #[arg(long, default_value = "codes", value_parser = parse_obs_encoding)]
    obs_encoding: ObsEncoding,
    /// Niceness of the actor's threads (0–19): on a machine the actor
    /// shares with the learner, 10 lets the learner's update thread, the
    /// run's bottleneck, keep its core (IMPALA over gRPC on 2 cores: 0.89
    /// of the embedded run's speed instead of 0.85, README "Measured on
    /// this 2-core machine"). 0: the learner's priority.
    #[arg(long, default_value_t = 0, env = "BURIDAN_ACTOR_NICE", value_parser = clap::value_parser!(u8).range(0..=19))]
    nice: u8,
    /// Send observations uncompressed (`--obs-encoding raw`; to measure what
    /// packing saves).
    #[arg(long, conflicts_with = "obs_encoding")]
    raw_obs: bool,
}

/// `--obs-encoding`'s names.
fn parse_obs_encoding(name: &str) -> Result<ObsEncoding, String> {
    match name {
        "codes" => Ok(ObsEncoding::Codes),
        "lz4" => Ok(ObsEncoding::Lz4),
        "raw" => Ok(ObsEncoding::Raw),
        other => Err(format!(
            "unknown observation encoding '{other}': expected codes, lz4 or raw"
        )),
    }
}

fn main() -> Result<()> {
    buridan_serving::logging::init("info");
    let args = Args::parse();
    // Before any thread exists, so that every thread inherits it.
    if args.nice > 0 {
        buridan_policy::threads::lower_priority(args.nice)
            .with_context(|| format!("lowering the actor's priority to nice {}", args.nice))?;
    }
    // One candle thread: the actor's batches are small (see README).
    buridan_policy::threads::pin_threads(1);
    let name = args.name.clone().unwrap_or_else(|| {
        std::env::var("HOSTNAME")
            .ok()
            .filter(|h| !h.is_empty())
            .or_else(|| {
                std::fs::read_to_string("/etc/hostname")
                    .ok()
                    .map(|h| h.trim().to_string())
            })
            .unwrap_or_else(|| format!("actor-{}", std::process::id()))
    });
    let opts = ActorOptions {
        name,
        envs: args.envs,
        token: args.token.clone(),
        env: args.env.clone(),
        give_up_after: args.give_up_after.map(Duration::from_secs_f64),
        backoff_max: Duration::from_secs_f64(args.backoff_max.max(0.1)),
        obs_encoding: if args.raw_obs {
            ObsEncoding::Raw
        } else {
            args.obs_encoding
        },
        ..ActorOptions::default()
    };
    let connector = url_connector(&args.connect, args.tls_ca.as_deref())?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .max_blocking_threads(1)
        .enable_all()
        .build()?;
    let report = runtime.block_on(run(connector, opts))?;
    eprintln!(
        "run finished: {} fragments accepted, {} refused, {} lost, {} env steps, {} session(s), {} env server reconnect(s)",
        report.accepted,
        report.refused,
        report.lost,
        report.env_steps,
        report.sessions,
        report.env_reconnects
    );
    Ok(())
}
