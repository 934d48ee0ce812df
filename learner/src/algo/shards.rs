//! One gradient on several cores: a batch's independent units (samples, or
//! whole trajectories) cut into shares, each share's forward and backward
//! pass on a thread of its own, the gradients summed.
//!
//! Every loss term is a mean over samples, so a share's loss weighted by
//! its fraction of the samples is its part of the whole batch's loss, and
//! the shares' gradients add up to the whole batch's gradient — the same
//! update on more cores, up to float rounding. PPO shares each minibatch
//! ([`crate::algo::ppo`]), IMPALA its train batch ([`crate::algo::impala`]).

use candle_core::{Tensor, Var};

use crate::algo::optim::collect_grads;
use crate::algo::{AlgoError, Result};

/// Fewest samples worth a thread of their own in a forward and backward
/// pass: below it, waking the thread costs more than it saves.
pub const MIN_SHARE: usize = 512;

/// How many shares `samples` samples make with at most `threads` threads:
/// at least one, and none smaller than [`MIN_SHARE`].
///
/// ```
/// use buridan_learner::algo::shards::share_count;
/// assert_eq!(share_count(4, 100_000), 4);
/// assert_eq!(share_count(4, 1_100), 2);
/// assert_eq!(share_count(4, 10), 1);
/// assert_eq!(share_count(0, 10_000), 1);
/// ```
pub fn share_count(threads: usize, samples: usize) -> usize {
    threads.clamp(1, (samples / MIN_SHARE).max(1))
}

/// Items `lo..hi` of share `i` when `n` items are cut into `shares`
/// nearly equal contiguous shares.
///
/// ```
/// use buridan_learner::algo::shards::share_range;
/// let cuts: Vec<_> = (0..3).map(|i| share_range(i, 3, 10)).collect();
/// assert_eq!(cuts, [0..3, 3..6, 6..10]);
/// ```
pub fn share_range(i: usize, shares: usize, n: usize) -> std::ops::Range<usize> {
    i * n / shares..(i + 1) * n / shares
}

/// Runs `share(i)` for every `i < shares`: share 0 on the calling thread,
/// the others on scoped threads; the results in share order. A panicking
/// share is an error, not a panic of the caller.
///
/// ```
/// use buridan_learner::algo::shards::on_threads;
/// let squares = on_threads(3, |i| Ok(i * i)).unwrap();
/// assert_eq!(squares, [0, 1, 4]);
/// ```
pub fn on_threads<T: Send>(
    shares: usize,
    share: impl Fn(usize) -> Result<T> + Sync,
) -> Result<Vec<T>> {
    let share = &share;
    std::thread::scope(|scope| {
        let others: Vec<_> = (1..shares.max(1))
            .map(|i| scope.spawn(move || share(i)))
            .collect();
        let mine = share(0);
        std::iter::once(mine)
            .chain(others.into_iter().map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(AlgoError::Batch("an update thread panicked".into())))
            }))
            .collect()
    })
}

/// One gradient of a loss cut into `shares` shares, one per thread — the
/// step PPO's minibatches and IMPALA's batches share. `share(i)` builds
/// share `i`'s part of the loss (`None` where the share holds no samples)
/// beside what else it measured; each part is differentiated with respect
/// to `vars` on its own thread; the gradients, and the measurements by
/// `add`, are summed in share order. The gradient is `None` when no share
/// had a loss.
///
/// ```
/// use buridan_learner::algo::shards::sharded_gradient;
/// use candle_core::{Device, Tensor, Var};
/// let w = Var::new(&[1.0f32, 2.0], &Device::Cpu).unwrap();
/// let vars = vec![("w".to_string(), w.clone())];
/// // Loss Σ (i + 1) · w over shares 0 and 1; share 2 has no samples.
/// let (grads, shares_with_loss) = sharded_gradient(
///     3,
///     &vars,
///     |i| {
///         if i == 2 {
///             return Ok((None, 0));
///         }
///         let loss = (w.as_tensor().sum_all()? * (i as f64 + 1.0))?;
///         Ok((Some(loss), 1))
///     },
///     |a, b| a + b,
/// )
/// .unwrap();
/// assert_eq!(grads.unwrap(), [vec![3.0, 3.0]]);
/// assert_eq!(shares_with_loss, 2);
/// ```
pub fn sharded_gradient<M: Send>(
    shares: usize,
    vars: &[(String, Var)],
    share: impl Fn(usize) -> Result<(Option<Tensor>, M)> + Sync,
    add: impl Fn(M, M) -> M,
) -> Result<(Option<Vec<Vec<f32>>>, M)> {
    let parts = on_threads(shares, |i| {
        let (loss, measured) = share(i)?;
        let grads = match loss {
            Some(loss) => Some(collect_grads(&loss.backward()?, vars)?),
            None => None,
        };
        Ok((grads, measured))
    })?;
    let mut parts = parts.into_iter();
    let (mut sum, mut measured) = parts.next().expect("on_threads runs at least one share");
    for (grads, m) in parts {
        match (&mut sum, grads) {
            (Some(sum), Some(g)) => add_grads(sum, g),
            (sum @ None, g) => *sum = g,
            (Some(_), None) => {}
        }
        measured = add(measured, m);
    }
    Ok((sum, measured))
}

/// Adds gradient `part` into `sum` (one buffer per variable, same order).
///
/// ```
/// use buridan_learner::algo::shards::add_grads;
/// let mut sum = vec![vec![1.0, 2.0], vec![3.0]];
/// add_grads(&mut sum, vec![vec![0.5, 0.5], vec![-3.0]]);
/// assert_eq!(sum, [vec![1.5, 2.5], vec![0.0]]);
/// ```
pub fn add_grads(sum: &mut [Vec<f32>], part: Vec<Vec<f32>>) {
    for (s, p) in sum.iter_mut().zip(part) {
        s.iter_mut().zip(p).for_each(|(s, p)| *s += p);
    }
}
