//! Runs the reservation and random controllers (and, for reference, every
//! AGV always driving forward) for one episode on a plant with 1–4 AGVs and
//! prints their KPIs.
//!
//! `cargo run -p buridan-plant --example baselines -- [plant] [seed]`

use std::sync::Arc;

use buridan_plant::controllers::{RandomController, ReservationController};
use buridan_plant::{Kpis, Plant, PlantConfig, PlantEnv};

fn run(plant: &Arc<Plant>, agents: usize, seed: u64, controller: &str) -> Kpis {
    let cfg = PlantConfig {
        agents,
        seed,
        ..PlantConfig::default()
    };
    let Ok(mut env) = PlantEnv::new(plant.clone(), cfg) else {
        return Kpis::default();
    };
    let mut res = ReservationController::new(agents);
    let mut random = RandomController::new(seed);
    let (mut actions, mut rewards) = (vec![0u8; agents], vec![0f32; agents]);
    while !env.is_over() {
        let chosen = match controller {
            "reservation" => res.actions(&env, &mut actions),
            "random" => random.actions(&env, &mut actions),
            _ => {
                actions.fill(buridan_plant::FORWARD);
                Ok(())
            }
        };
        if chosen
            .and_then(|_| env.step(&actions, &mut rewards).map(|_| ()))
            .is_err()
        {
            break;
        }
    }
    env.kpis()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let id = args.get(1).map_or("dissertation", String::as_str);
    let seed = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let plant = match Plant::load(id) {
        Ok(p) => Arc::new(p),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    println!("| controller | AGVs | deliveries | per hour | collisions | deadlocks | deadlock steps | util A | util B | lead time s | reward |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let max_agents = plant.starts.len().min(4);
    for controller in ["reservation", "random", "forward"] {
        for agents in 1..=max_agents {
            let k = run(&plant, agents, seed, controller);
            println!(
                "| {} | {agents} | {} | {:.1} | {} | {} | {} | {:.2} | {:.2} | {} | {:.1} |",
                controller,
                k.deliveries,
                k.throughput_per_hour,
                k.collisions,
                k.deadlock_events,
                k.deadlock_steps,
                k.unit_utilisation.first().copied().unwrap_or(0.0),
                k.unit_utilisation.get(1).copied().unwrap_or(0.0),
                k.mean_lead_time
                    .map_or("-".to_string(), |t| format!("{t:.0}")),
                k.reward,
            );
        }
    }
}
