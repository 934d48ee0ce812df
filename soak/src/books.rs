//! The fragment books at the end of a soak: whole, never used twice, and
//! the lost ones accounted for (see the crate docs).

use serde::Serialize;

use crate::sample::Sample;

/// The fragment books at the end.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Books {
    /// Env steps per fragment (length × envs per actor).
    pub steps_per_fragment: u64,
    /// Fragments accepted.
    pub accepted: u64,
    /// Fragments the learner took from its queue.
    pub dequeued: u64,
    /// Fragments consumed by updates.
    pub consumed: u64,
    /// Their env steps.
    pub consumed_steps: u64,
    /// Dropped as stale by the learner.
    pub stale_at_learner: u64,
    /// Still in the queue at the end.
    pub queued_at_end: u64,
    /// Taken, in the learner's unfinished batch at the end.
    pub partial_batch_at_end: u64,
    /// Accepted but not consumed (stale at learner + held at the end).
    pub lost: u64,
    /// Consumed fragments not whole (steps not matching).
    pub consumed_in_part: u64,
    /// Fragments used more than once (by the balance).
    pub used_twice: u64,
}

/// Balances the fragment books of the last sample (see the crate docs);
/// each book that does not balance goes to `failures`.
pub fn balance(
    last: &Sample,
    steps_per_fragment: u64,
    fragments_per_batch: u64,
    failures: &mut Vec<String>,
) -> Books {
    let mut books = Books {
        steps_per_fragment,
        accepted: last.accepted,
        consumed: last.consumed,
        consumed_steps: last.consumed_steps,
        stale_at_learner: last.stale_at_learner,
        ..Books::default()
    };
    if !last.env_steps.is_multiple_of(steps_per_fragment) {
        failures.push(format!(
            "the learner took {} env steps from its queue, not a whole number of {steps_per_fragment}-step fragments",
            last.env_steps
        ));
    }
    books.dequeued = last.env_steps / steps_per_fragment;
    let whole = last.consumed * steps_per_fragment;
    if last.consumed_steps != whole {
        books.consumed_in_part = last
            .consumed
            .saturating_sub(last.consumed_steps / steps_per_fragment)
            .max(1);
        failures.push(format!(
            "{} fragments consumed with {} env steps, not {whole}: some were used in part",
            last.consumed, last.consumed_steps
        ));
    }
    let used = last.consumed + last.stale_at_learner;
    if used > books.dequeued || books.dequeued > books.accepted {
        books.used_twice =
            used.saturating_sub(books.dequeued) + books.dequeued.saturating_sub(books.accepted);
        failures.push(format!(
            "fragments used twice: consumed {} + stale at learner {} > taken {} or taken > accepted {}",
            last.consumed, last.stale_at_learner, books.dequeued, books.accepted
        ));
    }
    books.queued_at_end = books.accepted.saturating_sub(books.dequeued);
    books.partial_batch_at_end = books.dequeued.saturating_sub(used);
    books.lost = books.accepted.saturating_sub(last.consumed);
    if books.partial_batch_at_end >= fragments_per_batch {
        failures.push(format!(
            "{} fragments taken but neither consumed nor dropped (a batch holds {fragments_per_batch})",
            books.partial_batch_at_end,
        ));
    }
    books
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The books of `last` at 4 steps a fragment and 2 fragments a batch,
    /// and the failures they record.
    fn books_of(last: Sample) -> (Books, Vec<String>) {
        let mut failures = Vec::new();
        let books = balance(&last, 4, 2, &mut failures);
        (books, failures)
    }

    #[test]
    fn balanced_books_fail_nothing_and_account_for_the_lost() {
        // 4 steps a fragment: 10 accepted, 8 taken (2 still queued), 6
        // consumed, 1 dropped as stale, 1 in the unfinished batch.
        let (b, failures) = books_of(Sample {
            accepted: 10,
            env_steps: 32,
            consumed: 6,
            consumed_steps: 24,
            stale_at_learner: 1,
            ..Sample::default()
        });
        assert!(failures.is_empty(), "{failures:?}");
        assert_eq!(
            (b.dequeued, b.queued_at_end, b.partial_batch_at_end, b.lost),
            (8, 2, 1, 4)
        );
        assert_eq!((b.used_twice, b.consumed_in_part), (0, 0));
    }

    #[test]
    fn fragments_used_twice_or_in_part_unbalance_the_books() {
        // 5 taken, 6 consumed; 22 steps consumed where 6 whole are 24.
        let (b, failures) = books_of(Sample {
            accepted: 5,
            env_steps: 20,
            consumed: 6,
            consumed_steps: 22,
            ..Sample::default()
        });
        assert_eq!((b.used_twice, b.consumed_in_part), (1, 1));
        assert_eq!(failures.len(), 2, "{failures:?}");
    }
}
