//! The service's Prometheus series, and the watch on robots that wait.
//!
//! | series | kind | what |
//! |---|---|---|
//! | `buridan_control_step_seconds` | histogram | a Step call's time in the service, from the request decoded to the reply built |
//! | `buridan_control_steps_total` | counter | Steps answered |
//! | `buridan_control_sessions` | gauge | sessions open |
//! | `buridan_control_robots` | gauge | robots in the open sessions |
//! | `buridan_control_overridden_moves_total` | counter | robot moves the shield changed from the policy's own choice |
//! | `buridan_control_robots_waiting{over_steps="K"}` | gauge | robots off their goal that have not moved for more than K consecutive steps |
//! | `buridan_control_long_waits_total` | counter | times a robot's wait passed K steps |
//! | `buridan_control_refused_total{code}` | counter | calls refused, by gRPC code |
//! | `buridan_control_sessions_expired_total` | counter | sessions ended by the idle timeout |

use buridan_env::Cell;
use metrics_exporter_prometheus::{BuildError, Matcher, PrometheusBuilder};

/// A Step's time in the service (histogram, seconds).
pub const STEP_SECONDS: &str = "buridan_control_step_seconds";
/// Steps answered (counter).
pub const STEPS: &str = "buridan_control_steps_total";
/// Sessions open (gauge).
pub const SESSIONS: &str = "buridan_control_sessions";
/// Robots in the open sessions (gauge).
pub const ROBOTS: &str = "buridan_control_robots";
/// Moves the shield changed (counter).
pub const OVERRIDDEN: &str = "buridan_control_overridden_moves_total";
/// Robots waiting longer than K steps (gauge, label `over_steps`).
pub const WAITING: &str = "buridan_control_robots_waiting";
/// Waits that passed K steps (counter).
pub const LONG_WAITS: &str = "buridan_control_long_waits_total";
/// Calls refused, by code (counter, label `code`).
pub const REFUSED: &str = "buridan_control_refused_total";
/// Sessions expired (counter).
pub const EXPIRED: &str = "buridan_control_sessions_expired_total";

/// The step histogram's buckets, seconds: 0.25 ms to 10 s.
pub const STEP_BUCKETS: &[f64] = &[
    0.000_25, 0.000_5, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0,
];

/// A Prometheus exporter's builder with the step histogram's buckets (the
/// binary adds its HTTP listener; a test installs its recorder and renders).
pub fn prometheus_builder() -> Result<PrometheusBuilder, BuildError> {
    PrometheusBuilder::new()
        .set_buckets_for_metric(Matcher::Full(STEP_SECONDS.into()), STEP_BUCKETS)
}

/// Describes every series (their HELP lines) and registers the counters
/// and gauges at 0, so that a scrape shows them before the first event.
pub fn describe() {
    use metrics::{describe_counter, describe_gauge, describe_histogram, Unit};
    describe_histogram!(
        STEP_SECONDS,
        Unit::Seconds,
        "a Step call's time in the service"
    );
    describe_counter!(STEPS, "Steps answered");
    describe_gauge!(SESSIONS, "fleet sessions open");
    describe_gauge!(ROBOTS, "robots in the open sessions");
    describe_counter!(
        OVERRIDDEN,
        "robot moves the shield changed from the policy's own choice"
    );
    describe_gauge!(
        WAITING,
        "robots off their goal that have not moved for more than K steps"
    );
    describe_counter!(LONG_WAITS, "times a robot's wait passed K steps");
    describe_counter!(REFUSED, "calls refused, by gRPC code");
    describe_counter!(EXPIRED, "sessions ended by the idle timeout");
    for counter in [STEPS, OVERRIDDEN, LONG_WAITS, EXPIRED] {
        metrics::counter!(counter).increment(0);
    }
    for gauge in [SESSIONS, ROBOTS] {
        metrics::gauge!(gauge).increment(0.0);
    }
}

/// Per robot of a session, how many consecutive reports found it on the
/// same cell off its goal; how many of them waited longer than `k` steps.
#[derive(Debug, Clone)]
pub struct WaitWatch {
    k: u32,
    last: Vec<Cell>,
    waits: Vec<u32>,
    over: usize,
}

impl WaitWatch {
    /// A watch of robots standing on `positions`, alarmed beyond `k` steps.
    pub fn new(k: u32, positions: &[Cell]) -> Self {
        Self {
            k,
            last: positions.to_vec(),
            waits: vec![0; positions.len()],
            over: 0,
        }
    }

    /// Reads an accepted report; returns the change of the number of
    /// robots over `k` and how many robots passed `k` with this report.
    ///
    /// ```
    /// use buridan_control::metrics::WaitWatch;
    /// use buridan_env::Cell;
    /// let (a, goal) = (Cell::new(0, 0), Cell::new(0, 5));
    /// let mut w = WaitWatch::new(2, &[a]);
    /// assert_eq!(w.report(&[a], &[goal]), (0, 0));
    /// assert_eq!(w.report(&[a], &[goal]), (0, 0));
    /// assert_eq!(w.report(&[a], &[goal]), (1, 1)); // the third wait is more than 2
    /// assert_eq!(w.report(&[a], &[goal]), (0, 0));
    /// assert_eq!(w.report(&[Cell::new(0, 1)], &[goal]), (-1, 0)); // it moved
    /// assert_eq!(w.over(), 0);
    /// ```
    pub fn report(&mut self, positions: &[Cell], goals: &[Cell]) -> (i64, u64) {
        let before = self.over as i64;
        let mut passed = 0;
        for ((last, wait), (&now, &goal)) in self
            .last
            .iter_mut()
            .zip(self.waits.iter_mut())
            .zip(positions.iter().zip(goals))
        {
            if now == *last && now != goal {
                *wait = wait.saturating_add(1);
                if *wait == self.k.saturating_add(1) {
                    passed += 1;
                }
            } else {
                *wait = 0;
            }
            *last = now;
        }
        self.over = self.waits.iter().filter(|&&w| w > self.k).count();
        (self.over as i64 - before, passed)
    }

    /// Robots waiting longer than `k` steps now.
    pub fn over(&self) -> usize {
        self.over
    }
}
