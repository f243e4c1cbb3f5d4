//! The engine's limits on what a caller's numbers may ask for, in one place.
//!
//! Sizes: every buffer whose size comes from a caller's numbers (`n_states`, `n_mix`,
//! `n_samples` of [`crate::hmm::Hmm::sample`], sequence length x components) is checked against
//! [`MAX_ELEMENTS`] with overflow-checked arithmetic before anything is allocated, so an absurd
//! size is an [`EngineError::InvalidParameter`] instead of an allocation failure (which aborts
//! the process) or an arithmetic overflow (which panics).
//!
//! Work: a loop whose length is a caller's number, not the size of an input, is bounded too, so
//! no argument can make a call run for hours: EM iterations ([`MAX_ITER`], `max_iter` of
//! [`crate::hmm::FitConfig`]) and filter coefficients ([`MAX_COEFFICIENTS`]; `lfilter_zi`
//! solves a dense system of that order, cubic in it).

use crate::error::{EngineError, Result};

/// The largest number of values (8 bytes each) of any one buffer the HMM engine allocates:
/// 2^28 = 268,435,456 values, 2 GiB.
pub const MAX_ELEMENTS: usize = 1 << 28;

/// The most EM iterations one training call may run (`max_iter`): 100 by default, hmmlearn's
/// default is 10; each iteration is a full pass over the data.
pub const MAX_ITER: usize = 10_000;

/// The most coefficients a filter (`b` or `a`) may have: a Butterworth low-pass of the highest
/// order [`crate::signal::butter_lowpass`] designs (20) has 21; `lfilter_zi` is cubic in it.
pub const MAX_COEFFICIENTS: usize = 1024;

/// `value` if it is at most `max`, else an `InvalidParameter` error naming `what`.
pub(crate) fn at_most(value: usize, max: usize, what: &str) -> Result<usize> {
    if value <= max {
        Ok(value)
    } else {
        Err(EngineError::InvalidParameter(format!(
            "{what} must be at most {max}, got {value}"
        )))
    }
}

/// The product of `dims`, or an `InvalidParameter` error naming `what` if it overflows or
/// exceeds [`MAX_ELEMENTS`].
pub(crate) fn checked_elements(dims: &[usize], what: &str) -> Result<usize> {
    let product = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
    match product {
        Some(p) if p <= MAX_ELEMENTS => Ok(p),
        _ => {
            let shown: Vec<String> = dims.iter().map(ToString::to_string).collect();
            Err(EngineError::InvalidParameter(format!(
                "{what} would need {} values, more than the engine's limit of {MAX_ELEMENTS} (2 GiB)",
                shown.join(" x ")
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_are_checked() {
        assert_eq!(checked_elements(&[3, 4, 5], "x").unwrap(), 60);
        assert_eq!(checked_elements(&[], "x").unwrap(), 1);
        assert_eq!(
            checked_elements(&[MAX_ELEMENTS], "x").unwrap(),
            MAX_ELEMENTS
        );
        let err = checked_elements(&[MAX_ELEMENTS, 2], "the table").unwrap_err();
        assert!(
            matches!(&err, EngineError::InvalidParameter(m) if m.contains("the table") && m.contains("268435456 x 2")),
            "{err}"
        );
        // Overflowing products are errors, not panics or wrapped values.
        assert!(matches!(
            checked_elements(&[1 << 40, 1 << 40], "x"),
            Err(EngineError::InvalidParameter(_))
        ));
        assert!(matches!(checked_elements(&[usize::MAX, 0, 2], "x"), Ok(0)));
    }

    #[test]
    fn counts_are_bounded() {
        assert_eq!(at_most(MAX_ITER, MAX_ITER, "max_iter").unwrap(), MAX_ITER);
        let err = at_most(1 << 40, MAX_ITER, "max_iter").unwrap_err();
        assert!(
            matches!(&err, EngineError::InvalidParameter(m) if m.contains("max_iter") && m.contains("10000")),
            "{err}"
        );
    }
}
