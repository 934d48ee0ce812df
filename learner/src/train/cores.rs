//! The cores a run's learner may use: the machine's, shared among the runs
//! this process is training at the same moment (a study or a tuner runs
//! several at once), so that `parallel` runs of `update_threads = 0`
//! together use each core once instead of oversubscribing them.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

static RUNS_LEARNING: AtomicUsize = AtomicUsize::new(0);

/// Runs this process trains at once by plan ([`plan_runs`]); 0 without.
static RUNS_PLANNED: AtomicUsize = AtomicUsize::new(0);

/// Declares that this process trains up to `runs` runs at once (a study's
/// or a tuner's `parallel`): from now on every run's share is the cores
/// divided by `runs` for its whole life, whatever the other runs are
/// doing at the moment. A run's update cuts its batch into as many shares
/// as it has threads, and float sums depend on the cut: with a share that
/// followed the runs learning at each moment, a run of a study got more
/// threads whenever its neighbour was evaluating or done, and its numbers
/// depended on the neighbour's timing. With a plan they depend only on
/// the run's seed and the machine's cores.
///
/// ```
/// use buridan_learner::train::cores::{self, Learning};
/// cores::plan_runs(2);
/// let alone = Learning::start();
/// let planned = cores::share();
/// let other = Learning::start();
/// assert_eq!(cores::share(), planned, "a neighbour starting changes nothing");
/// drop(other);
/// assert_eq!(cores::share(), planned, "nor one that stops");
/// drop(alone);
/// ```
pub fn plan_runs(runs: usize) {
    RUNS_PLANNED.store(runs, Ordering::SeqCst);
}

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
/// runs learning now (with [`plan_runs`], among the planned runs, or more
/// if more are learning), at least 1.
pub fn share() -> usize {
    // Asked once: on Linux the answer reads the cgroup's CPU quota from
    // files, and every PPO update asks for its share.
    static CORES: OnceLock<usize> = OnceLock::new();
    let cores = *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let runs = RUNS_LEARNING
        .load(Ordering::SeqCst)
        .max(RUNS_PLANNED.load(Ordering::SeqCst));
    share_of(cores, runs)
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
