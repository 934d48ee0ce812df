//! The live dashboard of a training run: one page, served over HTTP, that
//! shows the learning curves as they grow, steps per second, the actors and
//! what became of their fragments, the latest evaluation and the replay of
//! a recent episode.
//!
//! - [`board`]: the [`Board`], what the page shows; the trainer writes to it.
//! - [`server`]: the HTTP server ([`serve`]): the page, a JSON snapshot,
//!   server-sent events and the replay GIF.
//!
//! The page and its script are compiled into the binary (`include_str!`)
//! and draw their charts as inline SVG: nothing is fetched from elsewhere,
//! so the page works offline.
//!
//! ```
//! let board = buridan_dashboard::Board::default();
//! board.push_row(serde_json::json!({"env_steps": 1000, "success_rate": 0.5}));
//! assert_eq!(board.snapshot()["rows"][0]["env_steps"], 1000);
//! ```

pub mod board;
pub mod server;

pub use board::{Board, Status, Update};
pub use server::{serve, DashboardError, Running};
