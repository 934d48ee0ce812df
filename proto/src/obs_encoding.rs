//! Observation buffers on the wire ([`v1::ObsEncoding`]): raw little-endian
//! f32 bytes, one LZ4 block of those bytes, or 2-bit codes
//! ([`crate::obs_codes`]).
//!
//! Observations are mostly one-hot zeros and ones, so a fragment's megabyte
//! of them packs into about a tenth with LZ4 or with codes — and packing
//! costs the actor less CPU than HTTP/2 and the kernel spend moving the raw
//! bytes (`docs/results/transport/RESULTS.md`); codes decode faster than LZ4
//! (the learner's side) and encode in about its time. Decoding is bounded: the caller names the number
//! of values the shape asks for, a buffer must decode to exactly that, and
//! the output is never larger than the caller's byte limit, so a small
//! malicious buffer cannot make the learner allocate more than a raw
//! message of the size limit could.
//!
//! ```
//! use buridan_proto::obs_encoding::{decode, encode};
//! use buridan_proto::v1::ObsEncoding;
//! let obs = [0.0f32, 1.0, 0.0, 0.0, 0.25, 0.0];
//! for encoding in [ObsEncoding::Lz4, ObsEncoding::Codes] {
//!     let wire = encode(&obs, encoding);
//!     let back = decode("obs", &wire, encoding, Some(obs.len()), 1 << 20).unwrap();
//!     assert_eq!(back, obs);
//!     // A buffer that does not decode to the shape's size is refused.
//!     assert!(decode("obs", &wire, encoding, Some(7), 1 << 20).is_err());
//! }
//! ```

use std::borrow::Cow;

use crate::v1::ObsEncoding;

/// Default bound on the bytes compressed observation buffers of one
/// fragment may decode to: the learner's default message size limit, so
/// compression lets nothing larger in than a raw message could carry.
pub const DEFAULT_MAX_DECODED_BYTES: usize = 64 * 1024 * 1024;

/// Why an observation buffer cannot be decoded.
#[derive(Debug, thiserror::Error)]
pub enum ObsDecodeError {
    /// `obs_encoding` holds a value this version does not know.
    #[error("obs_encoding {0} is not a known encoding (0 raw, 1 LZ4, 2 codes)")]
    UnknownEncoding(i32),
    /// The shape asks for more decoded bytes than the limit allows (or
    /// more than a `usize` holds).
    #[error(
        "{field} would decode to {values} values ({bytes} bytes), over the limit of {limit} bytes"
    )]
    TooLarge {
        /// The message field.
        field: &'static str,
        /// Values the shape asks for (saturated at `usize::MAX`).
        values: usize,
        /// The same in bytes (saturated).
        bytes: usize,
        /// Decoded bytes still allowed.
        limit: usize,
    },
    /// The block is not valid LZ4, or decodes to more than the shape asks.
    #[error("{field} is not an LZ4 block of {expected} values: {source}")]
    Corrupt {
        /// The message field.
        field: &'static str,
        /// Values the shape asks for.
        expected: usize,
        /// lz4_flex's reason.
        source: lz4_flex::block::DecompressError,
    },
    /// The buffer is not the 2-bit codes of as many values as the shape
    /// asks for ([`crate::obs_codes`]).
    #[error("{field} is not the 2-bit codes of {expected} values: it {source}")]
    BadCodes {
        /// The message field.
        field: &'static str,
        /// Values the shape asks for.
        expected: usize,
        /// What is wrong with it.
        source: crate::obs_codes::CodesError,
    },
    /// The block decodes to fewer bytes than the shape asks.
    #[error("{field} decodes to {got} bytes, the shape asks for {expected} values ({} bytes)", expected * 4)]
    WrongSize {
        /// The message field.
        field: &'static str,
        /// Values the shape asks for.
        expected: usize,
        /// Bytes the block held.
        got: usize,
    },
    /// A raw buffer's length is not a multiple of 4.
    #[error("{field} holds {bytes} bytes, not a whole number of f32 values")]
    Ragged {
        /// The message field.
        field: &'static str,
        /// Its length.
        bytes: usize,
    },
}

