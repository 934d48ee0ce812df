//! `plant-server --plant ID|FILE --agents N --envs E --listen ADDR`: the AGV
//! plant behind the env API (`env.proto`), for `actor --env URL`.

use std::net::SocketAddr;

use anyhow::{Context, Result};
use buridan_env::ObsKind;
use buridan_plant_server::{serve, PlantEnvService, ServeConfig, DEFAULT_MAX_SESSIONS};
use clap::Parser;

/// Serves the native AGV plant as an external env (buridan.v1.Environment):
/// each Reset opens a session of E plant envs with N AGVs, seeded by the
/// client; Step steps them all. Runs until Ctrl-C or SIGTERM.
#[derive(Debug, Parser)]
#[command(name = "plant-server", version)]
struct Args {
    /// A bundled plant id (dissertation, hall) or a plant file.
    #[arg(long, default_value = "dissertation")]
    plant: String,
    /// AGVs per env.
    #[arg(long, default_value_t = 2)]
    agents: usize,
    /// Envs per session (the actor's batch).
    #[arg(long, default_value_t = 8)]
    envs: usize,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:50061")]
    listen: SocketAddr,
    /// Observation rows: `local` (one per AGV, CTDE/DTE) or `central` (one per env, CTE).
    #[arg(long, default_value = "local", value_parser = ["local", "central"])]
    obs: String,
    /// Episode length in steps (default: the plant file's T_max).
    #[arg(long)]
    t_max: Option<u32>,
    /// Observations in raw physical units instead of scaled to about [0, 1]
    /// (`learner train --plant` trains on scaled ones).
    #[arg(long)]
    raw_obs: bool,
    /// Sessions kept at once; a Reset beyond evicts the least recently used.
    #[arg(long, default_value_t = DEFAULT_MAX_SESSIONS)]
    max_sessions: usize,
}

fn main() -> Result<()> {
    buridan_serving::logging::init("info");
    let args = Args::parse();
    let mut cfg = ServeConfig::load(&args.plant, args.agents, args.envs, args.t_max)
        .with_context(|| format!("cannot load plant '{}'", args.plant))?;
    cfg.kind = if args.obs == "central" {
        ObsKind::Central
    } else {
        ObsKind::Local
    };
    cfg.normalize = !args.raw_obs;
    cfg.max_sessions = args.max_sessions;
    let service = PlantEnvService::new(cfg).context("cannot serve the plant as asked")?;
    let spec = service.spec().clone();
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind(args.listen)
            .await
            .with_context(|| format!("cannot listen on {}", args.listen))?;
        tracing::info!(
            addr = %listener.local_addr()?,
            name = %spec.name,
            envs = spec.num_envs,
            agents = spec.agents,
            obs_dim = spec.obs_dim,
            t_max = spec.t_max,
            "plant env server listening"
        );
        serve(service, listener, buridan_serving::shutdown_signal())
            .await
            .context("the env server failed")
    })?;
    tracing::info!("stopped");
    Ok(())
}
