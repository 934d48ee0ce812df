//! `lifelong-pibt`: PIBT one step at a time, as a controller of the grammar.

use std::sync::Arc;

use buridan_env::{EnvConfig, GridEnv, Map, Rules};
use buridan_eval::by_name::Controller as Spec;
use buridan_eval::fleet::{play, FleetSession};
use buridan_eval::lifelong::LifelongPibtController;
use buridan_mapf::lifelong::{run_episode, LifelongPibt};
use buridan_mapf::{ConflictModel, Limits};

#[test]
fn the_controller_steps_as_lifelong_pibt_does() {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let spec: Spec = "lifelong-pibt".parse().unwrap();
    for rules in [Rules::Thesis, Rules::Pogema] {
        for episode in 0..3 {
            let cfg = EnvConfig {
                agents: 8,
                lifelong: true,
                t_max: 200,
                seed: 42,
                rules,
                ..EnvConfig::default()
            };
            let mut pibt = LifelongPibt::new(
                &map.grid,
                ConflictModel::from(rules),
                LifelongPibtController::episode_seed(7, episode),
            );
            let expected = run_episode(&map, &cfg, episode, &mut pibt).unwrap();

            let mut env = GridEnv::with_episode(map.clone(), cfg, episode).unwrap();
            let mut controller = spec.factory(8, 7, Limits::default(), rules).unwrap()();
            controller.begin_episode(&env).unwrap();
            let (mut actions, mut rewards) = (vec![0u8; 8], vec![0.0; 8]);
            while !env.is_over() {
                controller.act(&env, &mut actions);
                env.step(&actions, &mut rewards).unwrap();
            }
            let got = env.stats();
            assert_eq!(
                (got.goals_reached, got.length),
                (expected.goals_reached, expected.length),
                "{rules:?}, episode {episode}"
            );
            assert!(got.goals_reached > 20, "{got:?}");
        }
    }
}

#[test]
fn lagging_robots_with_changing_goals_keep_reaching_them_where_a_one_shot_planner_stalls() {
    // POGEMA's warehouse, 192 robots, lifelong goals, one move in ten fails.
    let map = Arc::new(Map::load("warehouse/33x46/seed=0").unwrap());
    let cfg = EnvConfig {
        agents: 192,
        lifelong: true,
        delay: 0.1,
        t_max: 100,
        seed: 3,
        rules: Rules::Pogema,
        ..EnvConfig::default()
    };
    let mut reached = Vec::new();
    for name in ["lifelong-pibt", "pibt"] {
        let spec: Spec = name.parse().unwrap();
        let mut robots = GridEnv::with_episode(map.clone(), cfg.clone(), 0).unwrap();
        let mut fleet = FleetSession::open(
            map.clone(),
            Rules::Pogema,
            &spec,
            &robots.positions(),
            &robots.goals(),
            42,
        )
        .unwrap();
        play(&mut robots, &mut fleet, |_| {}).unwrap();
        reached.push(robots.stats().goals_reached);
    }
    // PIBT as a planner must bring every robot home within its step
    // limit (T_max) from every reported state; in this crowd it soon
    // cannot, gives up, and the robots wait. Lifelong PIBT plans nothing.
    assert!(reached[0] >= 150, "lifelong-pibt reached {}", reached[0]);
    assert!(reached[0] > 3 * reached[1], "{reached:?}");
}
