//! `RemoteEnv` against the reference env server (`buridan_plant_server`)
//! over loopback TCP: the same steps as a local plant batch through the
//! `BatchedEnv` trait (masks widened to the policy's heads), bad input
//! answered with the right status, and a server that stops and restarts.

use std::time::Duration;

use buridan_actor::misbehave::RawCodec;
use buridan_actor::remote_env::{RemoteEnv, RemoteEnvError, RemoteEnvOptions};
use buridan_env::{BatchedEnv, EnvError, ObsKind};
use buridan_plant::{PlantConfig, PlantVecEnv};
use buridan_plant_server::{EnvServer, ServeConfig};
use buridan_proto::v1;
use buridan_proto::v1::environment_client::EnvironmentClient;
use tonic::Code;

fn config(agents: usize, envs: usize, t_max: u32) -> ServeConfig {
    ServeConfig::load("dissertation", agents, envs, Some(t_max)).unwrap()
}

fn start(cfg: ServeConfig) -> EnvServer {
    EnvServer::start(cfg, "127.0.0.1:0".parse().unwrap()).unwrap()
}

fn opts(mask_slots: Option<usize>) -> RemoteEnvOptions {
    RemoteEnvOptions {
        mask_slots,
        connect_timeout: Duration::from_secs(2),
        call_timeout: Duration::from_secs(5),
    }
}

#[test]
fn a_remote_env_steps_like_the_local_batch_with_masks_widened_to_the_heads() {
    let (agents, envs, t_max, seed) = (2, 4, 12, 3);
    let cfg = config(agents, envs, t_max);
    let plant = cfg.plant.clone();
    let server = start(cfg);
    let mut remote = RemoteEnv::connect(&server.url(), seed, &opts(Some(5))).unwrap();
    let local_cfg = PlantConfig {
        agents,
        seed,
        normalize: true,
        action_slots: 5,
    };
    let mut local = PlantVecEnv::new(plant, local_cfg, envs, ObsKind::Local).unwrap();
    assert_eq!(
        (remote.rows(), remote.obs_dim()),
        (local.rows(), local.obs_dim())
    );
    assert_eq!(remote.obs(), local.obs());
    assert_eq!(
        remote.masks(),
        local.masks(),
        "3 actions widened to 5 slots"
    );
    let mut episodes = 0;
    for step in 0..30 {
        let actions: Vec<u8> = (0..envs * agents).map(|i| ((step + i) % 3) as u8).collect();
        remote.step(&actions).unwrap();
        local.step(&actions).unwrap();
        assert_eq!(remote.rewards(), local.rewards(), "step {step}");
        assert_eq!(remote.obs(), local.obs(), "step {step}");
        assert_eq!(remote.masks(), local.masks(), "step {step}");
        assert_eq!(remote.truncated(), local.truncated());
        assert_eq!(remote.terminated(), local.terminated());
        if local.truncated().iter().any(|&t| t != 0) {
            assert_eq!(remote.final_obs(), local.final_obs(), "step {step}");
        }
        let (r, l) = (remote.drain_episodes(), local.drain_episodes());
        assert_eq!(r, l, "step {step}");
        let kpis = remote.drain_kpis();
        assert_eq!(kpis.len(), r.len());
        for (k, stats) in kpis.iter().zip(&r) {
            let deliveries = k.iter().find(|(n, _)| n == "deliveries").unwrap().1;
            assert_eq!(deliveries, f64::from(stats.goals_reached));
        }
        episodes += r.len();
    }
    // 30 steps of episodes of 12: two rounds of 4 envs.
    assert_eq!(episodes, 8);
}

