//! The actor–learner gRPC API (`proto/buridan/v1/learner.proto`), generated
//! at build time, and conversions between its messages and the crate types.
//!
//! ```
//! use buridan_proto::v1;
//! let join = v1::JoinRequest { api_version: v1::ApiVersion::V1 as u32, ..Default::default() };
//! assert_eq!(join.api_version, 1);
//! ```

pub mod codec;
pub mod convert;

/// Generated messages and the `Learner` client and server.
pub mod v1 {
    tonic::include_proto!("buridan.v1");
}

pub use convert::{check_fragment, ConvertError};
