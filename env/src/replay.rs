//! Failure replay: an env slot that plays its failed episodes again.
//!
//! Under a good policy most training episodes are easy, and the few it
//! fails — two agents bound for one dead-end aisle in the wrong order, an
//! agent parked in the one cell another must pass — are the ones it has
//! yet to learn; at 98 % success they are 2 % of its experience. Prioritized
//! level replay (Jiang, Grefenstette, Rocktäschel, ICML 2021) replays the
//! levels with the most to learn; [`FailureReplay`] is its simplest form
//! for seeded episodes: an episode that ended without success is queued,
//! and a reset replays the oldest queued one with probability `share`
//! (its same starts and goals, so its same layout too) instead of drawing
//! the next fresh episode. An episode is replayed at most `tries` times
//! or until it succeeds; the queue keeps the `capacity` newest.
//!
//! Fresh episodes follow the plain schedule (`e, e + N, e + 2N, …`, see
//! [`crate::vec_env`]): a replay never shifts which fresh episodes a slot
//! plays, only delays them. [`EpisodeStats::replay`] tells a replayed
//! episode (its attempt, 1 for the first replay) from a fresh one (0), so
//! training statistics can count fresh episodes only.
//!
//! ```
//! use buridan_env::replay::{FailureReplay, ReplayConfig};
//! use buridan_env::{EnvConfig, EnvSlot, GridEnv, Map};
//! let map = std::sync::Arc::new(Map::load("rm-2.1").unwrap());
//! let env = GridEnv::with_episode(map, EnvConfig { t_max: 5, ..EnvConfig::default() }, 0).unwrap();
//! let every_failure = ReplayConfig { share: 1.0, tries: 2, capacity: 8 };
//! let mut slot = FailureReplay::new(env, every_failure, 7).unwrap();
//! let mut rewards = [0.0; 4];
//! let mut played = Vec::new();
//! for _ in 0..4 {
//!     // Standing still fails every episode at T_max.
//!     while !slot.env_mut().step(&[0; 4], &mut rewards).unwrap().done() {}
//!     played.push((slot.stats().episode, slot.stats().replay));
//!     slot.reset_next(1).unwrap();
//! }
//! // Episode 0, then twice again, then the next fresh one.
//! assert_eq!(played, [(0, 0), (0, 1), (0, 2), (1, 0)]);
//! ```

use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::EnvError;
use crate::stats::EpisodeStats;
use crate::vec_env::EnvSlot;
use crate::world::GridEnv;

/// How a [`FailureReplay`] slot replays failed episodes.
///
/// ```
/// let cfg = buridan_env::replay::ReplayConfig::default();
/// assert_eq!(cfg.share, 0.0); // off
/// assert!(cfg.validate().is_ok());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReplayConfig {
    /// Probability that a reset replays a queued failed episode (when one
    /// is queued) instead of the next fresh one; 0 turns replay off.
    pub share: f64,
    /// Replays of one episode at most (it leaves the queue earlier once it
    /// succeeds).
    pub tries: u32,
    /// Failed episodes queued per slot at most; the oldest give way.
    pub capacity: usize,
}

impl Default for ReplayConfig {
    fn default() -> Self {
        Self {
            share: 0.0,
            tries: 4,
            capacity: 64,
        }
    }
}

impl ReplayConfig {
    /// Whether replay is on (`share > 0`).
    pub fn enabled(&self) -> bool {
        self.share > 0.0
    }

    /// Checks the ranges: `share` in `[0, 1]`, and `tries` and `capacity`
    /// at least 1 when replay is on.
    ///
    /// ```
    /// use buridan_env::replay::ReplayConfig;
    /// assert!(ReplayConfig { share: 1.5, ..ReplayConfig::default() }.validate().is_err());
    /// assert!(ReplayConfig { share: 0.5, tries: 0, capacity: 8 }.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), EnvError> {
        if !(0.0..=1.0).contains(&self.share) {
            return Err(EnvError::InvalidConfig(format!(
                "replay.share must lie in [0, 1], got {}",
                self.share
            )));
        }
        if self.enabled() && (self.tries == 0 || self.capacity == 0) {
            return Err(EnvError::InvalidConfig(format!(
                "replay.tries and replay.capacity must be at least 1 when replay.share > 0 \
                 (got tries {}, capacity {})",
                self.tries, self.capacity
            )));
        }
        Ok(())
    }
}

/// An env slot that replays its failed episodes (see the [module
/// docs](self)): wraps a [`GridEnv`] or a [`crate::LayoutMixture`].
pub struct FailureReplay<S> {
    inner: S,
    cfg: ReplayConfig,
    /// The fresh episode most recently started (the plain schedule's cursor).
    fresh: u64,
    /// Replays of the current episode so far (0: a fresh episode).
    attempt: u32,
    /// Failed episodes waiting for a replay, oldest first, with the
    /// attempts they have had.
    queue: VecDeque<(u64, u32)>,
    rng: ChaCha8Rng,
}

impl<S: EnvSlot> FailureReplay<S> {
    /// Wraps `inner`, whose current episode is its first fresh one; `seed`
    /// drives the replay draws (one stream per slot).
    pub fn new(inner: S, cfg: ReplayConfig, seed: u64) -> Result<Self, EnvError> {
        cfg.validate()?;
        Ok(Self {
            fresh: inner.env().episode(),
            inner,
            cfg,
            attempt: 0,
            queue: VecDeque::new(),
            rng: ChaCha8Rng::seed_from_u64(crate::seed::failure_replay(seed)),
        })
    }

    /// Failed episodes waiting for a replay.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }
}

