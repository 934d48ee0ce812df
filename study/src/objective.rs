//! What a study maximises: training success over the last 100 episodes, or
//! the seed-42 evaluation with sampled or greedy actions; ties are broken by
//! shorter episodes, as the dissertation did.

use serde::{Deserialize, Serialize};

/// Everything a trial may report at one point of its training. Fields a
/// runner did not measure stay `None`.
///
/// ```
/// let m = buridan_study::Measurement { step: 4000, train_success: Some(0.5), ..Default::default() };
/// assert_eq!(m.eval_greedy_success, None);
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Env steps trained so far.
    pub step: u64,
    /// Success rate of the last 100 training episodes, in [0, 1].
    pub train_success: Option<f64>,
    /// Mean length of those episodes.
    pub train_len: Option<f64>,
    /// Success rate of the seed-42 evaluation with sampled actions.
    pub eval_sampled_success: Option<f64>,
    /// Mean length of those evaluation episodes.
    pub eval_sampled_len: Option<f64>,
    /// Success rate of the seed-42 evaluation with greedy actions.
    pub eval_greedy_success: Option<f64>,
    /// Mean length of those evaluation episodes.
    pub eval_greedy_len: Option<f64>,
}

/// The declared objective of a study.
///
/// ```
/// use buridan_study::{Measurement, Objective};
/// let m = Measurement { train_success: Some(0.9), train_len: Some(30.0), ..Default::default() };
/// assert_eq!(Objective::TrainSuccess.score(&m).unwrap().value, 0.9);
/// assert!(Objective::EvalGreedy.score(&m).is_none());
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Objective {
    /// Success over the last 100 training episodes.
    #[default]
    TrainSuccess,
    /// Seed-42 evaluation, sampled actions.
    EvalSampled,
    /// Seed-42 evaluation, greedy actions.
    EvalGreedy,
}

/// A trial's value under the objective, with the episode length that breaks ties.
///
/// ```
/// use buridan_study::Score;
/// let a = Score { value: 0.9, episode_len: Some(30.0) };
/// let b = Score { value: 0.9, episode_len: Some(25.0) };
/// assert!(b.key() > a.key()); // same success, shorter episodes win
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// Success rate (higher is better).
    pub value: f64,
    /// Mean episode length (shorter is better among equal values).
    pub episode_len: Option<f64>,
}

/// Episode lengths count this much per step against the value: far below one
/// episode in 100 (0.01) for any length under 10,000 steps.
const LEN_WEIGHT: f64 = 1e-6;

impl Score {
    /// One number to maximise: the value, minus a tie-breaking pinch of the
    /// episode length.
    ///
    /// ```
    /// let s = buridan_study::Score { value: 1.0, episode_len: Some(20.0) };
    /// assert!((s.key() - (1.0 - 20e-6)).abs() < 1e-12);
    /// ```
    pub fn key(&self) -> f64 {
        self.value - LEN_WEIGHT * self.episode_len.unwrap_or(1e4)
    }
}

impl Objective {
    /// The final score of a measurement, `None` if the objective's metric is missing.
    ///
    /// ```
    /// use buridan_study::{Measurement, Objective};
    /// let m = Measurement { eval_sampled_success: Some(0.95), eval_sampled_len: Some(22.5), ..Default::default() };
    /// assert_eq!(Objective::EvalSampled.score(&m).unwrap().episode_len, Some(22.5));
    /// ```
    pub fn score(&self, m: &Measurement) -> Option<Score> {
        let (value, episode_len) = match self {
            Objective::TrainSuccess => (m.train_success, m.train_len),
            Objective::EvalSampled => (m.eval_sampled_success, m.eval_sampled_len),
            Objective::EvalGreedy => (m.eval_greedy_success, m.eval_greedy_len),
        };
        value.filter(|v| v.is_finite()).map(|value| Score {
            value,
            episode_len: episode_len.filter(|l| l.is_finite()),
        })
    }

    /// The score schedulers judge intermediate reports by: the objective if
    /// measured, else training success (evaluations are usually run only at the end).
    ///
    /// ```
    /// use buridan_study::{Measurement, Objective};
    /// let m = Measurement { train_success: Some(0.4), ..Default::default() };
    /// assert_eq!(Objective::EvalGreedy.intermediate(&m).unwrap().value, 0.4);
    /// ```
    pub fn intermediate(&self, m: &Measurement) -> Option<Score> {
        self.score(m).or_else(|| Objective::TrainSuccess.score(m))
    }

    /// The objective's name as study files spell it.
    ///
    /// ```
    /// assert_eq!(buridan_study::Objective::EvalGreedy.name(), "eval_greedy");
    /// ```
    pub fn name(&self) -> &'static str {
        match self {
            Objective::TrainSuccess => "train_success",
            Objective::EvalSampled => "eval_sampled",
            Objective::EvalGreedy => "eval_greedy",
        }
    }
}
