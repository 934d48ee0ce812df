//! `actor --env URL` end to end: `learner serve` on a plant run (in
//! process, in-memory gRPC) and actors that step the reference env server
//! (`buridan_plant_server`, loopback TCP) — a short training run whose
//! fragments the learner accepts, the actor that has no env server and the
//! one whose server does not fit the run refused with a clear error, and an
//! env server that stops and restarts mid-run while the actor reconnects.

use std::sync::mpsc as std_mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

use buridan_actor::client::{run, ActorError, ActorOptions, SetupError};
use buridan_learner::serve::{serve, Listener, ServeError, ServeOptions};
use buridan_learner::train::{
    Algorithm, MetricsRow, ModelConfig, PpoConfig, Progress, RunConfig, Summary, Task, TrainConfig,
};
use buridan_plant_server::{EnvServer, ServeConfig};
use buridan_policy::Mode;
use buridan_tests::InMemoryNet;

struct Updates(std_mpsc::Sender<u64>);

impl Progress for Updates {
    fn on_update(&mut self, row: &MetricsRow) {
        let _ = self.0.send(row.update);
    }
}

/// PPO-CTDE on the dissertation's plant, 2 AGVs, episodes of 40 steps, a
/// tiny network: each update takes 160 env steps.
fn plant_run(steps: u64) -> TrainConfig {
    TrainConfig {
        algorithm: Algorithm::Ppo(PpoConfig {
            train_batch: 160,
            minibatch: 80,
            epochs: 2,
            ..PpoConfig::default()
        }),
        mode: Mode::Ctde,
        task: Task::Plant("dissertation".into()),
        agents: 2,
        t_max: 40,
        model: ModelConfig {
            hidden: vec![16, 16],
            ..ModelConfig::default()
        },
        run: RunConfig {
            steps,
            envs_per_actor: 4,
            fragment_len: 20,
            checkpoint_every: 0,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    }
}

fn start_learner(
    net: &InMemoryNet,
    cfg: TrainConfig,
    out: std::path::PathBuf,
) -> (
    JoinHandle<Result<Summary, ServeError>>,
    std_mpsc::Receiver<u64>,
) {
    let rx = net.plug_learner();
    let (tx, updates) = std_mpsc::channel();
    let handle = std::thread::spawn(move || {
        serve(
            &cfg,
            &out,
            &ServeOptions::default(),
            Listener::InMemory(rx),
            None,
            &mut Updates(tx),
        )
    });
    (handle, updates)
}

fn plant_server(agents: usize, envs: usize, addr: &str) -> EnvServer {
    let cfg = ServeConfig::load("dissertation", agents, envs, Some(40)).unwrap();
    EnvServer::start(cfg, addr.parse().unwrap()).unwrap()
}

fn actor_opts(name: &str, env: Option<String>) -> ActorOptions {
    ActorOptions {
        name: name.into(),
        env,
        backoff_initial: Duration::from_millis(50),
        backoff_max: Duration::from_millis(400),
        give_up_after: Some(Duration::from_secs(30)),
        ..ActorOptions::default()
    }
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap()
}

#[test]
fn a_plant_run_trains_with_an_actor_on_the_reference_env_server() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let (learner, _updates) = start_learner(&net, plant_run(2400), dir.path().into());
    let server = plant_server(2, 4, "127.0.0.1:0");
    let rt = runtime();

    // Without an env server the actor cannot run a plant run, and says so.
    let err = rt
        .block_on(run(net.connector(), actor_opts("no-env", None)))
        .unwrap_err();
    assert!(
        matches!(&err, ActorError::Setup(SetupError::NeedsEnv { plant, agents: 2 }) if plant == "plant:dissertation"),
        "{err:?}"
    );
    let why = std::error::Error::source(&err).unwrap().to_string();
    assert!(why.contains("--env URL"), "{why}");

    // An env server with 3 AGVs does not fit a 2-AGV run.
    let wrong = plant_server(3, 4, "127.0.0.1:0");
    let err = rt
        .block_on(run(net.connector(), actor_opts("wrong", Some(wrong.url()))))
        .unwrap_err();
    assert!(
        matches!(
            &err,
            ActorError::Setup(SetupError::EnvSpec { what: "agents", .. })
        ),
        "{err:?}"
    );
    if let ActorError::Setup(SetupError::EnvSpec { env, run, .. }) = &err {
        assert_eq!((env.as_str(), run.as_str()), ("3", "2"));
    }
    drop(wrong);

    let report = rt
        .block_on(run(
            net.connector(),
            actor_opts("remote", Some(server.url())),
        ))
        .unwrap();
    let summary = learner.join().unwrap().unwrap();
    assert!(summary.env_steps >= 2400, "{summary:?}");
    assert_eq!(summary.map, "plant:dissertation");
    assert!(report.accepted >= 15, "{report:?}");
    assert_eq!(report.env_reconnects, 0);
    // 4 envs × 600 steps: episodes of 40 steps finished and were counted.
    assert!(summary.episodes >= 40, "{summary:?}");
    assert_eq!(summary.episode_len_mean, 40.0);
    assert!(dir.path().join("summary.json").is_file());
}

#[test]
fn the_actor_reconnects_when_the_env_server_restarts_mid_run() {
    buridan_policy::threads::pin_threads(1);
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let (learner, updates) = start_learner(&net, plant_run(3200), dir.path().into());
    let server = plant_server(2, 4, "127.0.0.1:0");
    let (addr, url) = (server.addr().to_string(), server.url());
    let rt = runtime();
    let actor = rt.spawn(run(net.connector(), actor_opts("remote", Some(url))));
    while updates.recv().unwrap() < 3 {}
    server.stop().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let server = plant_server(2, 4, &addr);
    let summary = learner.join().unwrap().unwrap();
    let report = rt.block_on(actor).unwrap().unwrap();
    assert!(summary.env_steps >= 3200, "{summary:?}");
    assert!(report.env_reconnects >= 1, "{report:?}");
    assert_eq!(
        report.sessions, 1,
        "the learner session stayed open: {report:?}"
    );
    assert!(report.accepted >= 20, "{report:?}");
    drop(server);
}
