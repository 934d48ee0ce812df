//! A `learner serve` on a loopback port in a thread, for the tests that
//! talk to it as clients (`serve_hardening.rs`, `misbehave.rs`).

// Each test binary that includes this module uses a part of it.
#![allow(dead_code)]

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use buridan_learner::serve::{serve, Listener, ServeError, ServeOptions, SessionLimits};
use buridan_learner::train::{NoProgress, Summary, TrainConfig};
use buridan_proto::v1::learner_client::LearnerClient;
use tonic::transport::Channel;

/// A learner serving on loopback until dropped (then interrupted).
pub struct Learner {
    /// Where it listens.
    pub addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<Result<Summary, ServeError>>>,
    _dir: tempfile::TempDir,
}

impl Learner {
    /// Serves `cfg` with `sessions` limits on a free loopback port, its
    /// run directory a temporary one; returns once it listens.
    pub fn serve(cfg: TrainConfig, sessions: SessionLimits) -> Learner {
        let dir = tempfile::tempdir().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let opts = ServeOptions {
            interrupt: Some(stop.clone()),
            linger: Duration::ZERO,
            sessions,
            ..ServeOptions::default()
        };
        let out = dir.path().to_path_buf();
        let (ready_tx, ready) = std::sync::mpsc::channel();
        let thread = std::thread::spawn(move || {
            serve(
                &cfg,
                &out,
                &opts,
                Listener::Tcp("127.0.0.1:0".parse().unwrap()),
                Some(ready_tx),
                &mut NoProgress,
            )
        });
        let addr = ready
            .recv_timeout(Duration::from_secs(120))
            .expect("the learner starts")
            .expect("a TCP address");
        Learner {
            addr,
            stop,
            thread: Some(thread),
            _dir: dir,
        }
    }

    /// Its URL, `http://ADDR`.
    pub fn url(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// A connected channel.
    pub async fn channel(&self) -> Channel {
        Channel::from_shared(self.url())
            .unwrap()
            .connect()
            .await
            .unwrap()
    }

    /// A connected client.
    pub async fn client(&self) -> LearnerClient<Channel> {
        LearnerClient::new(self.channel().await)
    }
}

impl Drop for Learner {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
