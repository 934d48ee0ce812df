//! One gradient on several cores, the part every trainer shares: a batch's
//! independent units (samples, trajectories, windows) cut into shares, each
//! share's forward and backward pass on a thread of its own. PPO and
//! IMPALA (`buridan-learner`'s `algo::shards`) and behaviour cloning
//! (`buridan-imitate`) sum the shares' gradients in share order, so a
//! given thread count gives the same update every time.

/// Fewest samples worth a thread of their own in a forward and backward
/// pass: below it, waking the thread costs more than it saves.
pub const MIN_SHARE: usize = 512;

/// How many shares `samples` samples make with at most `threads` threads:
/// at least one, and none smaller than [`MIN_SHARE`].
///
/// ```
/// use buridan_policy::shards::share_count;
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
/// use buridan_policy::shards::share_range;
/// let cuts: Vec<_> = (0..3).map(|i| share_range(i, 3, 10)).collect();
/// assert_eq!(cuts, [0..3, 3..6, 6..10]);
/// ```
pub fn share_range(i: usize, shares: usize, n: usize) -> std::ops::Range<usize> {
    i * n / shares..(i + 1) * n / shares
}

/// A share's thread panicked; the callers' error types convert it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("an update thread panicked")]
pub struct SharePanicked;

/// Runs `share(i)` for every `i < shares`: share 0 on the calling thread,
/// the others on scoped threads; the results in share order. A panicking
/// share is an error ([`SharePanicked`]), not a panic of the caller.
///
/// ```
/// use buridan_policy::shards::{on_threads, SharePanicked};
/// let squares = on_threads(3, |i| Ok::<_, SharePanicked>(i * i)).unwrap();
/// assert_eq!(squares, [0, 1, 4]);
/// ```
pub fn on_threads<T: Send, E: Send + From<SharePanicked>>(
    shares: usize,
    share: impl Fn(usize) -> Result<T, E> + Sync,
) -> Result<Vec<T>, E> {
    let share = &share;
    std::thread::scope(|scope| {
        let others: Vec<_> = (1..shares.max(1))
            .map(|i| scope.spawn(move || share(i)))
            .collect();
        let mine = share(0);
        std::iter::once(mine)
            .chain(
                others
                    .into_iter()
                    .map(|h| h.join().unwrap_or_else(|_| Err(SharePanicked.into()))),
            )
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panicking_share_is_an_error_and_the_others_still_join() {
        let out: Result<Vec<usize>, SharePanicked> = on_threads(3, |i| {
            if i == 2 {
                panic!("share 2 fails");
            }
            Ok(i)
        });
        assert_eq!(out, Err(SharePanicked));
    }

    #[test]
    fn shares_cover_every_item_once() {
        for n in [0, 1, 7, 1000] {
            for shares in 1..5 {
                let covered: Vec<usize> = (0..shares)
                    .flat_map(|i| share_range(i, shares, n))
                    .collect();
                assert_eq!(covered, (0..n).collect::<Vec<_>>());
            }
        }
    }
}
