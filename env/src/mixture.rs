//! Several layouts behind one env: every episode plays a layout drawn from
//! a weighted distribution, so one policy trains on all of them.
//!
//! A [`LayoutMixture`] holds one prepared [`GridEnv`] per layout and makes
//! one of them current at each reset. The layout of episode `k` is a pure
//! function of (weights, seed, `k`) — drawn from its own ChaCha8 stream
//! ([`crate::seed::layout_draw`], stream `k`) — so a [`crate::VecEnv`] of
//! mixtures stays reproducible like a single-map one, and the episode's
//! starts and goals are those [`crate::episode_instance`] gives for that
//! layout. Local (CTDE/DTE) observations do not depend on the map size, so
//! any mix of layouts gives one observation shape; central (CTE) ones only
//! agree between layouts of the same size.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_env::{EnvConfig, LayoutMixture, Map, ObsKind, VecEnv};
//! let layouts = [
//!     (Arc::new(Map::load("rm-2.2").unwrap()), 3.0),
//!     (Arc::new(Map::load("rm-3.1").unwrap()), 1.0),
//! ];
//! let mix = LayoutMixture::new(&layouts, EnvConfig::default(), 0).unwrap();
//! let on_first = (0..400).filter(|&k| mix.layout_of(k) == 0).count();
//! assert!((270..330).contains(&on_first)); // about 3 in 4
//!
//! // A batch of such envs: each draws its layout at every reset.
//! let mut venv = VecEnv::with_layouts(&layouts, EnvConfig::default(), 8, ObsKind::Local, 1).unwrap();
//! for _ in 0..100 {
//!     venv.step(&[0u8; 8 * 4]).unwrap();
//! }
//! let episodes = venv.drain_episodes();
//! assert!(episodes.iter().all(|e| e.layout == mix.layout_of(e.episode) as u32));
//! ```

use std::sync::Arc;

use rand::distr::weighted::WeightedIndex;
use rand::distr::Distribution;

use crate::config::{episode_rng, EnvConfig};
use crate::error::EnvError;
use crate::map::Map;
use crate::stats::EpisodeStats;
use crate::vec_env::EnvSlot;
use crate::world::GridEnv;

/// A layout (a loaded map) and its weight in a mixture.
pub type WeightedLayout = (Arc<Map>, f64);

/// One env over several layouts with weights; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct LayoutMixture {
    /// One prepared env per layout, in the order given.
    envs: Vec<GridEnv>,
    dist: WeightedIndex<f64>,
    /// Seed of the layout draws (apart from the episode instances').
    draw_seed: u64,
    current: usize,
}

impl LayoutMixture {
    /// An env over `layouts` (each map with its weight, > 0 and finite),
    /// reset to episode `episode`. Every layout must fit `cfg` (enough free
    /// cells, or a scenario, for its agents).
    pub fn new(layouts: &[WeightedLayout], cfg: EnvConfig, episode: u64) -> Result<Self, EnvError> {
        if layouts.is_empty() {
            return Err(EnvError::InvalidConfig(
                "a layout mixture needs at least one layout".into(),
            ));
        }
        if let Some((map, w)) = layouts.iter().find(|(_, w)| !(w.is_finite() && *w > 0.0)) {
            return Err(EnvError::InvalidConfig(format!(
                "layout {} has weight {w}: weights must be positive and finite",
                map.name
            )));
        }
        let dist = WeightedIndex::new(layouts.iter().map(|(_, w)| *w)).map_err(|e| {
            EnvError::InvalidConfig(format!("the layout weights cannot be drawn from: {e}"))
        })?;
        let draw_seed = crate::seed::layout_draw(cfg.seed);
        let envs = layouts
            .iter()
            .map(|(map, _)| GridEnv::with_episode(map.clone(), cfg.clone(), episode))
            .collect::<Result<Vec<_>, _>>()?;
        let mut mix = Self {
            envs,
            dist,
            draw_seed,
            current: 0,
        };
        mix.current = mix.layout_of(episode);
        Ok(mix)
    }

    /// The layout episode `episode` plays (an index into the layouts given).
    pub fn layout_of(&self, episode: u64) -> usize {
        self.dist.sample(&mut episode_rng(self.draw_seed, episode))
    }

    /// The current episode's layout.
    pub fn layout(&self) -> usize {
        self.current
    }

    /// Number of layouts.
    pub fn layouts(&self) -> usize {
        self.envs.len()
    }

    /// The env of the current episode.
    pub fn env(&self) -> &GridEnv {
        &self.envs[self.current]
    }

    /// The env of the current episode, mutable (to step it).
    pub fn env_mut(&mut self) -> &mut GridEnv {
        &mut self.envs[self.current]
    }

    /// The prepared env of every layout (only [`Self::env`] is current).
    pub fn envs(&self) -> &[GridEnv] {
        &self.envs
    }

    /// Starts episode `episode` on the layout drawn for it.
    pub fn reset_to(&mut self, episode: u64) -> Result<(), EnvError> {
        self.current = self.layout_of(episode);
        self.envs[self.current].reset_to(episode)
    }

    /// Starts the next episode (`episode + stride`), on its layout.
    pub fn reset_next(&mut self, stride: u64) -> Result<(), EnvError> {
        self.reset_to(self.env().episode() + stride)
    }

    /// Statistics of the current episode, tagged with its layout.
    pub fn stats(&self) -> EpisodeStats {
        EpisodeStats {
            layout: self.current as u32,
            ..self.env().stats()
        }
    }
}

impl EnvSlot for LayoutMixture {
    fn env(&self) -> &GridEnv {
        LayoutMixture::env(self)
    }
    fn env_mut(&mut self) -> &mut GridEnv {
        LayoutMixture::env_mut(self)
    }
    fn reset_to(&mut self, episode: u64) -> Result<(), EnvError> {
        LayoutMixture::reset_to(self, episode)
    }
    fn stats(&self) -> EpisodeStats {
        LayoutMixture::stats(self)
    }
}
