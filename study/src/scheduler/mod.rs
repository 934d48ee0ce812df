//! Schedulers: whether a running trial deserves more steps. One trait, one
//! file per rule; population-based training is a decision function beside
//! them, which the study driver runs in rounds (`crate::population`).
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
    /// Population-based training: the population trains in rounds of
    /// `interval_steps`; after each round the bottom quantile continues from
    /// a top member's checkpoint with perturbed hyperparameters ([`pbt`]).
    Pbt {
        /// Env steps per round.
        interval_steps: u64,
        /// Members; the study file's `parallel` when not given.
        #[serde(default)]
        population: Option<usize>,
        /// Fraction of the population in the top and in the bottom group.
        #[serde(default = "quarter")]
        quantile: f64,
        /// Probability of redrawing a parameter instead of perturbing it.
        #[serde(default = "quarter")]
        resample_probability: f64,
    },
}

fn quarter() -> f64 {
    0.25
}

fn three() -> u64 {
    3
}

fn three_usize() -> usize {
    3
}

impl SchedulerKind {
    /// The scheduler for trials of `max_steps` steps. PBT stops no trial:
    /// its rounds are the study driver's, so it judges reports like `None`.
    ///
    /// ```
    /// let s = buridan_study::scheduler::SchedulerKind::None.build(1000);
    /// drop(s);
    /// ```
    pub fn build(&self, max_steps: u64) -> Box<dyn Scheduler> {
        match *self {
            SchedulerKind::None | SchedulerKind::Pbt { .. } => Box::new(NoStopping),
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

    /// The exploit-and-explore settings of a PBT scheduler, `None` for the others.
    ///
    /// ```
    /// let t: toml::Table = toml::from_str("kind = \"pbt\"\ninterval_steps = 1000").unwrap();
    /// let k: buridan_study::scheduler::SchedulerKind = t.try_into().unwrap();
    /// assert_eq!(k.pbt().unwrap().quantile, 0.25);
    /// assert!(buridan_study::scheduler::SchedulerKind::None.pbt().is_none());
    /// ```
    pub fn pbt(&self) -> Option<pbt::PbtConfig> {
        match *self {
            SchedulerKind::Pbt {
                quantile,
                resample_probability,
                ..
            } => Some(pbt::PbtConfig {
                quantile,
                resample_probability,
                ..pbt::PbtConfig::default()
            }),
            _ => None,
        }
    }
}
