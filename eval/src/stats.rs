//! Order statistics as box plots draw them.

/// Quantile `q` ∈ [0, 1] of sorted data by linear interpolation between
/// closest ranks (NumPy's and matplotlib's default), `None` if empty.
///
/// ```
/// use buridan_eval::stats::quantile;
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), Some(2.5));
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.25), Some(1.75));
/// assert_eq!(quantile(&[], 0.5), None);
/// ```
pub fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    Some(sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64))
}

/// Median, quartiles and whiskers of a sample (Tukey: the most extreme data
/// within 1.5 × IQR of the quartiles), as in the dissertation's box plots.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
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
    /// Box-plot statistics of `values` (any order), `None` if empty.
    ///
    /// ```
    /// let b = buridan_eval::stats::BoxStats::of(&[1.0, 2.0, 3.0, 4.0, 100.0]).unwrap();
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
