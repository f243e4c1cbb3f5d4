//! Runtime CPU-feature dispatch for the vectorised kernels (emission densities and `exp`).
//!
//! The crate is built for baseline x86-64 (SSE2), so it runs on any x86-64 machine. On a CPU
//! with AVX2 and FMA the same kernel code is compiled a second time with those features
//! enabled (four doubles per instruction instead of two, fused multiply-adds in the `exp`
//! polynomial) and chosen at run time. Results of the two versions differ by at most a few
//! units in the last place of each `exp`.
//!
//! This is the engine's only `unsafe` code: calling a `#[target_feature]` function is unsafe
//! because executing AVX2 / FMA instructions on a CPU without them is undefined behaviour.
//! The single call below is made only after `is_x86_feature_detected!` confirmed both
//! features on the running CPU, which is exactly the function's safety contract.
#![allow(unsafe_code)]

/// A computation written once and compiled for each instruction set. `FMA` says whether
/// fused multiply-add instructions are available (use [`madd`]).
pub(crate) trait Kernel {
    type Output;
    /// Must be `#[inline(always)]` (and so must everything it calls that should be
    /// vectorised), so that it is compiled inside the feature-enabled function.
    fn run<const FMA: bool>(self) -> Self::Output;
}

/// Run `kernel` with the best instruction set the running CPU supports.
#[inline]
pub(crate) fn dispatch<K: Kernel>(kernel: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the running CPU supports AVX2 and FMA (checked just above), which is the
            // only requirement of a `#[target_feature(enable = "avx2,fma")]` function.
            return unsafe { run_avx2_fma(kernel) };
        }
    }
    kernel.run::<false>()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2_fma<K: Kernel>(kernel: K) -> K::Output {
    kernel.run::<true>()
}

/// `a * b + c`, fused (one rounding) when `FMA`; a plain multiply and add otherwise (without
/// FMA hardware `mul_add` would call a slow software routine).
#[allow(clippy::inline_always)] // must be compiled inside the AVX2 function (simd)
#[inline(always)]
pub(crate) fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// `v = exp(v)` for every entry of `v` (every entry must be `<= 0`, NaN counts as `-inf`).
pub(crate) fn exp_nonpos_in_place(v: &mut [f64]) {
    struct Exp<'a>(&'a mut [f64]);
    impl Kernel for Exp<'_> {
        type Output = ();
        #[allow(clippy::inline_always)] // must be compiled inside the AVX2 function (simd)
        #[inline(always)]
        fn run<const FMA: bool>(self) {
            for x in self.0.iter_mut() {
                *x = super::fastexp::exp_nonpos_k::<FMA>(*x);
            }
        }
    }
    dispatch(Exp(v));
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn both_instruction_sets_agree() {
        let xs: Vec<f64> = (0..960).map(|i| -0.731 * f64::from(i)).collect();
        let mut fast = xs.clone();
        exp_nonpos_in_place(&mut fast);
        for (x, f) in xs.iter().zip(&fast) {
            let base = super::super::fastexp::exp_nonpos_k::<false>(*x);
            let want = x.exp();
            assert!((f - want).abs() <= 1e-15 * want, "{x}: {f} vs {want}");
            assert!((base - want).abs() <= 1e-15 * want, "{x}: {base} vs {want}");
        }
    }
}
