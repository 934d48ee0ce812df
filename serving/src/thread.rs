//! A server on a thread of its own, for tests and embedding.

use std::fmt::Display;
use std::future::Future;
use std::net::SocketAddr;
use std::pin::Pin;

use tokio::sync::oneshot;

use crate::error::{bind, ServerError};

/// Completes when [`ServerThread::stop`] is called or the handle dropped.
pub type StopRequested = Pin<Box<dyn Future<Output = ()> + Send>>;

/// A server running on its own thread (a current-thread runtime), stopped
/// by [`ServerThread::stop`] or when dropped. `E` is the server's error.
pub struct ServerThread<E: Display> {
    name: &'static str,
    addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<Result<(), E>>>,
}

impl<E> ServerThread<E>
where
    E: From<ServerError> + Display + Send + 'static,
{
    /// Binds `addr` (port 0: any free port) here, then runs
    /// `serve(listener, stop_requested)` on a thread named `name` until it
    /// ends.
    pub fn spawn<F, Fut>(name: &'static str, addr: SocketAddr, serve: F) -> Result<Self, E>
    where
        F: FnOnce(tokio::net::TcpListener, StopRequested) -> Fut + Send + 'static,
        Fut: Future<Output = Result<(), E>>,
    {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(ServerError::Runtime)?;
        let (listener, bound) = bind(addr)?;
        let (stop, stopped) = oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || {
                runtime.block_on(async move {
                    let listener = tokio::net::TcpListener::from_std(listener)
                        .map_err(|source| ServerError::Bind { addr, source })?;
                    let stop_requested: StopRequested = Box::pin(async {
                        let _ = stopped.await;
                    });
                    serve(listener, stop_requested).await
                })
            })
            .map_err(ServerError::Runtime)?;
        tracing::info!(%bound, "{name} listening");
        Ok(Self {
            name,
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
    pub fn stop(mut self) -> Result<(), E> {
        self.shut_down()
    }
}

impl<E: Display> ServerThread<E> {
    fn shut_down(&mut self) -> Result<(), E> {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(result)) => result,
            Some(Err(_)) => {
                tracing::error!("the {} thread panicked", self.name);
                Ok(())
            }
            None => Ok(()),
        }
    }
}

impl<E: Display> Drop for ServerThread<E> {
    fn drop(&mut self) {
        if let Err(e) = self.shut_down() {
            tracing::warn!("the {} ended with an error: {e}", self.name);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::AsyncWriteExt;

    /// A server that writes one byte to each connection until stopped.
    async fn one_byte_each(
        listener: tokio::net::TcpListener,
        stop: StopRequested,
    ) -> Result<(), ServerError> {
        let accept = async {
            loop {
                let (mut conn, _) = listener.accept().await.map_err(ServerError::Runtime)?;
                let _ = conn.write_all(b"x").await;
            }
        };
        tokio::select! {
            r = accept => r,
            () = stop => Ok(()),
        }
    }

    #[test]
    fn serves_on_its_thread_until_stopped() {
        let server =
            ServerThread::spawn("test server", "127.0.0.1:0".parse().unwrap(), one_byte_each)
                .unwrap();
        let mut conn = std::net::TcpStream::connect(server.addr()).unwrap();
        let mut byte = [0u8; 1];
        std::io::Read::read_exact(&mut conn, &mut byte).unwrap();
        assert_eq!(&byte, b"x");
        assert_eq!(server.url(), format!("http://{}", server.addr()));
        let addr = server.addr();
        server.stop().unwrap();
        // The port is free again once the thread has ended.
        assert!(std::net::TcpListener::bind(addr).is_ok());
    }

    #[test]
    fn the_servers_own_error_comes_back_from_stop() {
        let server = ServerThread::spawn(
            "failing server",
            "127.0.0.1:0".parse().unwrap(),
            |_listener, _stop| async {
                Err::<(), ServerError>(ServerError::Runtime(std::io::Error::other("boom")))
            },
        )
        .unwrap();
        let err = server.stop().unwrap_err();
        assert!(matches!(err, ServerError::Runtime(_)), "{err}");
    }
}
