//! The trial drivers' progress on the terminal: one bar per running trial.

use buridan_experiment::trial::{TrialDisplay, TrialView};
use buridan_learner::train::MetricsRow;
use buridan_study::TrialSpec;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};

/// One bar per running trial in a [`MultiProgress`].
pub struct TrialBars(pub MultiProgress);

impl TrialDisplay for TrialBars {
    fn trial(&self, spec: &TrialSpec) -> Box<dyn TrialView> {
        let bar = self.0.add(ProgressBar::new(spec.steps));
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{bar:20}] {human_pos}/{human_len} {msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_prefix(format!("trial {:>3}", spec.id));
        crate::heartbeat::watch(&bar);
        Box::new(TrialBar {
            bar,
            multi: self.0.clone(),
        })
    }
}

/// A trial's bar, removed when its training ends.
struct TrialBar {
    bar: ProgressBar,
    multi: MultiProgress,
}

impl TrialView for TrialBar {
    fn started(&mut self, total_steps: u64, env_steps: u64) {
        crate::heartbeat::start_at(&self.bar, total_steps, env_steps);
    }

    fn row(&mut self, row: &MetricsRow) {
        self.bar.set_position(row.env_steps);
        self.bar.set_message(format!(
            "success {:>5.1}%  len {:>5.1}  {:>6.0} steps/s",
            100.0 * row.success_rate,
            row.episode_len_mean,
            row.steps_per_s
        ));
    }
}

impl Drop for TrialBar {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
        self.multi.remove(&self.bar);
    }
}
