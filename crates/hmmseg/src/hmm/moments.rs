//! Weighted means and covariances of row-major point sets, and the covariance floor.

use nalgebra::{DMatrix, SymmetricEigen};

use super::config::CovarianceType;

/// Mean and (maximum-likelihood) covariance of the points `data[i*f .. (i+1)*f]` for `i` in
/// `idx`. Diag models get a diagonal matrix. `None` for an empty set.
pub(crate) fn mean_cov(
    data: &[f64],
    f: usize,
    idx: &[usize],
    covariance: CovarianceType,
) -> Option<(Vec<f64>, DMatrix<f64>)> {
    if idx.is_empty() {
        return None;
    }
    let count = idx.len() as f64;
    let mut mean = vec![0.0; f];
    for &i in idx {
        for (m, v) in mean.iter_mut().zip(&data[i * f..(i + 1) * f]) {
            *m += v;
        }
    }
    for m in &mut mean {
        *m /= count;
    }
    let mut cov = DMatrix::zeros(f, f);
    for &i in idx {
        let p = &data[i * f..(i + 1) * f];
        for r in 0..f {
            let dr = p[r] - mean[r];
            match covariance {
                CovarianceType::Diag => cov[(r, r)] += dr * dr,
                CovarianceType::Full => {
                    for c in 0..=r {
                        cov[(r, c)] += dr * (p[c] - mean[c]);
                    }
                }
            }
        }
    }
    for r in 0..f {
        for c in 0..=r {
            let v = cov[(r, c)] / count;
            cov[(r, c)] = v;
            cov[(c, r)] = v;
        }
    }
    Some((mean, cov))
}

/// Enforce the covariance floor: every eigenvalue (diag: every variance) at least `floor`.
///
/// A matrix that already satisfies the bound is only symmetrised, so a valid maximum-likelihood
/// update is left untouched; otherwise the eigenvalues below `floor` are raised to it (the
/// constrained maximum-likelihood estimate, so EM stays monotone).
pub(crate) fn floor_covariance(c: &mut DMatrix<f64>, floor: f64, covariance: CovarianceType) {
    let f = c.nrows();
    match covariance {
        CovarianceType::Diag => {
            for r in 0..f {
                for s in 0..f {
                    if r != s {
                        c[(r, s)] = 0.0;
                    }
                }
                // `max` also replaces a NaN variance by the floor.
                c[(r, r)] = c[(r, r)].max(floor);
            }
        }
        CovarianceType::Full => {
            for r in 0..f {
                for s in 0..r {
                    let v = 0.5 * (c[(r, s)] + c[(s, r)]);
                    c[(r, s)] = v;
                    c[(s, r)] = v;
                }
            }
            let shifted = &*c - DMatrix::identity(f, f) * floor;
            if shifted.cholesky().is_some() {
                return;
            }
            if c.iter().any(|v| !v.is_finite()) {
                *c = DMatrix::identity(f, f) * floor;
                return;
            }
            let eig = SymmetricEigen::new(c.clone());
            let clamped = eig.eigenvalues.map(|v| v.max(floor));
            let q = &eig.eigenvectors;
            let mut out = q * DMatrix::from_diagonal(&clamped) * q.transpose();
            for r in 0..f {
                for s in 0..r {
                    let v = 0.5 * (out[(r, s)] + out[(s, r)]);
                    out[(r, s)] = v;
                    out[(s, r)] = v;
                }
            }
            *c = out;
        }
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]
mod tests {
    use super::*;

    #[test]
    fn mean_cov_of_points() {
        let data = [0.0, 0.0, 2.0, 2.0, 4.0, 1.0];
        let (m, c) = mean_cov(&data, 2, &[0, 1, 2], CovarianceType::Full).unwrap();
        assert_eq!(m, vec![2.0, 1.0]);
        assert!((c[(0, 0)] - 8.0 / 3.0).abs() < 1e-12);
        assert!((c[(0, 1)] - 2.0 / 3.0).abs() < 1e-12 && c[(1, 0)] == c[(0, 1)]);
        assert!((c[(1, 1)] - 2.0 / 3.0).abs() < 1e-12);
        let (_, d) = mean_cov(&data, 2, &[0, 1, 2], CovarianceType::Diag).unwrap();
        assert_eq!(d[(0, 1)], 0.0);
        assert!(mean_cov(&data, 2, &[], CovarianceType::Diag).is_none());
    }

    #[test]
    fn floor_raises_small_eigenvalues_only() {
        let mut ok = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
        let before = ok.clone();
        floor_covariance(&mut ok, 1e-3, CovarianceType::Full);
        assert_eq!(ok, before);
        let mut singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        floor_covariance(&mut singular, 1e-2, CovarianceType::Full);
        let eig = SymmetricEigen::new(singular.clone()).eigenvalues;
        assert!(eig.min() >= 1e-2 - 1e-12, "{eig}");
        assert!((eig.max() - 2.0).abs() < 1e-12);
        let mut d = DMatrix::from_row_slice(2, 2, &[1e-9, 0.0, 0.0, 3.0]);
        floor_covariance(&mut d, 1e-3, CovarianceType::Diag);
        assert_eq!(d, DMatrix::from_row_slice(2, 2, &[1e-3, 0.0, 0.0, 3.0]));
    }
}
