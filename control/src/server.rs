//! Serving: token and TLS as the learner has them, the idle sweep, a
//! graceful shutdown within a grace period, and a server on a thread of
//! its own for tests.

use std::net::SocketAddr;
use std::time::Duration;

use buridan_proto::v1::fleet_control_server::FleetControlServer;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Identity, Server, ServerTlsConfig};
use tonic::{Request, Status};

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
    let mut builder = Server::builder();
    if let Some((cert, key)) = &cfg.tls {
        let read = |what, path: &std::path::PathBuf| {
            std::fs::read(path).map_err(|source| ServeError::TlsFile {
                what,
                path: path.clone(),
                source,
            })
        };
        let (cert, key) = (read("certificate", cert)?, read("key", key)?);
        builder = builder
            .tls_config(ServerTlsConfig::new().identity(Identity::from_pem(cert, key)))
            .map_err(ServeError::Tls)?;
    }
    // A step is a small request answered at once: no Nagle delay.
    let incoming = tokio_stream::StreamExt::map(
        tokio_stream::wrappers::TcpListenerStream::new(listener),
        |conn| conn.and_then(|s| s.set_nodelay(true).map(|()| s)),
    );
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
    let expected = cfg.token.as_ref().map(|t| format!("Bearer {t}"));
    let check = move |req: Request<()>| -> Result<Request<()>, Status> {
        let Some(e) = &expected else {
            return Ok(req);
        };
        match req.metadata().get("authorization") {
            Some(v) if v.as_bytes() == e.as_bytes() => Ok(req),
            refused => {
                ::metrics::counter!(crate::metrics::REFUSED, "code" => "unauthenticated")
                    .increment(1);
                Err(Status::unauthenticated(if refused.is_some() {
                    "wrong token"
                } else {
                    "this service needs a token: send authorization: Bearer TOKEN (fleet-control --token)"
                }))
            }
        }
    };
    let (health_reporter, health) = tonic_health::server::health_reporter();
    health_reporter
        .set_serving::<FleetControlServer<ControlService>>()
        .await;
    let (stop_tx, mut stop_rx) = tokio::sync::watch::channel(false);
    let mut graceful = stop_rx.clone();
    let server = builder
        .add_service(health)
        .add_service(InterceptedService::new(svc, check))
        .serve_with_incoming_shutdown(incoming, async move {
            let _ = graceful.wait_for(|&stop| stop).await;
        });
    let signal = async move {
        shutdown.await;
        tracing::info!(grace = ?cfg.grace, "shutting down: no new calls; calls in flight finish");
        let _ = stop_tx.send(true);
        std::future::pending::<()>().await;
    };
    let cut = async move {
        let _ = stop_rx.wait_for(|&stop| stop).await;
        tokio::time::sleep(cfg.grace).await;
    };
    tokio::select! {
        result = server => result.map_err(ServeError::Transport),
        _ = signal => Ok(()),
        _ = sweep => Ok(()),
        _ = cut => {
            tracing::info!("connections still open after the grace period were cut");
            Ok(())
        }
    }
}

/// A service running on its own thread, stopped by [`ControlServer::stop`]
/// or when dropped.
pub struct ControlServer {
    addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<Result<(), ServeError>>>,
}

impl ControlServer {
    /// Binds `addr` (port 0: any free port) and serves `cfg` on a thread
    /// (one reactor thread; controllers on tokio's blocking threads).
    pub fn start(cfg: ServeConfig, addr: SocketAddr) -> Result<Self, ServeError> {
        let service = ControlService::new(cfg)?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(ServeError::Runtime)?;
        let bind_failed = |source| ServeError::Bind { addr, source };
        // Bound here (std), registered with the runtime on its thread: a
        // caller inside a runtime of its own (an async test) may start one.
        let listener = std::net::TcpListener::bind(addr).map_err(bind_failed)?;
        listener.set_nonblocking(true).map_err(bind_failed)?;
        let bound = listener.local_addr().map_err(bind_failed)?;
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name("fleet-control".into())
            .spawn(move || {
                runtime.block_on(async move {
                    let listener = tokio::net::TcpListener::from_std(listener)
                        .map_err(|source| ServeError::Bind { addr, source })?;
                    serve(service, listener, async {
                        let _ = stopped.await;
                    })
                    .await
                })
            })
            .map_err(ServeError::Runtime)?;
        tracing::info!(%bound, "fleet control service listening");
        Ok(Self {
            addr: bound,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// The bound address.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// `http://ADDR`.
    pub fn url(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// Stops serving and waits for the thread; the server's own error, if
    /// it failed.
    pub fn stop(mut self) -> Result<(), ServeError> {
        self.shut_down()
    }

    fn shut_down(&mut self) -> Result<(), ServeError> {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(result)) => result,
            Some(Err(_)) => {
                tracing::error!("the fleet control server thread panicked");
                Ok(())
            }
            None => Ok(()),
        }
    }
}

impl Drop for ControlServer {
    fn drop(&mut self) {
        if let Err(e) = self.shut_down() {
            tracing::warn!("the fleet control server ended with an error: {e}");
        }
    }
}
