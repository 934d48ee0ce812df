//! Observations as 2-bit codes ([`crate::v1::ObsEncoding::Codes`]).
//!
//! # Why
//!
//! A grid observation is one-hot cells and a few scalars: on the IMPALA
//! benchmark 78 % of the values are `0.0`, 20 % are `1.0` and the rest
//! positions and offsets. LZ4 packs such buffers tenfold, but it searches
//! for matches byte by byte, and on two cores LZ4 was the largest wire
//! cost left (18 % of the actor's CPU, decoding the largest item of the
//! learner's gRPC thread; `docs/results/transport/`). Here each value is
//! three comparisons and two bits, and decoding is a table lookup per four
//! values. Measured on one fragment's observations (`cargo bench -p
//! buridan-proto --bench obs_encoding`): decoding — on the learner, the
//! run's bottleneck — takes 259 µs against LZ4's 352 µs; encoding about
//! what LZ4 takes (774 against 688 µs, SSE2); the buffer is 1.3 times
//! LZ4's (90.6 against 69.8 KB, still 11 times smaller than raw).
//!
//! # Format
//!
//! `n` values become their count (8 bytes, little-endian), `⌈n/4⌉` code
//! bytes, four codes per byte with the first value in the lowest two bits,
//! then the literals:
//!
//! | code | value |
//! |---|---|
//! | 0 | `+0.0` |
//! | 1 | `1.0` |
//! | 2 | `−1.0` |
//! | 3 | the next literal: little-endian f32 bytes after the codes, in order |
//!
//! Codes compare bit patterns, so every value (`−0.0`, NaN payloads)
//! comes back bit for bit. The count makes a buffer decode to exactly the
//! values it was made from (as an LZ4 block does) and the padding codes of
//! the last byte are 0, so each buffer has one encoding, and a decoder
//! refuses any other.
//!
//! ```
//! use buridan_proto::obs_codes::{decode, encode};
//! let values = [0.0f32, 1.0, 0.0, -1.0, 0.25];
//! let wire = encode(&values);
//! // The count, two code bytes, one literal.
//! assert_eq!(wire.len(), 8 + 2 + 4);
//! assert_eq!(decode(&wire, values.len()).unwrap(), values);
//! ```

/// The bit patterns codes 0–2 stand for.
const CODED: [u32; 3] = [0, 0x3f80_0000, 0xbf80_0000];

/// Code 3: the value follows among the literals.
const LITERAL: u8 = 3;

/// The code of one value.
#[inline(always)]
fn code_of(bits: u32) -> u8 {
    // Compares the compiler turns into selects: no branch per value.
    let coded = (bits == CODED[0]) | (bits == CODED[1]) | (bits == CODED[2]);
    let code = u8::from(bits == CODED[1]) | (u8::from(bits == CODED[2]) << 1);
    code | (LITERAL * u8::from(!coded))
}

/// For every code byte without a literal, the four values it stands for.
const EXPAND: [[f32; 4]; 256] = {
    let mut table = [[0f32; 4]; 256];
    let mut byte = 0;
    while byte < 256 {
        let mut k = 0;
        while k < 4 {
            let code = (byte >> (2 * k)) & 3;
            table[byte][k] = f32::from_bits(if code < 3 { CODED[code] } else { 0 });
            k += 1;
        }
        byte += 1;
    }
    table
};

/// The low bit of every literal code in a code byte, others cleared: a
/// code is 3 where both of its bits are set.
#[inline(always)]
fn literal_bits(byte: u8) -> u8 {
    byte & (byte >> 1) & 0x55
}

/// Bytes of the value count before the codes.
const COUNT_BYTES: usize = 8;

