//! The fleet control service over a real gRPC connection: an in-process
//! server on 127.0.0.1:0, a tonic client, robots played by an env whose
//! moves fail one time in ten.

use std::sync::Arc;
use std::time::Duration;

use buridan_control::{ControlServer, ServeConfig};
use buridan_env::map::MapSource;
use buridan_env::{Cell, EnvConfig, GridEnv, Map, Rules};
use buridan_proto::control_convert::{
    answer_from_message, open_to_message, report_to_message, FleetMapSource, FleetOpen,
};
use buridan_proto::v1;
use buridan_proto::v1::fleet_control_client::FleetControlClient;
use tonic::transport::Channel;
use tonic::Code;

const SHIELDED_MODEL: &str = "shield-lanes=16:checkpoint:model:rm-2.1";

fn server(cfg: ServeConfig) -> ControlServer {
    ControlServer::start(cfg, "127.0.0.1:0".parse().unwrap()).unwrap()
}

async fn client(server: &ControlServer) -> FleetControlClient<Channel> {
    FleetControlClient::connect(server.url()).await.unwrap()
}

/// The robots: episode `episode` of rm-2.1 with 4 agents, each move
/// failing with probability `delay` (seeded).
fn robots(episode: u64, delay: f32) -> GridEnv {
    let map = Arc::new(Map::load("rm-2.1").unwrap());
    let cfg = EnvConfig {
        agents: 4,
        delay,
        seed: 7,
        ..EnvConfig::default()
    };
    GridEnv::with_episode(map, cfg, episode).unwrap()
}

fn open_request(robots: &GridEnv, controller: &str) -> v1::FleetOpenRequest {
    open_to_message(&FleetOpen {
        map: FleetMapSource::Id("rm-2.1".into()),
        rules: Rules::Thesis,
        controller: controller.into(),
        positions: robots.positions(),
        goals: robots.goals(),
        seed: 42,
        shared_goals: false,
    })
}

/// Steps `robots` to the end of their episode through `session`; the
/// override flags seen.
async fn drive(
    client: &mut FleetControlClient<Channel>,
    session: u64,
    robots: &mut GridEnv,
) -> Vec<Option<Vec<bool>>> {
    let (mut rewards, mut flags) = (vec![0.0; robots.agents()], Vec::new());
    let mut steps = 0;
    while !robots.is_over() {
        let reply = client
            .step(report_to_message(
                session,
                &robots.positions(),
                &robots.goals(),
            ))
            .await
            .unwrap()
            .into_inner();
        let answer = answer_from_message(reply, robots.agents()).unwrap();
        steps += 1;
        assert_eq!(answer.step, steps);
        robots.step(&answer.moves, &mut rewards).unwrap();
        flags.push(answer.overridden);
    }
    flags
}

#[tokio::test]
async fn lacam_pibt_and_the_shield_bring_lagging_robots_home() {
    let server = server(ServeConfig::default());
    let mut client = client(&server).await;
    // PIBT solves about 9 in 10 of these episodes with 10 % delays
    // (eval/examples/fleet_delays.rs); episodes 0 and 1 are among them.
    for controller in ["lacam", "pibt", SHIELDED_MODEL] {
        for episode in 0..2 {
            let mut robots = robots(episode, 0.1);
            let open = client
                .open(open_request(&robots, controller))
                .await
                .unwrap()
                .into_inner();
            assert_eq!((open.agents, open.height, open.width), (4, 10, 20));
            assert_eq!(open.reports_overrides, controller == SHIELDED_MODEL);
            let flags = drive(&mut client, open.session, &mut robots).await;
            assert!(
                robots.stats().success,
                "{controller}, episode {episode}: {:?}",
                robots.stats()
            );
            assert!(robots.delayed_moves() > 0, "the robots lagged");
            for f in &flags {
                match (controller == SHIELDED_MODEL, f) {
                    (true, Some(f)) => assert_eq!(f.len(), 4),
                    (false, None) => {}
                    other => panic!("{controller}: flags {other:?}"),
                }
            }
            let closed = client
                .close(v1::FleetCloseRequest {
                    session: open.session,
                })
                .await
                .unwrap()
                .into_inner();
            assert_eq!(closed.steps, flags.len() as u64);
        }
    }
    server.stop().unwrap();
}

/// The status of a Step of `session` with `positions` and `goals`.
async fn refused(
    client: &mut FleetControlClient<Channel>,
    session: u64,
    positions: &[Cell],
    goals: &[Cell],
) -> tonic::Status {
    client
        .step(report_to_message(session, positions, goals))
        .await
        .unwrap_err()
}

