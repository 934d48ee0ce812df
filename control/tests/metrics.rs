//! The service's Prometheus series, rendered by the exporter the binary
//! installs (its own test binary: the recorder is process-wide).

use std::sync::Arc;

use buridan_control::metrics::{self as m, prometheus_builder};
use buridan_control::{ControlServer, ServeConfig};
use buridan_env::{EnvConfig, GridEnv, Map, Rules};
use buridan_proto::control_convert::{
    answer_from_message, open_to_message, report_to_message, FleetMapSource, FleetOpen,
};
use buridan_proto::v1;
use buridan_proto::v1::fleet_control_client::FleetControlClient;

/// The value of the series `name` (with its labels, as rendered) in `text`.
fn value(text: &str, name: &str) -> Option<f64> {
    text.lines()
        .find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.trim().parse().ok())
}

#[tokio::test]
async fn the_named_series_are_rendered() {
    let handle = prometheus_builder().unwrap().install_recorder().unwrap();
    let server = ControlServer::start(
        ServeConfig {
            wait_alarm: 2,
            ..ServeConfig::default()
        },
        "127.0.0.1:0".parse().unwrap(),
    )
    .unwrap();
    let mut client = FleetControlClient::connect(server.url()).await.unwrap();
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let cfg = EnvConfig {
        agents: 4,
        ..EnvConfig::default()
    };
    let mut robots = GridEnv::with_episode(map, cfg, 0).unwrap();
    let open = client
        .open(open_to_message(&FleetOpen {
            map: FleetMapSource::Id("rm-2.1".into()),
            rules: Rules::Thesis,
            controller: "shield-lanes=16:checkpoint:model:rm-2.1".into(),
            positions: robots.positions(),
            goals: robots.goals(),
            seed: 42,
            shared_goals: false,
        }))
        .await
        .unwrap()
        .into_inner();
    // Robots that never carry out their moves: after 3 reports every robot
    // off its goal has waited more than K = 2 steps.
    for _ in 0..3 {
        client
            .step(report_to_message(
                open.session,
                &robots.positions(),
                &robots.goals(),
            ))
            .await
            .unwrap();
    }
    let text = handle.render();
    let waiting = format!("{}{{over_steps=\"2\"}}", m::WAITING);
    assert_eq!(value(&text, &waiting), Some(4.0), "{text}");
    assert_eq!(value(&text, m::SESSIONS), Some(1.0), "{text}");
    assert_eq!(value(&text, m::ROBOTS), Some(4.0), "{text}");
    assert_eq!(value(&text, m::STEPS), Some(3.0), "{text}");
    assert_eq!(value(&text, m::LONG_WAITS), Some(4.0), "{text}");
    assert_eq!(
        value(&text, &format!("{}_count", m::STEP_SECONDS)),
        Some(3.0),
        "{text}"
    );
    assert!(
        text.contains(&format!("{}_bucket{{le=\"0.01\"}}", m::STEP_SECONDS)),
        "{text}"
    );
    assert!(value(&text, m::OVERRIDDEN).is_some(), "{text}");
    // Then they move: the shield's moves are carried out to the end.
    let mut rewards = [0.0; 4];
    let mut overridden = 0;
    while !robots.is_over() {
        let reply = client
            .step(report_to_message(
                open.session,
                &robots.positions(),
                &robots.goals(),
            ))
            .await
            .unwrap()
            .into_inner();
        let answer = answer_from_message(reply, 4).unwrap();
        overridden += answer.overridden.unwrap().iter().filter(|&&o| o).count();
        robots.step(&answer.moves, &mut rewards).unwrap();
    }
    assert!(robots.stats().success);
    // Home: the last report finds no robot waiting off its goal.
    client
        .step(report_to_message(
            open.session,
            &robots.positions(),
            &robots.goals(),
        ))
        .await
        .unwrap();
    let text = handle.render();
    assert_eq!(value(&text, &waiting), Some(0.0), "{text}");
    assert!(
        value(&text, m::OVERRIDDEN).unwrap() >= overridden as f64,
        "{text}"
    );
    // A refused call is counted by its code; a closed session leaves the gauges.
    let status = client
        .step(report_to_message(
            open.session,
            &robots.positions()[..2],
            &robots.goals(),
        ))
        .await
        .unwrap_err();
    assert_eq!(status.code(), tonic::Code::InvalidArgument);
    client
        .close(v1::FleetCloseRequest {
            session: open.session,
        })
        .await
        .unwrap();
    let text = handle.render();
    assert_eq!(
        value(
            &text,
            &format!("{}{{code=\"invalid_argument\"}}", m::REFUSED)
        ),
        Some(1.0),
        "{text}"
    );
    assert_eq!(value(&text, m::SESSIONS), Some(0.0), "{text}");
    assert_eq!(value(&text, m::ROBOTS), Some(0.0), "{text}");
    server.stop().unwrap();
}
