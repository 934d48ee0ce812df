//! Grid search: every combination of each parameter's grid points, in a
//! fixed order (the last key varies fastest).

use crate::overrides::Overrides;
use crate::sampler::{Observed, Sampler};
use crate::space::SearchSpace;

/// Enumerates the Cartesian product of [`crate::space::Domain::grid`] points.
///
/// ```
/// use buridan_study::sampler::{GridSampler, Sampler};
/// let space = buridan_study::SearchSpace::from_toml_str(
///     "a = { choice = [1, 2] }\nb = { choice = [\"x\", \"y\", \"z\"] }",
/// ).unwrap();
/// let g = GridSampler::new(5);
/// assert_eq!(g.size(&space), 6);
/// let third = g.suggest(&space, 2, &[]).unwrap();
/// assert_eq!((third["a"].as_integer(), third["b"].as_str()), (Some(1), Some("z")));
/// assert!(g.suggest(&space, 6, &[]).is_none());
/// ```
#[derive(Debug, Clone)]
pub struct GridSampler {
    resolution: usize,
}

impl GridSampler {
    /// A grid with `resolution` points per float range (and at most that
    /// many per integer range).
    ///
    /// ```
    /// let _ = buridan_study::sampler::GridSampler::new(5);
    /// ```
    pub fn new(resolution: usize) -> GridSampler {
        GridSampler {
            resolution: resolution.max(1),
        }
    }

    /// Number of grid points of `space` (saturating).
    ///
    /// ```
    /// use buridan_study::sampler::GridSampler;
    /// let space = buridan_study::SearchSpace::from_toml_str("x = { uniform = [0, 1] }").unwrap();
    /// assert_eq!(GridSampler::new(4).size(&space), 4);
    /// ```
    pub fn size(&self, space: &SearchSpace) -> u64 {
        space.params().iter().fold(1u64, |n, p| {
            n.saturating_mul(p.domain.grid(self.resolution).len() as u64)
        })
    }
}

impl Sampler for GridSampler {
    fn suggest(&self, space: &SearchSpace, index: u64, _history: &[Observed]) -> Option<Overrides> {
        if index >= self.size(space) {
            return None;
        }
        let mut rest = index;
        let mut out = Overrides::new();
        for p in space.params().iter().rev() {
            let points = p.domain.grid(self.resolution);
            let n = points.len() as u64;
            out.insert(p.key.clone(), points[(rest % n) as usize].clone());
            rest /= n;
        }
        Some(out)
    }
}
