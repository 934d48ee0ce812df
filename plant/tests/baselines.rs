//! The baseline controllers over whole episodes (1,000 steps).

use std::sync::Arc;

use buridan_plant::controllers::{RandomController, ReservationController};
use buridan_plant::{Kpis, Plant, PlantConfig, PlantEnv};

fn episode(plant: &str, agents: usize, seed: u64, reservation: bool) -> Kpis {
    let plant = Arc::new(Plant::load(plant).unwrap());
    let cfg = PlantConfig {
        agents,
        seed,
        ..PlantConfig::default()
    };
    let mut env = PlantEnv::new(plant, cfg).unwrap();
    let mut res = ReservationController::new(agents);
    let mut random = RandomController::new(seed);
    let (mut actions, mut rewards) = (vec![0u8; agents], vec![0f32; agents]);
    while !env.is_over() {
        if reservation {
            res.actions(&env, &mut actions).unwrap();
        } else {
            random.actions(&env, &mut actions).unwrap();
        }
        env.step(&actions, &mut rewards).unwrap();
    }
    let k = env.kpis();
    assert_eq!(k.steps, 1000);
    k
}

#[test]
fn reservation_on_the_dissertation_plant_delivers_without_collisions() {
    // Measured with seed 0: 5, 8, 6, 7 deliveries for 1-4 AGVs.
    let mut deliveries = Vec::new();
    for agents in 1..=4 {
        let k = episode("dissertation", agents, 0, true);
        assert_eq!(k.collisions, 0, "{agents} AGVs: {k:?}");
        assert_eq!(k.deadlock_events, 0, "{agents} AGVs: {k:?}");
        assert!(k.deliveries >= 5, "{agents} AGVs: {k:?}");
        assert!(k.mean_lead_time.is_some_and(|t| t > 0.0 && t < 1000.0));
        deliveries.push(k.deliveries);
    }
    // A second AGV helps (the line is single-lane, so more help little).
    assert!(deliveries[1] > deliveries[0], "{deliveries:?}");
}

#[test]
fn reservation_is_collision_free_over_seeds() {
    for seed in 1..6 {
        for agents in [2, 4] {
            let k = episode("dissertation", agents, seed, true);
            assert_eq!(
                (k.collisions, k.deadlock_events),
                (0, 0),
                "seed {seed}, {agents} AGVs"
            );
            assert!(k.deliveries >= 5, "seed {seed}, {agents} AGVs: {k:?}");
        }
    }
}

#[test]
fn reservation_on_the_hall() {
    for agents in [1, 4, 7] {
        let k = episode("hall", agents, 0, true);
        assert_eq!((k.collisions, k.deadlock_events), (0, 0), "{agents} AGVs");
        assert!(k.deliveries >= 4, "{agents} AGVs: {k:?}");
    }
}

#[test]
fn random_agvs_collide_and_deliver_nothing() {
    // A random walk rarely gets anywhere in 1,000 steps; with 4 AGVs on a
    // single line they keep meeting head-on.
    let k = episode("dissertation", 4, 0, false);
    assert_eq!(k.deliveries, 0);
    assert!(k.collisions > 50, "{k:?}");
    let alone = episode("dissertation", 1, 0, false);
    assert_eq!(alone.collisions, 0);
}