#[tokio::test]
async fn every_bad_report_gets_its_code_and_the_session_goes_on() {
    let server = server(ServeConfig::default());
    let mut client = client(&server).await;
    let mut robots = robots(1, 0.0);
    let session = client
        .open(open_request(&robots, "lacam"))
        .await
        .unwrap()
        .into_inner()
        .session;
    let map = robots.map().clone();
    let wall = (0..200)
        .map(|k| Cell::new(k / 20, k % 20))
        .find(|&c| map.grid.is_wall(c))
        .unwrap();
    let (p, g) = (robots.positions(), robots.goals());
    let with = |cells: &[Cell], i: usize, c: Cell| {
        let mut v = cells.to_vec();
        v[i] = c;
        v
    };
    let far = (0..200)
        .map(|k| Cell::new(k / 20, k % 20))
        .find(|&c| {
            !map.grid.is_wall(c)
                && c.row.abs_diff(p[2].row) + c.col.abs_diff(p[2].col) > 1
                && !p.contains(&c)
        })
        .unwrap();
    let cases: Vec<(Vec<Cell>, Vec<Cell>, Vec<String>)> = vec![
        (
            with(&p, 1, wall),
            g.clone(),
            vec![
                "agent 1".into(),
                format!("position ({}, {}) is a wall", wall.row, wall.col),
            ],
        ),
        (
            with(&p, 3, Cell::new(10, 3)),
            g.clone(),
            vec![
                "agent 3".into(),
                "position (10, 3) is outside the grid".into(),
            ],
        ),
        (
            with(&p, 1, p[0]),
            g.clone(),
            vec![format!(
                "agents 0 and 1 share the position cell ({}, {})",
                p[0].row, p[0].col
            )],
        ),
        (
            with(&p, 2, far),
            g.clone(),
            vec!["agent 2 moved from".into(), "more than one cell".into()],
        ),
        (
            p.clone(),
            with(&g, 0, wall),
            vec!["agent 0".into(), "goal".into(), "is a wall".into()],
        ),
        (
            p[..3].to_vec(),
            g.clone(),
            vec!["positions holds 3 values, expected 4".into()],
        ),
        (
            p.clone(),
            g[..2].to_vec(),
            vec!["goals holds 2 values, expected 4".into()],
        ),
    ];
    for (positions, goals, expected) in cases {
        let status = refused(&mut client, session, &positions, &goals).await;
        assert_eq!(status.code(), Code::InvalidArgument, "{}", status.message());
        for e in expected {
            assert!(
                status.message().contains(&e),
                "'{}' lacks '{e}'",
                status.message()
            );
        }
    }
    let status = refused(&mut client, session ^ 1, &p, &g).await;
    assert_eq!(status.code(), Code::NotFound, "{}", status.message());
    assert!(status.message().contains("unknown session"));
    // The session still answers, and the robots still get home.
    drive(&mut client, session, &mut robots).await;
    assert!(robots.stats().success, "{:?}", robots.stats());
    server.stop().unwrap();
}

#[tokio::test]
async fn a_bad_open_gets_a_status_that_names_the_problem() {
    let server = server(ServeConfig::default());
    let mut client = client(&server).await;
    let robots = robots(0, 0.0);
    let good = open_request(&robots, "pibt");
    let map = robots.map().clone();
    let wall = (0..200)
        .map(|k| Cell::new(k / 20, k % 20))
        .find(|&c| map.grid.is_wall(c))
        .unwrap();
    let mut on_wall = good.clone();
    on_wall.goals[2] = v1::GridCell {
        row: wall.row as u32,
        col: wall.col as u32,
    };
    let mut unknown_map = good.clone();
    unknown_map.map = Some(v1::FleetMap {
        source: Some(v1::fleet_map::Source::Id("/etc/hostname".into())),
    });
    let mut controller = good.clone();
    controller.controller = "teleport".into();
    let mut directory = good.clone();
    directory.controller = "shield-lanes=16:checkpoint:/tmp".into();
    let mut no_map = good.clone();
    no_map.map = None;
    let mut bad_text = good.clone();
    bad_text.map = Some(v1::FleetMap {
        source: Some(v1::fleet_map::Source::Text(v1::MapSource {
            name: "x".into(),
            map_text: "type octile\nheight 1\nwidth 2\nmap\n.?\n".into(),
            scen_text: None,
        })),
    });
    for (request, expected) in [
        (on_wall, "agent 2: goal"),
        (unknown_map, "unknown map '/etc/hostname'"),
        (controller, "controller 'teleport'"),
        (directory, "bundled models only"),
        (no_map, "map is missing"),
        (bad_text, "unknown terrain character '?'"),
    ] {
        let status = client.open(request).await.unwrap_err();
        assert_eq!(status.code(), Code::InvalidArgument, "{}", status.message());
        assert!(
            status.message().contains(expected),
            "'{}' lacks '{expected}'",
            status.message()
        );
    }
    // A map sent as MovingAI text works as the bundled one does.
    let mut text = good.clone();
    text.map = Some(v1::FleetMap {
        source: Some(v1::fleet_map::Source::Text(v1::MapSource {
            name: "sent".into(),
            map_text: MapSource::read("rm-2.1").unwrap().map_text,
            scen_text: None,
        })),
    });
    let reply = client.open(text).await.unwrap().into_inner();
    assert_eq!((reply.map_name.as_str(), reply.agents), ("sent", 4));
    server.stop().unwrap();
}