/// The encoding named by a message's `obs_encoding` field.
///
/// ```
/// use buridan_proto::obs_encoding::encoding_of;
/// use buridan_proto::v1::ObsEncoding;
/// assert_eq!(encoding_of(1).unwrap(), ObsEncoding::Lz4);
/// assert!(encoding_of(9).is_err());
/// ```
pub fn encoding_of(value: i32) -> Result<ObsEncoding, ObsDecodeError> {
    ObsEncoding::try_from(value).map_err(|_| ObsDecodeError::UnknownEncoding(value))
}

/// `values` for the wire in `encoding`.
///
/// ```
/// use buridan_proto::obs_encoding::encode;
/// use buridan_proto::v1::ObsEncoding;
/// assert_eq!(encode(&[1.0], ObsEncoding::Raw), 1.0f32.to_le_bytes());
/// ```
pub fn encode(values: &[f32], encoding: ObsEncoding) -> Vec<u8> {
    match encoding {
        ObsEncoding::Raw => le_bytes(values).into_owned(),
        ObsEncoding::Lz4 => lz4_flex::block::compress(&le_bytes(values)),
        ObsEncoding::Codes => crate::obs_codes::encode(values),
    }
}

/// A buffer from the wire as floats. Raw bytes need no `expected` count
/// (the shape checks judge their length); an LZ4 block or a code buffer
/// must decode to exactly `expected` values, in at most `limit` bytes, else
/// it is refused before anything larger than `limit` is allocated.
///
/// ```
/// use buridan_proto::obs_encoding::{decode, encode};
/// use buridan_proto::v1::ObsEncoding;
/// let wire = encode(&[0.0; 1000], ObsEncoding::Lz4);
/// assert!(wire.len() < 100);
/// // 1000 values are 4000 bytes: a 3999-byte limit refuses them.
/// assert!(decode("obs", &wire, ObsEncoding::Lz4, Some(1000), 3999).is_err());
/// ```
pub fn decode(
    field: &'static str,
    bytes: &[u8],
    encoding: ObsEncoding,
    expected: Option<usize>,
    limit: usize,
) -> Result<Vec<f32>, ObsDecodeError> {
    let bounded = || {
        let values = expected.unwrap_or(usize::MAX);
        values
            .checked_mul(4)
            .filter(|&b| b <= limit && b <= isize::MAX as usize)
            .map(|decoded| (values, decoded))
            .ok_or(ObsDecodeError::TooLarge {
                field,
                values,
                bytes: values.saturating_mul(4),
                limit,
            })
    };
    match encoding {
        ObsEncoding::Raw => raw_to_f32(field, bytes),
        ObsEncoding::Codes => {
            let (values, _) = bounded()?;
            crate::obs_codes::decode(bytes, values).map_err(|source| ObsDecodeError::BadCodes {
                field,
                expected: values,
                source,
            })
        }
        ObsEncoding::Lz4 => {
            let (values, decoded) = bounded()?;
            let mut out = vec![0f32; values];
            let got = lz4_flex::block::decompress_into(bytes, bytemuck::cast_slice_mut(&mut out))
                .map_err(|source| ObsDecodeError::Corrupt {
                field,
                expected: values,
                source,
            })?;
            if got != decoded {
                return Err(ObsDecodeError::WrongSize {
                    field,
                    expected: values,
                    got,
                });
            }
            from_le_in_place(&mut out);
            Ok(out)
        }
    }
}

/// Floats as little-endian bytes: borrowed as they are on little-endian
/// machines (no copy), swapped into a new buffer elsewhere.
fn le_bytes(values: &[f32]) -> Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        Cow::Borrowed(bytemuck::cast_slice(values))
    } else {
        Cow::Owned(values.iter().flat_map(|v| v.to_le_bytes()).collect())
    }
}

