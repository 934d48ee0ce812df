//! The generated service's codec: prost's, except that a request whose
//! bytes are not a protobuf message of its type is the caller's fault and
//! is answered with `INVALID_ARGUMENT` instead of prost's `INTERNAL`.
//!
//! Only the payload decode changes. Framing errors tonic finds before the
//! codec (a compressed-flag byte other than 0 or 1, a truncated frame) stay
//! `INTERNAL`, as the gRPC spec asks; an oversized message stays
//! `OUT_OF_RANGE`. A reply a client cannot decode also stays `INTERNAL`,
//! which actors treat as "reconnect".
//!
//! ```
//! use buridan_proto::codec::{undecodable, UNDECODABLE_METADATA};
//! let status = undecodable("Fragment", "invalid wire type");
//! assert_eq!(status.code(), tonic::Code::InvalidArgument);
//! assert!(status.metadata().get(UNDECODABLE_METADATA).is_some());
//! ```

use prost::Message;
use tonic::codec::{BufferSettings, Codec, DecodeBuf, Decoder};
use tonic::metadata::{MetadataMap, MetadataValue};
use tonic::{Code, Status};
use tonic_prost::{ProstCodec, ProstDecoder, ProstEncoder};

use crate::v1;

/// Metadata key on the status of an undecodable request (value `1`), so
/// that the server's status counter can tell it from other
/// `INVALID_ARGUMENT`s.
pub const UNDECODABLE_METADATA: &str = "buridan-undecodable";

/// A message type of the API: its protobuf name and who sends it.
pub trait WireMessage {
    /// The message's name in `learner.proto`, `env.proto` or `control.proto`.
    const NAME: &'static str;
    /// Whether clients send it (a request) rather than the server.
    const FROM_CLIENT: bool;
}

macro_rules! wire_messages {
    ($($ty:ident: $from_client:expr),* $(,)?) => {
        $(impl WireMessage for v1::$ty {
            const NAME: &'static str = stringify!($ty);
            const FROM_CLIENT: bool = $from_client;
        })*
    };
}

wire_messages! {
    JoinRequest: true,
    JoinReply: false,
    WatchRequest: true,
    Parameters: false,
    Fragment: true,
    SubmitReply: false,
    SpecRequest: true,
    EnvSpec: false,
    ResetRequest: true,
    ResetReply: false,
    StepRequest: true,
    StepReply: false,
    FleetOpenRequest: true,
    FleetOpenReply: false,
    FleetStepRequest: true,
    FleetStepReply: false,
    FleetCloseRequest: true,
    FleetCloseReply: false,
}

/// The status of a request that does not decode: `INVALID_ARGUMENT`, its
/// message naming the message type and prost's reason, marked with
/// [`UNDECODABLE_METADATA`].
pub fn undecodable(name: &str, reason: &str) -> Status {
    let mut metadata = MetadataMap::new();
    metadata.insert(UNDECODABLE_METADATA, MetadataValue::from_static("1"));
    Status::with_metadata(
        Code::InvalidArgument,
        format!("the {name} message could not be decoded: {reason}"),
        metadata,
    )
}

/// [`ProstCodec`] with [`WireDecoder`] (set as the codec of the generated
/// client and server by `build.rs`).
#[derive(Debug, Clone)]
pub struct WireCodec<T, U> {
    inner: ProstCodec<T, U>,
}

impl<T, U> Default for WireCodec<T, U> {
    fn default() -> Self {
        Self {
            inner: ProstCodec::default(),
        }
    }
}

impl<T, U> Codec for WireCodec<T, U>
where
    T: Message + Send + 'static,
    U: Message + Default + WireMessage + Send + 'static,
{
    type Encode = T;
    type Decode = U;
    type Encoder = ProstEncoder<T>;
    type Decoder = WireDecoder<U>;

    fn encoder(&mut self) -> Self::Encoder {
        self.inner.encoder()
    }

    fn decoder(&mut self) -> Self::Decoder {
        WireDecoder {
            inner: self.inner.decoder(),
        }
    }
}

/// prost's decoder; a request that fails to decode gets [`undecodable`].
#[derive(Debug, Clone)]
pub struct WireDecoder<U> {
    inner: ProstDecoder<U>,
}

impl<U: Message + Default + WireMessage> Decoder for WireDecoder<U> {
    type Item = U;
    type Error = Status;

    fn decode(&mut self, src: &mut DecodeBuf<'_>) -> Result<Option<U>, Status> {
        // prost's decoder fails only when the bytes are not a `U`.
        self.inner.decode(src).map_err(|status| {
            if U::FROM_CLIENT {
                undecodable(U::NAME, status.message())
            } else {
                status
            }
        })
    }

    fn buffer_settings(&self) -> BufferSettings {
        self.inner.buffer_settings()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_and_replies_are_told_apart() {
        const { assert!(v1::Fragment::FROM_CLIENT && !v1::SubmitReply::FROM_CLIENT) };
        assert_eq!(v1::WatchRequest::NAME, "WatchRequest");
        let status = undecodable("JoinRequest", "buffer underflow");
        assert_eq!(
            status.message(),
            "the JoinRequest message could not be decoded: buffer underflow"
        );
    }
}
