//! The cores a run's learner may use: the machine's, shared among the runs
//! this process is training at the same moment (a study or a tuner runs
//! several at once), so that `parallel` runs of `update_threads = 0`
//! together use each core once instead of oversubscribing them.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

static RUNS_LEARNING: AtomicUsize = AtomicUsize::new(0);

/// Marks one run as learning for as long as it lives.
///
/// ```
/// use buridan_learner::train::cores::{self, Learning};
/// let alone = cores::share();
/// let a = Learning::start();
/// let b = Learning::start();
/// assert!(cores::share() <= alone.max(1));
/// drop((a, b));
/// ```
#[derive(Debug)]
pub struct Learning(());

impl Learning {
    /// Counts a run as learning until the returned guard drops.
    pub fn start() -> Self {
        RUNS_LEARNING.fetch_add(1, Ordering::SeqCst);
        Self(())
    }
}

impl Drop for Learning {
    fn drop(&mut self) {
        RUNS_LEARNING.fetch_sub(1, Ordering::SeqCst);
    }
}

/// This run's share of the machine's cores: the cores divided among the
/// runs learning now, at least 1.
pub fn share() -> usize {
    // Asked once: on Linux the answer reads the cgroup's CPU quota from
    // files, and every PPO update asks for its share.
    static CORES: OnceLock<usize> = OnceLock::new();
    let cores = *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    share_of(cores, RUNS_LEARNING.load(Ordering::SeqCst))
}

/// The threads an `update_threads` setting (`[ppo]`, `[impala]`) asks for:
/// the number itself, or this run's [`share`] of the cores when it is 0.
///
/// ```
/// use buridan_learner::train::cores;
/// assert_eq!(cores::update_threads(3), 3);
/// assert!(cores::update_threads(0) >= 1);
/// ```
pub fn update_threads(setting: usize) -> usize {
    match setting {
        0 => share(),
        n => n,
    }
}

/// `cores` divided among `runs` runs (a run alone gets them all), at least 1.
///
/// ```
/// use buridan_learner::train::cores::share_of;
/// assert_eq!((share_of(2, 0), share_of(2, 1), share_of(2, 2), share_of(2, 3)), (2, 2, 1, 1));
/// assert_eq!(share_of(8, 3), 2);
/// ```
pub fn share_of(cores: usize, runs: usize) -> usize {
    (cores / runs.max(1)).max(1)
}
