//! A branch-free `exp` for non-positive arguments, written so the compiler vectorises loops
//! over it (the scaled forward pass takes one `exp` per state and time step, and the C
//! library's scalar `exp` dominated its cost).
//!
//! Method: `x = k ln 2 + r` with `|r| <= ln(2) / 2` (Cody-Waite split of ln 2), a degree-13
//! Taylor polynomial for `e^r` (truncation error below 1e-17), and `2^k` built from its bits.
//! Arguments below -708 (results below the smallest normal number) return exactly 0, so
//! underflow is still detected by the caller.

use super::simd::madd;

const LOG2E: f64 = std::f64::consts::LOG2_E;
const LN2_HI: f64 = 6.931_471_803_691_238e-1;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// 1.5 * 2^52: adding it rounds to an integer and leaves that integer in the low bits.
const SHIFT: f64 = 6_755_399_441_055_744.0;
const SHIFT_BITS: i64 = 0x4338_0000_0000_0000;

/// `e^x` for `x <= 0` (`-inf` and NaN give 0); relative error a few ulp.
#[cfg(test)]
pub(crate) fn exp_nonpos(x: f64) -> f64 {
    exp_nonpos_k::<false>(x)
}

/// [`exp_nonpos`], with fused multiply-adds in the polynomial when `FMA` (see `simd`).
#[allow(clippy::inline_always)] // must be compiled inside the AVX2 function (simd)
#[inline(always)]
pub(crate) fn exp_nonpos_k<const FMA: bool>(x: f64) -> f64 {
    let xc = x.max(-708.0);
    let shifted = madd::<FMA>(xc, LOG2E, SHIFT);
    let k = shifted - SHIFT;
    let r = madd::<FMA>(-k, LN2_LO, madd::<FMA>(-k, LN2_HI, xc));
    let mut p = 1.0 / 6_227_020_800.0; // 1/13!
    for c in [
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ] {
        p = madd::<FMA>(p, r, c);
    }
    let ki = shifted.to_bits() as i64 - SHIFT_BITS;
    let scale = f64::from_bits(((ki + 1023) << 52) as u64);
    // Written so that NaN (a comparison that is false) also gives 0.
    if x >= -708.0 {
        p * scale
    } else {
        0.0
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn matches_std_exp() {
        let mut worst: f64 = 0.0;
        let mut x = 0.0;
        while x > -708.0 {
            let (a, b) = (exp_nonpos(x), x.exp());
            worst = worst.max(((a - b) / b).abs());
            x -= 0.012_345_7;
        }
        assert!(worst < 1e-15, "worst relative error {worst}");
        for x in [
            0.0,
            -1e-300,
            -0.346_573_590_279_972_65,
            -0.346_573_590_279_972_7,
            -1.0,
            -707.9,
        ] {
            assert!(((exp_nonpos(x) - x.exp()) / x.exp()).abs() < 1e-15, "{x}");
        }
        assert_eq!(exp_nonpos(0.0), 1.0);
        assert_eq!(exp_nonpos(-708.5), 0.0);
        assert_eq!(exp_nonpos(f64::NEG_INFINITY), 0.0);
        assert_eq!(exp_nonpos(f64::NAN), 0.0);
    }
}
