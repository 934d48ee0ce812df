//! The actor–learner gRPC API (`proto/buridan/v1/learner.proto`) and the
//! environment API external simulators serve (`proto/buridan/v1/env.proto`),
//! generated at build time, and conversions between their messages and the
//! crate types ([`convert`], [`env_convert`]).
//!
//! ```
//! use buridan_proto::v1;
//! let join = v1::JoinRequest { api_version: v1::ApiVersion::V2 as u32, ..Default::default() };
//! assert_eq!(join.api_version, 2);
//! ```

pub mod codec;
pub mod convert;
pub mod env_convert;
pub mod obs_codes;
pub mod obs_encoding;

/// Generated messages, the `Learner` client and server, and the
/// `Environment` client and server.
pub mod v1 {
    tonic::include_proto!("buridan.v1");
}

pub use convert::{check_fragment, ConvertError};