/// `values` as their count, code bytes and literals.
///
/// ```
/// let wire = buridan_proto::obs_codes::encode(&[1.0; 8]);
/// assert_eq!(wire[..8], 8u64.to_le_bytes());
/// assert_eq!(wire[8..], [0b0101_0101, 0b0101_0101]);
/// ```
pub fn encode(values: &[f32]) -> Vec<u8> {
    // Blocks of 64 values: their codes first (a loop the compiler
    // vectorizes), then packed four to a byte, then the block's literals,
    // looked for only in blocks that have one.
    const BLOCK: usize = 64;
    let code_bytes = values.len().div_ceil(4);
    let mut out = Vec::with_capacity(COUNT_BYTES + code_bytes);
    out.extend_from_slice(&(values.len() as u64).to_le_bytes());
    out.resize(COUNT_BYTES + code_bytes, 0);
    let mut literals = Vec::new();
    let mut codes = [0u8; BLOCK];
    for (block, packed) in values
        .chunks(BLOCK)
        .zip(out[COUNT_BYTES..].chunks_mut(BLOCK / 4))
    {
        let mut any_literal = 0u8;
        for (code, v) in codes.iter_mut().zip(block) {
            *code = code_of(v.to_bits());
            any_literal |= *code & (*code >> 1);
        }
        codes[block.len()..].fill(0);
        for (byte, four) in packed.iter_mut().zip(codes.chunks_exact(4)) {
            *byte = four[0] | (four[1] << 2) | (four[2] << 4) | (four[3] << 6);
        }
        if any_literal != 0 {
            for (&code, v) in codes.iter().zip(block) {
                if code == LITERAL {
                    literals.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
    }
    out.extend_from_slice(&literals);
    out
}

/// Why a buffer is not the codes of `n` values.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CodesError {
    /// The buffer's count is not the number of values asked for.
    #[error("holds {declared} values")]
    Count {
        /// The count the buffer starts with.
        declared: u64,
    },
    /// Fewer bytes than the count and the codes of `n` values need.
    #[error(
        "holds {got} bytes, fewer than the {need} bytes of count and codes of {values} values"
    )]
    Short {
        /// Bytes in the buffer.
        got: usize,
        /// Count and code bytes `values` need.
        need: usize,
        /// Values asked for.
        values: usize,
    },
    /// The literals after the codes are not as many as the codes say.
    #[error("its codes name {named} literals, but {bytes} bytes follow them")]
    Literals {
        /// Literal codes among the first `n` codes.
        named: usize,
        /// Bytes after the codes.
        bytes: usize,
    },
    /// A code past the `n`th is not 0.
    #[error("the padding codes after value {values} are not 0")]
    Padding {
        /// Values asked for.
        values: usize,
    },
}

