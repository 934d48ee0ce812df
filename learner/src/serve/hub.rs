//! The run as the gRPC handlers see it: what joining actors are told, the
//! sessions, the on-policy gate, the latest weights and the fragment
//! queue. The learner loop reaches it through [`RemoteExchange`].

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use buridan_policy::{Fragment, Weights};
use buridan_proto::convert::weights_to_message;
use buridan_proto::v1;
use tokio::sync::{mpsc, watch};

use super::plausible::Plausibility;
pub use super::sessions::Session;
use super::sessions::{SessionCap, SessionLimits, SessionTable};
use crate::train::gate::{Gate, Refusal, Staleness};
use crate::train::{Exchange, ExchangeError};

/// What every joining actor is told (all but its session, id and seed),
/// and what the handlers check fragments against.
#[derive(Debug, Clone)]
pub struct RunInfo {
    /// This learner incarnation.
    pub run_id: String,
    /// The run as every join reply describes it: model spec, map or plant,
    /// env settings, fragment length, on-/off-policy, observation encodings.
    pub spec: v1::RunSpec,
    /// Default envs per actor.
    pub envs_per_actor: u32,
    /// Largest envs an actor may ask for.
    pub max_envs: u32,
    /// Base of the actors' env seeds.
    pub seed_base: u64,
    /// Observation floats per row.
    pub obs_dim: u32,
    /// Action heads per row.
    pub heads: u32,
    /// Actions per head.
    pub actions_per_head: u32,
    /// Rows per env (agents for local observations, 1 for central).
    pub rows_per_env: u32,
}

/// What happened to a submitted fragment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Queued for the learner.
    Accepted,
    /// Refused: collected with a policy too old.
    Stale,
    /// Refused: the on-policy batch of its version was already full.
    Surplus,
    /// Refused: malformed, wrong shape, unknown run, session or version.
    Invalid,
    /// Refused: sequence number already seen.
    Duplicate,
}

impl Outcome {
    /// The `outcome` label of `buridan_fragments_total`.
    pub fn label(self) -> &'static str {
        match self {
            Outcome::Accepted => "accepted",
            Outcome::Stale => "stale",
            Outcome::Surplus => "surplus",
            Outcome::Invalid => "invalid",
            Outcome::Duplicate => "duplicate",
        }
    }
}

/// Counters of what happened to submitted fragments.
#[derive(Debug, Default)]
pub struct FragmentCounters {
    /// Queued for the learner.
    pub accepted: AtomicU64,
    /// Refused: collected with a policy too old.
    pub stale: AtomicU64,
    /// Refused: the on-policy batch of their version was already full.
    pub surplus: AtomicU64,
    /// Refused: malformed, wrong shape, unknown run, session or version.
    pub invalid: AtomicU64,
    /// Refused: sequence number already seen.
    pub duplicate: AtomicU64,
}

impl FragmentCounters {
    /// Counts one `outcome`, here and in `buridan_fragments_total`.
    pub fn count(&self, outcome: Outcome) {
        let counter = match outcome {
            Outcome::Accepted => &self.accepted,
            Outcome::Stale => &self.stale,
            Outcome::Surplus => &self.surplus,
            Outcome::Invalid => &self.invalid,
            Outcome::Duplicate => &self.duplicate,
        };
        counter.fetch_add(1, Ordering::Relaxed);
        ::metrics::counter!("buridan_fragments_total", "outcome" => outcome.label()).increment(1);
    }
}

/// The state shared by the gRPC handlers and the learner loop.
pub struct Hub {
    /// What joining actors are told.
    pub info: RunInfo,
    /// What submitted fragments are checked against.
    pub plausibility: Plausibility,
    sessions: SessionTable,
    gate: Mutex<Gate>,
    params: watch::Sender<Arc<v1::Parameters>>,
    queue: mpsc::Sender<Fragment>,
    queued: AtomicUsize,
    /// Outcome counters.
    pub counters: FragmentCounters,
}

/// A reserved place in the learner's queue ([`Hub::reserve`]); dropped
/// unused, it frees the place.
pub struct QueueSlot<'a> {
    permit: mpsc::Permit<'a, Fragment>,
    queued: &'a AtomicUsize,
}

impl QueueSlot<'_> {
    /// Queues `f` in the reserved place, without waiting.
    pub fn send(self, f: Fragment) {
        self.queued.fetch_add(1, Ordering::SeqCst);
        self.permit.send(f);
    }
}

