//! `learner serve` against clients that misbehave, over loopback TCP:
//! implausible fragments, undecodable messages and corrupt or oversized
//! compressed observations get `INVALID_ARGUMENT` (and the learner carries
//! on), idle sessions expire while watching ones
//! stay, and joins beyond the session cap get `RESOURCE_EXHAUSTED` until a
//! session leaves or expires.

use std::time::{Duration, Instant};

use buridan_actor::client::build_collector;
use buridan_actor::misbehave::RawCodec;
use buridan_learner::serve::SessionLimits;
use buridan_learner::train::{RunConfig, Task, TrainConfig};
use buridan_proto::convert::{
    fragment_to_message, fragment_to_message_encoded, weights_from_message, WireTag,
};
use buridan_proto::v1;
use buridan_proto::v1::learner_client::LearnerClient;
use prost::Message;
use rand::{Rng, SeedableRng};
use tonic::transport::Channel;
use tonic::{Code, Status};

mod support;
use support::Learner;

/// Serves rm-1.1 with 2 agents (fixed starts), fragments of 20 steps,
/// with `sessions` limits.
fn start(sessions: SessionLimits) -> Learner {
    let cfg = TrainConfig {
        task: Task::Grid("rm-1.1".into()),
        agents: 2,
        starts: buridan_env::Starts::Fixed,
        run: RunConfig {
            steps: 10_000_000,
            envs_per_actor: 1,
            fragment_len: 20,
            ..RunConfig::default()
        },
        ..TrainConfig::default()
    };
    Learner::serve(cfg, sessions)
}

async fn join(client: &mut LearnerClient<Channel>, name: &str) -> Result<v1::JoinReply, Status> {
    client
        .join(v1::JoinRequest {
            api_version: v1::ApiVersion::V2 as u32,
            actor_name: name.into(),
            envs: 1,
        })
        .await
        .map(|r| r.into_inner())
}

async fn watch(
    client: &mut LearnerClient<Channel>,
    join: &v1::JoinReply,
) -> Result<tonic::Streaming<v1::Parameters>, Status> {
    client
        .watch_parameters(v1::WatchRequest {
            run_id: join.run_id.clone(),
            session: join.session,
        })
        .await
        .map(|r| r.into_inner())
}

/// Joins as `name`, loads the first weights and collects one honest
/// fragment; the join reply comes back for tagging submissions, and the
/// parameter stream to be held open (closing it ends the session).
async fn join_and_collect(
    client: &mut LearnerClient<Channel>,
    name: &str,
) -> (
    v1::JoinReply,
    tonic::Streaming<v1::Parameters>,
    buridan_policy::Fragment,
) {
    let joined = join(client, name).await.unwrap();
    let mut stream = watch(client, &joined).await.unwrap();
    let weights = stream.message().await.unwrap().expect("weights");
    let mut collector = build_collector(&joined).unwrap();
    collector
        .load(&weights_from_message(weights).unwrap())
        .unwrap();
    let good = collector.collect().unwrap();
    (joined, stream, good)
}

