//! One gradient on several cores: a batch's independent units (samples, or
//! whole trajectories) cut into shares ([`buridan_policy::shards`]), each
//! share's forward and backward pass on a thread of its own, the gradients
//! summed.
//!
//! Every loss term is a mean over samples, so a share's loss weighted by
//! its fraction of the samples is its part of the whole batch's loss, and
//! the shares' gradients add up to the whole batch's gradient — the same
//! update on more cores, up to float rounding. PPO shares each minibatch
//! ([`crate::algo::ppo`]), IMPALA its train batch ([`crate::algo::impala`]).

use candle_core::{Tensor, Var};

pub use buridan_policy::shards::{on_threads, share_count, share_range, SharePanicked, MIN_SHARE};

use crate::algo::optim::collect_grads;
use crate::algo::Result;

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
        Ok::<_, crate::algo::AlgoError>((grads, measured))
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
