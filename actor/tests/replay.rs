//! A remote actor replays failed episodes when the learner's join reply asks
//! for it (`[replay]`), and refuses replay settings out of range.

use buridan_actor::client::build_collector;
use buridan_env::{local_obs_dim, EnvConfig, MapSource};
use buridan_policy::{Mode, ModelSpec};
use buridan_proto::convert::{env_to_message, map_to_message, model_spec_to_message};
use buridan_proto::v1;

/// A join reply for 2 envs of rm-2.1 whose episodes end after 5 steps —
/// too few for an untrained policy to solve them.
fn join(replay: Option<v1::FailureReplay>) -> v1::JoinReply {
    let env = EnvConfig {
        t_max: 5,
        ..EnvConfig::default()
    };
    let spec = ModelSpec::new(Mode::Ctde, env.agents, local_obs_dim(env.sensor_range));
    v1::JoinReply {
        run_id: "run".into(),
        envs: 2,
        seed: 3,
        run: Some(v1::RunSpec {
            model: Some(model_spec_to_message(&spec)),
            map: Some(map_to_message(&MapSource::read("rm-2.1").unwrap())),
            env: Some(env_to_message(&env)),
            fragment_len: 40,
            on_policy: true,
            replay,
            ..Default::default()
        }),
        ..Default::default()
    }
}

#[test]
fn a_join_reply_with_replay_replays_failed_episodes() {
    let replay = v1::FailureReplay {
        share: 1.0,
        tries: 2,
        capacity: 8,
    };
    let mut collector = build_collector(&join(Some(replay))).unwrap();
    let episodes = collector.collect().unwrap().episodes;
    // 40 steps of 2 envs: 16 episodes of 5 steps, each failed one replayed
    // twice before the next fresh one.
    assert_eq!(episodes.len(), 16);
    assert!(episodes.iter().all(|e| !e.success));
    let attempts: Vec<u32> = episodes.iter().map(|e| e.replay).collect();
    assert_eq!(
        attempts.iter().filter(|&&a| a == 0).count(),
        6,
        "{attempts:?}"
    );
    assert!(attempts.iter().all(|&a| a <= 2), "{attempts:?}");

    let mut plain = build_collector(&join(None)).unwrap();
    let episodes = plain.collect().unwrap().episodes;
    assert!(episodes.iter().all(|e| e.replay == 0));
}

#[test]
fn replay_settings_out_of_range_are_refused() {
    let bad = v1::FailureReplay {
        share: 0.5,
        tries: 2,
        capacity: 0,
    };
    let err = build_collector(&join(Some(bad)))
        .err()
        .expect("capacity 0 is refused");
    assert!(err.to_string().contains("replay.capacity"), "{err}");
}
