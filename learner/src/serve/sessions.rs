//! The actors' sessions: opened by `Join`, kept alive by an open parameter
//! stream or by submitted fragments, closed when the last stream closes,
//! expired when idle, and capped in number.
//!
//! A session is **idle** when it has no open parameter stream and nothing
//! (its join, a stream, a fragment that passed the checks) happened in it for
//! [`SessionLimits::idle_timeout`]; idle sessions are removed (counted in
//! `buridan_sessions_expired_total`). A session with an open stream never
//! expires, however slowly its actor collects: the stream is its liveness.
//! At most [`SessionLimits::max_sessions`] sessions are open at once; a join
//! beyond that is refused (`buridan_joins_refused_total{reason}`). The
//! number open is the gauge `buridan_sessions`.
//!
//! ```
//! use std::time::{Duration, Instant};
//! use buridan_learner::serve::sessions::{SessionLimits, SessionTable};
//! let table = SessionTable::new(SessionLimits { idle_timeout: Duration::from_secs(60), max_sessions: 1 });
//! let (id, _) = table.open("a".into(), 4).unwrap();
//! assert!(table.open("b".into(), 4).is_err()); // the cap
//! assert!(table.open_watch(id));
//! assert_eq!(table.expire_idle(Instant::now() + Duration::from_secs(3600)), 0); // watched
//! table.close_watch(id); // its last stream closed: the session is gone
//! assert!(table.get(id).is_none());
//! ```

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Default [`SessionLimits::idle_timeout`].
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(300);

/// Default [`SessionLimits::max_sessions`].
pub const DEFAULT_MAX_SESSIONS: usize = 1024;

/// How long idle sessions live and how many may be open.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SessionLimits {
    /// A session without an open parameter stream and without activity for
    /// this long is removed.
    pub idle_timeout: Duration,
    /// Sessions open at once; joins beyond are refused.
    pub max_sessions: usize,
}

impl Default for SessionLimits {
    fn default() -> Self {
        Self {
            idle_timeout: DEFAULT_IDLE_TIMEOUT,
            max_sessions: DEFAULT_MAX_SESSIONS,
        }
    }
}

/// Longest accepted idle timeout of a session.
pub const MAX_IDLE_TIMEOUT: Duration = Duration::from_secs(30 * 24 * 3600);

/// Largest accepted session cap.
pub const MAX_SESSIONS_LIMIT: usize = 1_000_000;

/// Session limits that cannot be meant.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LimitsError {
    /// An idle timeout of zero or beyond [`MAX_IDLE_TIMEOUT`].
    #[error("a session idle timeout of {0:?} is not usable: give 1 ms to 30 days (--session-idle-timeout SECS)")]
    IdleTimeout(Duration),
    /// A session cap of zero or beyond [`MAX_SESSIONS_LIMIT`].
    #[error("a cap of {0} sessions is not usable: give 1 to 1000000 (--max-sessions N)")]
    MaxSessions(usize),
}

impl SessionLimits {
    /// Checks that the limits are usable: an idle timeout of 1 ms to 30
    /// days, a cap of 1 to 1,000,000 sessions.
    ///
    /// ```
    /// use buridan_learner::serve::{LimitsError, SessionLimits};
    /// assert!(SessionLimits::default().check().is_ok());
    /// let none = SessionLimits { max_sessions: 0, ..SessionLimits::default() };
    /// assert_eq!(none.check(), Err(LimitsError::MaxSessions(0)));
    /// ```
    pub fn check(&self) -> Result<(), LimitsError> {
        let t = self.idle_timeout;
        if t < Duration::from_millis(1) || t > MAX_IDLE_TIMEOUT {
            return Err(LimitsError::IdleTimeout(t));
        }
        if self.max_sessions == 0 || self.max_sessions > MAX_SESSIONS_LIMIT {
            return Err(LimitsError::MaxSessions(self.max_sessions));
        }
        Ok(())
    }
}

