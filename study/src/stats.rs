//! Aggregate statistics over independent runs, as rliable reports them
//! (Agarwal et al., "Deep RL at the Edge of the Statistical Precipice",
//! NeurIPS 2021): mean, interquartile mean, and percentile-bootstrap
//! confidence intervals with a seeded resampler.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Arithmetic mean, `None` if empty.
///
/// ```
/// assert_eq!(buridan_study::stats::mean(&[1.0, 2.0, 6.0]), Some(3.0));
/// assert_eq!(buridan_study::stats::mean(&[]), None);
/// ```
pub fn mean(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// Quantile `q` ∈ [0, 1] of sorted data, linear interpolation between
/// closest ranks (NumPy's default), `None` if empty.
///
/// ```
/// assert_eq!(buridan_study::stats::quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), Some(2.5));
/// ```
pub fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    Some(sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64))
}

/// Median, quartiles and whiskers of a sample (Tukey: the most extreme data
/// within 1.5 × IQR of the quartiles), as in the dissertation's box plots.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoxStats {
    /// Lower whisker.
    pub whisker_low: f64,
    /// First quartile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub q3: f64,
    /// Upper whisker.
    pub whisker_high: f64,
    /// Sample size.
    pub count: usize,
}

impl BoxStats {
    /// Box-plot statistics of `values` (any order; non-finite values are
    /// ignored), `None` if empty.
    ///
    /// ```
    /// let b = buridan_study::stats::BoxStats::of(&[1.0, 2.0, 3.0, 4.0, 100.0]).unwrap();
    /// assert_eq!((b.q1, b.median, b.q3), (2.0, 3.0, 4.0));
    /// assert_eq!((b.whisker_low, b.whisker_high), (1.0, 4.0)); // 100 is an outlier
    /// ```
    pub fn of(values: &[f64]) -> Option<BoxStats> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        let (q1, median, q3) = (quantile(&v, 0.25)?, quantile(&v, 0.5)?, quantile(&v, 0.75)?);
        let iqr = q3 - q1;
        let whisker_low = v
            .iter()
            .copied()
            .find(|&x| x >= q1 - 1.5 * iqr)
            .unwrap_or(q1);
        let whisker_high = v
            .iter()
            .rev()
            .copied()
            .find(|&x| x <= q3 + 1.5 * iqr)
            .unwrap_or(q3);
        Some(BoxStats {
            whisker_low,
            q1,
            median,
            q3,
            whisker_high,
            count: v.len(),
        })
    }
}

/// Interquartile mean: the mean of the middle half, dropping ⌊n/4⌋ values
/// from each end (SciPy's `trim_mean(x, 0.25)`, which rliable uses), `None`
/// if empty.
///
/// ```
/// // 8 values: drop 2 from each end, mean of 3, 4, 5, 100.
/// let v = [1.0, 2.0, 3.0, 4.0, 5.0, 100.0, 200.0, 300.0];
/// assert_eq!(buridan_study::stats::iqm(&v), Some(28.0));
/// ```
pub fn iqm(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let cut = v.len() / 4;
    mean(&v[cut..v.len() - cut])
}

/// A statistic of a sample, for bootstrapping.
///
/// ```
/// assert_eq!(buridan_study::stats::Statistic::Iqm.of(&[1.0, 2.0, 3.0, 4.0]), Some(2.5));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Statistic {
    /// [`mean`].
    Mean,
    /// [`iqm`].
    Iqm,
    /// The 0.5 [`quantile`].
    Median,
}

impl Statistic {
    /// The statistic of `values`, `None` if empty.
    ///
    /// ```
    /// assert_eq!(buridan_study::stats::Statistic::Median.of(&[3.0, 1.0, 2.0]), Some(2.0));
    /// ```
    pub fn of(&self, values: &[f64]) -> Option<f64> {
        match self {
            Statistic::Mean => mean(values),
            Statistic::Iqm => iqm(values),
            Statistic::Median => {
                let mut v = values.to_vec();
                v.sort_by(f64::total_cmp);
                quantile(&v, 0.5)
            }
        }
    }
}

