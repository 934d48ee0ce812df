//! The reference env server end to end in-process, over loopback TCP: a
//! session steps exactly like a local `PlantVecEnv` with the same seed and
//! actions (observations, masks, rewards, flags, final observations,
//! finished episodes and their KPIs), episodes end at T_max, and sessions
//! beyond the limit evict the least recently used.

use buridan_env::{BatchedEnv, ObsKind};
use buridan_plant::{PlantConfig, PlantVecEnv};
use buridan_plant_server::{EnvServer, ServeConfig};
use buridan_proto::env_convert::{ended, spec_from_message};
use buridan_proto::v1;
use buridan_proto::v1::environment_client::EnvironmentClient;
use tonic::transport::Channel;
use tonic::Code;

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
}

fn start(agents: usize, envs: usize, t_max: u32, kind: ObsKind, max_sessions: usize) -> EnvServer {
    let mut cfg = ServeConfig::load("dissertation", agents, envs, Some(t_max)).unwrap();
    cfg.kind = kind;
    cfg.max_sessions = max_sessions;
    EnvServer::start(cfg, "127.0.0.1:0".parse().unwrap()).unwrap()
}

async fn client(server: &EnvServer) -> EnvironmentClient<Channel> {
    EnvironmentClient::connect(server.url()).await.unwrap()
}

/// A deterministic action stream over all three actions (masked ones
/// included: the server and the local batch get the same).
fn actions(step: usize, n: usize) -> Vec<u8> {
    (0..n).map(|i| ((step * 7 + i * 3) % 5 % 3) as u8).collect()
}

#[test]
fn a_session_steps_exactly_like_a_local_plant_vec_env() {
    for kind in [ObsKind::Local, ObsKind::Central] {
        let (agents, envs, t_max, seed) = (2, 3, 25, 11);
        let server = start(agents, envs, t_max, kind, 4);
        let rt = runtime();
        let mut c = rt.block_on(client(&server));
        let spec = rt
            .block_on(c.spec(v1::SpecRequest {}))
            .unwrap()
            .into_inner();
        let spec = spec_from_message(&spec).unwrap();
        let cfg = ServeConfig::load("dissertation", agents, envs, Some(t_max)).unwrap();
        let plant_cfg = PlantConfig {
            agents,
            seed,
            normalize: true,
            action_slots: 3,
        };
        let mut local = PlantVecEnv::new(cfg.plant.clone(), plant_cfg, envs, kind).unwrap();
        assert_eq!(
            (spec.num_envs, spec.agents, spec.kind, spec.obs_dim),
            (envs, agents, kind, local.obs_dim())
        );
        assert_eq!((spec.num_actions, spec.t_max), (3, t_max));
        assert_eq!(spec.name, "plant:dissertation");

        let reset = rt
            .block_on(c.reset(v1::ResetRequest { seed }))
            .unwrap()
            .into_inner();
        assert_ne!(reset.session, 0);
        assert_eq!(reset.obs, local.obs());
        assert_eq!(reset.masks, local.masks());

        let mut finished = 0;
        for step in 0..2 * t_max as usize + 3 {
            let a = actions(step, envs * agents);
            let reply = rt
                .block_on(c.step(v1::StepRequest {
                    session: reset.session,
                    actions: a.clone(),
                }))
                .unwrap()
                .into_inner();
            local.step(&a).unwrap();
            assert_eq!(reply.rewards, local.rewards(), "{kind:?} step {step}");
            assert_eq!(reply.obs, local.obs(), "step {step}");
            assert_eq!(reply.masks, local.masks(), "step {step}");
            assert_eq!(reply.terminated, local.terminated());
            assert_eq!(reply.truncated, local.truncated());
            let row = spec.rows_per_env() * spec.obs_dim;
            let ended_envs: Vec<usize> = ended(local.terminated(), local.truncated()).collect();
            let mut final_obs = Vec::new();
            for &e in &ended_envs {
                final_obs.extend_from_slice(&local.final_obs()[e * row..(e + 1) * row]);
            }
            assert_eq!(reply.final_obs, final_obs, "step {step}");
            let stats = local.drain_episodes();
            let kpis = local.drain_kpis();
            assert_eq!(reply.episodes.len(), stats.len());
            for ((m, s), (k, &e)) in reply
                .episodes
                .iter()
                .zip(&stats)
                .zip(kpis.iter().zip(&ended_envs))
            {
                assert_eq!(m.env as usize, e);
                assert_eq!(
                    (m.reward, m.length, m.goals_reached),
                    (s.reward, s.length, s.goals_reached)
                );
                assert_eq!(m.length, t_max, "episodes end at T_max");
                assert_eq!(m.kpis["deliveries"], f64::from(k.deliveries));
                assert_eq!(m.kpis["collisions"], f64::from(k.collisions));
                assert!(m.kpis.contains_key("utilisation_A"));
            }
            // Every env ends its episode at T_max, all in the same step.
            let at_end = (step + 1) % t_max as usize == 0;
            assert_eq!(
                ended_envs.len(),
                if at_end { envs } else { 0 },
                "step {step}"
            );
            finished += stats.len();
        }
        assert_eq!(finished, 2 * envs);
        server.stop().unwrap();
    }
}