/// Raw little-endian bytes as floats, in one copy.
fn raw_to_f32(field: &'static str, bytes: &[u8]) -> Result<Vec<f32>, ObsDecodeError> {
    if !bytes.len().is_multiple_of(4) {
        return Err(ObsDecodeError::Ragged {
            field,
            bytes: bytes.len(),
        });
    }
    // One memcpy into an aligned Vec<f32>, whatever the input's alignment.
    let mut out = vec![0f32; bytes.len() / 4];
    bytemuck::cast_slice_mut::<f32, u8>(&mut out).copy_from_slice(bytes);
    from_le_in_place(&mut out);
    Ok(out)
}

/// Little-endian bit patterns to native floats (nothing to do on
/// little-endian machines).
fn from_le_in_place(values: &mut [f32]) {
    if cfg!(target_endian = "big") {
        for v in values {
            *v = f32::from_bits(u32::from_le(v.to_bits()));
        }
    }
}

/// Floats as little-endian bytes, 4 per value (one copy).
///
/// ```
/// assert_eq!(buridan_proto::obs_encoding::to_le_bytes(&[1.0]), 1.0f32.to_le_bytes());
/// ```
pub fn to_le_bytes(values: &[f32]) -> Vec<u8> {
    le_bytes(values).into_owned()
}