/// Settings of the percentile bootstrap.
///
/// ```
/// let b = buridan_study::stats::Bootstrap::default();
/// assert_eq!((b.resamples, b.confidence, b.seed), (2000, 0.95, 42));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bootstrap {
    /// Resamples drawn (rliable uses 2,000 for its stratified bootstrap).
    pub resamples: usize,
    /// Coverage of the interval, e.g. 0.95.
    pub confidence: f64,
    /// Seed of the resampler: the same data give the same interval.
    pub seed: u64,
}

impl Default for Bootstrap {
    fn default() -> Self {
        Bootstrap {
            resamples: 2000,
            confidence: 0.95,
            seed: 42,
        }
    }
}

/// A confidence interval.
///
/// ```
/// let i = buridan_study::stats::Interval { low: 0.8, high: 0.9 };
/// assert!(i.contains(0.85));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Lower end.
    pub low: f64,
    /// Upper end.
    pub high: f64,
}

impl Interval {
    /// `true` if `x` lies in `[low, high]`.
    ///
    /// ```
    /// assert!(!buridan_study::stats::Interval { low: 0.0, high: 1.0 }.contains(2.0));
    /// ```
    pub fn contains(&self, x: f64) -> bool {
        (self.low..=self.high).contains(&x)
    }
}

impl Bootstrap {
    /// The percentile-bootstrap interval of `statistic` over `values`:
    /// draw `resamples` samples of the same size with replacement, take the
    /// statistic of each, and report the (1 − c)/2 and (1 + c)/2 quantiles.
    /// `None` if `values` is empty or has a non-finite value.
    ///
    /// ```
    /// use buridan_study::stats::{Bootstrap, Statistic};
    /// let ci = Bootstrap::default().interval(&[0.9, 0.95, 1.0, 0.85], Statistic::Mean).unwrap();
    /// assert!(ci.low >= 0.85 && ci.high <= 1.0 && ci.low < ci.high);
    /// ```
    pub fn interval(&self, values: &[f64], statistic: Statistic) -> Option<Interval> {
        if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let n = values.len();
        let mut sample = vec![0.0; n];
        let mut stats: Vec<f64> = (0..self.resamples.max(1))
            .filter_map(|_| {
                for s in sample.iter_mut() {
                    *s = values[rng.random_range(0..n)];
                }
                statistic.of(&sample)
            })
            .collect();
        stats.sort_by(f64::total_cmp);
        let alpha = (1.0 - self.confidence.clamp(0.0, 1.0)) / 2.0;
        Some(Interval {
            low: quantile(&stats, alpha)?,
            high: quantile(&stats, 1.0 - alpha)?,
        })
    }

    /// [`Aggregate`] of a sample: count, mean, IQM, median, and bootstrap
    /// intervals of the mean and IQM; `None` if empty or non-finite.
    ///
    /// ```
    /// let a = buridan_study::stats::Bootstrap::default().aggregate(&[1.0, 1.0, 0.0, 1.0]).unwrap();
    /// assert_eq!((a.count, a.mean), (4, 0.75));
    /// ```
    pub fn aggregate(&self, values: &[f64]) -> Option<Aggregate> {
        Some(Aggregate {
            count: values.len(),
            mean: mean(values)?,
            iqm: iqm(values)?,
            median: Statistic::Median.of(values)?,
            mean_ci: self.interval(values, Statistic::Mean)?,
            iqm_ci: self.interval(values, Statistic::Iqm)?,
        })
    }

    /// Aggregates `(group, value)` pairs per group — e.g. one success rate
    /// per seed, grouped by layout × algorithm — skipping groups with no
    /// finite values.
    ///
    /// ```
    /// let rows = [("ppo", 1.0), ("ppo", 0.5), ("impala", 0.25)];
    /// let g = buridan_study::stats::Bootstrap::default().aggregate_groups(rows);
    /// assert_eq!(g["ppo"].mean, 0.75);
    /// assert_eq!(g["impala"].count, 1);
    /// ```
    pub fn aggregate_groups<K: Ord, I: IntoIterator<Item = (K, f64)>>(
        &self,
        rows: I,
    ) -> BTreeMap<K, Aggregate> {
        let mut groups: BTreeMap<K, Vec<f64>> = BTreeMap::new();
        for (k, v) in rows {
            groups.entry(k).or_default().push(v);
        }
        groups
            .into_iter()
            .filter_map(|(k, v)| Some((k, self.aggregate(&v)?)))
            .collect()
    }
}

