//! The service beside the same controller in-process, on POGEMA's lifelong
//! warehouse (the seed-0 goal file, 192 robots, 256 steps): driven through
//! gRPC, the robots reach the same goals at the same steps as
//! [`run_goal_file`] reaches them, with and without delays.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;

use buridan_control::{ControlServer, ServeConfig};
use buridan_env::map::MapSource;
use buridan_env::Map;
use buridan_eval::goal_sequences::GoalFile;
use buridan_eval::throughput::{lifelong_robots, run_goal_file, LifelongSpec};
use buridan_proto::control_convert::{
    answer_from_message, open_to_message, report_to_message, FleetMapSource, FleetOpen,
};
use buridan_proto::v1::fleet_control_client::FleetControlClient;
use tonic::Code;

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../eval/tests/data/lifelong")
}

/// Goals reached at each step when the service drives the robots of `file`
/// for `spec.steps` steps, the robots those of `run_goal_file`
/// ([`lifelong_robots`], so delays fall alike); and the steps at which two
/// robots headed for one cell.
async fn through_the_service(
    server: &ControlServer,
    map_text: &str,
    map: &Arc<Map>,
    file: &GoalFile,
    controller: &str,
    spec: &LifelongSpec,
) -> (Vec<u32>, usize) {
    let mut client = FleetControlClient::connect(server.url()).await.unwrap();
    let mut robots = lifelong_robots(map, file, spec).unwrap();
    let open = FleetOpen {
        map: FleetMapSource::Text(MapSource {
            name: "warehouse".into(),
            map_text: map_text.into(),
            scen_text: None,
        }),
        rules: robots.config().rules,
        controller: controller.into(),
        positions: robots.positions(),
        goals: robots.goals(),
        seed: spec.seed,
        shared_goals: true,
    };
    // Without shared goals allowed, a report naming one goal twice is refused.
    let exclusive = client
        .open(open_to_message(&FleetOpen {
            shared_goals: false,
            ..open.clone()
        }))
        .await
        .unwrap()
        .into_inner()
        .session;
    let mut twice = robots.goals();
    twice[1] = twice[0];
    let refused = client
        .step(report_to_message(exclusive, &robots.positions(), &twice))
        .await
        .unwrap_err();
    assert_eq!(refused.code(), Code::InvalidArgument, "{refused:?}");
    assert!(refused.message().contains("goal"), "{}", refused.message());
    let session = client
        .open(open_to_message(&open))
        .await
        .unwrap()
        .into_inner()
        .session;
    let (mut rewards, mut per_step, mut reached) = (vec![0.0; file.agents()], Vec::new(), 0);
    let mut shared_steps = 0;
    while !robots.is_over() {
        let goals = robots.goals();
        if goals.iter().collect::<HashSet<_>>().len() < goals.len() {
            shared_steps += 1;
        }
        let reply = client
            .step(report_to_message(
                session,
                &robots.positions(),
                &robots.goals(),
            ))
            .await
            .unwrap()
            .into_inner();
        let answer = answer_from_message(reply, file.agents()).unwrap();
        robots.step(&answer.moves, &mut rewards).unwrap();
        let now = robots.stats().goals_reached;
        per_step.push(now - reached);
        reached = now;
    }
    (per_step, shared_steps)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_service_reaches_the_goals_the_same_controller_reaches_in_process() {
    let map_text = std::fs::read_to_string(data().join("warehouse.map")).unwrap();
    let map = Arc::new(Map::from_file(&data().join("warehouse.map")).unwrap());
    let file = GoalFile::read(&data().join("warehouse-lifelong-0.goals")).unwrap();
    assert_eq!(file.agents(), 192);
    let server =
        ControlServer::start(ServeConfig::default(), "127.0.0.1:0".parse().unwrap()).unwrap();
    for delay in [0.0, 0.1] {
        let spec = LifelongSpec {
            delay,
            ..LifelongSpec::default()
        };
        let controller = "lifelong-pibt";
        let in_process =
            run_goal_file(&map, &file, "seed-0", &controller.parse().unwrap(), &spec).unwrap();
        let (served, shared_steps) =
            through_the_service(&server, &map_text, &map, &file, controller, &spec).await;
        assert_eq!(served.len(), 256);
        assert!(shared_steps > 0, "robots shared a goal on some steps");
        assert_eq!(served, in_process.per_step, "delay {delay}");
        assert!(in_process.throughput > 1.5, "{}", in_process.throughput);
    }
    server.stop().unwrap();
}
