//! Schedulers: whether a running trial deserves more steps. One trait, one
//! file per rule; population-based training is a decision function beside them.
//!
//! A scheduler sees the stream of intermediate reports `(trial, step,
//! value)`; a resumed study replays the recorded reports to rebuild it.

use serde::{Deserialize, Serialize};

pub mod asha;
pub mod median;
pub mod pbt;

pub use asha::Asha;
pub use median::MedianStopping;

/// A scheduler's answer to one report.
///
/// ```
/// assert!(buridan_study::Decision::Promote { rung: 0 }.keeps_going());
/// assert!(!buridan_study::Decision::Stop.keeps_going());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    /// Keep training.
    Continue,
    /// The trial passed rung `rung` and goes on to the next.
    Promote {
        /// The rung passed (0 = the first milestone).
        rung: usize,
    },
    /// End the trial now.
    Stop,
}

impl Decision {
    /// `true` unless the decision is [`Decision::Stop`].
    ///
    /// ```
    /// assert!(buridan_study::Decision::Continue.keeps_going());
    /// ```
    pub fn keeps_going(&self) -> bool {
        !matches!(self, Decision::Stop)
    }
}

/// Judges intermediate reports (values are maximised).
///
/// ```
/// use buridan_study::scheduler::{Scheduler, NoStopping};
/// let mut s = NoStopping;
/// assert_eq!(s.report(0, 100, -5.0), buridan_study::Decision::Continue);
/// ```
pub trait Scheduler: Send {
    /// Trial `trial` reached `step` with objective `value`.
    fn report(&mut self, trial: u64, step: u64, value: f64) -> Decision;
}

/// Never stops a trial.
///
/// ```
/// use buridan_study::scheduler::{NoStopping, Scheduler};
/// assert!(NoStopping.report(1, 1, 0.0).keeps_going());
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct NoStopping;

impl Scheduler for NoStopping {
    fn report(&mut self, _trial: u64, _step: u64, _value: f64) -> Decision {
        Decision::Continue
    }
}

/// The schedulers a study file can name, with their settings.
///
/// ```
/// let t: toml::Table = toml::from_str("kind = \"asha\"\ngrace_steps = 100000").unwrap();
/// let k: buridan_study::scheduler::SchedulerKind = t.try_into().unwrap();
/// assert!(matches!(k, buridan_study::scheduler::SchedulerKind::Asha { reduction: 3, .. }));
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SchedulerKind {
    /// Every trial runs its full budget.
    #[default]
    None,
    /// Asynchronous successive halving.
    Asha {
        /// First rung, in env steps.
        grace_steps: u64,
        /// Reduction factor η: rungs at grace·η^k, the top 1/η go on.
        #[serde(default = "three")]
        reduction: u64,
    },
    /// The median stopping rule.
    Median {
        /// No stopping before this step.
        grace_steps: u64,
        /// Other trials needed at a step before judging.
        #[serde(default = "three_usize")]
        min_trials: usize,
    },
}

fn three() -> u64 {
    3
}

fn three_usize() -> usize {
    3
}

impl SchedulerKind {
    /// The scheduler for trials of `max_steps` steps.
    ///
    /// ```
    /// let s = buridan_study::scheduler::SchedulerKind::None.build(1000);
    /// drop(s);
    /// ```
    pub fn build(&self, max_steps: u64) -> Box<dyn Scheduler> {
        match *self {
            SchedulerKind::None => Box::new(NoStopping),
            SchedulerKind::Asha {
                grace_steps,
                reduction,
            } => Box::new(Asha::new(grace_steps, reduction, max_steps)),
            SchedulerKind::Median {
                grace_steps,
                min_trials,
            } => Box::new(MedianStopping::new(grace_steps, min_trials)),
        }
    }
}