/// Summary of independent runs (e.g. one value per seed).
///
/// ```
/// let a = buridan_study::stats::Bootstrap::default().aggregate(&[0.5]).unwrap();
/// assert_eq!((a.mean_ci.low, a.mean_ci.high), (0.5, 0.5));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Aggregate {
    /// Number of runs.
    pub count: usize,
    /// Mean.
    pub mean: f64,
    /// Interquartile mean.
    pub iqm: f64,
    /// Median.
    pub median: f64,
    /// Bootstrap interval of the mean.
    pub mean_ci: Interval,
    /// Bootstrap interval of the IQM.
    pub iqm_ci: Interval,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Data 1, 2, 3: the 27 equally likely resamples have sums 3..=9 with
    /// counts 1, 3, 6, 7, 6, 3, 1 (by hand). The exact bootstrap CDF of the
    /// mean is therefore 1/27, 4/27, 10/27, 17/27, 23/27, 26/27, 1 at means
    /// 1, 4/3, 5/3, 2, 7/3, 8/3, 3. Its 2.5 % and 97.5 % quantiles are 1 and
    /// 3; its 5 % and 95 % quantiles are 4/3 (1/27 < 0.05 ≤ 4/27) and 8/3
    /// (23/27 < 0.95 ≤ 26/27). A seeded Monte-Carlo bootstrap with 20,000
    /// resamples lands on the same atoms.
    #[test]
    fn bootstrap_matches_the_hand_computed_exact_distribution() {
        let data = [1.0, 2.0, 3.0];
        let b95 = Bootstrap {
            resamples: 20_000,
            confidence: 0.95,
            seed: 7,
        };
        let ci = b95.interval(&data, Statistic::Mean).unwrap();
        assert_eq!((ci.low, ci.high), (1.0, 3.0));
        let b90 = Bootstrap {
            confidence: 0.90,
            ..b95
        };
        let ci = b90.interval(&data, Statistic::Mean).unwrap();
        assert!((ci.low - 4.0 / 3.0).abs() < 1e-12, "{ci:?}");
        assert!((ci.high - 8.0 / 3.0).abs() < 1e-12, "{ci:?}");
    }

    #[test]
    fn bootstrap_is_seeded_and_narrows_with_more_runs() {
        let few = [0.7, 0.9, 1.0, 0.8];
        let many: Vec<f64> = few.iter().cycle().take(40).copied().collect();
        let b = Bootstrap::default();
        assert_eq!(
            b.interval(&few, Statistic::Mean),
            b.interval(&few, Statistic::Mean)
        );
        let w = |i: Interval| i.high - i.low;
        let (a, c) = (
            b.interval(&few, Statistic::Mean).unwrap(),
            b.interval(&many, Statistic::Mean).unwrap(),
        );
        assert!(w(c) < w(a) / 2.0, "{a:?} {c:?}");
        assert!(c.contains(0.85));
    }

    #[test]
    fn iqm_by_hand() {
        // n = 10: drop 2 each side, mean of the middle 6.
        let v = [9.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        assert_eq!(iqm(&v), Some(4.5));
        // n = 3: nothing dropped.
        assert_eq!(iqm(&[0.0, 0.0, 3.0]), Some(1.0));
        assert_eq!(iqm(&[]), None);
    }

    #[test]
    fn bad_input_gives_none_not_a_panic() {
        let b = Bootstrap::default();
        assert!(b.interval(&[], Statistic::Mean).is_none());
        assert!(b.interval(&[1.0, f64::NAN], Statistic::Mean).is_none());
        assert!(b.aggregate(&[]).is_none());
    }
}
