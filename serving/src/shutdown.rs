//! Stopping a server: the signal, and the grace period after it.
//!
//! A server stops in two stages. When `shutdown` completes it accepts no
//! new calls and lets the calls in flight finish; connections still open
//! after the grace period are cut (a client whose runtime idles between
//! calls never answers a graceful close, and would otherwise keep the
//! process alive).

use std::future::Future;
use std::time::Duration;

use tokio::sync::watch;

/// Completes on Ctrl-C or (on Unix) SIGTERM, whichever comes first; on
/// Ctrl-C alone when no SIGTERM handler can be installed.
pub async fn shutdown_signal() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, SignalKind};
        match signal(SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            }
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}

/// The moment a server begins to stop: hand [`Stopping::wait`] to tonic's
/// `serve_with_incoming_shutdown`.
pub struct Stopping(watch::Receiver<bool>);

impl Stopping {
    /// Completes when the shutdown signal has come.
    pub async fn wait(mut self) {
        let _ = self.0.wait_for(|&stop| stop).await;
    }
}

/// Runs the server `serve` builds until it ends by itself or `shutdown`
/// completes; after `shutdown`, the server gets `grace` to wind down
/// before it is cut. Returns the server's own result when it ends
/// within the grace period, `Ok` when it is cut.
///
/// ```
/// # tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap().block_on(async {
/// use std::time::Duration;
/// // A server that ignores the signal is cut after the grace period.
/// let ended = buridan_serving::serve_with_grace(
///     |_stopping| std::future::pending::<Result<(), ()>>(),
///     async {},
///     Duration::from_millis(10),
/// )
/// .await;
/// assert_eq!(ended, Ok(()));
/// # });
/// ```
pub async fn serve_with_grace<S, E>(
    serve: impl FnOnce(Stopping) -> S,
    shutdown: impl Future<Output = ()>,
    grace: Duration,
) -> Result<(), E>
where
    S: Future<Output = Result<(), E>>,
{
    let (stop_tx, mut stop_rx) = watch::channel(false);
    let server = serve(Stopping(stop_rx.clone()));
    let signal = async move {
        shutdown.await;
        tracing::info!(
            ?grace,
            "shutting down: no new calls; calls in flight finish"
        );
        let _ = stop_tx.send(true);
        // The sender lives on while the server winds down.
        std::future::pending::<()>().await;
    };
    let cut = async move {
        let _ = stop_rx.wait_for(|&stop| stop).await;
        tokio::time::sleep(grace).await;
    };
    tokio::select! {
        result = server => result,
        _ = signal => Ok(()),
        _ = cut => {
            tracing::info!("connections still open after the grace period were cut");
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use tokio::time::{sleep, Instant};

    #[tokio::test]
    async fn a_server_that_honours_the_signal_ends_with_its_own_result() {
        let started = Instant::now();
        let ended = serve_with_grace(
            |stopping| async move {
                stopping.wait().await;
                Err::<(), _>("its own error")
            },
            sleep(Duration::from_millis(30)),
            Duration::from_secs(600),
        )
        .await;
        assert_eq!(ended, Err("its own error"));
        let took = started.elapsed();
        assert!(took >= Duration::from_millis(30), "{took:?}");
        assert!(
            took < Duration::from_secs(60),
            "waited for the grace period: {took:?}"
        );
    }

    #[tokio::test]
    async fn a_server_still_busy_after_the_grace_period_is_cut() {
        let started = Instant::now();
        let told = Arc::new(AtomicBool::new(false));
        let seen = told.clone();
        let ended = serve_with_grace(
            |stopping| async move {
                stopping.wait().await;
                seen.store(true, Ordering::SeqCst);
                std::future::pending::<Result<(), ()>>().await
            },
            sleep(Duration::from_millis(20)),
            Duration::from_millis(100),
        )
        .await;
        assert_eq!(ended, Ok(()));
        assert!(told.load(Ordering::SeqCst), "the server heard the signal");
        let took = started.elapsed();
        assert!(
            took >= Duration::from_millis(120),
            "cut before the grace period: {took:?}"
        );
    }

    #[tokio::test]
    async fn a_server_that_ends_by_itself_needs_no_signal() {
        let ended = serve_with_grace(
            |_| async { Ok::<(), ()>(()) },
            std::future::pending::<()>(),
            Duration::from_secs(1),
        )
        .await;
        assert_eq!(ended, Ok(()));
    }
}
