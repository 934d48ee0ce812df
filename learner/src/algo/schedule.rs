//! Piecewise-linear hyperparameter schedules over env steps, in RLlib's
//! `lr_schedule` / `entropy_coeff_schedule` format: a list of
//! `[env_step, value]` points, linear between them, the first value before
//! the first point and the last value after the last.
//!
//! Why: a constant learning rate and entropy bonus keep a policy's updates
//! as noisy at the end of a run as at its start; annealing them lets the
//! policy settle on what it has learned (the dissertation's RLlib runs had
//! the same knobs, unused in its comparison configs).
//!
//! In a config file:
//!
//! ```toml
//! [impala]
//! lr_schedule = [[0, 5e-4], [10_000_000, 5e-5]]
//! entropy_schedule = [[0, 0.01], [8_000_000, 0]]
//! ```

use serde::{Deserialize, Serialize};

/// Why a list of points is not a schedule.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScheduleError {
    /// No points.
    #[error("a schedule needs at least one [env_step, value] point")]
    Empty,
    /// The steps do not increase.
    #[error(
        "schedule point {index}: env step {step} is not after the previous point's {previous}"
    )]
    NotIncreasing {
        /// Position of the point (0-based).
        index: usize,
        /// Its env step.
        step: u64,
        /// The previous point's env step.
        previous: u64,
    },
    /// A value is NaN or infinite.
    #[error("schedule point {index}: value {value} must be a finite number")]
    BadValue {
        /// Position of the point (0-based).
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// A value that changes linearly between `(env_step, value)` points.
///
/// ```
/// use buridan_learner::algo::schedule::Schedule;
/// let lr = Schedule::new(vec![(0, 1e-3), (1000, 1e-4)]).unwrap();
/// assert_eq!(lr.value(0), 1e-3);
/// assert!((lr.value(500) - 5.5e-4).abs() < 1e-12); // halfway
/// assert_eq!(lr.value(5000), 1e-4); // flat after the last point
/// assert!(Schedule::new(vec![(10, 1.0), (10, 2.0)]).is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<(u64, Number)>", into = "Vec<(u64, f64)>")]
pub struct Schedule {
    points: Vec<(u64, f64)>,
}

/// A TOML number as written: `0` and `0.0` both mean zero.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(untagged)]
enum Number {
    Int(i64),
    Float(f64),
}

impl Schedule {
    /// A schedule through `points`: at least one, steps strictly
    /// increasing, values finite. The range a value must lie in is the
    /// setting's (a learning rate at least 0, an entropy coefficient of
    /// either sign), checked where the configuration is validated.
    pub fn new(points: Vec<(u64, f64)>) -> Result<Self, ScheduleError> {
        if points.is_empty() {
            return Err(ScheduleError::Empty);
        }
        for (index, &(step, value)) in points.iter().enumerate() {
            if !value.is_finite() {
                return Err(ScheduleError::BadValue { index, value });
            }
            if index > 0 && step <= points[index - 1].0 {
                return Err(ScheduleError::NotIncreasing {
                    index,
                    step,
                    previous: points[index - 1].0,
                });
            }
        }
        Ok(Self { points })
    }

    /// The value at `env_step`.
    pub fn value(&self, env_step: u64) -> f64 {
        let p = &self.points;
        let after = p.partition_point(|&(s, _)| s <= env_step);
        if after == 0 {
            return p[0].1;
        }
        if after == p.len() {
            return p[p.len() - 1].1;
        }
        let (s0, v0) = p[after - 1];
        let (s1, v1) = p[after];
        let frac = (env_step - s0) as f64 / (s1 - s0) as f64;
        v0 + frac * (v1 - v0)
    }

    /// The points, as configured.
    pub fn points(&self) -> &[(u64, f64)] {
        &self.points
    }
}

impl TryFrom<Vec<(u64, Number)>> for Schedule {
    type Error = ScheduleError;

    fn try_from(points: Vec<(u64, Number)>) -> Result<Self, Self::Error> {
        Schedule::new(
            points
                .into_iter()
                .map(|(s, v)| match v {
                    Number::Int(i) => (s, i as f64),
                    Number::Float(f) => (s, f),
                })
                .collect(),
        )
    }
}

impl From<Schedule> for Vec<(u64, f64)> {
    fn from(s: Schedule) -> Self {
        s.points
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_between_points_and_holds_the_ends() {
        let s = Schedule::new(vec![(100, 1.0), (200, 0.0), (400, 0.5)]).unwrap();
        assert_eq!(s.value(0), 1.0);
        assert_eq!(s.value(100), 1.0);
        assert!((s.value(150) - 0.5).abs() < 1e-12);
        assert_eq!(s.value(200), 0.0);
        assert!((s.value(300) - 0.25).abs() < 1e-12);
        assert_eq!(s.value(400), 0.5);
        assert_eq!(s.value(u64::MAX), 0.5);
    }

    #[test]
    fn one_point_is_a_constant() {
        let s = Schedule::new(vec![(0, 0.01)]).unwrap();
        assert_eq!(s.value(0), 0.01);
        assert_eq!(s.value(1_000_000), 0.01);
    }

    #[test]
    fn rejects_empty_unsorted_and_non_finite_schedules() {
        assert_eq!(Schedule::new(vec![]), Err(ScheduleError::Empty));
        assert_eq!(
            Schedule::new(vec![(5, 1.0), (3, 1.0)]),
            Err(ScheduleError::NotIncreasing {
                index: 1,
                step: 3,
                previous: 5
            })
        );
        assert!(matches!(
            Schedule::new(vec![(0, 1.0), (10, f64::NAN)]),
            Err(ScheduleError::BadValue { index: 1, .. })
        ));
        assert!(Schedule::new(vec![(0, f64::INFINITY)]).is_err());
        // A negative value is the setting's to refuse (an entropy penalty is one).
        assert_eq!(Schedule::new(vec![(0, -0.05)]).unwrap().value(7), -0.05);
    }

    #[derive(Debug, Deserialize, Serialize)]
    struct Holder {
        s: Schedule,
    }

    #[test]
    fn reads_toml_with_integer_and_float_values_and_round_trips() {
        let h: Holder = toml::from_str("s = [[0, 0.01], [1_000, 0]]").unwrap();
        assert_eq!(h.s.points(), &[(0, 0.01), (1000, 0.0)]);
        let back: Holder = toml::from_str(&toml::to_string(&h).unwrap()).unwrap();
        assert_eq!(back.s, h.s);
        let err = toml::from_str::<Holder>("s = [[10, 1.0], [5, 0.5]]").unwrap_err();
        assert!(err.to_string().contains("not after"), "{err}");
    }
}
