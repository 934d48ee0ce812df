//! Random search: each parameter drawn independently and uniformly (in log
//! space for log-uniform ranges), from a stream seeded per trial.

use crate::overrides::Overrides;
use crate::sampler::{trial_rng, Observed, Sampler};
use crate::space::SearchSpace;

/// Independent uniform draws; trial `i` always gets the same configuration.
///
/// ```
/// use buridan_study::sampler::{RandomSampler, Sampler};
/// let space = buridan_study::SearchSpace::from_toml_str("\"ppo.lr\" = { log_uniform = [1e-4, 1e-3] }").unwrap();
/// let c = RandomSampler::new(0).suggest(&space, 0, &[]).unwrap();
/// let lr = c["ppo.lr"].as_float().unwrap();
/// assert!((1e-4..=1e-3).contains(&lr));
/// ```
#[derive(Debug, Clone)]
pub struct RandomSampler {
    seed: u64,
}

impl RandomSampler {
    /// A random sampler with this seed.
    ///
    /// ```
    /// let _ = buridan_study::sampler::RandomSampler::new(42);
    /// ```
    pub fn new(seed: u64) -> RandomSampler {
        RandomSampler { seed }
    }
}

impl Sampler for RandomSampler {
    fn suggest(&self, space: &SearchSpace, index: u64, _history: &[Observed]) -> Option<Overrides> {
        let mut rng = trial_rng(self.seed, index);
        Some(
            space
                .params()
                .iter()
                .map(|p| (p.key.clone(), p.domain.sample(&mut rng)))
                .collect(),
        )
    }
}
