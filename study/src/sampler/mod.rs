//! Samplers: where the next trial looks. One trait, one file per sampler.
//!
//! A sampler is a pure function of (space, trial index, finished trials), so
//! a resumed study asks the same questions and needs no sampler state on disk.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::overrides::Overrides;
use crate::space::SearchSpace;

pub mod grid;
pub mod random;
pub mod tpe;

pub use grid::GridSampler;
pub use random::RandomSampler;
pub use tpe::TpeSampler;

/// A finished trial as samplers see it: its configuration and the value to maximise.
///
/// ```
/// let o = buridan_study::sampler::Observed { overrides: Default::default(), objective: 0.5 };
/// assert_eq!(o.objective, 0.5);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Observed {
    /// The trial's configuration.
    pub overrides: Overrides,
    /// Its objective (higher is better).
    pub objective: f64,
}

/// Proposes configurations.
///
/// ```
/// use buridan_study::sampler::{RandomSampler, Sampler};
/// let space = buridan_study::SearchSpace::from_toml_str("x = { uniform = [0, 1] }").unwrap();
/// let s = RandomSampler::new(7);
/// assert_eq!(s.suggest(&space, 0, &[]), s.suggest(&space, 0, &[])); // seeded
/// ```
pub trait Sampler: Send + Sync {
    /// The configuration of trial `index` (0-based) given the finished
    /// trials, `None` when the sampler has nothing left to propose (a grid
    /// that is exhausted).
    fn suggest(&self, space: &SearchSpace, index: u64, history: &[Observed]) -> Option<Overrides>;
}

/// The samplers a study file can name.
///
/// ```
/// let k: buridan_study::sampler::SamplerKind = toml::from_str::<toml::Table>("s = \"tpe\"").unwrap()["s"].clone().try_into().unwrap();
/// assert_eq!(k, buridan_study::sampler::SamplerKind::Tpe);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SamplerKind {
    /// Every combination of [`crate::space::Domain::grid`] points.
    Grid,
    /// Independent uniform draws.
    #[default]
    Random,
    /// Tree-structured Parzen estimator.
    Tpe,
}

impl SamplerKind {
    /// The sampler of this kind (`grid_points` per float range for a grid).
    ///
    /// ```
    /// use buridan_study::sampler::SamplerKind;
    /// let space = buridan_study::SearchSpace::from_toml_str("x = { int = [1, 3] }").unwrap();
    /// let grid = SamplerKind::Grid.build(0, 5);
    /// assert!(grid.suggest(&space, 2, &[]).is_some());
    /// assert!(grid.suggest(&space, 3, &[]).is_none());
    /// ```
    pub fn build(self, seed: u64, grid_points: usize) -> Box<dyn Sampler> {
        match self {
            SamplerKind::Grid => Box::new(GridSampler::new(grid_points)),
            SamplerKind::Random => Box::new(RandomSampler::new(seed)),
            SamplerKind::Tpe => Box::new(TpeSampler::new(seed)),
        }
    }
}

/// The random stream of trial `index` of a study seeded `seed`: the same
/// numbers whenever (and in whichever order) the trial is sampled.
///
/// ```
/// use rand::Rng;
/// let a: u64 = buridan_study::sampler::trial_rng(1, 5).random();
/// let b: u64 = buridan_study::sampler::trial_rng(1, 5).random();
/// assert_eq!(a, b);
/// ```
pub fn trial_rng(seed: u64, index: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index);
    rng
}
