//! The actor: runs env instances with the learner's policy and streams
//! trajectory fragments to it.
//!
//! - [`Collector`]: envs + inference → [`buridan_policy::Fragment`]; used
//!   in-process by `learner train` and here.
//! - [`client`]: the stateless gRPC actor behind the `actor` binary — join,
//!   receive weights, submit fragments, reconnect with backoff.
//! - [`remote_env`]: [`remote_env::RemoteEnv`], envs stepped on an external
//!   simulator over the env API (`env.proto`), behind the same
//!   [`buridan_env::BatchedEnv`] as the built-in envs (`actor --env URL`).
//! - `misbehave` (the non-default `misbehave` feature): a client that sends
//!   what a learner must refuse and checks the answers (the soak harness,
//!   `buridan-soak`, and the learner's hardening tests).

pub mod client;
pub mod collector;
#[cfg(feature = "misbehave")]
pub mod misbehave;
pub mod remote_env;

pub use collector::{ActorEnv, CollectError, Collector};