/// The wire tag of this session's `seq`-th submission.
fn wire_tag(joined: &v1::JoinReply, seq: u64) -> WireTag {
    WireTag {
        run_id: joined.run_id.clone(),
        session: joined.session,
        seq,
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
fn implausible_rewards_are_refused_naming_the_field_and_training_goes_on() {
    let learner = start(SessionLimits::default());
    runtime().block_on(async {
        let mut client = learner.client().await;
        let (joined, _stream, good) = join_and_collect(&mut client, "liar").await;
        let tag = |seq| wire_tag(&joined, seq);

        let mut bad = good.clone();
        bad.rewards[17] = 1e30;
        let status = client
            .submit_fragment(fragment_to_message(bad, &tag(1)))
            .await
            .expect_err("a reward of 1e30 is refused");
        assert_eq!(status.code(), Code::InvalidArgument, "{status:?}");
        assert!(
            status
                .message()
                .starts_with("fragment.rewards[17] = 1e30 is outside the env's reward range ["),
            "{}",
            status.message()
        );

        let reply = client
            .submit_fragment(fragment_to_message(good, &tag(2)))
            .await
            .expect("the same fragment with its real rewards is taken")
            .into_inner();
        assert!(reply.accepted, "{reply:?}");
    });
}

#[test]
fn bad_compressed_observations_are_refused_naming_the_field_and_training_goes_on() {
    let learner = start(SessionLimits::default());
    runtime().block_on(async {
        let mut client = learner.client().await;
        let (joined, _stream, good) = join_and_collect(&mut client, "squeezer").await;
        assert_eq!(
            joined.run.as_ref().unwrap().obs_encodings,
            [v1::ObsEncoding::Codes as i32, v1::ObsEncoding::Lz4 as i32]
        );
        let tag = |seq| wire_tag(&joined, seq);
        let packed = |seq, encoding| fragment_to_message_encoded(good.clone(), &tag(seq), encoding);
        let refused = |m: v1::Fragment| {
            let mut client = client.clone();
            async move {
                let status = client.submit_fragment(m).await.expect_err("refused");
                assert_eq!(status.code(), Code::InvalidArgument, "{status:?}");
                status.message().to_string()
            }
        };

        for encoding in [v1::ObsEncoding::Lz4, v1::ObsEncoding::Codes] {
            // A corrupt buffer: its bytes cut short (it then fails to parse,
            // or parses to less than the shape asks, depending on where the
            // cut falls).
            let values = format!("{} values", good.obs.len());
            let mut m = packed(1, encoding);
            m.obs.truncate(m.obs.len() / 2);
            let message = refused(m).await;
            assert!(message.starts_with("malformed fragment: obs "), "{message}");
            assert!(message.contains(&values), "{message}");
            // ... and its bytes garbled.
            let mut m = packed(1, encoding);
            m.obs
                .iter_mut()
                .for_each(|b| *b = b.wrapping_mul(7).wrapping_add(13));
            let message = refused(m).await;
            assert!(message.starts_with("malformed fragment: obs "), "{message}");
            // A buffer that decodes to more than its shape asks: last_obs
            // carrying all of obs.
            let mut m = packed(2, encoding);
            m.last_obs = packed(2, encoding).obs;
            let message = refused(m).await;
            assert!(
                message.starts_with("malformed fragment: last_obs "),
                "{message}"
            );
            // A shape far beyond the run's fragments: refused before decoding.
            let mut m = packed(3, encoding);
            m.len = 1 << 20;
            let message = refused(m).await;
            assert!(
                message.starts_with("malformed fragment: obs would decode to "),
                "{message}"
            );
            assert!(message.contains("over the limit of"), "{message}");
        }
        // An encoding from the future.
        let mut m = packed(4, v1::ObsEncoding::Codes);
        m.obs_encoding = 9;
        let message = refused(m).await;
        assert_eq!(
            message,
            "malformed fragment: obs_encoding 9 is not a known encoding (0 raw, 1 LZ4, 2 codes)"
        );

        // The learner carries on: the same fragment, well packed either way,
        // and then raw, are taken.
        for m in [
            packed(5, v1::ObsEncoding::Lz4),
            packed(6, v1::ObsEncoding::Codes),
            fragment_to_message(good.clone(), &tag(7)),
        ] {
            let reply = client.submit_fragment(m).await.expect("taken").into_inner();
            assert!(reply.accepted, "{reply:?}");
        }
    });
}

#[test]
fn random_bytes_get_invalid_argument() {
    let learner = start(SessionLimits::default());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(16);
    runtime().block_on(async {
        let mut grpc = tonic::client::Grpc::new(learner.channel().await);
        for method in ["Join", "WatchParameters", "SubmitFragment"] {
            let bytes: Vec<u8> = (0..64).map(|_| rng.random()).collect();
            // The bytes must really be undecodable as every request type.
            assert!(v1::JoinRequest::decode(&bytes[..]).is_err());
            assert!(v1::WatchRequest::decode(&bytes[..]).is_err());
            assert!(v1::Fragment::decode(&bytes[..]).is_err());
            grpc.ready().await.unwrap();
            let path = format!("/buridan.v1.Learner/{method}").parse().unwrap();
            let request = tonic::Request::new(bytes);
            let status = if method == "WatchParameters" {
                grpc.server_streaming(request, path, RawCodec)
                    .await
                    .map(|_| ())
            } else {
                grpc.unary(request, path, RawCodec).await.map(|_| ())
            }
            .expect_err("random bytes are refused");
            assert_eq!(status.code(), Code::InvalidArgument, "{method}: {status:?}");
            assert!(
                status.message().contains("message could not be decoded"),
                "{method}: {}",
                status.message()
            );
            // The server's counting mark is not sent on.
            assert!(status.metadata().get("buridan-undecodable").is_none());
        }
        // The learner still answers well-formed calls.
        let mut client = learner.client().await;
        join(&mut client, "after").await.unwrap();
    });
}

#[test]
fn idle_sessions_expire_while_watching_ones_stay() {
    let idle_timeout = Duration::from_millis(400);
    let learner = start(SessionLimits {
        idle_timeout,
        max_sessions: 16,
    });
    runtime().block_on(async {
        let mut client = learner.client().await;
        let idle = join(&mut client, "idle").await.unwrap();
        let watching = join(&mut client, "watching").await.unwrap();
        let mut stream = watch(&mut client, &watching).await.unwrap();
        let weights = stream.message().await.unwrap().expect("weights");
        tokio::time::sleep(idle_timeout * 3).await;

        let status = watch(&mut client, &idle)
            .await
            .expect_err("the idle session expired");
        assert_eq!(status.code(), Code::NotFound, "{status:?}");
        assert!(
            status
                .message()
                .starts_with(&format!("unknown session {}", idle.session)),
            "{}",
            status.message()
        );
        // A well-formed fragment naming it is refused the same way.
        let mut collector = build_collector(&idle).unwrap();
        collector
            .load(&weights_from_message(weights).unwrap())
            .unwrap();
        let status = client
            .submit_fragment(fragment_to_message(
                collector.collect().unwrap(),
                &wire_tag(&idle, 1),
            ))
            .await
            .expect_err("the idle session expired");
        assert_eq!(status.code(), Code::NotFound, "{status:?}");

        // The watching session is still open: a second stream is accepted.
        watch(&mut client, &watching)
            .await
            .expect("a session with an open stream never expires");
    });
}

#[test]
fn joins_beyond_the_cap_are_refused_until_a_session_leaves_or_expires() {
    let idle_timeout = Duration::from_millis(800);
    let learner = start(SessionLimits {
        idle_timeout,
        max_sessions: 2,
    });
    runtime().block_on(async {
        let mut client = learner.client().await;
        let a = join(&mut client, "a").await.unwrap();
        let mut a_stream = watch(&mut client, &a).await.unwrap();
        a_stream.message().await.unwrap().expect("weights");
        join(&mut client, "b").await.unwrap();

        let status = join(&mut client, "c").await.expect_err("the third join");
        assert_eq!(status.code(), Code::ResourceExhausted, "{status:?}");
        assert!(
            status.message().contains("2 sessions") && status.message().contains("--max-sessions"),
            "{}",
            status.message()
        );

        // a leaves (its only stream closes): c gets in.
        drop(a_stream);
        let c = retry_join(&mut client, "c", Duration::from_secs(10)).await;
        let c_joined = Instant::now();
        let status = join(&mut client, "d").await.expect_err("full again");
        assert_eq!(status.code(), Code::ResourceExhausted, "{status:?}");

        // b and c never watch: once b expires, d gets in.
        let started = Instant::now();
        retry_join(&mut client, "d", Duration::from_secs(10)).await;
        assert!(
            started.elapsed() >= idle_timeout / 2,
            "d got in before b could expire"
        );
        // c, joined after b, expires in its turn (the sweep runs every
        // idle_timeout / 4).
        let c_expired = c_joined + idle_timeout + idle_timeout / 2;
        tokio::time::sleep(c_expired.saturating_duration_since(Instant::now())).await;
        let status = watch(&mut client, &c).await.expect_err("c expired");
        assert_eq!(status.code(), Code::NotFound, "{status:?}");
    });
}

/// Joins, retrying every 50 ms while the cap refuses, for at most `limit`.
async fn retry_join(
    client: &mut LearnerClient<Channel>,
    name: &str,
    limit: Duration,
) -> v1::JoinReply {
    let start = Instant::now();
    loop {
        match join(client, name).await {
            Ok(j) => return j,
            Err(s) if s.code() == Code::ResourceExhausted && start.elapsed() < limit => {
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
            Err(s) => panic!("join {name}: {s:?}"),
        }
    }
}
