//! The median stopping rule (Golovin et al., "Google Vizier", KDD 2017):
//! stop a trial at step s if its best value so far is below the median of
//! the other trials' running means up to s.
//!
//! "The other trials" are all that have reported at or before s, including
//! those not yet at s (their mean so far): with parallel trials reporting in
//! turn, requiring others to have reached s would exempt whichever trial
//! reports first in each round, for ever. Others behind s have lower means
//! on rising curves, so this errs towards continuing.

use std::collections::BTreeMap;

use crate::scheduler::{Decision, Scheduler};
use crate::stats::{mean, quantile};

/// Every trial's reports, to compare a trial with the others at equal steps.
///
/// ```
/// use buridan_study::scheduler::{MedianStopping, Scheduler};
/// use buridan_study::Decision;
/// let mut m = MedianStopping::new(0, 2);
/// for t in 0..2 { m.report(t, 10, 0.8); }
/// assert_eq!(m.report(2, 10, 0.1), Decision::Stop);
/// assert_eq!(m.report(3, 10, 0.9), Decision::Continue);
/// ```
#[derive(Debug, Clone, Default)]
pub struct MedianStopping {
    grace_steps: u64,
    min_trials: usize,
    reports: BTreeMap<u64, Vec<(u64, f64)>>,
}

impl MedianStopping {
    /// No decisions before `grace_steps` nor with fewer than `min_trials`
    /// other trials that have reported.
    ///
    /// ```
    /// let _ = buridan_study::scheduler::MedianStopping::new(100_000, 3);
    /// ```
    pub fn new(grace_steps: u64, min_trials: usize) -> MedianStopping {
        MedianStopping {
            grace_steps,
            min_trials: min_trials.max(1),
            reports: BTreeMap::new(),
        }
    }
}

impl Scheduler for MedianStopping {
    fn report(&mut self, trial: u64, step: u64, value: f64) -> Decision {
        let value = if value.is_nan() {
            f64::NEG_INFINITY
        } else {
            value
        };
        self.reports.entry(trial).or_default().push((step, value));
        if step < self.grace_steps {
            return Decision::Continue;
        }
        let best = self.reports[&trial]
            .iter()
            .filter(|(s, _)| *s <= step)
            .map(|(_, v)| *v)
            .fold(f64::NEG_INFINITY, f64::max);
        let mut others: Vec<f64> = self
            .reports
            .iter()
            .filter(|(&t, _)| t != trial)
            .filter_map(|(_, r)| {
                let upto: Vec<f64> = r
                    .iter()
                    .filter(|(s, _)| *s <= step)
                    .map(|(_, v)| *v)
                    .collect();
                mean(&upto)
            })
            .collect();
        if others.len() < self.min_trials {
            return Decision::Continue;
        }
        others.sort_by(f64::total_cmp);
        match quantile(&others, 0.5) {
            Some(median) if best < median => Decision::Stop,
            _ => Decision::Continue,
        }
    }
}
