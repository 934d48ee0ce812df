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

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use tokio_stream::wrappers::errors::BroadcastStreamRecvError;
use tokio_stream::wrappers::BroadcastStream;
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

/// A running dashboard; dropping it stops the server.
pub struct Running {
    addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
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
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The routes over `board`.
pub fn router(board: Board) -> Router {
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
        .with_state(board)
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
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
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
                let server = axum::serve(listener, router(board)).with_graceful_shutdown(async {
                    let _ = stopped.await;
                });
                if let Err(e) = server.await {
                    tracing::error!(error = %e, "dashboard server");
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

async fn state(State(board): State<Board>) -> Json<serde_json::Value> {
    Json(board.snapshot())
}

async fn events(State(board): State<Board>) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let stream = BroadcastStream::new(board.subscribe()).map(|u| {
        Ok(match u {
            Ok(u) => Event::default().event(u.kind).data(u.data.to_string()),
            // The page fell behind: it reloads the snapshot.
            Err(BroadcastStreamRecvError::Lagged(_)) => Event::default().event("resync").data("{}"),
        })
    });
    // The first event tells the page it is connected.
    let hello = tokio_stream::once(Ok(Event::default().event("hello").data("{}")));
    Sse::new(hello.chain(stream)).keep_alive(KeepAlive::default())
}

async fn replay(State(board): State<Board>) -> Response {
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

    #[test]
    fn events_stream_the_rows() {
        let board = Board::default();
        let running = serve("127.0.0.1:0".parse().unwrap(), board.clone()).unwrap();
        let mut s = std::net::TcpStream::connect(running.addr()).unwrap();
        write!(s, "GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
        let mut seen = String::new();
        let mut buf = [0u8; 4096];
        while !seen.contains("event: hello") {
            let n = s.read(&mut buf).unwrap();
            assert!(n > 0, "closed early: {seen}");
            seen.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
        board.push_row(serde_json::json!({"update": 7}));
        while !seen.contains("{\"update\":7}") {
            let n = s.read(&mut buf).unwrap();
            assert!(n > 0, "closed early: {seen}");
            seen.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
        assert!(seen.contains("event: row"), "{seen}");
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
