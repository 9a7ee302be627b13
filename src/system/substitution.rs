//! The dense kernels of the sparse triangular solves ([`super::refactor::StaticPivotLu`]):
//! L's rows and U's columns are runs of consecutive indices, so the forward substitution is
//! dot products and the back substitution `y −= u s` over contiguous slices. ED's 2 × 2
//! blocks ([`Block2`]) also have their refactorization's column update written out.
//!
//! The AVX2 versions for complex numbers are written out: the compiler's own vectorization
//! of a complex product shuffles real and imaginary parts apart and back (six shuffles per
//! two products). So are a block's: one four-wide product per block (−25 % per ED exact
//! solve, −7 % per refactorization on the beam pendulum). Either version performs the same
//! IEEE operations in the same order (a complex product `(a_r b_r − a_i b_i, a_r b_i +
//! a_i b_r)`, no fused multiply-adds, the dot products' partial sums), so their results agree
//! bit for bit.

use super::paired::{Block2, Pair2};
use super::refactor::Scalar;
use faer::c64;

/// `Σ a_i b_i` in four interleaved partial sums: independent additions the processor
/// overlaps (and vector instructions carry), in an order that does not depend on them.
#[inline(always)]
pub(super) fn dot<T: Scalar>(a: &[T], b: &[T::Vector]) -> T::Vector {
    let mut acc = [T::Vector::default(); 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ar, br) = (a4.remainder(), b4.remainder());
    for (x, y) in a4.zip(b4) {
        for j in 0..4 {
            acc[j] += x[j].apply(y[j]);
        }
    }
    for (x, y) in ar.iter().zip(br) {
        acc[0] += x.apply(*y);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// `y_i −= u_i s`.
#[inline(always)]
pub(super) fn sub_scaled<T: Scalar>(y: &mut [T::Vector], u: &[T], s: T::Vector) {
    for (yi, &ui) in y.iter_mut().zip(u) {
        *yi -= ui.apply(s);
    }
}

/// [`dot`] for complex numbers with AVX2: two products per instruction.
///
/// # Safety
/// The processor has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn dot_c64_avx2(a: &[c64], b: &[c64]) -> c64 {
    use std::arch::x86_64::*;
    let n = a.len().min(b.len());
    let (ap, bp) = (a.as_ptr().cast::<f64>(), b.as_ptr().cast::<f64>());
    // Partial sums 0 and 1 in `lo`, 2 and 3 in `hi`, as in `dot`.
    let (mut lo, mut hi) = (_mm256_setzero_pd(), _mm256_setzero_pd());
    let mut j = 0;
    while j + 4 <= n {
        // SAFETY: entries j..j + 4 of both slices, two f64 each (c64 is `repr(C)`).
        unsafe {
            lo = _mm256_add_pd(lo, mul_c64x2(ap.add(2 * j), bp.add(2 * j)));
            hi = _mm256_add_pd(hi, mul_c64x2(ap.add(2 * j + 4), bp.add(2 * j + 4)));
        }
        j += 4;
    }
    let mut acc = [c64::new(0.0, 0.0); 4];
    // SAFETY: four c64 are eight f64.
    unsafe {
        _mm256_storeu_pd(acc.as_mut_ptr().cast::<f64>(), lo);
        _mm256_storeu_pd(acc.as_mut_ptr().cast::<f64>().add(4), hi);
    }
    for (x, y) in a[j..n].iter().zip(&b[j..n]) {
        acc[0] += *x * *y;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// [`sub_scaled`] for complex numbers with AVX2: two entries per instruction.
///
/// # Safety
/// The processor has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn sub_scaled_c64_avx2(y: &mut [c64], u: &[c64], s: c64) {
    use std::arch::x86_64::*;
    let n = y.len().min(u.len());
    let (yp, up) = (y.as_mut_ptr().cast::<f64>(), u.as_ptr().cast::<f64>());
    let (s_re, s_im) = (_mm256_set1_pd(s.re), _mm256_set1_pd(s.im));
    let mut j = 0;
    while j + 2 <= n {
        // SAFETY: entries j, j + 1 of both slices (four f64).
        unsafe {
            let uv = _mm256_loadu_pd(up.add(2 * j));
            let p = times(uv, s_re, s_im);
            _mm256_storeu_pd(
                yp.add(2 * j),
                _mm256_sub_pd(_mm256_loadu_pd(yp.add(2 * j)), p),
            );
        }
        j += 2;
    }
    if j < n {
        y[j] -= u[j] * s;
    }
}

/// Two complex products `a b` from `a` and `b` at the pointers (four f64 each).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn mul_c64x2(a: *const f64, b: *const f64) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    // SAFETY: the caller's pointers hold four f64 each.
    let (av, bv) = unsafe { (_mm256_loadu_pd(a), _mm256_loadu_pd(b)) };
    // (b_r, b_r) and (b_i, b_i) per entry.
    times(av, _mm256_movedup_pd(bv), _mm256_permute_pd(bv, 0b1111))
}

/// `a b` per complex entry of `a`, with `b`'s real and imaginary parts spread over both
/// halves of each entry: `(a_r b_r − a_i b_i, a_i b_r + a_r b_i)`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn times(
    a: std::arch::x86_64::__m256d,
    b_re: std::arch::x86_64::__m256d,
    b_im: std::arch::x86_64::__m256d,
) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let swapped = _mm256_permute_pd(a, 0b0101);
    _mm256_addsub_pd(_mm256_mul_pd(a, b_re), _mm256_mul_pd(swapped, b_im))
}

