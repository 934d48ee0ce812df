//! The distributed learner and actors in one process, connected by tonic
//! over in-memory streams: learning, a dropped actor, malformed input,
//! tokens, a learner restart, the session cap.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc as std_mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::Result;
use buridan_actor::client::{build_collector, run, ActorError, ActorOptions, ActorReport};
use buridan_learner::serve::{serve, Listener, ServeError, ServeOptions, SessionLimits};
use buridan_learner::train::{MetricsRow, Progress, Summary, TrainConfig, TrainError};
use buridan_proto::convert::{fragment_to_message, weights_from_message, WireTag};
use buridan_proto::v1;
use buridan_proto::v1::learner_client::LearnerClient;
use buridan_tests::{rm11_ppo, InMemoryNet};
use tonic::Code;

/// Reports each finished update to the test.
struct Updates(std_mpsc::Sender<u64>);

impl Progress for Updates {
    fn on_update(&mut self, row: &MetricsRow) {
        let _ = self.0.send(row.update);
    }
}

fn start_learner(
    net: &InMemoryNet,
    cfg: TrainConfig,
    out: std::path::PathBuf,
    opts: ServeOptions,
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
            &opts,
            Listener::InMemory(rx),
            None,
            &mut Updates(tx),
        )
    });
    (handle, updates)
}

