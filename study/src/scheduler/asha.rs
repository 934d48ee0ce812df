//! Asynchronous successive halving (Li et al., "A System for Massively
//! Parallel Hyperparameter Tuning", MLSys 2020), in its stopping form (as
//! Ray Tune's `AsyncHyperBandScheduler`): rungs at `grace · η^k` steps below
//! the trial budget; a trial reaching a rung is compared with every value
//! recorded there so far and goes on only if it is in the top 1/η.

use std::collections::BTreeSet;

use crate::scheduler::{Decision, Scheduler};
use crate::stats::quantile;

/// ASHA's state: the milestones and the values recorded at each.
///
/// ```
/// use buridan_study::scheduler::{Asha, Scheduler};
/// use buridan_study::Decision;
/// let mut asha = Asha::new(100, 3, 10_000);
/// assert_eq!(asha.milestones(), [100, 300, 900, 2700, 8100]);
/// assert_eq!(asha.report(0, 100, 0.9), Decision::Promote { rung: 0 });
/// assert_eq!(asha.report(1, 100, 0.5), Decision::Stop); // below the top third
/// assert_eq!(asha.report(1, 150, 0.5), Decision::Continue); // no new rung
/// ```
#[derive(Debug, Clone)]
pub struct Asha {
    milestones: Vec<u64>,
    reduction: f64,
    recorded: Vec<Vec<f64>>,
    seen: BTreeSet<(u64, usize)>,
}

impl Asha {
    /// Rungs at `grace · η^k < max_steps` (η = `reduction`, at least 2).
    ///
    /// ```
    /// assert_eq!(buridan_study::scheduler::Asha::new(10, 2, 50).milestones(), [10, 20, 40]);
    /// ```
    pub fn new(grace_steps: u64, reduction: u64, max_steps: u64) -> Asha {
        let eta = reduction.max(2);
        let mut milestones = Vec::new();
        let mut m = grace_steps.max(1);
        while m < max_steps {
            milestones.push(m);
            m = m.saturating_mul(eta);
        }
        Asha {
            recorded: vec![Vec::new(); milestones.len()],
            milestones,
            reduction: eta as f64,
            seen: BTreeSet::new(),
        }
    }

    /// The rung milestones in env steps.
    ///
    /// ```
    /// assert!(buridan_study::scheduler::Asha::new(100, 3, 100).milestones().is_empty());
    /// ```
    pub fn milestones(&self) -> &[u64] {
        &self.milestones
    }
}

impl Scheduler for Asha {
    fn report(&mut self, trial: u64, step: u64, value: f64) -> Decision {
        // The highest milestone reached decides; lower ones a trial skipped
        // over (reports are sparse) are not recorded.
        let Some(rung) = self.milestones.iter().rposition(|&m| step >= m) else {
            return Decision::Continue;
        };
        if !self.seen.insert((trial, rung)) {
            return Decision::Continue;
        }
        let value = if value.is_nan() {
            f64::NEG_INFINITY
        } else {
            value
        };
        self.recorded[rung].push(value);
        let mut sorted = self.recorded[rung].clone();
        sorted.sort_by(f64::total_cmp);
        let cutoff = quantile(&sorted, 1.0 - 1.0 / self.reduction).unwrap_or(value);
        if value < cutoff {
            Decision::Stop
        } else {
            Decision::Promote { rung }
        }
    }
}