impl<S: EnvSlot> EnvSlot for FailureReplay<S> {
    fn env(&self) -> &GridEnv {
        self.inner.env()
    }

    fn env_mut(&mut self) -> &mut GridEnv {
        self.inner.env_mut()
    }

    fn reset_to(&mut self, episode: u64) -> Result<(), EnvError> {
        self.fresh = episode;
        self.attempt = 0;
        self.inner.reset_to(episode)
    }

    fn reset_next(&mut self, stride: u64) -> Result<(), EnvError> {
        if self.cfg.enabled() && !self.inner.stats().success && self.attempt < self.cfg.tries {
            if self.queue.len() == self.cfg.capacity {
                self.queue.pop_front();
            }
            self.queue
                .push_back((self.inner.env().episode(), self.attempt));
        }
        if !self.queue.is_empty() && self.rng.random_bool(self.cfg.share) {
            let (episode, attempts) = self.queue.pop_front().expect("not empty");
            self.attempt = attempts + 1;
            return self.inner.reset_to(episode);
        }
        self.attempt = 0;
        self.fresh += stride;
        self.inner.reset_to(self.fresh)
    }

    fn stats(&self) -> EpisodeStats {
        EpisodeStats {
            replay: self.attempt,
            ..self.inner.stats()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::EnvConfig;
    use crate::map::Map;
    use std::sync::Arc;

    fn slot(t_max: u32, cfg: ReplayConfig) -> FailureReplay<GridEnv> {
        let map = Arc::new(Map::load("rm-2.1").unwrap());
        let env = GridEnv::with_episode(
            map,
            EnvConfig {
                t_max,
                ..EnvConfig::default()
            },
            3,
        )
        .unwrap();
        FailureReplay::new(env, cfg, 11).unwrap()
    }

    /// Plays the slot's current episode standing still; (episode, replay,
    /// starts).
    fn play_still(s: &mut FailureReplay<GridEnv>) -> (u64, u32, Vec<crate::Cell>) {
        let starts = s.env().positions().to_vec();
        let mut rewards = [0.0; 4];
        while !s.env_mut().step(&[0; 4], &mut rewards).unwrap().done() {}
        let st = s.stats();
        (st.episode, st.replay, starts)
    }

    #[test]
    fn a_replayed_episode_has_the_same_starts_and_fresh_ones_keep_their_schedule() {
        let mut s = slot(
            3,
            ReplayConfig {
                share: 0.5,
                tries: 3,
                capacity: 4,
            },
        );
        let mut starts_of = std::collections::HashMap::new();
        let mut fresh = Vec::new();
        let mut replays = 0;
        for _ in 0..200 {
            let (episode, replay, starts) = play_still(&mut s);
            let first = starts_of.entry(episode).or_insert_with(|| starts.clone());
            assert_eq!(
                *first, starts,
                "episode {episode} replayed with other starts"
            );
            if replay == 0 {
                fresh.push(episode);
            } else {
                replays += 1;
                assert!(replay <= 3);
            }
            s.reset_next(5).unwrap();
            assert!(s.queued() <= 4);
        }
        // Fresh episodes 3, 8, 13, … in order, none skipped or repeated.
        let expected: Vec<u64> = (0..fresh.len() as u64).map(|k| 3 + 5 * k).collect();
        assert_eq!(fresh, expected);
        // Every episode fails, so about half the resets replay one.
        assert!((70..=130).contains(&replays), "{replays} replays of 200");
    }

    #[test]
    fn a_solved_episode_is_not_replayed_and_share_zero_is_the_plain_schedule() {
        // One agent walking its shortest path solves every episode: nothing
        // is queued even when every reset would replay.
        let map = Arc::new(Map::load("rm-2.1").unwrap());
        let cfg = EnvConfig {
            agents: 1,
            ..EnvConfig::default()
        };
        let env = GridEnv::with_episode(map.clone(), cfg, 0).unwrap();
        let always = ReplayConfig {
            share: 1.0,
            ..ReplayConfig::default()
        };
        let mut s = FailureReplay::new(env, always, 1).unwrap();
        let mut rewards = [0.0];
        for k in 0..20 {
            loop {
                let (at, goal) = (s.env().positions()[0], s.env().goals()[0]);
                let dist = map.grid.distances_to(goal);
                let best = (1..5u8)
                    .filter_map(|a| {
                        map.grid
                            .neighbour(at, a)
                            .map(|c| (dist[map.grid.index(c)], a))
                    })
                    .min()
                    .map_or(0, |(_, a)| a);
                if s.env_mut().step(&[best], &mut rewards).unwrap().done() {
                    break;
                }
            }
            let st = s.stats();
            assert!(st.success);
            assert_eq!((st.episode, st.replay), (k, 0));
            s.reset_next(1).unwrap();
        }
        assert_eq!(s.queued(), 0);
        // Share 0: the plain schedule, nothing queued.
        let mut plain = slot(3, ReplayConfig::default());
        for k in 0..20 {
            let (episode, replay, _) = play_still(&mut plain);
            assert_eq!((episode, replay), (3 + 2 * k, 0));
            plain.reset_next(2).unwrap();
        }
        assert_eq!(plain.queued(), 0);
    }

    #[test]
    fn bad_settings_are_refused() {
        let map = Arc::new(Map::load("rm-2.1").unwrap());
        let env = GridEnv::new(map, EnvConfig::default()).unwrap();
        let bad = ReplayConfig {
            share: -0.1,
            ..ReplayConfig::default()
        };
        assert!(matches!(
            FailureReplay::new(env, bad, 0),
            Err(EnvError::InvalidConfig(msg)) if msg.contains("replay.share")
        ));
    }
}
