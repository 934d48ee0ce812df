//! Messages ↔ crate types. Byte and integer buffers move between the two;
//! float buffers that travel as bytes (observations, logits) are copied
//! once, into bytes on the way out and into floats on the way in —
//! observations LZ4-compressed if the learner accepts that
//! ([`fragment_to_message_encoded`], [`crate::obs_encoding`]).
//! Everything arriving from the wire is checked: shapes, finite numbers,
//! value ranges.
//!
//! ```
//! use buridan_policy::Fragment;
//! use buridan_proto::convert::{fragment_from_message, fragment_to_message, WireTag};
//! let mut f = Fragment::with_capacity(0, 3, 1, 1, 1, 2, 1, 5);
//! f.len = 1;
//! f.obs = vec![0.5, 1.0];
//! f.masks = vec![1; 5];
//! f.actions = vec![2];
//! f.behaviour_logits = vec![0.0; 5];
//! f.behaviour_logp = vec![-1.6];
//! f.rewards = vec![-0.1];
//! f.terminated = vec![0];
//! f.truncated = vec![0];
//! f.last_obs = vec![0.5, 0.0];
//! f.env_steps = 1;
//! let tag = WireTag { run_id: "run".into(), session: 7, seq: 1 };
//! let msg = fragment_to_message(f.clone(), &tag);
//! let (back_tag, back) = fragment_from_message(msg).unwrap();
//! assert_eq!((back_tag, back), (tag, f));
//! ```
mod fragment;
mod settings;
mod spec;

pub use fragment::{
    check_fragment, fragment_from_message, fragment_from_message_within, fragment_to_message,
    fragment_to_message_encoded,
};
pub use settings::{
    env_from_message, env_to_message, map_from_message, map_to_message, replay_from_message,
    replay_to_message, weights_from_message, weights_to_message,
};
pub use spec::{check_run_spec, model_spec_from_message, model_spec_to_message};

use buridan_policy::PolicyError;

use crate::obs_encoding::{self, ObsDecodeError};

/// What is wrong with a message received from the wire.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    /// A buffer's length does not match the shape fields.
    #[error(transparent)]
    Shape(#[from] PolicyError),
    /// A float is NaN or infinite.
    #[error("{field}[{index}] is {value} (must be finite)")]
    NonFinite {
        /// The message field.
        field: &'static str,
        /// Position in the buffer.
        index: usize,
        /// The value found.
        value: f32,
    },
    /// An integer outside its allowed range.
    #[error("{field}[{index}] = {value} is out of range (must be < {limit})")]
    OutOfRange {
        /// The message field.
        field: &'static str,
        /// Position in the buffer.
        index: usize,
        /// The value found.
        value: u64,
        /// Exclusive upper bound.
        limit: u64,
    },
    /// A buffer holds a wrong number of values.
    #[error("{field} holds {got} values, expected {expected}")]
    Length {
        /// The message field.
        field: &'static str,
        /// The number the shape asks for.
        expected: usize,
        /// The number found.
        got: usize,
    },
    /// An observation buffer does not decode (unknown encoding, corrupt
    /// or oversized LZ4 block).
    #[error(transparent)]
    Obs(#[from] ObsDecodeError),
    /// A message or enum the receiver needs is unset (an enum left at its
    /// UNSPECIFIED zero counts as unset).
    #[error("{field} is missing")]
    Missing {
        /// The field, by its path in the message.
        field: &'static str,
    },
    /// An enum field holds a number its enum does not define.
    #[error("{field} = {value} is not a value its enum defines")]
    UnknownEnum {
        /// The field, by its path in the message.
        field: &'static str,
        /// The number found.
        value: i32,
    },
    /// A size that must be positive is 0.
    #[error("{field}{} is 0 (must be positive)", at(.index))]
    Zero {
        /// The field, by its path in the message.
        field: &'static str,
        /// Position in a repeated field.
        index: Option<usize>,
    },
    /// A field's value is not allowed, alone or beside the others.
    #[error("{field}: {reason}")]
    Field {
        /// The field, by its path in the message.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// Something else that makes the message unusable.
    #[error("{0}")]
    Invalid(String),
}

/// `[index]`, or nothing.
fn at(index: &Option<usize>) -> String {
    index.map_or_else(String::new, |i| format!("[{i}]"))
}

/// Where a fragment comes from: the run, the actor's session and the
/// fragment's sequence number within that session.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct WireTag {
    /// The learner incarnation the actor joined.
    pub run_id: String,
    /// The actor's session.
    pub session: u64,
    /// Sequence number within the session.
    pub seq: u64,
}

/// Floats as little-endian bytes, 4 per value.
pub fn f32_to_le_bytes(values: &[f32]) -> Vec<u8> {
    obs_encoding::to_le_bytes(values)
}

/// Little-endian bytes as floats; the length must be a multiple of 4.
pub fn le_bytes_to_f32(field: &'static str, bytes: &[u8]) -> Result<Vec<f32>, ConvertError> {
    Ok(obs_encoding::from_le_bytes(field, bytes)?)
}

pub(crate) fn check_finite(field: &'static str, buf: &[f32]) -> Result<(), ConvertError> {
    match buf.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(index) => Err(ConvertError::NonFinite {
            field,
            index,
            value: buf[index],
        }),
    }
}

pub(crate) fn check_below(field: &'static str, buf: &[u8], limit: u64) -> Result<(), ConvertError> {
    match buf.iter().position(|&x| u64::from(x) >= limit) {
        None => Ok(()),
        Some(index) => Err(ConvertError::OutOfRange {
            field,
            index,
            value: u64::from(buf[index]),
            limit,
        }),
    }
}
