//! The throughput cost of the env API's hop: env steps per second of the
//! AGV plant stepped locally (`PlantVecEnv`) and through `RemoteEnv`
//! against the reference env server on loopback TCP, same plant, envs,
//! AGVs, seed and actions, measured in one run.
//!
//! ```sh
//! cargo run --release -p buridan-actor --example remote_env_throughput -- \
//!     [--plant dissertation] [--agents 2] [--envs 8] [--steps 20000] [--server URL]
//! ```
//!
//! Without `--server` the reference server runs in this process on its own
//! thread (as `plant-server` would in its own process); with it, the remote
//! side is that server (start it with the same plant, agents and envs).
//! Actions: each AGV drives forward when its mask allows it, else holds.

use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use buridan_actor::remote_env::{RemoteEnv, RemoteEnvOptions};
use buridan_env::{BatchedEnv, ObsKind};
use buridan_plant::{PlantConfig, PlantVecEnv, FORWARD, HOLD, NUM_ACTIONS};
use buridan_plant_server::{EnvServer, ServeConfig};

struct Args {
    plant: String,
    agents: usize,
    envs: usize,
    steps: usize,
    server: Option<String>,
}

fn args() -> Result<Args> {
    let mut a = Args {
        plant: "dissertation".into(),
        agents: 2,
        envs: 8,
        steps: 20_000,
        server: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let value = it.next().with_context(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--plant" => a.plant = value,
            "--agents" => a.agents = value.parse().context("--agents")?,
            "--envs" => a.envs = value.parse().context("--envs")?,
            "--steps" => a.steps = value.parse().context("--steps")?,
            "--server" => a.server = Some(value),
            _ => bail!("unknown flag {flag} (--plant, --agents, --envs, --steps, --server)"),
        }
    }
    Ok(a)
}

/// Forward where the mask allows it, else hold.
fn choose(env: &dyn BatchedEnv, actions: &mut [u8], slots: usize) {
    for (a, mask) in actions.iter_mut().zip(env.masks().chunks_exact(slots)) {
        *a = if mask[usize::from(FORWARD)] != 0 {
            FORWARD
        } else {
            HOLD
        };
    }
}

/// Env steps per second over `steps` batch steps (each `num_envs` env steps).
fn measure(env: &mut dyn BatchedEnv, steps: usize, slots: usize) -> Result<(f64, f32)> {
    let mut actions = vec![0u8; env.num_envs() * env.agents()];
    let mut reward = 0.0;
    let start = Instant::now();
    for _ in 0..steps {
        choose(env, &mut actions, slots);
        env.step(&actions)?;
        reward += env.rewards().iter().sum::<f32>();
    }
    let secs = start.elapsed().as_secs_f64();
    Ok(((steps * env.num_envs()) as f64 / secs, reward))
}

fn main() -> Result<()> {
    let a = args()?;
    let seed = 42;
    let cfg = ServeConfig::load(&a.plant, a.agents, a.envs, None)?;
    let plant = Arc::clone(&cfg.plant);
    let local_batch = || {
        let plant_cfg = PlantConfig {
            agents: a.agents,
            seed,
            normalize: true,
            action_slots: NUM_ACTIONS,
        };
        PlantVecEnv::new(Arc::clone(&plant), plant_cfg, a.envs, ObsKind::Local)
    };
    let (_server, url) = match &a.server {
        Some(url) => (None, url.clone()),
        None => {
            let server = EnvServer::start(cfg, "127.0.0.1:0".parse()?)?;
            let url = server.url();
            (Some(server), url)
        }
    };
    let opts = RemoteEnvOptions::default();
    // Warm up both (allocations, the connection), then measure fresh
    // batches of the same seed.
    measure(&mut local_batch()?, 200, NUM_ACTIONS)?;
    measure(
        &mut RemoteEnv::connect(&url, seed, &opts)?,
        200,
        NUM_ACTIONS,
    )?;
    let mut local = local_batch()?;
    let mut remote = RemoteEnv::connect(&url, seed, &opts)?;
    let (local_rate, local_reward) = measure(&mut local, a.steps, NUM_ACTIONS)?;
    let (remote_rate, remote_reward) = measure(&mut remote, a.steps, NUM_ACTIONS)?;
    if (local_reward - remote_reward).abs() > 1e-3 * local_reward.abs().max(1.0) {
        bail!("the two sides diverged: reward {local_reward} locally, {remote_reward} remotely");
    }
    println!(
        "plant {} with {} AGVs, {} envs, {} batch steps ({} env steps) each, seed {seed}, same actions (reward {local_reward:.2} on both sides)",
        a.plant,
        a.agents,
        a.envs,
        a.steps,
        a.steps * a.envs
    );
    println!("local  PlantVecEnv:            {local_rate:>10.0} env steps/s");
    println!("remote RemoteEnv ({url}): {remote_rate:>10.0} env steps/s");
    println!(
        "remote / local: {:.4} ({:.1} µs per batch step remotely, {:.1} µs locally)",
        remote_rate / local_rate,
        1e6 * a.envs as f64 / remote_rate,
        1e6 * a.envs as f64 / local_rate
    );
    Ok(())
}
