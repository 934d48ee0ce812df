//! The learner's end of the data path: where fragments come from and where
//! new weights go. [`InProcess`] runs actor threads over channels (the
//! embedded default); `crate::serve` implements the same trait over gRPC.
//!
//! ```text
//! actor: Collector ──Fragment──▶ bounded queue ──▶ Exchange::next_fragment ─▶ learner
//!        ◀──────── Weights{version} ◀──────────── Exchange::publish ◀──────── update
//! ```

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError};
use std::sync::{Arc, Condvar, Mutex, RwLock};
use std::thread::JoinHandle;
use std::time::Duration;

use buridan_actor::{CollectError, Collector};
use buridan_env::BatchedEnv;
use buridan_policy::{Fragment, Weights};

use crate::train::error::ExchangeError;
use crate::train::gate::{Gate, Staleness};

/// Where the learner gets fragments and sends weights.
pub trait Exchange {
    /// Makes `weights` the ones actors collect with. On-policy runs pass
    /// `wanted_env_steps`: collect that much experience with exactly this
    /// version, then wait for the next.
    fn publish(
        &mut self,
        weights: Weights,
        wanted_env_steps: Option<u64>,
    ) -> Result<(), ExchangeError>;
    /// The next fragment, or `None` if none arrived within `timeout`.
    fn next_fragment(&mut self, timeout: Duration) -> Result<Option<Fragment>, ExchangeError>;
    /// Fragments waiting in the queue.
    fn queue_depth(&self) -> usize;
    /// Actors currently connected.
    fn connected_actors(&self) -> usize;
    /// Fragments so far by what became of them at the exchange
    /// (`accepted`, `stale`, …); none if it does not count them.
    fn fragment_outcomes(&self) -> Vec<(&'static str, u64)> {
        Vec::new()
    }
    /// Ends the learner's side. `complete`: the run reached its goal and
    /// actors are told to stop; otherwise (interrupted) remote actors are
    /// left to reconnect to a restarted learner. Returns the first actor
    /// failure, if any.
    fn finish(&mut self, complete: bool) -> Result<(), ExchangeError>;
}

/// What an in-process actor is told to do next: the data its loop matches
/// on (never a message to parse).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ticket {
    /// Collect one fragment with this policy version.
    Collect(u64),
    /// The run is over: stop.
    Finished,
}

/// What the learner shares with its in-process actors: the newest weights
/// and the gate that says how much to collect with them.
pub struct Shared {
    weights: RwLock<Arc<Weights>>,
    gate: Mutex<(Gate, bool)>,
    wake: Condvar,
}

impl Shared {
    /// Starts with `weights` and a closed gate.
    pub fn new(weights: Weights, staleness: Staleness) -> Self {
        Self {
            weights: RwLock::new(Arc::new(weights)),
            gate: Mutex::new((Gate::new(staleness), false)),
            wake: Condvar::new(),
        }
    }

    /// Publishes new weights and opens the gate for them.
    pub fn publish(&self, weights: Weights, wanted_env_steps: Option<u64>) {
        let version = weights.version;
        *self.weights.write().expect("weights lock") = Arc::new(weights);
        let mut g = self.gate.lock().expect("gate lock");
        g.0.open(version, wanted_env_steps);
        self.wake.notify_all();
    }

    /// The latest weights.
    pub fn latest(&self) -> Arc<Weights> {
        self.weights.read().expect("weights lock").clone()
    }

    /// Ends the run: every waiting and future [`Shared::ticket`] is
    /// [`Ticket::Finished`].
    pub fn finish(&self) {
        let mut g = self.gate.lock().expect("gate lock");
        g.0.close();
        g.1 = true;
        self.wake.notify_all();
    }

    /// Waits until `env_steps` more of the newest version are wanted.
    pub fn ticket(&self, env_steps: u64) -> Ticket {
        let mut g = self.gate.lock().expect("gate lock");
        loop {
            if g.1 {
                return Ticket::Finished;
            }
            let version = g.0.version();
            if g.0.admit(version, env_steps).is_ok() {
                return Ticket::Collect(version);
            }
            g = self.wake.wait(g).expect("gate lock");
        }
    }
}

/// Actor threads in the learner's process, feeding a bounded queue.
pub struct InProcess {
    shared: Arc<Shared>,
    rx: Option<Receiver<Fragment>>,
    actors: Vec<(u32, JoinHandle<Result<(), CollectError>>)>,
    depth: Arc<AtomicUsize>,
    received: u64,
}