/// One actor's session.
#[derive(Debug, Clone)]
pub struct Session {
    /// Actor id.
    pub actor_id: u32,
    /// Name the actor gave.
    pub name: String,
    /// Envs it runs.
    pub envs: u32,
    /// Highest fragment sequence number received.
    pub last_seq: Option<u64>,
    /// Open parameter streams (its liveness).
    pub watchers: usize,
    /// When something last happened in it (join, stream, submit).
    pub last_active: Instant,
}

/// A join refused because [`SessionLimits::max_sessions`] are open.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("this learner already has {open} sessions open, its cap: raise it with `learner serve --max-sessions N` (now {cap}), or join again once a session leaves or expires")]
pub struct SessionCap {
    /// Sessions open.
    pub open: usize,
    /// The cap.
    pub cap: usize,
}

/// The open sessions, by id.
#[derive(Debug)]
pub struct SessionTable {
    sessions: Mutex<HashMap<u64, Session>>,
    next: AtomicU64,
    limits: SessionLimits,
}

impl SessionTable {
    /// An empty table with `limits`.
    pub fn new(limits: SessionLimits) -> Self {
        Self {
            sessions: Mutex::new(HashMap::new()),
            next: AtomicU64::new(1),
            limits,
        }
    }

    /// The limits it enforces.
    pub fn limits(&self) -> SessionLimits {
        self.limits
    }

    fn lock(&self) -> MutexGuard<'_, HashMap<u64, Session>> {
        // A handler that panicked holding the lock leaves a usable map.
        self.sessions
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Opens a session (after expiring idle ones), unless the cap is reached.
    pub fn open(&self, name: String, envs: u32) -> Result<(u64, Session), SessionCap> {
        let now = Instant::now();
        let mut sessions = self.lock();
        self.expire_locked(&mut sessions, now);
        if sessions.len() >= self.limits.max_sessions {
            return Err(SessionCap {
                open: sessions.len(),
                cap: self.limits.max_sessions,
            });
        }
        let id = self.next.fetch_add(1, Ordering::SeqCst);
        let session = Session {
            actor_id: (id - 1) as u32,
            name,
            envs,
            last_seq: None,
            watchers: 0,
            last_active: now,
        };
        sessions.insert(id, session.clone());
        publish_gauges(&sessions);
        Ok((id, session))
    }

    /// The session `id`, if open.
    pub fn get(&self, id: u64) -> Option<Session> {
        self.lock().get(&id).cloned()
    }

    /// Sessions with an open parameter stream.
    pub fn connected(&self) -> usize {
        watching(&self.lock())
    }

    /// Records a parameter stream opening in session `id`; false (and
    /// nothing recorded) if the session is not open.
    pub fn open_watch(&self, id: u64) -> bool {
        let mut sessions = self.lock();
        let Some(s) = sessions.get_mut(&id) else {
            return false;
        };
        s.watchers += 1;
        s.last_active = Instant::now();
        publish_gauges(&sessions);
        true
    }

    /// Records a parameter stream of session `id` closing; a session whose
    /// last stream closes is gone (its actor died or cut the connection).
    pub fn close_watch(&self, id: u64) {
        let mut sessions = self.lock();
        if let Some(s) = sessions.get_mut(&id) {
            s.watchers = s.watchers.saturating_sub(1);
            s.last_active = Instant::now();
            if s.watchers == 0 {
                tracing::info!(session = id, actor = s.actor_id, name = %s.name, "actor left");
                sessions.remove(&id);
            }
        }
        publish_gauges(&sessions);
    }

    /// Marks `seq` of session `id` as received (activity that keeps the
    /// session alive); `Err(last)` if it is not newer than the last one,
    /// `None` if the session is not open.
    pub fn claim_seq(&self, id: u64, seq: u64) -> Option<Result<(), u64>> {
        let mut sessions = self.lock();
        let s = sessions.get_mut(&id)?;
        s.last_active = Instant::now();
        Some(match s.last_seq {
            Some(last) if seq <= last => Err(last),
            _ => {
                s.last_seq = Some(seq);
                Ok(())
            }
        })
    }