/// [`dot`] for 2 × 2 blocks, in the order [`dot_block2_avx2`] takes: each of the four
/// products `a x, b y, c x, d y` summed on its own over the even and the odd entries, the
/// two sums added, then `(a x + b y, c x + d y)` formed once.
#[inline(always)]
pub(super) fn dot_block2(a: &[Block2], b: &[Pair2]) -> Pair2 {
    let mut acc = [[0.0f64; 4]; 2];
    for (j, (x, v)) in a.iter().zip(b).enumerate() {
        let [p, q] = v.0;
        let products = [x.0[0] * p, x.0[1] * q, x.0[2] * p, x.0[3] * q];
        for (s, t) in acc[j % 2].iter_mut().zip(products) {
            *s += t;
        }
    }
    let s: [f64; 4] = std::array::from_fn(|k| acc[0][k] + acc[1][k]);
    Pair2([s[0] + s[1], s[2] + s[3]])
}

/// [`dot_block2`] with AVX2: one block's four products per instruction, its pair of reals
/// broadcast to both halves.
///
/// # Safety
/// The processor has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn dot_block2_avx2(a: &[Block2], b: &[Pair2]) -> Pair2 {
    use std::arch::x86_64::*;
    let n = a.len().min(b.len());
    let (ap, bp) = (a.as_ptr().cast::<f64>(), b.as_ptr().cast::<f64>());
    // SAFETY (all loads): entry j of `a` is four f64 at 4j, of `b` two at 2j, for j < n.
    let term = |j: usize| unsafe {
        let v = _mm_loadu_pd(bp.add(2 * j));
        _mm256_mul_pd(_mm256_loadu_pd(ap.add(4 * j)), _mm256_set_m128d(v, v))
    };
    let (mut even, mut odd) = (_mm256_setzero_pd(), _mm256_setzero_pd());
    let mut j = 0;
    while j + 2 <= n {
        even = _mm256_add_pd(even, term(j));
        odd = _mm256_add_pd(odd, term(j + 1));
        j += 2;
    }
    if j < n {
        even = _mm256_add_pd(even, term(j));
    }
    let mut s = [0.0f64; 4];
    // SAFETY: four f64.
    unsafe { _mm256_storeu_pd(s.as_mut_ptr(), _mm256_add_pd(even, odd)) };
    Pair2([s[0] + s[1], s[2] + s[3]])
}

/// [`sub_scaled`] for 2 × 2 blocks with AVX2: two blocks' products per pair of
/// instructions, their halves summed by one horizontal addition.
///
/// # Safety
/// The processor has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn sub_scaled_block2_avx2(y: &mut [Pair2], u: &[Block2], s: Pair2) {
    use std::arch::x86_64::*;
    let n = y.len().min(u.len());
    let (yp, up) = (y.as_mut_ptr().cast::<f64>(), u.as_ptr().cast::<f64>());
    let [s0, s1] = s.0;
    let sv = _mm256_set_pd(s1, s0, s1, s0);
    let mut j = 0;
    while j + 2 <= n {
        // SAFETY: entries j, j + 1: eight f64 of `u`, four of `y`.
        unsafe {
            let first = _mm256_mul_pd(_mm256_loadu_pd(up.add(4 * j)), sv);
            let second = _mm256_mul_pd(_mm256_loadu_pd(up.add(4 * j + 4)), sv);
            // (a s0 + b s1 of j, of j + 1, c s0 + d s1 of j, of j + 1), then in pair order.
            let sums = _mm256_permute4x64_pd(_mm256_hadd_pd(first, second), 0b11_01_10_00);
            let at = yp.add(2 * j);
            _mm256_storeu_pd(at, _mm256_sub_pd(_mm256_loadu_pd(at), sums));
        }
        j += 2;
    }
    if j < n {
        y[j] -= u[j].apply(s);
    }
}

/// [`Scalar::sub_products`] for 2 × 2 blocks with AVX2: `l u` as `(a, a, c, c)(e, f, e, f)
/// + (b, b, d, d)(g, h, g, h)`, the products of `Block2`'s `Mul` in its order.
///
/// # Safety
/// The processor has AVX2, and every row is below `x.len()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn sub_products_block2_avx2(
    x: &mut [Block2],
    rows: &[usize],
    l: &[Block2],
    u: Block2,
) {
    use std::arch::x86_64::*;
    // SAFETY: a block is four f64.
    let uv = unsafe { _mm256_loadu_pd(u.0.as_ptr()) };
    let (u_top, u_bottom) = (
        _mm256_permute2f128_pd(uv, uv, 0x00),
        _mm256_permute2f128_pd(uv, uv, 0x11),
    );
    for (&i, li) in rows.iter().zip(l) {
        // SAFETY: four f64 per block; `i < x.len()` (the caller's).
        unsafe {
            let lv = _mm256_loadu_pd(li.0.as_ptr());
            let product = _mm256_add_pd(
                _mm256_mul_pd(_mm256_permute_pd(lv, 0b0000), u_top),
                _mm256_mul_pd(_mm256_permute_pd(lv, 0b1111), u_bottom),
            );
            let at = x.as_mut_ptr().add(i).cast::<f64>();
            _mm256_storeu_pd(at, _mm256_sub_pd(_mm256_loadu_pd(at), product));
        }
    }
}
