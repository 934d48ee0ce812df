//! The dashboard's HTTP server (axum, on a runtime of its own thread):
//!
//! | path | what |
//! |---|---|
//! | `/` | the page (embedded HTML) |
//! | `/app.js` | its script (embedded) |
//! | `/api/state` | everything shown, as JSON |
//! | `/api/events` | changes as server-sent events: `run`, `row`, `status`, `eval`, `replay`, `resync` |
//! | `/api/replay.gif` | the replay shown (404 before the first) |

use std::convert::Infallible;
use std::net::SocketAddr;
use std::time::Duration;

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use tokio::sync::watch;
use tokio_stream::wrappers::errors::BroadcastStreamRecvError;
use tokio_stream::wrappers::{BroadcastStream, WatchStream};
use tokio_stream::{Stream, StreamExt};

use crate::board::Board;

const INDEX_HTML: &str = include_str!("../assets/index.html");
const APP_JS: &str = include_str!("../assets/app.js");

/// Why the dashboard could not start.
#[derive(Debug, thiserror::Error)]
pub enum DashboardError {
    /// The address cannot be bound (in use, not local, no permission).
    #[error("cannot serve the dashboard on {addr}")]
    Bind {
        /// The address asked for.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// The server's runtime could not start.
    #[error("cannot start the dashboard's runtime")]
    Runtime(#[source] std::io::Error),
}

/// How long a stopping server waits for its connections to close before it
/// drops them: event streams end at once on a stop, so this only bounds a
/// client that does not read.
pub const SHUTDOWN_GRACE: Duration = Duration::from_secs(2);

/// A running dashboard; dropping it stops the server: open event streams
/// end, and the server's thread is gone within [`SHUTDOWN_GRACE`].
pub struct Running {
    addr: SocketAddr,
    stop: Option<watch::Sender<bool>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Running {
    /// The address the server listens on (the port chosen for port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(true);
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// What the handlers share: the board, and the stop signal that ends the
/// event streams.
#[derive(Clone)]
struct Served {
    board: Board,
    stopping: watch::Receiver<bool>,
}

/// The routes over `board`; event streams end when `stopping` turns true.
pub fn router(board: Board, stopping: watch::Receiver<bool>) -> Router {
    Router::new()
        .route("/", get(|| async { Html(INDEX_HTML) }))
        .route(
            "/app.js",
            get(|| async {
                (
                    [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
                    APP_JS,
                )
            }),
        )
        .route("/api/state", get(state))
        .route("/api/events", get(events))
        .route("/api/replay.gif", get(replay))
        .with_state(Served { board, stopping })
}

/// Serves `board` on `addr` from a thread of its own until the returned
/// [`Running`] is dropped.
///
/// ```
/// let board = buridan_dashboard::Board::default();
/// let running = buridan_dashboard::serve("127.0.0.1:0".parse().unwrap(), board).unwrap();
/// assert_ne!(running.addr().port(), 0);
/// ```
pub fn serve(addr: SocketAddr, board: Board) -> Result<Running, DashboardError> {
    let listener = std::net::TcpListener::bind(addr)
        .and_then(|l| l.set_nonblocking(true).map(|()| l))
        .map_err(|source| DashboardError::Bind { addr, source })?;
    let bound = listener
        .local_addr()
        .map_err(|source| DashboardError::Bind { addr, source })?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(DashboardError::Runtime)?;
    let (stop, stopping) = watch::channel(false);
    let thread = std::thread::Builder::new()
        .name("dashboard".into())
        .spawn(move || {
            runtime.block_on(async move {
                let listener = match tokio::net::TcpListener::from_std(listener) {
                    Ok(l) => l,
                    Err(e) => {
                        tracing::error!(error = %e, "dashboard listener");
                        return;
                    }
                };
                let (mut stopped, mut grace) = (stopping.clone(), stopping.clone());
                let server = axum::serve(listener, router(board, stopping)).with_graceful_shutdown(
                    async move {
                        let _ = stopped.wait_for(|&s| s).await;
                    },
                );
                // Graceful shutdown waits for open connections; a client
                // that holds one past the grace period is dropped with the
                // runtime.
                let deadline = async move {
                    let _ = grace.wait_for(|&s| s).await;
                    tokio::time::sleep(SHUTDOWN_GRACE).await;
                };
                tokio::select! {
                    served = server => if let Err(e) = served {
                        tracing::error!(error = %e, "dashboard server");
                    },
                    () = deadline => tracing::warn!(
                        grace_s = SHUTDOWN_GRACE.as_secs_f64(),
                        "dashboard: connections still open after the grace period, closed"
                    ),
                }
            });
        })
        .map_err(DashboardError::Runtime)?;
    Ok(Running {
        addr: bound,
        stop: Some(stop),
        thread: Some(thread),
    })
}

async fn state(State(served): State<Served>) -> Json<serde_json::Value> {
    Json(served.board.snapshot())
}

/// The board's changes until the server stops: then the stream ends, so a
/// page left open does not keep a stopping server alive.
async fn events(
    State(served): State<Served>,
) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let changes = BroadcastStream::new(served.board.subscribe()).map(|u| {
        Some(match u {
            Ok(u) => Event::default().event(u.kind).data(u.data.to_string()),
            // The page fell behind: it reloads the snapshot.
            Err(BroadcastStreamRecvError::Lagged(_)) => Event::default().event("resync").data("{}"),
        })
    });
    // `None` marks the stop; the stream ends there.
    let stop = WatchStream::new(served.stopping)
        .filter(|&s| s)
        .map(|_| None);
    let stream = changes
        .merge(stop)
        .take_while(Option::is_some)
        .filter_map(|e| e.map(Ok));
    // The first event tells the page it is connected.
    let hello = tokio_stream::once(Ok(Event::default().event("hello").data("{}")));
    Sse::new(hello.chain(stream)).keep_alive(KeepAlive::default())
}

async fn replay(State(Served { board, .. }): State<Served>) -> Response {
    match board.replay_gif() {
        Some(gif) => (
            [
                (header::CONTENT_TYPE, "image/gif"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            gif.as_ref().clone(),
        )
            .into_response(),
        None => (StatusCode::NOT_FOUND, "no replay yet").into_response(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    fn get(addr: SocketAddr, path: &str) -> String {
        let mut s = std::net::TcpStream::connect(addr).unwrap();
        write!(
            s,
            "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    }

    #[test]
    fn the_page_the_state_and_the_replay_are_served() {
        let board = Board::default();
        board.push_row(serde_json::json!({"env_steps": 2048}));
        let running = serve("127.0.0.1:0".parse().unwrap(), board.clone()).unwrap();
        let page = get(running.addr(), "/");
        assert!(page.starts_with("HTTP/1.1 200"), "{page}");
        assert!(page.contains("<script src=\"/app.js\">"));
        assert!(
            !page.contains("http://") && !page.contains("https://"),
            "no outside links"
        );
        assert!(get(running.addr(), "/app.js").contains("EventSource"));
        let state = get(running.addr(), "/api/state");
        assert!(state.contains("\"env_steps\":2048"), "{state}");
        assert!(get(running.addr(), "/api/replay.gif").starts_with("HTTP/1.1 404"));
        board.set_replay(b"GIF89a".to_vec(), "episode 0".into());
        assert!(get(running.addr(), "/api/replay.gif").ends_with("GIF89a"));
    }

    /// Reads `s` into `seen` until it holds `text`.
    fn read_until(s: &mut std::net::TcpStream, seen: &mut String, text: &str) {
        let mut buf = [0u8; 4096];
        while !seen.contains(text) {
            let n = s.read(&mut buf).unwrap();
            assert!(n > 0, "closed early: {seen}");
            seen.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    }

    /// An event stream of the server at `addr`, past its greeting.
    fn open_events(addr: SocketAddr) -> (std::net::TcpStream, String) {
        let mut s = std::net::TcpStream::connect(addr).unwrap();
        write!(s, "GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
        let mut seen = String::new();
        read_until(&mut s, &mut seen, "event: hello");
        (s, seen)
    }

    #[test]
    fn events_stream_the_rows() {
        let board = Board::default();
        let running = serve("127.0.0.1:0".parse().unwrap(), board.clone()).unwrap();
        let (mut s, mut seen) = open_events(running.addr());
        board.push_row(serde_json::json!({"update": 7}));
        read_until(&mut s, &mut seen, "{\"update\":7}");
        assert!(seen.contains("event: row"), "{seen}");
    }

    #[test]
    fn a_stop_ends_open_event_streams() {
        let running = serve("127.0.0.1:0".parse().unwrap(), Board::default()).unwrap();
        let (mut s, _) = open_events(running.addr());
        // The page stays connected while the server stops: the stop must not
        // wait for it to leave.
        let t0 = std::time::Instant::now();
        drop(running);
        assert!(
            t0.elapsed() < SHUTDOWN_GRACE,
            "the stop waited {:?} for an open event stream",
            t0.elapsed()
        );
        // And the stream was ended, not left dangling.
        s.set_read_timeout(Some(std::time::Duration::from_secs(5)))
            .unwrap();
        let mut rest = Vec::new();
        assert!(
            s.read_to_end(&mut rest).is_ok(),
            "the stream was not closed"
        );
    }

    #[test]
    fn a_busy_address_is_an_error() {
        let first = serve("127.0.0.1:0".parse().unwrap(), Board::default()).unwrap();
        let err = serve(first.addr(), Board::default()).err().unwrap();
        assert!(
            err.to_string().contains("cannot serve the dashboard"),
            "{err}"
        );
    }
}
