//! Checks at the boundary: observation matrices and probability vectors / matrices.

use nalgebra::DMatrix;

use crate::error::{EngineError, Result};

/// Tolerance on `|sum - 1|` for a probability vector.
pub(crate) const STOCHASTIC_TOL: f64 = 1e-6;

/// Check one observation sequence: non-empty, `n_features` columns, all finite.
pub(crate) fn check_sequence(x: &DMatrix<f64>, n_features: usize, what: &str) -> Result<()> {
    if x.nrows() == 0 {
        return Err(EngineError::EmptySequence(format!("{what} has no samples")));
    }
    if x.ncols() != n_features {
        return Err(EngineError::ShapeMismatch(format!(
            "{what} has {} features per sample, the model has {n_features}",
            x.ncols()
        )));
    }
    if x.as_slice().iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    if let Some(pos) = x.as_slice().iter().position(|v| !v.is_finite()) {
        let (row, col) = (pos % x.nrows(), pos / x.nrows());
        return Err(EngineError::NonFinite(format!(
            "{what} has {} at sample {row}, feature {col}",
            x[(row, col)]
        )));
    }
    Ok(())
}

/// Check a set of training sequences; returns the common number of features.
pub(crate) fn check_sequences(seqs: &[DMatrix<f64>], n_features: Option<usize>) -> Result<usize> {
    let Some(first) = seqs.first() else {
        return Err(EngineError::EmptySequence(
            "no training sequences given".into(),
        ));
    };
    let f = n_features.unwrap_or(first.ncols());
    if f == 0 {
        return Err(EngineError::ShapeMismatch(
            "sequences have 0 features".into(),
        ));
    }
    for (i, x) in seqs.iter().enumerate() {
        check_sequence(x, f, &format!("sequence {i}"))?;
    }
    Ok(f)
}

/// Check that `p` is a probability vector (finite, >= 0, sums to 1).
pub(crate) fn check_stochastic(p: impl Iterator<Item = f64>, what: &str) -> Result<()> {
    let mut sum = 0.0;
    for v in p {
        if !v.is_finite() {
            return Err(EngineError::NonFinite(format!("{what} contains {v}")));
        }
        if v < 0.0 {
            return Err(EngineError::NotStochastic(format!(
                "{what} has a negative entry {v}"
            )));
        }
        sum += v;
    }
    if (sum - 1.0).abs() > STOCHASTIC_TOL {
        return Err(EngineError::NotStochastic(format!(
            "{what} sums to {sum}, not 1"
        )));
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]
mod tests {
    use super::*;

    #[test]
    fn sequence_errors() {
        let empty = DMatrix::<f64>::zeros(0, 2);
        assert!(matches!(
            check_sequence(&empty, 2, "x"),
            Err(EngineError::EmptySequence(_))
        ));
        let x = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 2.0, 3.0]);
        assert!(matches!(
            check_sequence(&x, 3, "x"),
            Err(EngineError::ShapeMismatch(_))
        ));
        let nan = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, f64::NAN, 3.0]);
        let err = check_sequence(&nan, 2, "x").unwrap_err();
        assert!(matches!(&err, EngineError::NonFinite(m) if m.contains("sample 1, feature 0")));
        assert!(check_sequence(&x, 2, "x").is_ok());
        assert!(matches!(
            check_sequences(&[], None),
            Err(EngineError::EmptySequence(_))
        ));
        let y = DMatrix::from_row_slice(1, 1, &[0.0]);
        assert!(matches!(
            check_sequences(&[x, y], None),
            Err(EngineError::ShapeMismatch(_))
        ));
    }

    #[test]
    fn stochastic_errors() {
        assert!(check_stochastic([0.5, 0.5].into_iter(), "p").is_ok());
        assert!(matches!(
            check_stochastic([0.5, 0.6].into_iter(), "p"),
            Err(EngineError::NotStochastic(_))
        ));
        assert!(matches!(
            check_stochastic([1.5, -0.5].into_iter(), "p"),
            Err(EngineError::NotStochastic(_))
        ));
        assert!(matches!(
            check_stochastic([f64::NAN, 1.0].into_iter(), "p"),
            Err(EngineError::NonFinite(_))
        ));
    }
}
