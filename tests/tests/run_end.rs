//! The end of a run is data, not an error message: a client that never
//! reads a status message sees it in the replies — over the in-process
//! exchange and over gRPC (in-memory transport and real TCP).

use std::net::SocketAddr;
use std::sync::mpsc as std_mpsc;
use std::time::Duration;

use buridan_actor::client::{build_collector, run, ActorOptions};
use buridan_learner::serve::{serve, Listener, ServeOptions};
use buridan_learner::train::exchange::{Shared, Ticket};
use buridan_learner::train::gate::Staleness;
use buridan_learner::train::NoProgress;
use buridan_policy::Weights;
use buridan_proto::convert::{fragment_to_message, weights_from_message, WireTag};
use buridan_proto::v1;
use buridan_proto::v1::learner_client::LearnerClient;
use buridan_tests::{rm11_ppo, InMemoryNet};
use tonic::transport::Channel;

#[test]
fn in_process_actors_see_the_end_as_a_ticket() {
    let shared = std::sync::Arc::new(Shared::new(Weights::default(), Staleness::OnPolicy));
    let actor = {
        let shared = shared.clone();
        std::thread::spawn(move || {
            let mut tickets = Vec::new();
            loop {
                let t = shared.ticket(100);
                tickets.push(t);
                if t == Ticket::Finished {
                    return tickets;
                }
            }
        })
    };
    // Version 1 wants 200 env steps: two tickets of 100, then the actor waits.
    shared.publish(
        Weights {
            version: 1,
            ..Weights::default()
        },
        Some(200),
    );
    std::thread::sleep(Duration::from_millis(100));
    shared.finish();
    let tickets = actor.join().unwrap();
    assert_eq!(
        tickets,
        vec![Ticket::Collect(1), Ticket::Collect(1), Ticket::Finished]
    );
    // Whoever asks after the end is told so at once.
    assert_eq!(shared.ticket(100), Ticket::Finished);
}

/// Joins with one env; any error status fails the test.
async fn join_as(client: &mut LearnerClient<Channel>, name: &str) -> v1::JoinReply {
    client
        .join(v1::JoinRequest {
            api_version: v1::ApiVersion::V2 as u32,
            actor_name: name.into(),
            envs: 1,
        })
        .await
        .expect("a join is answered, never refused with a status")
        .into_inner()
}

/// A raw client that joins, keeps one valid fragment, follows the
/// parameter stream to its `finished` message, then joins and submits
/// again: every answer is `Ok`, and the end shows in `run_finished`.
async fn end_seen_through_data_fields(channel: Channel) {
    let mut client = LearnerClient::new(channel);
    let join = join_as(&mut client, "data-only").await;
    assert!(!join.run_finished);
    let mut stream = client
        .watch_parameters(v1::WatchRequest {
            run_id: join.run_id.clone(),
            session: join.session,
        })
        .await
        .expect("watch")
        .into_inner();
    let first = stream.message().await.expect("stream").expect("weights");
    let mut collector = build_collector(&join).unwrap();
    collector
        .load(&weights_from_message(first).unwrap())
        .unwrap();
    let fragment = collector.collect().unwrap();
    let mut seen_end = false;
    while let Some(p) = stream.message().await.expect("stream") {
        if p.finished {
            seen_end = true;
            break;
        }
    }
    assert!(seen_end, "the stream closed without a finished message");

    let again = join_as(&mut client, "late").await;
    assert!(again.run_finished);
    assert!(again.run_id.is_empty() && again.run.is_none());

    let tag = WireTag {
        run_id: join.run_id.clone(),
        session: join.session,
        seq: 1,
    };
    let reply = client
        .submit_fragment(fragment_to_message(fragment, &tag))
        .await
        .expect("a late fragment is answered, not refused")
        .into_inner();
    assert!(reply.run_finished && !reply.accepted, "{reply:?}");
}

fn serve_options() -> ServeOptions {
    ServeOptions {
        // Keep answering long enough after the end for the late calls.
        linger: Duration::from_secs(3),
        ..ServeOptions::default()
    }
}

fn actor_options() -> ActorOptions {
    ActorOptions {
        name: "driver".into(),
        backoff_initial: Duration::from_millis(50),
        give_up_after: Some(Duration::from_secs(60)),
        ..ActorOptions::default()
    }
}

#[test]
fn grpc_clients_see_the_end_in_the_replies_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    let net = InMemoryNet::default();
    let rx = net.plug_learner();
    let cfg = rm11_ppo(4_000, 4);
    let out = dir.path().to_path_buf();
    let learner = std::thread::spawn(move || {
        serve(
            &cfg,
            &out,
            &serve_options(),
            Listener::InMemory(rx),
            None,
            &mut NoProgress,
        )
    });
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let watcher = end_seen_through_data_fields(net.channel().await.unwrap());
        let driver = run(net.connector(), actor_options());
        let ((), report) = tokio::join!(watcher, driver);
        assert!(report.unwrap().accepted > 0);
    });
    learner.join().unwrap().unwrap();
}

#[test]
fn grpc_clients_see_the_end_in_the_replies_over_tcp() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = rm11_ppo(4_000, 4);
    let out = dir.path().to_path_buf();
    let (ready_tx, ready) = std_mpsc::channel::<Option<SocketAddr>>();
    let learner = std::thread::spawn(move || {
        let listener = Listener::Tcp("127.0.0.1:0".parse().unwrap());
        serve(
            &cfg,
            &out,
            &serve_options(),
            listener,
            Some(ready_tx),
            &mut NoProgress,
        )
    });
    let addr = ready.recv().unwrap().expect("a TCP address");
    let url = format!("http://{addr}");
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let channel = Channel::from_shared(url.clone())
            .unwrap()
            .connect()
            .await
            .unwrap();
        let connector = buridan_actor::client::url_connector(&url, None).unwrap();
        let watcher = end_seen_through_data_fields(channel);
        let driver = run(connector, actor_options());
        let ((), report) = tokio::join!(watcher, driver);
        assert!(report.unwrap().accepted > 0);
    });
    learner.join().unwrap().unwrap();
}