impl InProcess {
    /// Starts one thread per collector, at niceness `nice` (0: the
    /// learner's priority; `TrainConfig::actor_nice`); the queue holds
    /// `capacity` fragments. Actors start collecting at the first
    /// [`Exchange::publish`].
    pub fn spawn<E: BatchedEnv + Send + 'static>(
        collectors: Vec<Collector<E>>,
        capacity: usize,
        staleness: Staleness,
        nice: u8,
    ) -> Result<Self, ExchangeError> {
        if collectors.is_empty() {
            return Err(ExchangeError::NoActors);
        }
        let shared = Arc::new(Shared::new(Weights::default(), staleness));
        let (tx, rx) = sync_channel::<Fragment>(capacity.max(1));
        let depth = Arc::new(AtomicUsize::new(0));
        let mut actors = Vec::new();
        for mut collector in collectors {
            let (shared, tx, depth) = (shared.clone(), tx.clone(), depth.clone());
            let id = collector.id;
            let handle = std::thread::Builder::new()
                .name(format!("actor-{id}"))
                .spawn(move || -> Result<(), CollectError> {
                    if nice > 0 {
                        if let Err(e) = buridan_policy::threads::lower_priority(nice) {
                            tracing::warn!(
                                actor = id,
                                nice,
                                "actor thread keeps its priority: {e}"
                            );
                        }
                    }
                    let env_steps = collector.fragment_env_steps();
                    while let Ticket::Collect(_) = shared.ticket(env_steps) {
                        collector.load(&shared.latest())?;
                        let fragment = collector.collect()?;
                        depth.fetch_add(1, Ordering::SeqCst);
                        if tx.send(fragment).is_err() {
                            break;
                        }
                    }
                    Ok(())
                })
                .map_err(ExchangeError::Spawn)?;
            actors.push((id, handle));
        }
        Ok(Self {
            shared,
            rx: Some(rx),
            actors,
            depth,
            received: 0,
        })
    }

    /// Joins every finished actor thread; the first failure, with its cause.
    fn reap_finished(&mut self) -> Option<ExchangeError> {
        let (done, running): (Vec<_>, Vec<_>) =
            self.actors.drain(..).partition(|(_, h)| h.is_finished());
        self.actors = running;
        first_failure(done)
    }
}

/// Joins every given actor and returns the first failure.
fn first_failure(
    actors: Vec<(u32, JoinHandle<Result<(), CollectError>>)>,
) -> Option<ExchangeError> {
    actors
        .into_iter()
        .filter_map(|(actor, h)| join_actor(actor, h).err())
        .fold(None, |first, e| first.or(Some(e)))
}

fn join_actor(
    actor: u32,
    handle: JoinHandle<Result<(), CollectError>>,
) -> Result<(), ExchangeError> {
    match handle.join() {
        Ok(Ok(())) => Ok(()),
        Ok(Err(source)) => Err(ExchangeError::Actor { actor, source }),
        Err(_) => Err(ExchangeError::ActorPanicked { actor }),
    }
}

impl Exchange for InProcess {
    fn publish(
        &mut self,
        weights: Weights,
        wanted_env_steps: Option<u64>,
    ) -> Result<(), ExchangeError> {
        self.shared.publish(weights, wanted_env_steps);
        Ok(())
    }

    fn next_fragment(&mut self, timeout: Duration) -> Result<Option<Fragment>, ExchangeError> {
        let Some(rx) = self.rx.as_ref() else {
            return Err(ExchangeError::QueueClosed);
        };
        match rx.recv_timeout(timeout) {
            Ok(f) => {
                self.depth.fetch_sub(1, Ordering::SeqCst);
                self.received += 1;
                Ok(Some(f))
            }
            Err(RecvTimeoutError::Timeout) => {
                // An actor that stops before the run ends has failed: its
                // own error is the learner's.
                match self.reap_finished() {
                    Some(e) => Err(e),
                    None => Ok(None),
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                // Every actor dropped its sender: all are ending; their
                // own errors say why.
                let actors = std::mem::take(&mut self.actors);
                Err(first_failure(actors).unwrap_or(ExchangeError::QueueClosed))
            }
        }
    }

    fn queue_depth(&self) -> usize {
        self.depth.load(Ordering::SeqCst)
    }

    fn connected_actors(&self) -> usize {
        self.actors.iter().filter(|(_, h)| !h.is_finished()).count()
    }

    fn fragment_outcomes(&self) -> Vec<(&'static str, u64)> {
        vec![("accepted", self.received)]
    }

    fn finish(&mut self, _complete: bool) -> Result<(), ExchangeError> {
        self.shared.finish();
        // Dropping the receiver unblocks actors waiting on a full queue.
        self.rx = None;
        first_failure(std::mem::take(&mut self.actors)).map_or(Ok(()), Err)
    }
}

impl Drop for InProcess {
    fn drop(&mut self) {
        if !self.actors.is_empty() {
            let _ = self.finish(false);
        }
    }
}