/// The `n` values of a buffer made by [`encode`], bit for bit; any other
/// buffer is an error (never a panic). Allocates `n` values, so callers
/// bound `n` first.
///
/// ```
/// use buridan_proto::obs_codes::{decode, encode};
/// let wire = encode(&[0.5, 0.0]);
/// assert!(decode(&wire, 2).is_ok());
/// assert!(decode(&wire[..wire.len() - 1], 2).is_err()); // a literal cut short
/// assert!(decode(&wire, 5).is_err());      // more values than the buffer holds
/// ```
pub fn decode(bytes: &[u8], n: usize) -> Result<Vec<f32>, CodesError> {
    let need = n.div_ceil(4);
    if bytes.len() < COUNT_BYTES + need {
        return Err(CodesError::Short {
            got: bytes.len(),
            need: COUNT_BYTES + need,
            values: n,
        });
    }
    let (count, rest) = bytes.split_at(COUNT_BYTES);
    let declared = u64::from_le_bytes(count.try_into().expect("8 bytes"));
    if u64::try_from(n).ok() != Some(declared) {
        return Err(CodesError::Count { declared });
    }
    let (codes, literals) = rest.split_at(need);
    if !n.is_multiple_of(4) {
        let last = codes[need - 1];
        if last >> (2 * (n % 4)) != 0 {
            return Err(CodesError::Padding { values: n });
        }
    }
    let named = codes
        .iter()
        .map(|&b| literal_bits(b).count_ones() as usize)
        .sum::<usize>();
    if literals.len() != named * 4 {
        return Err(CodesError::Literals {
            named,
            bytes: literals.len(),
        });
    }
    let mut out: Vec<f32> = Vec::with_capacity(need * 4);
    let mut next = literals.chunks_exact(4);
    for &b in codes {
        if literal_bits(b) != 0 {
            for k in 0..4 {
                let code = (b >> (2 * k)) & 3;
                let bits = if code == LITERAL {
                    // Counted above, so a chunk is always there.
                    let Some(chunk) = next.next() else {
                        return Err(CodesError::Literals {
                            named,
                            bytes: literals.len(),
                        });
                    };
                    u32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]])
                } else {
                    CODED[usize::from(code)]
                };
                out.push(f32::from_bits(bits));
            }
        } else {
            out.extend_from_slice(&EXPAND[usize::from(b)]);
        }
    }
    out.truncate(n);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn codes_follow_the_table() {
        let wire = encode(&[0.0, 1.0, -1.0, 2.0, -0.0]);
        assert_eq!(wire[..8], 5u64.to_le_bytes());
        let wire = &wire[8..];
        // Byte 0: codes 0, 1, 2, 3 from the low bits; byte 1: −0.0 is a literal.
        assert_eq!(wire[0], 0b11_10_01_00);
        assert_eq!(wire[1], 0b11);
        assert_eq!(&wire[2..6], &2.0f32.to_le_bytes());
        assert_eq!(&wire[6..10], &(-0.0f32).to_le_bytes());
        assert_eq!(wire.len(), 10);
    }

    #[test]
    fn awkward_values_round_trip_bit_for_bit() {
        let v = [
            -0.0,
            f32::from_bits(0x7fc0_1234),
            f32::INFINITY,
            f32::MIN_POSITIVE / 3.0,
            1.0 / 3.0,
            1.0,
            0.0,
        ];
        for n in 0..=v.len() {
            let back = decode(&encode(&v[..n]), n).unwrap();
            assert_eq!(bits(&back), bits(&v[..n]), "first {n}");
        }
    }

    #[test]
    fn one_hot_observations_take_two_bits_a_value() {
        let v: Vec<f32> = (0..4000).map(|i| f32::from(u8::from(i % 5 == 2))).collect();
        assert_eq!(encode(&v).len(), 8 + 1000);
    }

    #[test]
    fn malformed_buffers_are_named() {
        let wire = encode(&[0.5, 1.0, 0.0]);
        assert_eq!(
            decode(&wire, 40).unwrap_err().to_string(),
            "holds 13 bytes, fewer than the 18 bytes of count and codes of 40 values"
        );
        // One more value than it holds, though its last code byte has room.
        assert_eq!(
            decode(&wire, 4).unwrap_err(),
            CodesError::Count { declared: 3 }
        );
        assert_eq!(
            decode(&wire[..11], 3).unwrap_err(),
            CodesError::Literals { named: 1, bytes: 2 }
        );
        let mut padded = wire.clone();
        padded[8] |= 0b01 << 6;
        assert_eq!(
            decode(&padded, 3).unwrap_err(),
            CodesError::Padding { values: 3 }
        );
        let mut extra = wire;
        extra.extend_from_slice(&[0; 4]);
        assert!(matches!(
            decode(&extra, 3).unwrap_err(),
            CodesError::Literals { named: 1, bytes: 8 }
        ));
    }

    proptest! {
        #[test]
        fn any_values_round_trip(raw in proptest::collection::vec(
            prop_oneof![Just(0u32), Just(0x3f80_0000), Just(0xbf80_0000), any::<u32>()], 0..200)) {
            let v: Vec<f32> = raw.iter().copied().map(f32::from_bits).collect();
            let back = decode(&encode(&v), v.len()).unwrap();
            prop_assert_eq!(bits(&back), raw);
        }

        #[test]
        fn any_bytes_decode_or_fail_without_panicking(bytes in proptest::collection::vec(any::<u8>(), 0..64), n in 0usize..200) {
            if let Ok(v) = decode(&bytes, n) {
                prop_assert_eq!(v.len(), n);
                // The one encoding of those values is the buffer itself.
                prop_assert_eq!(encode(&v), bytes);
            }
        }
    }
}