fn actor_opts(name: &str) -> ActorOptions {
    ActorOptions {
        name: name.into(),
        backoff_initial: Duration::from_millis(50),
        backoff_max: Duration::from_millis(500),
        give_up_after: Some(Duration::from_secs(60)),
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
fn two_actors_train_rm11_to_reward_3() {
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let mut cfg = rm11_ppo(200_000, 8);
    cfg.run.stop_return = Some(2.95);
    let (learner, _updates) = start_learner(&net, cfg, dir.path().into(), ServeOptions::default());
    let rt = runtime();
    let a = rt.spawn(run(net.connector(), actor_opts("a")));
    let b = rt.spawn(run(net.connector(), actor_opts("b")));
    let summary = learner.join().unwrap().unwrap();
    let reports: Vec<ActorReport> =
        rt.block_on(async { vec![a.await.unwrap().unwrap(), b.await.unwrap().unwrap()] });
    assert!(
        summary.episode_return_mean >= 2.95,
        "return {} after {} steps",
        summary.episode_return_mean,
        summary.env_steps
    );
    assert!(summary.stopped_early);
    for r in &reports {
        assert!(r.accepted > 0, "{r:?}");
        assert_eq!(r.sessions, 1);
    }
    assert!(dir.path().join("summary.json").is_file());
    assert!(dir
        .path()
        .join("checkpoints/final/model.safetensors")
        .is_file());
}

#[test]
fn training_goes_on_when_an_actor_dies() {
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    // 2 actors × 4 envs × 50 steps = 400 env steps per round; 4000 per update.
    let cfg = rm11_ppo(24_000, 4);
    let (learner, updates) = start_learner(&net, cfg, dir.path().into(), ServeOptions::default());
    let rt = runtime();
    let doomed = rt.spawn(run(net.connector(), actor_opts("doomed")));
    let survivor = rt.spawn(run(net.connector(), actor_opts("survivor")));
    // Kill one actor after the second update.
    while updates.recv().unwrap() < 2 {}
    doomed.abort();
    let summary = learner.join().unwrap().unwrap();
    assert!(summary.env_steps >= 24_000);
    assert_eq!(summary.updates, 6);
    let report = rt.block_on(survivor).unwrap().unwrap();
    assert!(rt.block_on(doomed).unwrap_err().is_cancelled());
    // The survivor alone collected the last updates' batches.
    assert!(report.env_steps >= 4 * 4000 / 2, "{report:?}");
}

#[test]
fn an_actor_refused_by_the_session_cap_waits_for_room_and_trains() {
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let opts = ServeOptions {
        sessions: SessionLimits {
            idle_timeout: Duration::from_millis(800),
            max_sessions: 1,
        },
        ..ServeOptions::default()
    };
    let (learner, _updates) = start_learner(&net, rm11_ppo(8_000, 4), dir.path().into(), opts);
    let rt = runtime();
    // A client that joins and then does nothing holds the only session
    // until it idles out; the actor's joins meanwhile get RESOURCE_EXHAUSTED.
    let idle = rt.block_on(async {
        let mut client = LearnerClient::new(net.channel().await.unwrap());
        client
            .join(v1::JoinRequest {
                api_version: v1::ApiVersion::V2 as u32,
                actor_name: "idle".into(),
                envs: 2,
            })
            .await
            .unwrap()
            .into_inner()
    });
    let started = std::time::Instant::now();
    let report = rt
        .block_on(run(net.connector(), actor_opts("patient")))
        .unwrap_or_else(|e| panic!("the actor gave up instead of waiting for room: {e}"));
    let summary = learner.join().unwrap().unwrap();
    assert!(summary.env_steps >= 8_000, "{summary:?}");
    assert!(report.accepted > 0, "{report:?}");
    assert!(
        started.elapsed() >= Duration::from_millis(800),
        "the actor trained before the idle session ({}) expired",
        idle.session
    );
}

/// Joins as a raw client and collects one real fragment.
async fn raw_client(
    net: &InMemoryNet,
) -> (
    LearnerClient<tonic::transport::Channel>,
    v1::JoinReply,
    v1::Fragment,
) {
    let mut client = LearnerClient::new(net.channel().await.unwrap());
    let join = client
        .join(v1::JoinRequest {
            api_version: v1::ApiVersion::V2 as u32,
            actor_name: "raw".into(),
            envs: 2,
        })
        .await
        .unwrap()
        .into_inner();
    let mut stream = client
        .watch_parameters(v1::WatchRequest {
            run_id: join.run_id.clone(),
            session: join.session,
        })
        .await
        .unwrap()
        .into_inner();
    let weights = weights_from_message(stream.message().await.unwrap().unwrap()).unwrap();
    let mut collector = build_collector(&join).unwrap();
    collector.load(&weights).unwrap();
    let fragment = collector.collect().unwrap();
    let tag = WireTag {
        run_id: join.run_id.clone(),
        session: join.session,
        seq: 1,
    };
    // Keep the stream open: the session lives as long as it does.
    std::mem::forget(stream);
    (client, join, fragment_to_message(fragment, &tag))
}

#[test]
fn malformed_fragments_get_a_status_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let opts = ServeOptions {
        max_message_bytes: 256 * 1024,
        ..ServeOptions::default()
    };
    let (learner, _updates) = start_learner(&net, rm11_ppo(8000, 2), dir.path().into(), opts);
    let rt = runtime();
    rt.block_on(async {
        let (mut client, join, good) = raw_client(&net).await;
        let submit = |m: v1::Fragment| {
            let mut c = client.clone();
            async move { c.submit_fragment(m).await }
        };
        let expect =
            |r: Result<tonic::Response<v1::SubmitReply>, tonic::Status>, code: Code, text: &str| {
                let s = r.expect_err("should be refused");
                assert_eq!(s.code(), code, "{s:?}");
                assert!(
                    s.message().contains(text),
                    "'{}' lacks '{text}'",
                    s.message()
                );
            };

        let mut short = good.clone();
        short.obs.truncate(short.obs.len() - 4);
        expect(
            submit(short).await,
            Code::InvalidArgument,
            "fragment obs: expected",
        );

        let mut nan = good.clone();
        nan.obs[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
        expect(submit(nan).await, Code::InvalidArgument, "obs[3] is NaN");

        let mut inf = good.clone();
        inf.rewards[0] = f32::INFINITY;
        expect(
            submit(inf).await,
            Code::InvalidArgument,
            "rewards[0] is inf",
        );

        let mut other_run = good.clone();
        other_run.run_id = "someone-else".into();
        expect(
            submit(other_run).await,
            Code::NotFound,
            "unknown run 'someone-else'",
        );

        let mut future = good.clone();
        future.policy_version = 99;
        expect(
            submit(future).await,
            Code::InvalidArgument,
            "unknown policy version 99",
        );

        let mut no_session = good.clone();
        no_session.session = 12345;
        expect(
            submit(no_session).await,
            Code::NotFound,
            "unknown session 12345",
        );

        // Shapes consistent in themselves but not with the run.
        let mut wrong_envs = good.clone();
        wrong_envs.rows = 2;
        wrong_envs.len = 25;
        wrong_envs.obs.truncate(25 * 2 * 129 * 4);
        wrong_envs.masks.truncate(25 * 2 * 5);
        wrong_envs.actions.truncate(25 * 2);
        wrong_envs.behaviour_logits.truncate(25 * 2 * 5 * 4);
        for v in [&mut wrong_envs.behaviour_logp, &mut wrong_envs.rewards] {
            v.truncate(50);
        }
        wrong_envs.terminated = vec![0; 50];
        wrong_envs.truncated = vec![0; 50];
        wrong_envs.final_obs.clear();
        wrong_envs.final_obs_index.clear();
        wrong_envs.last_obs.truncate(2 * 129 * 4);
        wrong_envs.env_steps = 25;
        expect(
            submit(wrong_envs).await,
            Code::InvalidArgument,
            "fragment len is 25; this run expects 50",
        );

        let huge = v1::Fragment {
            obs: vec![0; 400_000],
            ..good.clone()
        };
        let s = submit(huge).await.unwrap_err();
        assert_eq!(s.code(), Code::OutOfRange, "{s:?}");

        let reply = submit(good.clone()).await.unwrap().into_inner();
        assert!(reply.accepted, "{reply:?}");
        expect(submit(good).await, Code::AlreadyExists, "already received");

        // Another API version: refused naming both versions and who must
        // upgrade; v1 is the actor before the typed RunSpec.
        for (version, expected) in [
            (
                v1::ApiVersion::V1 as u32,
                "this actor speaks API v1, this learner speaks v2: upgrade the actor",
            ),
            (
                0,
                "this actor names no API version (api_version 0), this learner speaks v2: upgrade the actor",
            ),
            (
                7,
                "this actor speaks API v7, this learner speaks v2: upgrade the learner, or run an actor that speaks v2",
            ),
        ] {
            let bad_join = client
                .join(v1::JoinRequest {
                    api_version: version,
                    ..Default::default()
                })
                .await;
            let s = bad_join.unwrap_err();
            assert_eq!(s.code(), Code::FailedPrecondition, "{s:?}");
            assert_eq!(s.message(), expected);
        }
        let _ = join;
    });
    // The learner is unaffected: a real actor finishes the run.
    let report = rt
        .block_on(run(net.connector(), actor_opts("after")))
        .unwrap();
    assert!(report.accepted > 0);
    let summary = learner.join().unwrap().unwrap();
    assert!(summary.env_steps >= 8000);
}

#[test]
fn a_token_is_required_when_set() {
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let opts = ServeOptions {
        token: Some("s3cret".into()),
        ..ServeOptions::default()
    };
    let (learner, _updates) = start_learner(&net, rm11_ppo(4000, 2), dir.path().into(), opts);
    let rt = runtime();
    let refused = rt.block_on(async {
        let mut client = LearnerClient::new(net.channel().await.unwrap());
        client
            .join(v1::JoinRequest {
                api_version: v1::ApiVersion::V2 as u32,
                ..Default::default()
            })
            .await
    });
    assert_eq!(refused.unwrap_err().code(), Code::Unauthenticated);
    let wrong = ActorOptions {
        token: Some("guess".into()),
        give_up_after: Some(Duration::from_millis(1)),
        ..actor_opts("wrong")
    };
    let err = rt.block_on(run(net.connector(), wrong)).unwrap_err();
    let ActorError::Refused(status) = &err else {
        panic!("not a refusal: {err:?}");
    };
    assert_eq!(status.code(), Code::Unauthenticated);
    assert!(status.message().contains("wrong token"), "{status:?}");
    let right = ActorOptions {
        token: Some("s3cret".into()),
        ..actor_opts("right")
    };
    let report = rt.block_on(run(net.connector(), right)).unwrap();
    assert!(report.accepted > 0);
    learner.join().unwrap().unwrap();
}

#[test]
fn actors_reconnect_to_a_restarted_learner() {
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let mut cfg = rm11_ppo(20_000, 4);
    cfg.run.checkpoint_every = 1;
    let interrupt = Arc::new(AtomicBool::new(false));
    let opts = ServeOptions {
        interrupt: Some(interrupt.clone()),
        ..ServeOptions::default()
    };
    let (first, updates) = start_learner(&net, cfg.clone(), dir.path().into(), opts);
    let rt = runtime();
    let actor = rt.spawn(run(net.connector(), actor_opts("steady")));
    while updates.recv().unwrap() < 2 {}
    interrupt.store(true, Ordering::SeqCst);
    let err = first.join().unwrap().unwrap_err();
    let ServeError::Train(err) = err else {
        panic!("not a run error: {err}");
    };
    let TrainError::Interrupted(interrupted) = *err else {
        panic!("not an interruption: {err}");
    };
    assert!(interrupted.updates >= 2);
    assert!(interrupted.checkpoint.join("trainer.json").is_file());
    // The actor keeps trying while no learner answers.
    std::thread::sleep(Duration::from_millis(300));
    assert!(!actor.is_finished());

    let mut resumed = cfg;
    resumed.run.resume = Some(interrupted.checkpoint.clone());
    let (second, _updates) =
        start_learner(&net, resumed, dir.path().into(), ServeOptions::default());
    let summary = second.join().unwrap().unwrap();
    let report = rt.block_on(actor).unwrap().unwrap();
    assert!(report.sessions >= 2, "{report:?}");
    assert!(summary.env_steps >= 20_000);
    assert_eq!(
        summary.updates, 5,
        "the resumed run continues the update count"
    );
    let metrics = std::fs::read_to_string(dir.path().join("metrics.csv")).unwrap();
    assert!(metrics.lines().count() > 5, "{metrics}");
}