#[test]
fn bad_input_gets_a_status_naming_the_problem_and_the_server_carries_on() {
    let server = start(config(2, 8, 50));
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let channel = tonic::transport::Endpoint::from_shared(server.url())
            .unwrap()
            .connect()
            .await
            .unwrap();
        let mut c = EnvironmentClient::new(channel.clone());
        let session = c
            .reset(v1::ResetRequest { seed: 1 })
            .await
            .unwrap()
            .into_inner()
            .session;
        let step = |session, actions: Vec<u8>| v1::StepRequest { session, actions };
        let err = c.step(step(session, vec![0; 15])).await.unwrap_err();
        assert_eq!(err.code(), Code::InvalidArgument, "{err:?}");
        assert!(
            err.message()
                .starts_with("actions holds 15 values, expected 16 (8 envs x 2 agents"),
            "{}",
            err.message()
        );
        let mut actions = vec![0; 16];
        actions[5] = 3;
        let err = c.step(step(session, actions)).await.unwrap_err();
        assert_eq!(err.code(), Code::InvalidArgument);
        assert!(
            err.message()
                .starts_with("actions[5] = 3 is out of range (must be < 3)"),
            "{}",
            err.message()
        );
        let err = c.step(step(session + 100, vec![0; 16])).await.unwrap_err();
        assert_eq!(err.code(), Code::NotFound);
        assert!(
            err.message()
                .contains(&format!("unknown session {}", session + 100)),
            "{}",
            err.message()
        );
        let err = c.step(step(0, vec![0; 16])).await.unwrap_err();
        assert_eq!(err.code(), Code::FailedPrecondition);
        assert!(
            err.message().contains("call Reset first"),
            "{}",
            err.message()
        );
        // Bytes that are no StepRequest.
        let mut grpc = tonic::client::Grpc::new(channel);
        grpc.ready().await.unwrap();
        let path = "/buridan.v1.Environment/Step".parse().unwrap();
        let err = grpc
            .unary(tonic::Request::new(vec![0xff; 8]), path, RawCodec)
            .await
            .unwrap_err();
        assert_eq!(err.code(), Code::InvalidArgument, "{err:?}");
        assert!(
            err.message()
                .starts_with("the StepRequest message could not be decoded"),
            "{}",
            err.message()
        );
        // Still serving, the session intact.
        let reply = c
            .step(step(session, vec![1; 16]))
            .await
            .unwrap()
            .into_inner();
        assert_eq!(reply.rewards.len(), 16);
    });
}

#[test]
fn a_stopped_server_is_a_retryable_error_and_a_restarted_one_serves_new_sessions() {
    let cfg = config(2, 2, 50);
    let server = start(cfg.clone());
    let addr = server.addr();
    let url = server.url();
    let mut env = RemoteEnv::connect(&url, 9, &opts(None)).unwrap();
    env.step(&[1, 1, 1, 1]).unwrap();
    server.stop().unwrap();
    let err = env.step(&[1, 1, 1, 1]).unwrap_err();
    match &err {
        EnvError::Remote {
            target, retryable, ..
        } => {
            assert_eq!(target, &url);
            assert!(*retryable, "{err}");
        }
        other => panic!("not a remote error: {other:?}"),
    }
    let refused = RemoteEnv::connect(&url, 9, &opts(None)).unwrap_err();
    assert!(
        matches!(refused, RemoteEnvError::Connect { .. }) && refused.retryable(),
        "{refused:?}"
    );
    // The simulator comes back on the same address: the old session is
    // gone (NOT_FOUND, retryable), a new one steps.
    let server = EnvServer::start(cfg, addr).unwrap();
    let err = env.step(&[1, 1, 1, 1]).unwrap_err();
    assert!(
        matches!(&err, EnvError::Remote { retryable: true, message, .. } if message.contains("unknown session")),
        "{err:?}"
    );
    let mut again = RemoteEnv::connect(&url, 9, &opts(None)).unwrap();
    again.step(&[1, 1, 1, 1]).unwrap();
    drop(server);
}

#[test]
fn a_policy_with_fewer_slots_than_the_server_has_actions_is_refused() {
    let server = start(config(2, 2, 50));
    let err = RemoteEnv::connect(&server.url(), 0, &opts(Some(2))).unwrap_err();
    assert!(
        matches!(
            err,
            RemoteEnvError::TooManyActions {
                actions: 3,
                slots: 2,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(!err.retryable());
    let err = RemoteEnv::connect("localhost:1", 0, &opts(None)).unwrap_err();
    assert!(matches!(err, RemoteEnvError::Url { .. }), "{err:?}");
}
