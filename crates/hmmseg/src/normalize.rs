//! Per-column min-max normalisation to `[0, 1]` (paper Sec. III-B.2: templates and data are
//! normalised to `[0, 1]` for invariance to spatial variations such as hand size).
//!
//! Rows are samples, columns are features. A constant column (`max == min`) has no scale: it is
//! mapped to `0.5`, the middle of the interval, rather than dividing by zero.

use nalgebra::DMatrix;

use crate::error::{EngineError, Result};

/// Column-wise minimum and maximum of `x` (`n x d`), checked non-empty and finite.
pub fn column_range(x: &DMatrix<f64>) -> Result<(Vec<f64>, Vec<f64>)> {
    check(x)?;
    let lo = x.column_iter().map(|c| c.min()).collect();
    let hi = x.column_iter().map(|c| c.max()).collect();
    Ok((lo, hi))
}

fn check(x: &DMatrix<f64>) -> Result<()> {
    if x.nrows() == 0 || x.ncols() == 0 {
        return Err(EngineError::EmptySequence(format!(
            "cannot normalise a {} x {} matrix",
            x.nrows(),
            x.ncols()
        )));
    }
    for (j, c) in x.column_iter().enumerate() {
        if let Some(i) = c.iter().position(|v| !v.is_finite()) {
            return Err(EngineError::NonFinite(format!("x[{i}, {j}] = {}", c[i])));
        }
    }
    Ok(())
}

/// Map every column of `x` (`n x d`) linearly onto `[0, 1]` using its own min and max.
///
/// A constant column becomes `0.5` everywhere.
///
/// # Errors
/// [`EngineError::EmptySequence`] for an empty matrix, [`EngineError::NonFinite`] for NaN/inf.
pub fn minmax(x: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let (lo, hi) = column_range(x)?;
    minmax_with(x, &lo, &hi)
}

/// Map column `j` of `x` (`n x d`) linearly so that `lo[j] -> 0` and `hi[j] -> 1`.
///
/// Use it to normalise new data with a template's fixed range: values outside `[lo, hi]` map
/// outside `[0, 1]` (no clipping). A column with `hi[j] == lo[j]` becomes `0.5` everywhere.
///
/// # Errors
/// Besides those of [`minmax`]: [`EngineError::ShapeMismatch`] if `lo`/`hi` do not have `d`
/// entries, [`EngineError::InvalidParameter`] if `hi[j] < lo[j]` or a bound is not finite.
pub fn minmax_with(x: &DMatrix<f64>, lo: &[f64], hi: &[f64]) -> Result<DMatrix<f64>> {
    check(x)?;
    let d = x.ncols();
    if lo.len() != d || hi.len() != d {
        return Err(EngineError::ShapeMismatch(format!(
            "x has {d} columns but lo has {} and hi has {} entries",
            lo.len(),
            hi.len()
        )));
    }
    for (j, (&l, &h)) in lo.iter().zip(hi).enumerate() {
        if !l.is_finite() || !h.is_finite() || h < l {
            return Err(EngineError::InvalidParameter(format!(
                "column {j}: need finite lo <= hi, got lo = {l}, hi = {h}"
            )));
        }
    }
    let mut out = x.clone();
    for (j, mut c) in out.column_iter_mut().enumerate() {
        let span = hi[j] - lo[j];
        if span > 0.0 {
            c.apply(|v| *v = (*v - lo[j]) / span);
        } else {
            c.fill(0.5);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_scaled_independently() {
        let x = DMatrix::from_row_slice(3, 3, &[0.0, 10.0, 7.0, 1.0, 20.0, 7.0, 2.0, 30.0, 7.0]);
        let y = minmax(&x).unwrap();
        let want = DMatrix::from_row_slice(3, 3, &[0.0, 0.0, 0.5, 0.5, 0.5, 0.5, 1.0, 1.0, 0.5]);
        assert!((y - want).abs().max() < 1e-12);
    }

    #[test]
    fn fixed_range_does_not_clip() {
        let x = DMatrix::from_row_slice(2, 1, &[-1.0, 3.0]);
        let y = minmax_with(&x, &[0.0], &[2.0]).unwrap();
        assert_eq!(y.as_slice(), &[-0.5, 1.5]);
    }

    #[test]
    fn errors() {
        let x = DMatrix::from_row_slice(2, 1, &[0.0, f64::NAN]);
        assert!(matches!(minmax(&x), Err(EngineError::NonFinite(m)) if m.contains("x[1, 0]")));
        assert!(matches!(
            minmax(&DMatrix::zeros(0, 2)),
            Err(EngineError::EmptySequence(_))
        ));
        let x = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        assert!(matches!(
            minmax_with(&x, &[1.0], &[0.0]),
            Err(EngineError::InvalidParameter(_))
        ));
        assert!(matches!(
            minmax_with(&x, &[0.0, 0.0], &[1.0]),
            Err(EngineError::ShapeMismatch(_))
        ));
    }
}
