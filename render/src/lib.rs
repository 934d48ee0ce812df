//! Draws recorded episodes ([`buridan_eval::replay::Trace`]): the layout,
//! each robot and its goal in one colour, short trails, the step counter,
//! and blocked (stuck), deadlocked and livelocked robots ringed in orange,
//! red and purple, as an animated GIF.
//!
//! - [`palette`]: the fixed colours and the mapping of drawn pixels to them.
//! - [`frame`]: one snapshot drawn as RGB pixels.
//! - [`animation`]: the snapshots encoded as a GIF, each frame only where
//!   it differs from the one before.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_eval::replay::{record_episode, Warmup};
//! use buridan_eval::{EvalSpec, RandomController};
//! let map = Arc::new(buridan_env::Map::load("rm-1.1").unwrap());
//! let spec = EvalSpec { agents: 2, episodes: 1, t_max: 10, ..EvalSpec::default() };
//! let make = || -> Box<dyn buridan_eval::Controller> { Box::new(RandomController::new(42)) };
//! let trace = record_episode(&map, &spec, &make, 0, Warmup::Fresh).unwrap();
//! let bytes = buridan_render::gif_bytes(&trace, &buridan_render::GifOptions::default()).unwrap();
//! assert_eq!(&bytes[..6], b"GIF89a");
//! ```

pub mod animation;
pub mod frame;
pub mod palette;

pub use animation::{gif_bytes, write_gif, GifOptions, RenderError};
