//! What every gRPC server of the project shares: the learner (`learner
//! serve`), the plant env server (`plant-server`) and the fleet control
//! service (`fleet-control`).
//!
//! - [`tls`]: a PEM certificate and key read from files into the server's
//!   TLS configuration, with errors that name the file.
//! - [`token`]: the `authorization: Bearer TOKEN` check as an interceptor.
//! - [`shutdown`]: Ctrl-C or SIGTERM as a future; serving until it
//!   completes, then cutting connections still open after a grace period.
//! - [`incoming`]: a listener's connections with TCP_NODELAY (every
//!   server answers small requests at once; Nagle's delay would add
//!   tens of milliseconds to each).
//! - [`thread`]: a server on a thread of its own, for tests and embedding.
//! - [`error`]: what can go wrong in any server, and binding a port.
//! - `logging` (feature `logging`): the binaries' `tracing` setup.
//!
//! Each server keeps its own service, limits and errors; this crate only
//! holds the plumbing they would otherwise each write again.

pub mod error;
pub mod incoming;
#[cfg(feature = "logging")]
pub mod logging;
pub mod shutdown;
pub mod thread;
pub mod tls;
pub mod token;

pub use error::{bind, ServerError};
pub use incoming::nodelay;
pub use shutdown::{serve_with_grace, shutdown_signal, Stopping};
pub use thread::{ServerThread, StopRequested};
pub use tls::{with_tls, TlsError};
pub use token::BearerToken;
