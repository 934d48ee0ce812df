//! The open fleet sessions: limits (sessions, robots per session), idle
//! expiry, and a memory of sessions that ended so that a late call hears
//! why its session is gone.

use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use buridan_eval::fleet::FleetSession;

use crate::metrics::{self as m, WaitWatch};

/// Ended sessions remembered for their NOT_FOUND message.
const REMEMBERED: usize = 4096;

/// One fleet under control: the closed-loop session and what the service
/// keeps beside it.
pub struct Fleet {
    /// The controller's session.
    pub session: FleetSession,
    /// Steps answered.
    pub steps: u64,
    /// Robots that wait, for the metrics.
    pub waits: WaitWatch,
    /// Ended: a step that finds its session so (it was waiting for the
    /// lock while the session ended) answers NOT_FOUND.
    pub ended: Option<Ended>,
}

impl Fleet {
    /// A fleet under `session`, its robots on `positions`, waits alarmed
    /// beyond `k` steps.
    pub fn new(session: FleetSession, k: u32, positions: &[buridan_env::Cell]) -> Self {
        Self {
            session,
            steps: 0,
            waits: WaitWatch::new(k, positions),
            ended: None,
        }
    }
}

/// Why a session is no longer open.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// Closed by a client.
    Closed,
    /// No call for longer than the idle timeout.
    Expired,
    /// Its controller panicked; the session was dropped.
    Failed,
}

struct Entry {
    fleet: Arc<Mutex<Fleet>>,
    agents: usize,
    used: Instant,
}

#[derive(Default)]
struct Table {
    live: HashMap<u64, Entry>,
    /// Opens admitted and still building their session.
    pending: usize,
    ended: VecDeque<(u64, Ended)>,
    robots: usize,
}

/// A lock that survives a panicked holder.
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Why a session cannot be found or opened.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum SessionError {
    /// At the session limit.
    #[error("{open} sessions are open, the server's limit (--max-sessions {max}): close one or wait for idle ones to expire")]
    Full {
        /// Sessions open or opening.
        open: usize,
        /// The limit.
        max: usize,
    },
    /// No session by that id.
    #[error("unknown session {0}: Open a new one (sessions end on Close, after the idle timeout, and when the server restarts)")]
    Unknown(u64),
    /// The session ended.
    #[error("session {id} {}: Open a new one", match .why {
        Ended::Closed => "was closed",
        Ended::Expired => "expired (no call for longer than the idle timeout)",
        Ended::Failed => "was dropped after its controller failed",
    })]
    Ended {
        /// The session.
        id: u64,
        /// Why it ended.
        why: Ended,
    },
}

/// The sessions of a service.
pub struct Sessions {
    max: usize,
    idle: Duration,
    /// The waiting gauge's `over_steps` label.
    k: String,
    table: Mutex<Table>,
}

/// A place for a session being opened; released if dropped unused.
pub struct Admission<'a> {
    sessions: &'a Sessions,
    used: bool,
}

impl Drop for Admission<'_> {
    fn drop(&mut self) {
        if !self.used {
            lock(&self.sessions.table).pending -= 1;
        }
    }
}

impl Sessions {
    /// At most `max` sessions, each expiring after `idle` without a call;
    /// robots waiting longer than `k` steps are counted.
    pub fn new(max: usize, idle: Duration, k: u32) -> Self {
        let sessions = Self {
            max,
            idle,
            k: k.to_string(),
            table: Mutex::new(Table::default()),
        };
        sessions.waiting_gauge().increment(0.0);
        sessions
    }

    /// The gauge of robots waiting longer than K steps.
    pub fn waiting_gauge(&self) -> metrics::Gauge {
        ::metrics::gauge!(m::WAITING, "over_steps" => self.k.clone())
    }

    /// The idle timeout.
    pub fn idle_timeout(&self) -> Duration {
        self.idle
    }

    /// Sessions open now.
    pub fn len(&self) -> usize {
        lock(&self.table).live.len()
    }

    /// No session open.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Robots in the open sessions.
    pub fn robots(&self) -> usize {
        lock(&self.table).robots
    }

