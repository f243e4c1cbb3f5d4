//! Size limits: every buffer whose size comes from a caller's numbers (`n_states`, `n_mix`,
//! `n_samples` of [`crate::hmm::Hmm::sample`], sequence length x components) is checked against
//! [`MAX_ELEMENTS`] with overflow-checked arithmetic before anything is allocated, so an absurd
//! size is an [`EngineError::InvalidParameter`] instead of an allocation failure (which aborts
//! the process) or an arithmetic overflow (which panics).

use crate::error::{EngineError, Result};

/// The largest number of values (8 bytes each) of any one buffer the HMM engine allocates:
/// 2^28 = 268,435,456 values, 2 GiB.
pub const MAX_ELEMENTS: usize = 1 << 28;

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
}
