//! DTW against a naive full-matrix implementation, and its metric-like properties.

use hmmseg::dtw::{align_to_reference, dtw, dtw_distance, dtw_distance_slices};
use hmmseg::EngineError;
use nalgebra::DMatrix;
use proptest::prelude::*;

/// Textbook O(n m) DTW on a full (n+1) x (m+1) matrix with infinite padding.
fn naive(a: &DMatrix<f64>, b: &DMatrix<f64>, band: Option<usize>) -> f64 {
    let (n, m) = (a.nrows(), b.nrows());
    let mut acc = vec![vec![f64::INFINITY; m + 1]; n + 1];
    acc[0][0] = 0.0;
    for i in 1..=n {
        for j in 1..=m {
            if band.is_some_and(|r| i.abs_diff(j) > r) {
                continue;
            }
            let c = (a.row(i - 1) - b.row(j - 1)).norm_squared();
            acc[i][j] = c + acc[i - 1][j - 1].min(acc[i - 1][j]).min(acc[i][j - 1]);
        }
    }
    acc[n][m].sqrt()
}

fn seq(max_len: usize, dim: usize) -> impl Strategy<Value = DMatrix<f64>> {
    (1..=max_len).prop_flat_map(move |n| {
        prop::collection::vec(-5.0..5.0f64, n * dim)
            .prop_map(move |v| DMatrix::from_row_slice(n, dim, &v))
    })
}

fn pair(max_len: usize) -> impl Strategy<Value = (DMatrix<f64>, DMatrix<f64>)> {
    (1..=3usize).prop_flat_map(move |d| (seq(max_len, d), seq(max_len, d)))
}

fn path_cost(a: &DMatrix<f64>, b: &DMatrix<f64>, path: &[(usize, usize)]) -> f64 {
    path.iter()
        .map(|&(i, j)| (a.row(i) - b.row(j)).norm_squared())
        .sum::<f64>()
        .sqrt()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn matches_naive((a, b) in pair(12), r in 0usize..6) {
        let want = naive(&a, &b, None);
        let got = dtw(&a, &b, None).unwrap();
        prop_assert!((got.distance - want).abs() <= 1e-9 * (1.0 + want));
        prop_assert!((dtw_distance(&a, &b, None).unwrap() - want).abs() <= 1e-9 * (1.0 + want));
        // The path is monotone, connects the corners and realises the distance.
        let p = &got.path;
        prop_assert_eq!(p[0], (0, 0));
        prop_assert_eq!(*p.last().unwrap(), (a.nrows() - 1, b.nrows() - 1));
        for w in p.windows(2) {
            let (di, dj) = (w[1].0 - w[0].0, w[1].1 - w[0].1);
            prop_assert!(di <= 1 && dj <= 1 && di + dj >= 1);
        }
        prop_assert!((path_cost(&a, &b, p) - got.distance).abs() <= 1e-9 * (1.0 + want));

        // Banded: same as naive when the band connects the corners, an error otherwise.
        if a.nrows().abs_diff(b.nrows()) <= r {
            let want = naive(&a, &b, Some(r));
            let got = dtw(&a, &b, Some(r)).unwrap();
            prop_assert!((got.distance - want).abs() <= 1e-9 * (1.0 + want));
            prop_assert!((dtw_distance(&a, &b, Some(r)).unwrap() - want).abs() <= 1e-9 * (1.0 + want));
            prop_assert!(got.path.iter().all(|&(i, j)| i.abs_diff(j) <= r));
            prop_assert!((path_cost(&a, &b, &got.path) - got.distance).abs() <= 1e-9 * (1.0 + want));
        } else {
            let is_invalid = matches!(dtw(&a, &b, Some(r)), Err(EngineError::InvalidParameter(_)));
            prop_assert!(is_invalid);
        }
    }

    #[test]
    fn identity_and_symmetry((a, b) in pair(15)) {
        prop_assert!(dtw_distance(&a, &a, None).unwrap() == 0.0);
        prop_assert!(dtw_distance(&a, &a, Some(0)).unwrap() == 0.0);
        let ab = dtw_distance(&a, &b, None).unwrap();
        let ba = dtw_distance(&b, &a, None).unwrap();
        prop_assert!((ab - ba).abs() <= 1e-12 * (1.0 + ab));
    }

    #[test]
    fn bounded_by_euclidean(a in seq(20, 2), noise in prop::collection::vec(-1.0..1.0f64, 40)) {
        let n = a.nrows();
        let b = DMatrix::from_fn(n, 2, |i, j| a[(i, j)] + noise[2 * i + j]);
        let euclid = (&a - &b).norm();
        prop_assert!(dtw_distance(&a, &b, None).unwrap() <= euclid + 1e-12);
        prop_assert!((dtw_distance(&a, &b, Some(0)).unwrap() - euclid).abs() <= 1e-9);
    }
}

#[test]
fn slices_api_equals_matrix_api() {
    let a = DMatrix::from_row_slice(4, 2, &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
    let b = DMatrix::from_row_slice(3, 2, &[0.5, 1.0, 4.0, 4.0, 6.0, 8.0]);
    let flat = |m: &DMatrix<f64>| m.transpose().as_slice().to_vec();
    let d1 = dtw_distance(&a, &b, None).unwrap();
    let d2 = dtw_distance_slices(&flat(&a), &flat(&b), 2, None).unwrap();
    assert!((d1 - d2).abs() < 1e-15);
    assert!((d1 - naive(&a, &b, None)).abs() < 1e-12);
    assert!(matches!(
        dtw_distance_slices(&[1.0, 2.0, 3.0], &[1.0, 2.0], 2, None),
        Err(EngineError::ShapeMismatch(_))
    ));
}

#[test]
fn align_to_reference_recovers_time_warped_copies() {
    // A ramp and a copy that dwells twice as long at every sample: aligned back exactly.
    let reference = DMatrix::from_fn(10, 2, |i, j| (i * (j + 1)) as f64);
    let slow = DMatrix::from_fn(20, 2, |i, j| ((i / 2) * (j + 1)) as f64);
    let out = align_to_reference(&reference, &[slow, reference.clone()], Some(10)).unwrap();
    assert_eq!(out.len(), 2);
    assert_eq!(out[0], reference);
    assert_eq!(out[1], reference);
    assert!(matches!(
        align_to_reference(&reference, &[DMatrix::zeros(0, 2)], None),
        Err(EngineError::EmptySequence(_))
    ));
    assert!(matches!(
        align_to_reference(&reference, &[DMatrix::zeros(25, 2)], Some(10)),
        Err(EngineError::InvalidParameter(_))
    ));
}

#[test]
fn huge_band_and_huge_inputs_are_handled() {
    let a = DMatrix::from_row_slice(3, 1, &[0.0, 1.0, 2.0]);
    assert!(dtw(&a, &a, Some(usize::MAX)).unwrap().distance == 0.0);
    assert!(dtw_distance(&a, &a, Some(usize::MAX)).unwrap() == 0.0);
    let long = DMatrix::<f64>::zeros(20_000, 1);
    assert!(matches!(
        dtw(&long, &long, None),
        Err(EngineError::InvalidParameter(_))
    ));
    assert!(dtw(&long, &long, Some(2)).is_ok());
}
