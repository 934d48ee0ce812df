//! The learner's end of the data path: where fragments come from and where
//! new weights go. [`InProcess`] runs actor threads over channels (the
//! embedded default); `crate::serve` implements the same trait over gRPC.
//!
//! ```text
//! actor: Collector ──Fragment──▶ bounded queue ──▶ Exchange::next_fragment ─▶ learner
//!        ◀──────── Weights{version} ◀──────────── Exchange::publish ◀──────── update
//! ```

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError};
use std::sync::{Arc, Condvar, Mutex, RwLock};
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::{anyhow, bail, Context, Result};
use buridan_actor::Collector;
use buridan_policy::{Fragment, Weights};

/// Where the learner gets fragments and sends weights.
pub trait Exchange {
    /// Makes `weights` the ones actors collect with. On-policy runs pass
    /// `wanted_env_steps`: collect that much experience with exactly this
    /// version, then wait for the next.
    fn publish(&mut self, weights: Weights, wanted_env_steps: Option<u64>) -> Result<()>;
    /// The next fragment, or `None` if none arrived within `timeout`.
    fn next_fragment(&mut self, timeout: Duration) -> Result<Option<Fragment>>;
    /// Fragments waiting in the queue.
    fn queue_depth(&self) -> usize;
    /// Actors currently connected.
    fn connected_actors(&self) -> usize;
    /// Ends the learner's side. `complete`: the run reached its goal and
    /// actors are told to stop; otherwise (interrupted) remote actors are
    /// left to reconnect to a restarted learner.
    fn finish(&mut self, complete: bool) -> Result<()>;
}

/// What the learner shares with its in-process actors.
pub struct Shared {
    weights: RwLock<Arc<Weights>>,
    gate: Mutex<Gate>,
    wake: Condvar,
    stop: AtomicBool,
}

/// On-policy gating: how many more fragments may be collected with which
/// policy version.
struct Gate {
    version: u64,
    remaining: usize,
}

impl Shared {
    /// Starts with `weights`; actors may not collect until [`Self::open`]
    /// (on-policy) unless `unlimited`.
    pub fn new(weights: Weights, unlimited: bool) -> Self {
        let version = weights.version;
        Self {
            weights: RwLock::new(Arc::new(weights)),
            gate: Mutex::new(Gate {
                version,
                remaining: if unlimited { usize::MAX } else { 0 },
            }),
            wake: Condvar::new(),
            stop: AtomicBool::new(false),
        }
    }

    /// Publishes new weights (actors load them before their next fragment).
    pub fn publish(&self, weights: Weights) {
        *self.weights.write().expect("weights lock") = Arc::new(weights);
    }

    /// The latest weights.
    pub fn latest(&self) -> Arc<Weights> {
        self.weights.read().expect("weights lock").clone()
    }

    /// Allows `fragments` more fragments with policy `version` (on-policy:
    /// the weights of that version must already be published).
    pub fn open(&self, version: u64, fragments: usize) {
        let mut g = self.gate.lock().expect("gate lock");
        g.version = version;
        g.remaining = fragments;
        self.wake.notify_all();
    }

    /// Asks every actor to stop.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
        let _g = self.gate.lock().expect("gate lock");
        self.wake.notify_all();
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Takes a ticket for one fragment; `None` once stopped.
    fn ticket(&self) -> Option<u64> {
        let mut g = self.gate.lock().expect("gate lock");
        loop {
            if self.stopped() {
                return None;
            }
            if g.remaining > 0 {
                if g.remaining != usize::MAX {
                    g.remaining -= 1;
                }
                return Some(g.version);
            }
            g = self.wake.wait(g).expect("gate lock");
        }
    }
}

/// Actor threads in the learner's process, feeding a bounded queue.
pub struct InProcess {
    shared: Arc<Shared>,
    rx: Option<Receiver<Fragment>>,
    handles: Vec<JoinHandle<Result<()>>>,
    fragment_env_steps: u64,
    on_policy: bool,
    depth: Arc<std::sync::atomic::AtomicUsize>,
}

impl InProcess {
    /// Starts one thread per collector; the queue holds `capacity`
    /// fragments. Actors start collecting at the first [`Exchange::publish`].
    pub fn spawn(collectors: Vec<Collector>, capacity: usize, on_policy: bool) -> Result<Self> {
        let first = collectors
            .first()
            .ok_or_else(|| anyhow!("at least one actor is needed"))?;
        let fragment_env_steps = (first.fragment_len * first.venv.num_envs()) as u64;
        let shared = Arc::new(Shared::new(Weights::default(), false));
        let (tx, rx) = sync_channel::<Fragment>(capacity.max(1));
        let depth = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let mut handles = Vec::new();
        for (i, mut collector) in collectors.into_iter().enumerate() {
            let (shared, tx, depth) = (shared.clone(), tx.clone(), depth.clone());
            handles.push(
                std::thread::Builder::new()
                    .name(format!("actor-{i}"))
                    .spawn(move || -> Result<()> {
                        while let Some(_version) = shared.ticket() {
                            collector.load(&shared.latest())?;
                            let fragment = collector.collect()?;
                            depth.fetch_add(1, Ordering::SeqCst);
                            if tx.send(fragment).is_err() {
                                break;
                            }
                        }
                        Ok(())
                    })
                    .context("cannot start an actor thread")?,
            );
        }
        Ok(Self {
            shared,
            rx: Some(rx),
            handles,
            fragment_env_steps,
            on_policy,
            depth,
        })
    }
}

impl Exchange for InProcess {
    fn publish(&mut self, weights: Weights, wanted_env_steps: Option<u64>) -> Result<()> {
        let version = weights.version;
        self.shared.publish(weights);
        match (self.on_policy, wanted_env_steps) {
            (true, Some(steps)) => {
                let fragments = steps.div_ceil(self.fragment_env_steps.max(1)) as usize;
                self.shared.open(version, fragments);
            }
            _ => self.shared.open(version, usize::MAX),
        }
        Ok(())
    }

    fn next_fragment(&mut self, timeout: Duration) -> Result<Option<Fragment>> {
        let rx = self
            .rx
            .as_ref()
            .ok_or_else(|| anyhow!("the run is finished"))?;
        match rx.recv_timeout(timeout) {
            Ok(f) => {
                self.depth.fetch_sub(1, Ordering::SeqCst);
                Ok(Some(f))
            }
            Err(RecvTimeoutError::Timeout) => {
                if self.handles.iter().any(|h| h.is_finished()) {
                    bail!("an actor stopped unexpectedly");
                }
                Ok(None)
            }
            Err(RecvTimeoutError::Disconnected) => bail!("all actors stopped"),
        }
    }

    fn queue_depth(&self) -> usize {
        self.depth.load(Ordering::SeqCst)
    }

    fn connected_actors(&self) -> usize {
        self.handles.iter().filter(|h| !h.is_finished()).count()
    }

    fn finish(&mut self, _complete: bool) -> Result<()> {
        self.shared.stop();
        // Dropping the receiver unblocks actors waiting on a full queue.
        self.rx = None;
        let mut error = None;
        for h in self.handles.drain(..) {
            match h.join() {
                Ok(Ok(())) => {}
                Ok(Err(e)) => error = Some(e),
                Err(_) => error = Some(anyhow!("an actor thread panicked")),
            }
        }
        match error {
            Some(e) => Err(e.context("actor failed")),
            None => Ok(()),
        }
    }
}

impl Drop for InProcess {
    fn drop(&mut self) {
        if !self.handles.is_empty() {
            let _ = self.finish(false);
        }
    }
}
