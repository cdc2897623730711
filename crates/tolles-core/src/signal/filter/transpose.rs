//! Transposes of 8×8 blocks of samples between signals and the lane kernels' tiles.
//!
//! The lane kernels ([`super::lanes`]) read eight consecutive samples of each of eight signals
//! and need them as eight samples of eight lanes, and back. Written as plain array indexing,
//! the compiler turns that into AVX-512 gather instructions and single-value loads and stores,
//! which took more of a band-pass than its recursion (`perf` of 16 signals: 56 % of the
//! kernel against 44 %). With AVX-512 the block is transposed in registers instead, by 24
//! shuffles. A transpose only moves values, so every way gives the same bits.

/// A way of transposing an 8×8 block of `f64`.
pub(super) trait Transpose: Copy {
    /// `out[i][l] = block[l][i]`.
    fn transpose8(self, block: &[[f64; 8]; 8]) -> [[f64; 8]; 8];
}

/// Array indexing, for any processor.
#[derive(Debug, Clone, Copy)]
pub(super) struct Plain;

impl Transpose for Plain {
    #[inline(always)]
    fn transpose8(self, block: &[[f64; 8]; 8]) -> [[f64; 8]; 8] {
        std::array::from_fn(|i| std::array::from_fn(|l| block[l][i]))
    }
}

/// AVX-512 shuffles. A value of it exists only where the processor has AVX-512F.
#[cfg(target_arch = "x86_64")]
#[derive(Debug, Clone, Copy)]
pub(super) struct Avx512(());

#[cfg(target_arch = "x86_64")]
impl Avx512 {
    /// The shuffles, if the running processor has AVX-512F.
    #[cfg(test)]
    pub(super) fn detected() -> Option<Self> {
        std::arch::is_x86_feature_detected!("avx512f").then_some(Self(()))
    }

    /// The shuffles, without asking the processor.
    ///
    /// # Safety
    /// The running processor has AVX-512F: the caller is code compiled for AVX-512 and chosen
    /// at run time because the processor has it.
    pub(super) const unsafe fn assumed() -> Self {
        Self(())
    }
}

#[cfg(target_arch = "x86_64")]
impl Transpose for Avx512 {
    #[inline(always)]
    fn transpose8(self, block: &[[f64; 8]; 8]) -> [[f64; 8]; 8] {
        // SAFETY: a value of `Avx512` exists only on a processor with AVX-512F (`assumed`).
        unsafe { transpose8_avx512(block) }
    }
}

/// [`Transpose::transpose8`] in three rounds of shuffles: pairs of rows interleaved by
/// element, then pairs of those by 128-bit lane, then by 256-bit half.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn transpose8_avx512(block: &[[f64; 8]; 8]) -> [[f64; 8]; 8] {
    use std::arch::x86_64::{
        __m512d, _mm512_loadu_pd, _mm512_permutex2var_pd, _mm512_set_epi64, _mm512_shuffle_f64x2,
        _mm512_storeu_pd, _mm512_unpackhi_pd, _mm512_unpacklo_pd,
    };
    // SAFETY: each pointer is to eight `f64` of `block`; unaligned loads.
    let r: [__m512d; 8] = std::array::from_fn(|l| unsafe { _mm512_loadu_pd(block[l].as_ptr()) });
    // t[2p] = [r(2p)[0], r(2p+1)[0], r(2p)[2], r(2p+1)[2], ...], t[2p+1] the odd elements.
    let t: [__m512d; 8] = std::array::from_fn(|k| {
        let (a, b) = (r[k & !1], r[k | 1]);
        match k % 2 {
            0 => _mm512_unpacklo_pd(a, b),
            _ => _mm512_unpackhi_pd(a, b),
        }
    });
    // Indices of `_mm512_permutex2var_pd`, 8 and up taking the second operand; `set` lists the
    // last element first.
    let even_pairs = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);
    let odd_pairs = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
    // u[4q + 0] = element 0 and 4 of rows 4q..4q+4, u[4q + 1] elements 2 and 6, u[4q + 2] 1
    // and 5, u[4q + 3] 3 and 7.
    let u: [__m512d; 8] = std::array::from_fn(|k| {
        let (quad, which) = (k / 4, k % 4);
        let (a, b) = (t[4 * quad + which / 2], t[4 * quad + 2 + which / 2]);
        match which % 2 {
            0 => _mm512_permutex2var_pd(a, even_pairs, b),
            _ => _mm512_permutex2var_pd(a, odd_pairs, b),
        }
    });
    // Element i of the eight rows: the low halves (i < 4) or high halves of u[j] and u[4 + j].
    let source = [0, 2, 1, 3, 0, 2, 1, 3];
    let mut out = [[0.0; 8]; 8];
    for (i, o) in out.iter_mut().enumerate() {
        let (a, b) = (u[source[i]], u[4 + source[i]]);
        let v = match i < 4 {
            true => _mm512_shuffle_f64x2::<0x44>(a, b),
            false => _mm512_shuffle_f64x2::<0xEE>(a, b),
        };
        // SAFETY: `o` holds eight `f64`; unaligned store.
        unsafe { _mm512_storeu_pd(o.as_mut_ptr(), v) };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(seed: f64) -> [[f64; 8]; 8] {
        std::array::from_fn(|l| std::array::from_fn(|i| seed + (8 * l + i) as f64 * 1.25))
    }

    #[test]
    fn plain_transposes() {
        let b = block(0.5);
        let t = Plain.transpose8(&b);
        for (l, row) in b.iter().enumerate() {
            for (i, v) in row.iter().enumerate() {
                assert_eq!(t[i][l], *v);
            }
        }
        assert_eq!(Plain.transpose8(&t), b);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx512_equals_plain() {
        let Some(avx512) = Avx512::detected() else {
            eprintln!("no AVX-512 here: the shuffles are not tested");
            return;
        };
        for seed in [0.0, -3.5, 1e300] {
            let mut b = block(seed);
            b[3][5] = f64::NAN;
            b[7][0] = -0.0;
            let (fast, plain) = (avx512.transpose8(&b), Plain.transpose8(&b));
            let bits = |m: [[f64; 8]; 8]| m.map(|r| r.map(f64::to_bits));
            assert_eq!(bits(fast), bits(plain));
        }
    }
}