impl Hub {
    /// A hub whose queue holds `capacity` fragments, whose sessions follow
    /// `limits` and whose fragments are checked against `plausibility`;
    /// returns the learner's end of the queue.
    pub fn new(
        info: RunInfo,
        capacity: usize,
        limits: SessionLimits,
        plausibility: Plausibility,
    ) -> (Arc<Hub>, mpsc::Receiver<Fragment>) {
        let staleness = if info.spec.on_policy {
            Staleness::OnPolicy
        } else {
            Staleness::MaxLag(info.spec.max_policy_lag)
        };
        let (tx, rx) = mpsc::channel(capacity.max(1));
        let (params, _) = watch::channel(Arc::new(v1::Parameters {
            run_id: info.run_id.clone(),
            ..Default::default()
        }));
        let hub = Hub {
            info,
            plausibility,
            sessions: SessionTable::new(limits),
            gate: Mutex::new(Gate::new(staleness)),
            params,
            queue: tx,
            queued: AtomicUsize::new(0),
            counters: FragmentCounters::default(),
        };
        (Arc::new(hub), rx)
    }

    /// Opens a session for an actor, unless the session cap is reached.
    pub fn open_session(&self, name: String, envs: u32) -> Result<(u64, Session), SessionCap> {
        self.sessions.open(name, envs)
    }

    /// The session `id`, if open.
    pub fn session(&self, id: u64) -> Option<Session> {
        self.sessions.get(id)
    }

    /// Records a parameter stream of session `id` opening; false if the
    /// session is not open (unknown, left or expired).
    pub fn open_watch(&self, id: u64) -> bool {
        self.sessions.open_watch(id)
    }

    /// Records a parameter stream of session `id` closing; a session whose
    /// last stream closes is gone (its actor died or cut the connection).
    pub fn close_watch(&self, id: u64) {
        self.sessions.close_watch(id)
    }

    /// Sessions with an open parameter stream.
    pub fn connected(&self) -> usize {
        self.sessions.connected()
    }

    /// The session limits.
    pub fn session_limits(&self) -> SessionLimits {
        self.sessions.limits()
    }

    /// Marks `seq` of session `id` as received; `Err(last)` if it is not
    /// newer than the last one, `None` if the session is not open.
    pub fn claim_seq(&self, id: u64, seq: u64) -> Option<Result<(), u64>> {
        self.sessions.claim_seq(id, seq)
    }

    /// Removes idle sessions every [`SessionTable::sweep_every`], until
    /// the runtime it is spawned on shuts down.
    pub async fn expire_idle_sessions(self: Arc<Self>) {
        let mut every = tokio::time::interval(self.sessions.sweep_every());
        every.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            every.tick().await;
            self.sessions.expire_idle(Instant::now());
        }
    }

    /// A receiver of the weights: the latest at once, then each new one.
    pub fn subscribe(&self) -> watch::Receiver<Arc<v1::Parameters>> {
        self.params.subscribe()
    }

    /// The newest policy version.
    pub fn version(&self) -> u64 {
        self.gate.lock().expect("gate lock").version()
    }

    /// Admission of `env_steps` collected with `version` by the run's
    /// [`Gate`]: `Ok(wait_for_next)` if admitted, `Err(reason)` if refused.
    /// The caller checked `version` is not newer than the learner's.
    pub fn admit(&self, version: u64, env_steps: u64) -> Result<bool, Refusal> {
        self.gate
            .lock()
            .expect("gate lock")
            .admit(version, env_steps)
    }

    /// A place in the learner's queue, waited for while the queue is full;
    /// `None` once the learner stopped taking fragments.
    ///
    /// The wait is the only await between a fragment's checks and its
    /// queueing: a handler cancelled there (its client gone) has admitted
    /// nothing and counted nothing, so the gate's step count and the queue
    /// depth stay true.
    pub async fn reserve(&self) -> Option<QueueSlot<'_>> {
        let permit = self.queue.reserve().await.ok()?;
        Some(QueueSlot {
            permit,
            queued: &self.queued,
        })
    }

    /// Publishes weights to every parameter stream and resets the gate.
    pub fn publish(&self, weights: &Weights, wanted_env_steps: Option<u64>) {
        let msg = Arc::new(weights_to_message(weights, &self.info.run_id));
        self.gate
            .lock()
            .expect("gate lock")
            .open(weights.version, wanted_env_steps);
        self.params.send_replace(msg);
    }

    /// Tells every actor the run is over.
    pub fn finish(&self) {
        self.gate.lock().expect("gate lock").close();
        let version = self.version();
        self.params.send_replace(Arc::new(v1::Parameters {
            run_id: self.info.run_id.clone(),
            version,
            tensors: Vec::new(),
            finished: true,
        }));
    }

    /// Whether [`Self::finish`] was called.
    pub fn finished(&self) -> bool {
        self.params.borrow().finished
    }
}

