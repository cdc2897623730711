//! Where given bytes are in a block of 64, as the bits of a u64 (bit i for byte i): what the
//! CSV reader ([`crate::rawcsv`]) jumps between. Sixteen bytes are compared at once with SSE2,
//! which every x86_64 processor has; elsewhere a byte at a time.
//!
//! Jumping from bit to bit of these masks finds a survey's commas and line feeds three times
//! as fast as a search from each one to the next (`memchr3`): the cells are short, so a
//! search's start-up cost, paid per cell, was most of its time.

/// Bytes in a block.
pub(crate) const BLOCK: usize = 64;

/// The bits of the bytes of `block` equal to any of `needles`.
pub(crate) fn any_of<const K: usize>(block: &[u8; BLOCK], needles: [u8; K]) -> u64 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: the function only needs SSE2, which is part of every x86_64 processor.
        unsafe { sse2::any_of(block, needles) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let (found, _) = portable::each_of(block, needles);
        found.iter().fold(0, |all, f| all | f)
    }
}

/// For each of `needles`, the bits of the bytes of `block` equal to it; and the bits of the
/// bytes from 0x80 on (those of multi-byte characters).
pub(crate) fn each_of<const K: usize>(block: &[u8; BLOCK], needles: [u8; K]) -> ([u64; K], u64) {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: the function only needs SSE2, which is part of every x86_64 processor.
        unsafe { sse2::each_of(block, needles) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        portable::each_of(block, needles)
    }
}

/// `f` of the block of `text` from `at`: the text's own bytes where a whole block is left,
/// else a copy padded with zero bytes past its end.
pub(crate) fn with_block<R>(text: &[u8], at: usize, f: impl FnOnce(&[u8; BLOCK]) -> R) -> R {
    match text.get(at..at + BLOCK).map(<&[u8; BLOCK]>::try_from) {
        Some(Ok(block)) => f(block),
        _ => f(&block_at(text, at)),
    }
}

/// The bytes of `text` from `at` as a block, padded with zero bytes past its end.
fn block_at(text: &[u8], at: usize) -> [u8; BLOCK] {
    let mut block = [0; BLOCK];
    let part = &text[at.min(text.len())..(at + BLOCK).min(text.len())];
    block[..part.len()].copy_from_slice(part);
    block
}

/// The masks a byte at a time: the reference, and the way on other processors.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
mod portable {
    use super::BLOCK;

    pub(super) fn each_of<const K: usize>(
        block: &[u8; BLOCK],
        needles: [u8; K],
    ) -> ([u64; K], u64) {
        let mut found = [0u64; K];
        let mut high = 0u64;
        for (i, &b) in block.iter().enumerate() {
            for (f, &needle) in found.iter_mut().zip(&needles) {
                *f |= u64::from(b == needle) << i;
            }
            high |= u64::from(b >= 0x80) << i;
        }
        (found, high)
    }
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    use super::BLOCK;
    use std::arch::x86_64::{
        __m128i, _mm_cmpeq_epi8, _mm_movemask_epi8, _mm_or_si128, _mm_set1_epi8, _mm_set_epi64x,
        _mm_setzero_si128,
    };

    #[target_feature(enable = "sse2")]
    pub(super) fn any_of<const K: usize>(block: &[u8; BLOCK], needles: [u8; K]) -> u64 {
        let mut found = 0u64;
        for (k, part) in block.chunks_exact(16).enumerate() {
            let v = sixteen(part);
            let mut equal = _mm_setzero_si128();
            for &needle in &needles {
                equal = _mm_or_si128(equal, _mm_cmpeq_epi8(v, _mm_set1_epi8(needle as i8)));
            }
            found |= bits(equal) << (16 * k);
        }
        found
    }

    #[target_feature(enable = "sse2")]
    pub(super) fn each_of<const K: usize>(
        block: &[u8; BLOCK],
        needles: [u8; K],
    ) -> ([u64; K], u64) {
        let mut found = [0u64; K];
        let mut high = 0u64;
        for (k, part) in block.chunks_exact(16).enumerate() {
            let v = sixteen(part);
            for (f, &needle) in found.iter_mut().zip(&needles) {
                *f |= bits(_mm_cmpeq_epi8(v, _mm_set1_epi8(needle as i8))) << (16 * k);
            }
            high |= bits(v) << (16 * k);
        }
        (found, high)
    }

    /// The high bit of each of the sixteen bytes.
    #[target_feature(enable = "sse2")]
    fn bits(v: __m128i) -> u64 {
        u64::from(_mm_movemask_epi8(v) as u16)
    }

    /// Sixteen bytes as a vector, the first in the lowest lane (no pointer, so no `unsafe`:
    /// the compiler makes it one load).
    #[target_feature(enable = "sse2")]
    fn sixteen(part: &[u8]) -> __m128i {
        let half = |at: usize| {
            let bytes: [u8; 8] = part[at..at + 8].try_into().unwrap_or_default();
            i64::from_le_bytes(bytes)
        };
        _mm_set_epi64x(half(8), half(0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Blocks of the bytes a CSV holds, and any others.
    fn blocks() -> impl Strategy<Value = [u8; BLOCK]> {
        let byte = prop_oneof![
            prop::sample::select(b",\n\r\"0123456789.-e ".to_vec()),
            any::<u8>(),
        ];
        prop::collection::vec(byte, BLOCK).prop_map(|v| v.try_into().unwrap())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn masks_mark_exactly_the_bytes_asked_for(block in blocks()) {
            let (found, high) = each_of(&block, [b',', b'\n', b'"']);
            let any = any_of(&block, [b',', b'\n', b'\r']);
            for (i, &b) in block.iter().enumerate() {
                let bit = |mask: u64| mask >> i & 1 == 1;
                prop_assert_eq!(bit(found[0]), b == b',');
                prop_assert_eq!(bit(found[1]), b == b'\n');
                prop_assert_eq!(bit(found[2]), b == b'"');
                prop_assert_eq!(bit(high), b >= 0x80);
                prop_assert_eq!(bit(any), matches!(b, b',' | b'\n' | b'\r'));
            }
            prop_assert_eq!((found, high), portable::each_of(&block, [b',', b'\n', b'"']));
        }
    }

    #[test]
    fn a_block_past_the_end_is_padded_with_zeros() {
        let block = block_at(b"abc", 1);
        assert_eq!(&block[..3], b"bc\0");
        assert!(block_at(b"abc", 7).iter().all(|&b| b == 0));
        let text: Vec<u8> = (0..=200).collect();
        assert_eq!(with_block(&text, 100, |b| b[63]), 163);
        assert_eq!(with_block(&text, 150, |b| (b[50], b[51])), (200, 0));
    }
}
