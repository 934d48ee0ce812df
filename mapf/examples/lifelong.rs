//! Lifelong PIBT in the env's lifelong mode: throughput (goals reached per
//! step, the env's own `EpisodeStats`) per layout and agent count.
//!
//! ```text
//! cargo run --release -p buridan-mapf --example lifelong -- STEPS EPISODES MAP[,MAP...] N[,N...]
//! ```

use std::sync::Arc;

use buridan_env::{EnvConfig, Map};
use buridan_mapf::lifelong::{run_episode, LifelongPibt};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        eprintln!("usage: lifelong STEPS EPISODES MAPS AGENT_COUNTS");
        std::process::exit(2);
    }
    let steps: u32 = args[1].parse().expect("STEPS");
    let episodes: u64 = args[2].parse().expect("EPISODES");
    println!("map,agents,episodes,steps,throughput,goals_per_agent_per_100_steps,blocked_moves,deadlock_steps");
    for m in args[3].split(',') {
        let map = Arc::new(Map::load(m).expect("map"));
        for n in args[4].split(',') {
            let agents: usize = n.parse().expect("agent count");
            let cfg = EnvConfig {
                agents,
                lifelong: true,
                t_max: steps,
                seed: 42,
                ..EnvConfig::default()
            };
            let (mut goals, mut blocked, mut deadlock) = (0u64, 0u64, 0u64);
            for e in 0..episodes {
                let mut pibt = LifelongPibt::new(&map.grid, Default::default(), e);
                let s = run_episode(&map, &cfg, e, &mut pibt).expect("episode");
                goals += u64::from(s.goals_reached);
                blocked += u64::from(s.blocked_moves);
                deadlock += u64::from(s.deadlock_steps);
            }
            let total_steps = f64::from(steps) * episodes as f64;
            let tp = goals as f64 / total_steps;
            println!(
                "{m},{agents},{episodes},{steps},{tp:.4},{:.2},{blocked},{deadlock}",
                tp * 100.0 / agents as f64
            );
        }
    }
}
