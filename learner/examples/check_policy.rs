//! Quick check of a checkpoint: success rate, mean/median length and mean
//! return over episodes 0..N of an env seed, greedy and sampled.
//!
//! `cargo run --release -p buridan-learner --example check_policy -- CKPT MAP AGENTS fixed|random [EPISODES] [SEED]`

use std::sync::Arc;

use buridan_env::{EnvConfig, Map};
use buridan_learner::train::rollout::rollout;
use buridan_policy::{ActMode, Policy};

fn main() -> anyhow::Result<()> {
    buridan_policy::threads::pin_threads(1);
    let a: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        a.len() >= 4,
        "usage: check_policy CKPT MAP AGENTS fixed|random [EPISODES] [SEED]"
    );
    let policy = Policy::load(std::path::Path::new(&a[0]))?;
    let map = Arc::new(Map::load(&a[1])?);
    let agents: usize = a[2].parse()?;
    let starts = a[3].parse().map_err(anyhow::Error::msg)?;
    let episodes: usize = a.get(4).map_or(Ok(100), |s| s.parse())?;
    let seed: u64 = a.get(5).map_or(Ok(42), |s| s.parse())?;
    let env = EnvConfig {
        agents,
        starts,
        seed,
        ..EnvConfig::default()
    };
    for (name, mode) in [("greedy", ActMode::Greedy), ("sampled", ActMode::Sample)] {
        // One env: episodes 0, 1, … in order.
        let eps = rollout(&policy, map.clone(), env.clone(), episodes, 1, mode, 1)?;
        let n = eps.len() as f64;
        let mut lens: Vec<u32> = eps.iter().filter(|e| e.success).map(|e| e.length).collect();
        lens.sort_unstable();
        let median = if lens.is_empty() {
            f64::NAN
        } else if lens.len() % 2 == 1 {
            lens[lens.len() / 2] as f64
        } else {
            (lens[lens.len() / 2 - 1] + lens[lens.len() / 2]) as f64 / 2.0
        };
        println!(
            "{name:>7}: episodes {} success {:.3} mean length {:.2} median length (successes) {} mean return {:.3}",
            eps.len(),
            eps.iter().filter(|e| e.success).count() as f64 / n,
            eps.iter().map(|e| e.length as f64).sum::<f64>() / n,
            median,
            eps.iter().map(|e| e.reward as f64).sum::<f64>() / n
        );
    }
    Ok(())
}
