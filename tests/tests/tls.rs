//! TLS (rustls) between a learner and an actor over loopback TCP, with a
//! self-signed certificate made for the test.

use std::net::SocketAddr;
use std::time::Duration;

use buridan_actor::client::{run, url_connector, ActorOptions};
use buridan_learner::serve::{serve, Listener, ServeOptions};
use buridan_learner::train::NoProgress;
use buridan_tests::rm11_ppo;

#[test]
fn an_actor_trains_with_a_learner_over_tls() {
    let dir = tempfile::tempdir().unwrap();
    let cert = rcgen::generate_simple_self_signed(vec!["localhost".to_string()]).unwrap();
    let (cert_path, key_path) = (dir.path().join("cert.pem"), dir.path().join("key.pem"));
    std::fs::write(&cert_path, cert.cert.pem()).unwrap();
    std::fs::write(&key_path, cert.key_pair.serialize_pem()).unwrap();
    let opts = ServeOptions {
        tls: Some((cert_path.clone(), key_path)),
        token: Some("t".into()),
        ..ServeOptions::default()
    };
    let out = dir.path().join("run");
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let learner = std::thread::spawn(move || {
        serve(
            &rm11_ppo(4000, 2),
            &out,
            &opts,
            Listener::Tcp("127.0.0.1:0".parse().unwrap()),
            Some(ready_tx),
            &mut NoProgress,
        )
    });
    let addr: SocketAddr = ready_rx
        .recv_timeout(Duration::from_secs(60))
        .unwrap()
        .unwrap();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let actor_opts = ActorOptions {
        token: Some("t".into()),
        give_up_after: Some(Duration::from_secs(30)),
        backoff_initial: Duration::from_millis(50),
        ..ActorOptions::default()
    };
    // Without the CA the handshake fails: the actor gives up.
    let plain = url_connector(&format!("https://localhost:{}", addr.port()), None).unwrap();
    let quick = ActorOptions {
        give_up_after: Some(Duration::from_millis(1)),
        ..actor_opts.clone()
    };
    assert!(rt.block_on(run(plain, quick)).is_err());
    let connector = url_connector(
        &format!("https://localhost:{}", addr.port()),
        Some(&cert_path),
    )
    .unwrap();
    let report = rt.block_on(run(connector, actor_opts)).unwrap();
    assert!(report.accepted > 0);
    let summary = learner.join().unwrap().unwrap();
    assert!(summary.env_steps >= 4000);
}
