//! Properties under arbitrary actions: AGVs never overlap (the contact
//! rule stops every move at the first touch, collisions included), and
//! products are conserved.

use std::sync::Arc;

use buridan_plant::{Plant, PlantConfig, PlantEnv};
use proptest::prelude::*;

fn check_run(
    plant: &Arc<Plant>,
    agents: usize,
    seed: u64,
    actions: &[u8],
) -> Result<(), TestCaseError> {
    let cfg = PlantConfig {
        agents,
        seed,
        ..PlantConfig::default()
    };
    let mut env = PlantEnv::new(plant.clone(), cfg).unwrap();
    let mut rewards = vec![0.0f32; agents];
    let mut obs = vec![0.0f32; env.local_obs_dim()];
    for step in actions.chunks_exact(agents) {
        let before = env.kpis().collisions;
        env.step(step, &mut rewards).unwrap();
        let collided = env.kpis().collisions - before;
        // Each collision costs exactly its -1; other rewards are small.
        let collision_reward: f32 = rewards.iter().filter(|&&r| r <= -0.9).count() as f32;
        prop_assert_eq!(collision_reward as u32, collided);
        for i in 0..agents {
            for j in i + 1..agents {
                let d = env.track_distance(env.agvs()[i].pos, env.agvs()[j].pos);
                prop_assert!(
                    d >= env.contact() - 1e-6,
                    "AGVs {i} and {j} overlap: {d} m at t {}",
                    env.time()
                );
            }
            env.write_local_obs(i, &mut obs).unwrap();
            prop_assert!(obs.iter().all(|v| v.is_finite()));
        }
        let k = env.kpis();
        prop_assert_eq!(
            env.products_in_plant() as u32 + k.deliveries,
            k.products_created
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn dissertation_never_overlaps_and_conserves_products(
        agents in 1usize..=4,
        seed in 0u64..1000,
        actions in prop::collection::vec(0u8..3, 4 * 250),
    ) {
        let plant = Arc::new(Plant::load("dissertation").unwrap());
        check_run(&plant, agents, seed, &actions[..agents * 250])?;
    }

    #[test]
    fn hall_never_overlaps_and_conserves_products(
        agents in 1usize..=8,
        seed in 0u64..1000,
        actions in prop::collection::vec(0u8..3, 8 * 150),
    ) {
        let plant = Arc::new(Plant::load("hall").unwrap());
        check_run(&plant, agents, seed, &actions[..agents * 150])?;
    }

    /// Mostly forward: the AGVs actually meet and deliver.
    #[test]
    fn forward_heavy_runs_keep_the_invariants(
        agents in 2usize..=4,
        seed in 0u64..1000,
        actions in prop::collection::vec(prop::sample::select(vec![1u8, 1, 1, 1, 0, 2]), 4 * 400),
    ) {
        let plant = Arc::new(Plant::load("dissertation").unwrap());
        check_run(&plant, agents, seed, &actions[..agents * 400])?;
    }
}