/// The outcome a refusal is counted as.
pub fn refusal_outcome(refusal: &Refusal) -> Outcome {
    match refusal {
        Refusal::Stale { .. } => Outcome::Stale,
        Refusal::Surplus { .. } => Outcome::Surplus,
    }
}

/// The learner loop's [`Exchange`] over the hub.
pub struct RemoteExchange {
    hub: Arc<Hub>,
    rx: mpsc::Receiver<Fragment>,
    runtime: tokio::runtime::Handle,
}

impl RemoteExchange {
    /// The learner's end of `hub`; `runtime` runs the gRPC server.
    pub fn new(
        hub: Arc<Hub>,
        rx: mpsc::Receiver<Fragment>,
        runtime: tokio::runtime::Handle,
    ) -> Self {
        Self { hub, rx, runtime }
    }
}

impl Exchange for RemoteExchange {
    fn publish(
        &mut self,
        weights: Weights,
        wanted_env_steps: Option<u64>,
    ) -> Result<(), ExchangeError> {
        self.hub.publish(&weights, wanted_env_steps);
        Ok(())
    }

    fn next_fragment(&mut self, timeout: Duration) -> Result<Option<Fragment>, ExchangeError> {
        let rx = &mut self.rx;
        let got = self
            .runtime
            .block_on(async { tokio::time::timeout(timeout, rx.recv()).await });
        match got {
            Ok(Some(f)) => {
                self.hub.queued.fetch_sub(1, Ordering::SeqCst);
                Ok(Some(f))
            }
            Ok(None) => Err(ExchangeError::QueueClosed),
            Err(_) => Ok(None),
        }
    }

    fn queue_depth(&self) -> usize {
        self.hub.queued.load(Ordering::SeqCst)
    }

    fn connected_actors(&self) -> usize {
        self.hub.connected()
    }

    fn fragment_outcomes(&self) -> Vec<(&'static str, u64)> {
        let c = &self.hub.counters;
        [
            (Outcome::Accepted, &c.accepted),
            (Outcome::Stale, &c.stale),
            (Outcome::Surplus, &c.surplus),
            (Outcome::Invalid, &c.invalid),
            (Outcome::Duplicate, &c.duplicate),
        ]
        .into_iter()
        .map(|(o, n)| (o.label(), n.load(Ordering::Relaxed)))
        .collect()
    }

    fn finish(&mut self, complete: bool) -> Result<(), ExchangeError> {
        if complete {
            self.hub.finish();
        }
        // Unblock handlers waiting on a full queue: they answer `run_finished`.
        self.rx.close();
        while self.rx.try_recv().is_ok() {
            self.hub.queued.fetch_sub(1, Ordering::SeqCst);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hub(capacity: usize) -> (Arc<Hub>, mpsc::Receiver<Fragment>) {
        let info = RunInfo {
            run_id: "test".into(),
            spec: v1::RunSpec {
                map: Some(v1::MapSource::default()),
                env: Some(v1::EnvSettings::default()),
                fragment_len: 1,
                on_policy: true,
                ..Default::default()
            },
            envs_per_actor: 1,
            max_envs: 1,
            seed_base: 0,
            obs_dim: 1,
            heads: 1,
            actions_per_head: 5,
            rows_per_env: 1,
        };
        let plausibility = Plausibility::new(&buridan_env::EnvConfig::default(), 10, 1, 1);
        Hub::new(info, capacity, SessionLimits::default(), plausibility)
    }

    /// A submit handler cancelled while it waits for room in a full queue
    /// (its client gone) must leave the gate's step count and the queue
    /// depth as they were: on-policy, steps admitted but never queued would
    /// leave the learner waiting for a batch that cannot fill.
    #[tokio::test]
    async fn a_wait_for_room_cancelled_admits_and_counts_nothing() {
        let (hub, mut rx) = hub(1);
        hub.publish(&Weights::default(), Some(2));
        hub.reserve().await.expect("room").send(Fragment::default());
        assert_eq!(hub.admit(0, 1), Ok(false), "one of two steps admitted");
        assert_eq!(hub.queued.load(Ordering::SeqCst), 1);

        let waiting = tokio::time::timeout(Duration::from_millis(50), hub.reserve()).await;
        assert!(waiting.is_err(), "the queue is full, the wait times out");
        assert_eq!(
            hub.queued.load(Ordering::SeqCst),
            1,
            "the cancelled wait counted nothing"
        );

        rx.recv().await.expect("the queued fragment");
        hub.queued.fetch_sub(1, Ordering::SeqCst);
        let slot = hub.reserve().await.expect("room again");
        assert_eq!(
            hub.admit(0, 1),
            Ok(true),
            "the batch's last step is still open"
        );
        slot.send(Fragment::default());
        assert_eq!(hub.queued.load(Ordering::SeqCst), 1);
    }
}