    /// A place for one more session, or [`SessionError::Full`].
    pub fn admit(&self) -> Result<Admission<'_>, SessionError> {
        let mut t = lock(&self.table);
        let open = t.live.len() + t.pending;
        if open >= self.max {
            return Err(SessionError::Full {
                open,
                max: self.max,
            });
        }
        t.pending += 1;
        Ok(Admission {
            sessions: self,
            used: false,
        })
    }

    /// Inserts `fleet` of `agents` robots in the place `admission` holds;
    /// its id (random, never 0: a stale id from before a restart finds
    /// nothing).
    pub fn insert(&self, mut admission: Admission<'_>, fleet: Fleet, agents: usize) -> u64 {
        let mut t = lock(&self.table);
        admission.used = true;
        t.pending -= 1;
        let id = loop {
            let id = rand::random::<u64>();
            if id != 0 && !t.live.contains_key(&id) {
                break id;
            }
        };
        t.live.insert(
            id,
            Entry {
                fleet: Arc::new(Mutex::new(fleet)),
                agents,
                used: Instant::now(),
            },
        );
        t.robots += agents;
        publish(&t);
        id
    }

    /// Session `id` and its robots, marked as used now; a session idle
    /// past the timeout expires here if the sweep has not ended it yet.
    pub fn get(&self, id: u64) -> Result<(Arc<Mutex<Fleet>>, usize), SessionError> {
        let now = Instant::now();
        let mut t = lock(&self.table);
        let idle = match t.live.get(&id) {
            None => return Err(gone(&t, id)),
            Some(e) => now.duration_since(e.used) > self.idle,
        };
        if idle {
            let removed = end(&mut t, id, Ended::Expired);
            drop(t);
            if let Some(fleet) = removed {
                self.retire(&fleet, Ended::Expired);
            }
            return Err(SessionError::Ended {
                id,
                why: Ended::Expired,
            });
        }
        let e = t.live.get_mut(&id).ok_or(SessionError::Unknown(id))?;
        e.used = now;
        Ok((e.fleet.clone(), e.agents))
    }

    /// Marks session `id` as used now (after a long step).
    pub fn touch(&self, id: u64) {
        if let Some(e) = lock(&self.table).live.get_mut(&id) {
            e.used = Instant::now();
        }
    }

    /// Ends session `id` for `why`; its fleet, if it was open.
    pub fn end(&self, id: u64, why: Ended) -> Result<Arc<Mutex<Fleet>>, SessionError> {
        let mut t = lock(&self.table);
        let fleet = end(&mut t, id, why).ok_or_else(|| gone(&t, id))?;
        drop(t);
        self.retire(&fleet, why);
        Ok(fleet)
    }

    /// Marks a fleet taken out of the table as ended and takes its
    /// waiting robots off the gauge (under the fleet's lock, so that a
    /// step in flight counts them first or not at all).
    fn retire(&self, fleet: &Mutex<Fleet>, why: Ended) {
        let mut f = lock(fleet);
        f.ended = Some(why);
        let over = f.waits.over();
        if over > 0 {
            self.waiting_gauge().decrement(over as f64);
        }
    }

    /// Ends every session idle longer than the timeout (a session whose
    /// step is running is not idle); how many ended.
    pub fn expire(&self) -> usize {
        let now = Instant::now();
        let mut t = lock(&self.table);
        let stale: Vec<u64> = t
            .live
            .iter()
            .filter(|(_, e)| now.duration_since(e.used) > self.idle && e.fleet.try_lock().is_ok())
            .map(|(&id, _)| id)
            .collect();
        let removed: Vec<_> = stale
            .iter()
            .filter_map(|&id| end(&mut t, id, Ended::Expired))
            .collect();
        drop(t);
        for fleet in &removed {
            self.retire(fleet, Ended::Expired);
        }
        removed.len()
    }
}

/// Removes `id` from the table, remembers why, updates the gauges (the
/// caller retires the fleet once the table's lock is released).
fn end(t: &mut Table, id: u64, why: Ended) -> Option<Arc<Mutex<Fleet>>> {
    let e = t.live.remove(&id)?;
    t.robots -= e.agents;
    if t.ended.len() == REMEMBERED {
        t.ended.pop_front();
    }
    t.ended.push_back((id, why));
    if why == Ended::Expired {
        ::metrics::counter!(m::EXPIRED).increment(1);
        tracing::info!(session = id, "session expired");
    }
    publish(t);
    Some(e.fleet)
}

fn gone(t: &Table, id: u64) -> SessionError {
    match t.ended.iter().rev().find(|(ended, _)| *ended == id) {
        Some(&(id, why)) => SessionError::Ended { id, why },
        None => SessionError::Unknown(id),
    }
}

fn publish(t: &Table) {
    ::metrics::gauge!(m::SESSIONS).set(t.live.len() as f64);
    ::metrics::gauge!(m::ROBOTS).set(t.robots as f64);
}