/// Little-endian bytes as floats; the length must be a multiple of 4.
///
/// ```
/// let back = buridan_proto::obs_encoding::from_le_bytes("obs", &2.5f32.to_le_bytes()).unwrap();
/// assert_eq!(back, [2.5]);
/// ```
pub fn from_le_bytes(field: &'static str, bytes: &[u8]) -> Result<Vec<f32>, ObsDecodeError> {
    raw_to_f32(field, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values whose bits must survive: signed zeros, subnormals, extremes,
    /// NaN payloads, one-hot runs.
    fn awkward() -> Vec<f32> {
        let mut v = vec![
            0.0,
            -0.0,
            f32::MIN_POSITIVE / 3.0,
            f32::MAX,
            f32::MIN,
            f32::from_bits(0x7fc0_1234),
            f32::INFINITY,
            1.0 / 3.0,
        ];
        for i in 0..5000 {
            v.push(if i % 129 == 7 { 1.0 } else { 0.0 });
        }
        v
    }

    /// [`decode`] of `len` values, with no limit on the decoded size.
    fn decode_len(
        field: &'static str,
        wire: &[u8],
        encoding: ObsEncoding,
        len: usize,
    ) -> Result<Vec<f32>, ObsDecodeError> {
        decode(field, wire, encoding, Some(len), usize::MAX)
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn both_encodings_round_trip_bit_for_bit() {
        let v = awkward();
        for encoding in [ObsEncoding::Raw, ObsEncoding::Lz4, ObsEncoding::Codes] {
            let wire = encode(&v, encoding);
            let back = decode_len("obs", &wire, encoding, v.len()).unwrap();
            assert_eq!(bits(&back), bits(&v), "{encoding:?}");
        }
        let empty = encode(&[], ObsEncoding::Lz4);
        assert!(decode("final_obs", &empty, ObsEncoding::Lz4, Some(0), 0)
            .unwrap()
            .is_empty());
    }

    #[test]
    fn raw_bytes_are_the_old_format() {
        let v = awkward();
        let old: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        assert_eq!(encode(&v, ObsEncoding::Raw), old);
        assert_eq!(to_le_bytes(&v), old);
        // Unaligned input decodes too.
        let mut shifted = vec![0u8];
        shifted.extend_from_slice(&old);
        assert_eq!(
            bits(&from_le_bytes("obs", &shifted[1..]).unwrap()),
            bits(&v)
        );
        let ragged = from_le_bytes("last_obs", &old[..5]).unwrap_err();
        assert_eq!(
            ragged.to_string(),
            "last_obs holds 5 bytes, not a whole number of f32 values"
        );
    }

    #[test]
    fn one_hot_observations_shrink() {
        let v = awkward();
        assert!(encode(&v, ObsEncoding::Lz4).len() * 8 < v.len() * 4);
    }

    #[test]
    fn a_block_of_the_wrong_size_is_refused() {
        let v = awkward();
        let wire = encode(&v, ObsEncoding::Lz4);
        let short = decode_len("obs", &wire, ObsEncoding::Lz4, v.len() + 1);
        assert!(
            matches!(short, Err(ObsDecodeError::WrongSize { field: "obs", .. })),
            "{short:?}"
        );
        let long = decode_len("last_obs", &wire, ObsEncoding::Lz4, v.len() - 1);
        assert!(
            matches!(
                long,
                Err(ObsDecodeError::Corrupt {
                    field: "last_obs",
                    ..
                })
            ),
            "{long:?}"
        );
    }

    #[test]
    fn code_buffers_of_the_wrong_size_are_refused_naming_the_field() {
        let v = awkward();
        let wire = encode(&v, ObsEncoding::Codes);
        // About as small as LZ4 on one-hot values.
        assert!(wire.len() * 8 < v.len() * 4);
        let e = decode_len("last_obs", &wire, ObsEncoding::Codes, v.len() + 4).unwrap_err();
        assert!(
            matches!(
                e,
                ObsDecodeError::BadCodes {
                    field: "last_obs",
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .starts_with("last_obs is not the 2-bit codes of"),
            "{e}"
        );
    }

    #[test]
    fn garbage_is_refused_naming_the_field() {
        let v = awkward();
        let mut wire = encode(&v, ObsEncoding::Lz4);
        // Truncated, and then every byte flipped in turn: refused or (if the
        // flip still parses) decoded to exactly the asked size, never a panic.
        let cut = decode_len(
            "final_obs",
            &wire[..wire.len() / 2],
            ObsEncoding::Lz4,
            v.len(),
        )
        .unwrap_err();
        assert!(cut.to_string().starts_with("final_obs "), "{cut}");
        for i in 0..wire.len() {
            wire[i] ^= 0xa5;
            if let Ok(back) = decode_len("obs", &wire, ObsEncoding::Lz4, v.len()) {
                assert_eq!(back.len(), v.len());
            }
            wire[i] ^= 0xa5;
        }
    }

    #[test]
    fn the_limit_is_checked_before_allocating() {
        // A 20-byte block cannot claim a terabyte of observations.
        let claim = 1usize << 38;
        let e = decode("obs", &[0u8; 20], ObsEncoding::Lz4, Some(claim), 64 << 20).unwrap_err();
        assert!(
            matches!(e, ObsDecodeError::TooLarge { field: "obs", .. }),
            "{e:?}"
        );
        assert!(
            e.to_string().contains("over the limit of 67108864 bytes"),
            "{e}"
        );
        let e = decode("obs", &[0u8; 20], ObsEncoding::Lz4, None, usize::MAX).unwrap_err();
        assert!(matches!(e, ObsDecodeError::TooLarge { .. }), "{e:?}");
        // Codes are bounded the same way.
        let e = decode("obs", &[0u8; 20], ObsEncoding::Codes, Some(claim), 64 << 20).unwrap_err();
        assert!(
            matches!(e, ObsDecodeError::TooLarge { field: "obs", .. }),
            "{e:?}"
        );
    }

    #[test]
    fn unknown_encodings_are_named() {
        assert_eq!(
            encoding_of(7).unwrap_err().to_string(),
            "obs_encoding 7 is not a known encoding (0 raw, 1 LZ4, 2 codes)"
        );
        assert_eq!(encoding_of(0).unwrap(), ObsEncoding::Raw);
    }
}
