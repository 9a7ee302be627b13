//! Kernels compiled for the processor's wider vectors.
//!
//! The crate is built for the x86-64 baseline (two-wide SSE2), so that one wheel runs
//! everywhere; the element kernels' 3×3 block algebra then runs two lanes at a time. [`wide`]
//! runs a closure compiled for AVX2 (four lanes) where the processor has it: the closure and
//! everything inlined into it (mark the closure and its hot callees `#[inline(always)]`).
//! Fused multiply-add is not enabled and Rust does not reassociate floating-point operations,
//! so the results are the baseline build's to the bit.

/// Runs `f`, compiled for AVX2 where the processor has it (detection is cached by the
/// standard library).
#[inline(always)]
pub fn wide<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2.
        return unsafe { avx2(f) };
    }
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same arithmetic gives the same bits inside and outside `wide` (no contraction to
    /// fused multiply-adds, no reassociation): a dot product of awkward numbers.
    #[test]
    fn wide_code_rounds_like_the_baseline() {
        let x: Vec<f64> = (0..37)
            .map(|k| (k as f64 * 0.731).sin() * 1e3 + 0.1)
            .collect();
        let dot = |x: &[f64]| {
            let mut acc = [0.0f64; 4];
            for (k, v) in x.iter().enumerate() {
                acc[k % 4] += v * (1.0 / 3.0) * v + 1e-7;
            }
            acc
        };
        assert_eq!(wide(|| dot(&x)), dot(&x));
    }
}