    /// Removes the sessions idle at `now`; returns how many.
    pub fn expire_idle(&self, now: Instant) -> usize {
        let mut sessions = self.lock();
        let expired = self.expire_locked(&mut sessions, now);
        if expired > 0 {
            publish_gauges(&sessions);
        }
        expired
    }

    fn expire_locked(&self, sessions: &mut HashMap<u64, Session>, now: Instant) -> usize {
        let timeout = self.limits.idle_timeout;
        let before = sessions.len();
        sessions.retain(|&id, s| {
            let idle = s.watchers == 0 && now.saturating_duration_since(s.last_active) >= timeout;
            if idle {
                tracing::info!(
                    session = id,
                    actor = s.actor_id,
                    name = %s.name,
                    idle_secs = timeout.as_secs_f64(),
                    "session expired: no parameter stream and no submission"
                );
            }
            !idle
        });
        let expired = before - sessions.len();
        if expired > 0 {
            ::metrics::counter!("buridan_sessions_expired_total").increment(expired as u64);
        }
        expired
    }

    /// How often [`Self::expire_idle`] should run: a quarter of the idle
    /// timeout, between 10 ms and 5 s.
    pub fn sweep_every(&self) -> Duration {
        (self.limits.idle_timeout / 4).clamp(Duration::from_millis(10), Duration::from_secs(5))
    }
}

/// Sessions with an open parameter stream.
fn watching(sessions: &HashMap<u64, Session>) -> usize {
    sessions.values().filter(|s| s.watchers > 0).count()
}

fn publish_gauges(sessions: &HashMap<u64, Session>) {
    ::metrics::gauge!("buridan_sessions").set(sessions.len() as f64);
    ::metrics::gauge!("buridan_connected_actors").set(watching(sessions) as f64);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(idle_ms: u64, max: usize) -> SessionTable {
        SessionTable::new(SessionLimits {
            idle_timeout: Duration::from_millis(idle_ms),
            max_sessions: max,
        })
    }

    #[test]
    fn idle_sessions_expire_and_watched_ones_do_not() {
        let t = table(100, 10);
        let (idle, _) = t.open("idle".into(), 1).unwrap();
        let (watched, _) = t.open("watched".into(), 1).unwrap();
        assert!(t.open_watch(watched));
        let later = Instant::now() + Duration::from_millis(150);
        assert_eq!(t.expire_idle(later), 1);
        assert!(t.get(idle).is_none());
        assert!(t.get(watched).is_some());
        assert_eq!(t.claim_seq(idle, 1), None);
    }

    #[test]
    fn submissions_keep_a_session_alive() {
        let t = table(100, 10);
        let (id, _) = t.open("a".into(), 1).unwrap();
        std::thread::sleep(Duration::from_millis(60));
        assert_eq!(t.claim_seq(id, 1), Some(Ok(())));
        // 60 ms after the submission, 120 ms after the join.
        let at = Instant::now() + Duration::from_millis(60);
        assert_eq!(t.expire_idle(at), 0);
        assert_eq!(t.expire_idle(at + Duration::from_millis(60)), 1);
    }

    #[test]
    fn the_cap_refuses_then_frees() {
        let t = table(60_000, 2);
        let (a, _) = t.open("a".into(), 1).unwrap();
        t.open("b".into(), 1).unwrap();
        let err = t.open("c".into(), 1).unwrap_err();
        assert_eq!(err, SessionCap { open: 2, cap: 2 });
        assert!(err.to_string().contains("--max-sessions"), "{err}");
        assert!(t.open_watch(a));
        t.close_watch(a);
        t.open("c".into(), 1).unwrap();
        assert!(!t.open_watch(999));
    }
}
