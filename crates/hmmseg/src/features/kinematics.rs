//! Input checks and the small kinematic helpers the features share: finite differences, speeds,
//! object motion intervals.

use nalgebra::DMatrix;

use crate::error::{EngineError, Result};

/// Error unless every entry of `x` is finite; names the array and the (row, column).
pub(crate) fn check_finite(x: &DMatrix<f64>, name: &str) -> Result<()> {
    for (j, c) in x.column_iter().enumerate() {
        if let Some(i) = c.iter().position(|v| !v.is_finite()) {
            return Err(EngineError::NonFinite(format!(
                "{name}[{i}, {j}] = {} (features need NaN-free input: crop the trajectory to \
                 valid samples)",
                c[i]
            )));
        }
    }
    Ok(())
}

/// Error unless `x` is `rows x cols`.
pub(crate) fn check_shape(x: &DMatrix<f64>, rows: usize, cols: usize, name: &str) -> Result<()> {
    if x.nrows() != rows || x.ncols() != cols {
        return Err(EngineError::ShapeMismatch(format!(
            "{name} is {} x {}, expected {rows} x {cols}",
            x.nrows(),
            x.ncols()
        )));
    }
    Ok(())
}

/// Error unless `dt` is a positive finite sample period.
pub(crate) fn check_dt(dt: f64) -> Result<()> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(EngineError::InvalidParameter(format!(
            "sample period dt = {dt} must be positive and finite"
        )))
    }
}

/// Error unless there are at least two samples (needed for any velocity).
pub(crate) fn check_len(n: usize) -> Result<()> {
    match n {
        0 => Err(EngineError::EmptySequence(
            "the trajectory has no samples".into(),
        )),
        1 => Err(EngineError::EmptySequence(
            "the trajectory has 1 sample; velocities need at least 2".into(),
        )),
        _ => Ok(()),
    }
}

/// Time derivative of each column of `x` (`n x c`, `n >= 2`) like `numpy.gradient(x, dt,
/// axis=0)`: central differences inside, one-sided first-order differences at both ends.
pub(crate) fn gradient(x: &DMatrix<f64>, dt: f64) -> DMatrix<f64> {
    let n = x.nrows();
    let mut out = DMatrix::zeros(n, x.ncols());
    for (mut o, c) in out.column_iter_mut().zip(x.column_iter()) {
        o[0] = (c[1] - c[0]) / dt;
        o[n - 1] = (c[n - 1] - c[n - 2]) / dt;
        for i in 1..n - 1 {
            o[i] = (c[i + 1] - c[i - 1]) / (2.0 * dt);
        }
    }
    out
}

/// Euclidean norm of each row of `x`.
pub(crate) fn row_norms(x: &DMatrix<f64>) -> Vec<f64> {
    x.row_iter().map(|r| r.norm()).collect()
}

/// Speed `|d p / dt|` of a position track `p` (`n x 3`).
pub(crate) fn speed(p: &DMatrix<f64>, dt: f64) -> Vec<f64> {
    row_norms(&gradient(p, dt))
}

/// Maximal runs `start..end` where `speed > v_th`, keeping only runs of at least `min_len`
/// samples (shorter runs are tracking noise).
pub(crate) fn motion_intervals(speed: &[f64], v_th: f64, min_len: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (t, &s) in speed.iter().enumerate() {
        match (s > v_th, start) {
            (true, None) => start = Some(t),
            (false, Some(s0)) => {
                if t - s0 >= min_len {
                    out.push((s0, t));
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s0) = start {
        if speed.len() - s0 >= min_len {
            out.push((s0, speed.len()));
        }
    }
    out
}

/// Number of samples covering `seconds` at period `dt` (at least 1).
pub(crate) fn samples_for(seconds: f64, dt: f64) -> usize {
    ((seconds / dt).round() as usize).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_matches_numpy() {
        // numpy.gradient([1, 4, 9, 16], 0.5) = [6, 8, 12, 14]
        let x = DMatrix::from_column_slice(4, 1, &[1.0, 4.0, 9.0, 16.0]);
        let g = gradient(&x, 0.5);
        assert_eq!(g.as_slice(), &[6.0, 8.0, 12.0, 14.0]);
    }

    #[test]
    fn motion_intervals_drop_short_runs() {
        let s = [0.0, 1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0];
        assert_eq!(motion_intervals(&s, 0.5, 2), vec![(3, 6), (7, 9)]);
        assert_eq!(motion_intervals(&s, 0.5, 1), vec![(1, 2), (3, 6), (7, 9)]);
    }

    #[test]
    fn input_checks() {
        let x = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, f64::INFINITY, 2.0]);
        assert!(
            matches!(check_finite(&x, "tcp"), Err(EngineError::NonFinite(m)) if m.starts_with("tcp[1, 0]"))
        );
        assert!(check_shape(&x, 2, 3, "tcp").is_err());
        assert!(check_dt(0.0).is_err() && check_dt(f64::NAN).is_err() && check_dt(0.1).is_ok());
        assert!(check_len(1).is_err() && check_len(2).is_ok());
    }
}
