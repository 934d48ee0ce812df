//! Success of controllers driving lagging robots through a closed-loop
//! [`FleetSession`], beside their success when they follow the harness's
//! open loop (`learner eval --delay P`).
//!
//! ```text
//! cargo run --release -p buridan-eval --example fleet_delays -- \
//!     MAP AGENTS EPISODES DELAY[,DELAY…] CONTROLLER[,CONTROLLER…] > fleet.csv
//! ```
//!
//! The robots are a [`GridEnv`] whose moves fail with probability DELAY
//! (`EnvConfig::delay`), thesis rules, env seed 42, episodes 0..EPISODES
//! (the seed-42 protocol's instances). Each episode opens a session on the
//! robots' starts and goals; every step the session gets the robots'
//! positions and answers with their moves. Prints one CSV row per
//! controller and delay: `controller,delay,episodes,success,median_steps,replans`.

use std::sync::Arc;

use buridan_env::{EnvConfig, GridEnv, Map, Rules};
use buridan_eval::by_name::Controller;
use buridan_eval::fleet::{play, FleetSession};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [map, agents, episodes, delays, controllers] = args.as_slice() else {
        return Err(
            "usage: fleet_delays MAP AGENTS EPISODES DELAY[,DELAY...] CONTROLLER[,CONTROLLER...]"
                .into(),
        );
    };
    let map = Arc::new(Map::load(map)?);
    let (agents, episodes): (usize, u64) = (agents.parse()?, episodes.parse()?);
    println!("controller,delay,episodes,success,median_steps,replans");
    for name in controllers.split(',') {
        let spec: Controller = name.parse()?;
        let made = spec.factory(agents, 42, Default::default(), Rules::Thesis)?();
        for delay in delays.split(',') {
            let delay: f32 = delay.parse()?;
            let cfg = EnvConfig {
                agents,
                delay,
                seed: 42,
                sensor_range: made.obs_sensor_range(),
                features: made.obs_features(),
                ..EnvConfig::default()
            };
            let (mut solved, mut steps, mut replans) = (0, Vec::new(), 0);
            for episode in 0..episodes {
                let mut robots = GridEnv::with_episode(map.clone(), cfg.clone(), episode)?;
                let mut fleet = FleetSession::open(
                    map.clone(),
                    Rules::Thesis,
                    &spec,
                    &robots.positions(),
                    &robots.goals(),
                    42,
                )?;
                play(&mut robots, &mut fleet, |_| {})?;
                replans += fleet.replans();
                if robots.stats().success {
                    solved += 1;
                    steps.push(robots.t());
                }
            }
            steps.sort_unstable();
            let median = steps
                .get(steps.len() / 2)
                .map_or(String::new(), |s| s.to_string());
            println!(
                "{name},{delay},{episodes},{:.3},{median},{replans}",
                solved as f64 / episodes as f64
            );
        }
    }
    Ok(())
}
