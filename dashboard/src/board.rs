//! What the dashboard shows, shared between the trainer (the writer) and
//! the HTTP handlers (the readers): every metrics row so far, the exchange's
//! status, the latest evaluation and replay; each change is also broadcast
//! to the pages listening.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, MutexGuard};

use serde::Serialize;
use serde_json::{json, Value};
use tokio::sync::broadcast;

/// The exchange between actors and learner, after an update.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Status {
    /// Actors connected (actor threads in process, or gRPC actors).
    pub connected_actors: usize,
    /// Fragments waiting for the learner.
    pub queue_depth: usize,
    /// Fragments by outcome (accepted, stale, surplus, …), so far.
    pub fragments: BTreeMap<String, u64>,
}

/// One change, as sent to the pages (the server-sent event's name and data).
#[derive(Debug, Clone, PartialEq)]
pub struct Update {
    /// `run`, `row`, `status`, `eval` or `replay`.
    pub kind: &'static str,
    /// The new value.
    pub data: Value,
}

#[derive(Default)]
struct State {
    run: Value,
    rows: Vec<Value>,
    status: Status,
    eval: Value,
    replay: Option<Replay>,
}

struct Replay {
    version: u64,
    caption: String,
    gif: Arc<Vec<u8>>,
}

/// What the dashboard shows. Cloning shares it.
///
/// ```
/// use buridan_dashboard::{Board, Status};
/// let board = Board::default();
/// let mut updates = board.subscribe();
/// board.set_status(Status { connected_actors: 3, ..Status::default() });
/// assert_eq!(updates.try_recv().unwrap().kind, "status");
/// assert_eq!(board.snapshot()["status"]["connected_actors"], 3);
/// ```
#[derive(Clone)]
pub struct Board {
    state: Arc<Mutex<State>>,
    tx: broadcast::Sender<Update>,
}

impl Default for Board {
    fn default() -> Self {
        let (tx, _) = broadcast::channel(1024);
        Self {
            state: Arc::new(Mutex::new(State::default())),
            tx,
        }
    }
}

impl Board {
    fn state(&self) -> MutexGuard<'_, State> {
        // A writer that panicked left whole values behind: keep showing them.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn send(&self, kind: &'static str, data: Value) {
        // No page listening is fine.
        let _ = self.tx.send(Update { kind, data });
    }

    /// Describes the run (algorithm, map, agents, step budget, …).
    pub fn set_run(&self, run: Value) {
        self.state().run = run.clone();
        self.send("run", run);
    }

    /// Appends one metrics row (a `metrics.csv` line as JSON).
    pub fn push_row(&self, row: Value) {
        self.state().rows.push(row.clone());
        self.send("row", row);
    }

    /// Replaces the exchange's status.
    pub fn set_status(&self, status: Status) {
        let data = serde_json::to_value(&status).expect("a status serialises");
        self.state().status = status;
        self.send("status", data);
    }

    /// Replaces the latest evaluation (an evaluation summary as JSON).
    pub fn set_eval(&self, eval: Value) {
        self.state().eval = eval.clone();
        self.send("eval", eval);
    }

    /// Replaces the replay shown (a GIF) and its caption.
    pub fn set_replay(&self, gif: Vec<u8>, caption: String) {
        let data = {
            let mut s = self.state();
            let version = s.replay.as_ref().map_or(1, |r| r.version + 1);
            s.replay = Some(Replay {
                version,
                caption: caption.clone(),
                gif: Arc::new(gif),
            });
            json!({"version": version, "caption": caption})
        };
        self.send("replay", data);
    }

    /// The replay's GIF, if there is one.
    pub fn replay_gif(&self) -> Option<Arc<Vec<u8>>> {
        self.state().replay.as_ref().map(|r| r.gif.clone())
    }

    /// Everything shown, as the page's first load reads it.
    pub fn snapshot(&self) -> Value {
        let s = self.state();
        json!({
            "run": s.run,
            "rows": s.rows,
            "status": s.status,
            "eval": s.eval,
            "replay": s.replay.as_ref().map(|r| json!({"version": r.version, "caption": r.caption})),
        })
    }

    /// Changes from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Update> {
        self.tx.subscribe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replays_are_numbered_and_served() {
        let board = Board::default();
        assert!(board.replay_gif().is_none());
        board.set_replay(b"GIF89a-1".to_vec(), "first".into());
        board.set_replay(b"GIF89a-2".to_vec(), "second".into());
        let snap = board.snapshot();
        assert_eq!(snap["replay"]["version"], 2);
        assert_eq!(snap["replay"]["caption"], "second");
        assert_eq!(board.replay_gif().unwrap().as_slice(), b"GIF89a-2");
    }

    #[test]
    fn rows_keep_their_order() {
        let board = Board::default();
        for k in 0..5 {
            board.push_row(json!({ "update": k }));
        }
        let rows = board.snapshot()["rows"].as_array().unwrap().clone();
        let updates: Vec<i64> = rows.iter().map(|r| r["update"].as_i64().unwrap()).collect();
        assert_eq!(updates, vec![0, 1, 2, 3, 4]);
    }
}
