//! The pair pass's overlap test across periodic faces in its AVX2 copy,
//! four listed pairs at once. The scalar test rounds each of a pair's
//! three separations to its nearest image (`f64::round`, a short sequence
//! each); here one exact emulation serves three axes and four pairs. A
//! [`Sphere`] row is four `f64` (x, y, z, r), so each pair's separation
//! and radius sum take one 256-bit subtraction and addition, and a 4×4
//! transpose (moves only) lines the four pairs' squared terms up for the
//! sums. The operations are the scalar test's, in its order, so the
//! decisions are the same. Without periodic axes the scalar test is as
//! fast and is kept.
//! Every function here must run only where the CPU has AVX2 (the pair
//! pass's AVX2 copy, entered through `Simd::Avx2`).

use std::arch::x86_64::*;

use super::particles::Sphere;
use super::periodic::Images;

/// One row of four (unaligned load: the rows are aligned, but the
/// instruction costs the same).
#[target_feature(enable = "avx2")]
#[inline]
fn load(row: &[f64; 4]) -> __m256d {
    // SAFETY: `row` is 32 readable bytes.
    unsafe { _mm256_loadu_pd(row.as_ptr()) }
}

/// Four rows of four transposed: output c holds `rows[l][c]` in lane l.
#[target_feature(enable = "avx2")]
#[inline]
fn transpose([a, b, c, d]: [__m256d; 4]) -> [__m256d; 4] {
    // [a0 b0 a2 b2], [a1 b1 a3 b3], and the same of c, d.
    let (ab0, ab1) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
    let (cd0, cd1) = (_mm256_unpacklo_pd(c, d), _mm256_unpackhi_pd(c, d));
    [
        _mm256_permute2f128_pd::<0x20>(ab0, cd0),
        _mm256_permute2f128_pd::<0x20>(ab1, cd1),
        _mm256_permute2f128_pd::<0x31>(ab0, cd0),
        _mm256_permute2f128_pd::<0x31>(ab1, cd1),
    ]
}

/// `f64::round` lane by lane (half away from zero), bit for bit: the
/// fraction `x − trunc(x)` is exact, and a whole step away from zero is
/// added where it is at least one half; a blend, not an add of zero, so
/// that −0 stays −0.
#[target_feature(enable = "avx2")]
#[inline]
fn round(x: __m256d) -> __m256d {
    let sign = _mm256_set1_pd(-0.0);
    let t = _mm256_round_pd::<{ _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC }>(x);
    let fraction = _mm256_andnot_pd(sign, _mm256_sub_pd(x, t));
    let up = _mm256_cmp_pd::<_CMP_GE_OQ>(fraction, _mm256_set1_pd(0.5));
    let step = _mm256_or_pd(_mm256_and_pd(x, sign), _mm256_set1_pd(1.0));
    _mm256_blendv_pd(t, _mm256_add_pd(t, step), up)
}

/// [`Images::shift`] of separations `d` (m), all axes in one vector
/// (lane 3 is left to the caller).
#[target_feature(enable = "avx2")]
#[inline]
fn shift_row(d: __m256d, images: &Images) -> __m256d {
    let (length, inverse) = images.rows();
    // −L by flipping the sign bit, as `f64`'s negation.
    let minus_length = _mm256_xor_pd(load(&length), _mm256_set1_pd(-0.0));
    _mm256_mul_pd(minus_length, round(_mm256_mul_pd(d, load(&inverse))))
}

/// Bit l set where spheres `i[l]` and `j[l]` of `p` overlap, j at its
/// nearest image: [`Sphere::overlaps_nearest`] of four pairs, the same
/// operations in the same order, so the same decisions.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn overlap_mask_nearest(
    p: &[Sphere],
    i: [usize; 4],
    j: [usize; 4],
    images: &Images,
) -> usize {
    let squares = std::array::from_fn(|l| {
        let (a, b) = (load(&p[i[l]].0), load(&p[j[l]].0));
        let d = _mm256_sub_pd(a, b);
        let d = _mm256_add_pd(d, shift_row(d, images));
        // [dx, dy, dz, r_i + r_j], squared.
        let v = _mm256_blend_pd::<0b1000>(d, _mm256_add_pd(a, b));
        _mm256_mul_pd(v, v)
    });
    let [x, y, z, sum] = transpose(squares);
    let d2 = _mm256_add_pd(_mm256_add_pd(x, y), z);
    _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(d2, sum)) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_is_f64_round_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let below_half = 0.5f64.next_down();
        let xs = [
            0.0,
            -0.0,
            0.3,
            -0.3,
            0.5,
            -0.5,
            below_half,
            -below_half,
            1.5,
            -2.5,
            2.5000000000000004,
            4503599627370495.5,
            -4503599627370497.0,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
        ];
        for x in xs {
            let mut out = [0.0; 4];
            // SAFETY: AVX2 was detected above; `out` is 32 writable bytes.
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), round(_mm256_set1_pd(x))) };
            assert_eq!(out[0].to_bits(), x.round().to_bits(), "round({x:e})");
        }
        let mut out = [0.0; 4];
        // SAFETY: as above.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), round(_mm256_set1_pd(f64::NAN))) };
        assert!(out[0].is_nan());
    }
}