#[test]
fn sessions_beyond_the_limit_evict_the_least_recently_used() {
    let server = start(2, 2, 50, ObsKind::Local, 2);
    let rt = runtime();
    rt.block_on(async {
        let mut c = client(&server).await;
        let base = c.clone();
        let reset = |seed| {
            let mut c = base.clone();
            async move {
                c.reset(v1::ResetRequest { seed })
                    .await
                    .unwrap()
                    .into_inner()
                    .session
            }
        };
        let a = reset(1).await;
        let b = reset(2).await;
        let step = |session| v1::StepRequest {
            session,
            actions: vec![0; 4],
        };
        c.step(step(a)).await.unwrap();
        // b is now the least recently used: a third session evicts it.
        let third = reset(3).await;
        assert!(third != a && third != b);
        let err = c.step(step(b)).await.unwrap_err();
        assert_eq!(err.code(), Code::NotFound, "{err:?}");
        assert!(
            err.message().contains(&format!("unknown session {b}")),
            "{err:?}"
        );
        c.step(step(a)).await.unwrap();
        c.step(step(third)).await.unwrap();
    });
}

#[test]
fn the_same_seed_gives_the_same_session_and_another_seed_another() {
    let server = start(2, 2, 50, ObsKind::Local, 4);
    let rt = runtime();
    rt.block_on(async {
        let mut c = client(&server).await;
        let mut first = Vec::new();
        for seed in [5, 5, 6] {
            let r = c
                .reset(v1::ResetRequest { seed })
                .await
                .unwrap()
                .into_inner();
            first.push(r.obs);
        }
        assert_eq!(first[0], first[1]);
        assert_ne!(first[0], first[2]);
    });
}

#[test]
fn a_session_of_a_server_before_its_restart_is_not_found_after_it() {
    let rt = runtime();
    let server = start(2, 2, 50, ObsKind::Local, 4);
    let old = rt.block_on(async {
        let mut c = client(&server).await;
        c.reset(v1::ResetRequest { seed: 1 })
            .await
            .unwrap()
            .into_inner()
            .session
    });
    drop(server);
    // The restarted server's first sessions must not answer to the old id
    // (a counter would hand out the same id again).
    let server = start(2, 2, 50, ObsKind::Local, 4);
    rt.block_on(async {
        let mut c = client(&server).await;
        let mut fresh = Vec::new();
        for seed in 1..=3 {
            let r = c.reset(v1::ResetRequest { seed }).await.unwrap();
            fresh.push(r.into_inner().session);
        }
        assert!(!fresh.contains(&old), "{old} reissued: {fresh:?}");
        let err = c
            .step(v1::StepRequest {
                session: old,
                actions: vec![0; 4],
            })
            .await
            .unwrap_err();
        assert_eq!(err.code(), Code::NotFound, "{err:?}");
    });
}
