//! Serving: token and TLS as the learner has them, the idle sweep, a
//! graceful shutdown within a grace period, and a server on a thread of
//! its own for tests.

use std::net::SocketAddr;
use std::time::Duration;

use buridan_proto::v1::fleet_control_server::FleetControlServer;
use buridan_serving::{serve_with_grace, BearerToken, ServerError, ServerThread};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Server;

use crate::{ControlService, ServeConfig, ServeError};

/// Serves `service` on `listener` until `shutdown` completes; calls in
/// flight then get the configured grace period before the connections are
/// cut. Sessions idle past the timeout are swept meanwhile.
pub async fn serve(
    service: ControlService,
    listener: tokio::net::TcpListener,
    shutdown: impl std::future::Future<Output = ()> + Send,
) -> Result<(), ServeError> {
    let cfg: ServeConfig = service.config().clone();
    cfg.check()?;
    let mut builder =
        buridan_serving::with_tls(Server::builder(), cfg.tls.as_ref()).map_err(ServerError::Tls)?;
    let sessions = service.sessions();
    let sweep_every =
        (sessions.idle_timeout() / 4).clamp(Duration::from_millis(10), Duration::from_secs(1));
    let sweep = async move {
        let mut tick = tokio::time::interval(sweep_every);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tick.tick().await;
            sessions.expire();
        }
    };
    let svc = FleetControlServer::new(service)
        .max_decoding_message_size(cfg.max_message_bytes)
        .max_encoding_message_size(cfg.max_message_bytes);
    let check = BearerToken::new(
        cfg.token.as_deref(),
        "this service needs a token: send authorization: Bearer TOKEN (fleet-control --token)",
    )
    .on_refusal(|_| {
        ::metrics::counter!(crate::metrics::REFUSED, "code" => "unauthenticated").increment(1);
    });
    let (health_reporter, health) = tonic_health::server::health_reporter();
    health_reporter
        .set_serving::<FleetControlServer<ControlService>>()
        .await;
    let router = builder
        .add_service(health)
        .add_service(InterceptedService::new(svc, check));
    // A step is a small request answered at once: no Nagle delay.
    let incoming = buridan_serving::nodelay(listener);
    let served = serve_with_grace(
        |stopping| router.serve_with_incoming_shutdown(incoming, stopping.wait()),
        shutdown,
        cfg.grace,
    );
    tokio::select! {
        result = served => result.map_err(|e| ServerError::Transport(e).into()),
        _ = sweep => Ok(()),
    }
}

/// A service running on its own thread, stopped by [`ControlServer::stop`]
/// or when dropped.
pub struct ControlServer(ServerThread<ServeError>);

impl ControlServer {
    /// Binds `addr` (port 0: any free port) and serves `cfg` on a thread
    /// (one reactor thread; controllers on tokio's blocking threads).
    pub fn start(cfg: ServeConfig, addr: SocketAddr) -> Result<Self, ServeError> {
        let service = ControlService::new(cfg)?;
        ServerThread::spawn("fleet control service", addr, |listener, stop| {
            serve(service, listener, stop)
        })
        .map(Self)
    }

    /// The bound address.
    pub fn addr(&self) -> SocketAddr {
        self.0.addr()
    }

    /// `http://ADDR`.
    pub fn url(&self) -> String {
        self.0.url()
    }

    /// Stops serving and waits for the thread; the server's own error, if
    /// it failed.
    pub fn stop(self) -> Result<(), ServeError> {
        self.0.stop()
    }
}
