//! The step bench's workload, deterministic, for profilers and for
//! comparing builds:
//!
//! ```sh
//! cargo build --release -p buridan-env --example step_instructions
//! perf record target/release/examples/step_instructions grid 16 2000000
//! valgrind --tool=callgrind target/release/examples/step_instructions grid 16 200000
//! ```
//!
//! `grid AGENTS STEPS` steps one `GridEnv` on rm-2.1 (the bench's
//! `rules_only`), `local|central AGENTS STEPS` a 64-env `VecEnv` (the bench's
//! `vec_env_step`), with uniform random actions drawn beforehand. It prints a
//! checksum of the deadlock monitor's verdicts: builds that agree print the
//! same. Instruction counts are reproducible, but branch-free code runs more
//! instructions in less time: time the builds side by side too.

use std::sync::Arc;

use buridan_env::{EnvConfig, GridEnv, Map, ObsKind, VecEnv};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: step_instructions grid|local|central AGENTS STEPS";
    let (Some(mode), Some(agents), Some(steps)) = (args.get(1), args.get(2), args.get(3)) else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let agents: usize = agents.parse().expect("AGENTS is a number");
    let steps: usize = steps.parse().expect("STEPS is a number");
    let map = Arc::new(Map::load("rm-2.1").expect("bundled map"));
    let cfg = EnvConfig {
        agents,
        seed: 1,
        ..EnvConfig::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(agents as u64);
    let envs = if mode == "grid" { 1 } else { 64 };
    let batches: Vec<Vec<u8>> = (0..512)
        .map(|_| {
            (0..envs * agents)
                .map(|_| rng.random_range(0..5u8))
                .collect()
        })
        .collect();
    let mut check = 0u64;
    let episode = |s: buridan_env::EpisodeStats| {
        u64::from(s.deadlock_steps) << 20
            | u64::from(s.livelock_steps) << 10
            | u64::from(s.deadlock_events)
    };
    if mode == "grid" {
        let mut env = GridEnv::new(map, cfg).expect("valid config");
        let mut rewards = vec![0.0; agents];
        for k in 0..steps {
            let out = env
                .step(&batches[k % 512], &mut rewards)
                .expect("valid actions");
            let m = env.monitor();
            check += (m.deadlocked() * 1000 + m.livelocked()) as u64;
            if out.done() {
                check += episode(env.stats());
                env.reset_next(1).expect("next episode");
            }
        }
    } else {
        let kind = match mode.as_str() {
            "local" => ObsKind::Local,
            "central" => ObsKind::Central,
            _ => {
                eprintln!("{usage}");
                std::process::exit(2);
            }
        };
        let mut venv = VecEnv::new(map, cfg, 64, kind, 1).expect("valid config");
        for k in 0..steps {
            venv.step(&batches[k % 512]).expect("valid actions");
            check += venv.obs()[0] as u64;
        }
        check += venv.drain_episodes().into_iter().map(episode).sum::<u64>();
    }
    println!("{mode} {agents} agents, {steps} steps: check {check}");
}