#[tokio::test]
async fn sessions_and_robots_are_limited_and_closed_sessions_are_gone() {
    let server = server(ServeConfig {
        max_sessions: 2,
        max_robots: 3,
        ..ServeConfig::default()
    });
    let mut client = client(&server).await;
    let robots = robots(0, 0.0);
    let status = client
        .open(open_request(&robots, "pibt"))
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::ResourceExhausted);
    assert!(
        status
            .message()
            .contains("4 robots, more than the server's limit of 3"),
        "{}",
        status.message()
    );
    let mut three = open_request(&robots, "pibt");
    three.positions.pop();
    three.goals.pop();
    let a = client
        .open(three.clone())
        .await
        .unwrap()
        .into_inner()
        .session;
    let b = client
        .open(three.clone())
        .await
        .unwrap()
        .into_inner()
        .session;
    let status = client.open(three.clone()).await.unwrap_err();
    assert_eq!(status.code(), Code::ResourceExhausted);
    assert!(
        status.message().contains("--max-sessions 2"),
        "{}",
        status.message()
    );
    let (p, g) = (&robots.positions()[..3], &robots.goals()[..3]);
    client.step(report_to_message(a, p, g)).await.unwrap();
    let closed = client
        .close(v1::FleetCloseRequest { session: a })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(closed.steps, 1);
    let status = refused(&mut client, a, p, g).await;
    assert_eq!(status.code(), Code::NotFound);
    assert!(
        status
            .message()
            .contains(&format!("session {a} was closed")),
        "{}",
        status.message()
    );
    let status = client
        .close(v1::FleetCloseRequest { session: a })
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::NotFound);
    // Closing made room; the other session was untouched.
    client.open(three).await.unwrap();
    client.step(report_to_message(b, p, g)).await.unwrap();
    server.stop().unwrap();
}

#[tokio::test]
async fn idle_sessions_expire() {
    let server = server(ServeConfig {
        idle_timeout: Duration::from_millis(300),
        ..ServeConfig::default()
    });
    let mut client = client(&server).await;
    let robots = robots(0, 0.0);
    let (p, g) = (robots.positions(), robots.goals());
    let idle = client
        .open(open_request(&robots, "pibt"))
        .await
        .unwrap()
        .into_inner()
        .session;
    let busy = client
        .open(open_request(&robots, "pibt"))
        .await
        .unwrap()
        .into_inner()
        .session;
    // A session used within the timeout lives on.
    for _ in 0..4 {
        tokio::time::sleep(Duration::from_millis(150)).await;
        client.step(report_to_message(busy, &p, &g)).await.unwrap();
        // Robots that stay put are a valid report.
    }
    let status = refused(&mut client, idle, &p, &g).await;
    assert_eq!(status.code(), Code::NotFound);
    assert!(status.message().contains("expired"), "{}", status.message());
    client.step(report_to_message(busy, &p, &g)).await.unwrap();
    server.stop().unwrap();
}

#[tokio::test]
async fn a_token_is_required_when_set() {
    let server = server(ServeConfig {
        token: Some("s3cret".into()),
        ..ServeConfig::default()
    });
    let robots = robots(0, 0.0);
    let mut bare = client(&server).await;
    let status = bare.open(open_request(&robots, "pibt")).await.unwrap_err();
    assert_eq!(status.code(), Code::Unauthenticated);
    assert!(
        status.message().contains("needs a token"),
        "{}",
        status.message()
    );
    let channel = Channel::from_shared(server.url())
        .unwrap()
        .connect()
        .await
        .unwrap();
    for (token, ok) in [("wrong", false), ("s3cret", true)] {
        let header: tonic::metadata::MetadataValue<_> = format!("Bearer {token}").parse().unwrap();
        let mut c = FleetControlClient::with_interceptor(
            channel.clone(),
            move |mut req: tonic::Request<()>| {
                req.metadata_mut().insert("authorization", header.clone());
                Ok(req)
            },
        );
        let result = c.open(open_request(&robots, "pibt")).await;
        match (ok, result) {
            (true, Ok(_)) => {}
            (false, Err(s)) => assert_eq!(s.code(), Code::Unauthenticated),
            (ok, r) => panic!("token {token} (ok {ok}): {r:?}"),
        }
    }
    server.stop().unwrap();
}
