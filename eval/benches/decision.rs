//! The latency of one fleet decision on one core: the shipped warehouse
//! policy (`models/pogema-warehouse`) choosing every robot's move, raw and
//! through the collision shield (`shield-settle=16`), on POGEMA's
//! warehouse under pogema rules with 32 to 192 robots.
//!
//! `cargo bench -p buridan-eval --bench decision -- --warm-up-time 1 --measurement-time 3`
//!
//! The instance is `env/benches/data/warehouse.map` with its `.scen`
//! (`../shared/pogema/warehouse-192-0.scen`: the first N robots). One
//! iteration is one `Controller::act` for the whole fleet (observations,
//! the policy's forward pass, the shield's PIBT pass); the env step that
//! follows it, to move the fleet on to the next state, is outside the
//! timing (`iter_custom`). An episode that ends starts again from the
//! instance (`begin_episode`: the recurrent state reset).

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use buridan_env::{EnvConfig, GridEnv, Map, Rules, Starts};
use buridan_eval::by_name::Controller as ControllerSpec;
use buridan_mapf::Limits;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

/// Robot counts: POGEMA's warehouse set runs 32 to 192.
const AGENTS: [usize; 4] = [32, 64, 128, 192];

fn decision(c: &mut Criterion) {
    buridan_policy::threads::pin_threads(1);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let map = Arc::new(Map::from_file(&root.join("env/benches/data/warehouse.map")).unwrap());
    let model = root.join("models/pogema-warehouse");
    let rules = Rules::Pogema;
    let mut group = c.benchmark_group("decision/warehouse");
    group.sample_size(20);
    for agents in AGENTS {
        for wrapper in ["", "shield-settle=16:"] {
            let spec: ControllerSpec = format!("{wrapper}checkpoint:{}", model.display())
                .parse()
                .unwrap();
            let mut controller = spec.factory(agents, 42, Limits::default(), rules).unwrap()();
            let cfg = EnvConfig {
                agents,
                starts: Starts::Fixed,
                t_max: rules.default_t_max(),
                sensor_range: controller.obs_sensor_range(),
                features: controller.obs_features(),
                ..EnvConfig::for_rules(rules)
            };
            let mut env = GridEnv::new(map.clone(), cfg).unwrap();
            controller.begin_episode(&env).unwrap();
            let (mut actions, mut rewards) = (vec![0u8; agents], vec![0.0f32; agents]);
            let label = if wrapper.is_empty() {
                "raw"
            } else {
                "shield-settle=16"
            };
            group.throughput(Throughput::Elements(agents as u64));
            group.bench_function(BenchmarkId::new(label, format!("{agents}_agents")), |b| {
                b.iter_custom(|iters| {
                    let mut spent = Duration::ZERO;
                    for _ in 0..iters {
                        let started = Instant::now();
                        controller.act(&env, &mut actions);
                        spent += started.elapsed();
                        let out = env.step(&actions, &mut rewards).unwrap();
                        controller.after_step(&rewards);
                        if out.done() {
                            env.reset_to(0).unwrap();
                            controller.begin_episode(&env).unwrap();
                        }
                    }
                    spent
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, decision);
criterion_main!(benches);
