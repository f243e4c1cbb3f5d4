//! Stage 1 of the segmentation (paper Sec. III-B.3, "segment point modelling"): an
//! over-segmentation of a demonstration into data sections.
//!
//! Each criterion is one feature column compared with its per-sample threshold column (Table I:
//! fingertip distance vs `d_i + gamma`, hand velocity vs `v_th`, TCP rise/fall vs 0). A section
//! boundary is put where a criterion changes side. A hysteresis band around the threshold and a
//! minimum section length keep sensor noise from producing chatter.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{EngineError, Result};

/// One threshold criterion: the feature `column` crossing the threshold in the same column of
/// the thresholds matrix.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Criterion {
    /// Column index in the feature (and threshold) matrix.
    pub column: usize,
    /// Half-width of the hysteresis band: the state flips to "above" only when the value exceeds
    /// `threshold + hysteresis`, and back to "below" only under `threshold - hysteresis`.
    pub hysteresis: f64,
}

/// Parameters of stage 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stage1Params {
    /// The criteria whose crossings give boundaries.
    pub criteria: Vec<Criterion>,
    /// Minimum number of samples in a section (boundaries closer than this to the previous one
    /// or to the end are dropped).
    pub min_section: usize,
}

/// The crossing indices of one criterion: sample `t` where the side of the threshold changed
/// (the first sample on the new side). Non-finite samples keep the previous state.
pub fn crossings(values: &[f64], thresholds: &[f64], hysteresis: f64) -> Result<Vec<usize>> {
    if values.len() != thresholds.len() {
        return Err(EngineError::ShapeMismatch(format!(
            "{} values but {} thresholds",
            values.len(),
            thresholds.len()
        )));
    }
    if !hysteresis.is_finite() || hysteresis < 0.0 {
        return Err(EngineError::InvalidParameter(format!(
            "hysteresis must be finite and >= 0, got {hysteresis}"
        )));
    }
    let mut state: Option<bool> = None;
    let mut out = Vec::new();
    for (t, (&v, &thr)) in values.iter().zip(thresholds).enumerate() {
        if !v.is_finite() || !thr.is_finite() {
            continue;
        }
        match state {
            None => state = Some(v > thr),
            Some(true) if v < thr - hysteresis => {
                state = Some(false);
                out.push(t);
            }
            Some(false) if v > thr + hysteresis => {
                state = Some(true);
                out.push(t);
            }
            Some(_) => {}
        }
    }
    Ok(out)
}

/// Section boundaries of a demonstration: sorted indices `0 = b_0 < b_1 < ... < b_K = n`, so
/// section `k` is the samples `b_k .. b_{k+1}`.
///
/// `values` and `thresholds` are `(n_samples, n_features)`, one row per time step.
pub fn section_boundaries(
    values: &DMatrix<f64>,
    thresholds: &DMatrix<f64>,
    params: &Stage1Params,
) -> Result<Vec<usize>> {
    let (n, f) = values.shape();
    if n == 0 {
        return Err(EngineError::EmptySequence(
            "stage 1 needs at least one sample".into(),
        ));
    }
    if thresholds.shape() != (n, f) {
        return Err(EngineError::ShapeMismatch(format!(
            "values are {n}x{f} but thresholds are {}x{}",
            thresholds.nrows(),
            thresholds.ncols()
        )));
    }
    let mut cuts = Vec::new();
    for c in &params.criteria {
        if c.column >= f {
            return Err(EngineError::InvalidParameter(format!(
                "criterion column {} out of range for {f} features",
                c.column
            )));
        }
        let v: Vec<f64> = values.column(c.column).iter().copied().collect();
        let th: Vec<f64> = thresholds.column(c.column).iter().copied().collect();
        cuts.extend(crossings(&v, &th, c.hysteresis)?);
    }
    cuts.sort_unstable();
    cuts.dedup();
    Ok(enforce_min_section(&cuts, n, params.min_section))
}

/// Keep the interior `cuts` that leave at least `min_section` samples to the previous kept cut
/// and to the end; returns the full boundary list `[0, ..., n]`.
pub fn enforce_min_section(cuts: &[usize], n: usize, min_section: usize) -> Vec<usize> {
    let min = min_section.max(1);
    let mut out = vec![0];
    for &c in cuts {
        let last = *out.last().unwrap_or(&0);
        if c > last && c - last >= min && c < n && n - c >= min {
            out.push(c);
        }
    }
    if n > 0 {
        out.push(n);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossings_with_hysteresis_ignore_noise() {
        // a square wave 0 -> 1 -> 0 with +-0.05 noise around the threshold 0.5 region
        let mut v = vec![0.0; 10];
        v.extend(vec![1.0; 10]);
        v.extend(vec![0.0; 10]);
        v[5] = 0.52; // noise just above the threshold, inside the band
        let th = vec![0.5; v.len()];
        assert_eq!(crossings(&v, &th, 0.1).unwrap(), vec![10, 20]);
        assert_eq!(crossings(&v, &th, 0.0).unwrap(), vec![5, 6, 10, 20]);
    }

    #[test]
    fn nan_keeps_state() {
        let v = [0.0, f64::NAN, 1.0, f64::NAN, 1.0, 0.0];
        let th = [0.5; 6];
        assert_eq!(crossings(&v, &th, 0.0).unwrap(), vec![2, 5]);
    }

    #[test]
    fn boundaries_combine_criteria_and_respect_min_length() {
        let n = 100;
        // column 0 crosses at 30 and 70, column 1 at 32 (too close to 30) and 50
        let values = DMatrix::from_fn(n, 2, |t, c| match c {
            0 => f64::from(u8::from((30..70).contains(&t))),
            _ => f64::from(u8::from((32..50).contains(&t))),
        });
        let thresholds = DMatrix::from_element(n, 2, 0.5);
        let params = Stage1Params {
            criteria: vec![
                Criterion {
                    column: 0,
                    hysteresis: 0.1,
                },
                Criterion {
                    column: 1,
                    hysteresis: 0.1,
                },
            ],
            min_section: 5,
        };
        let b = section_boundaries(&values, &thresholds, &params).unwrap();
        assert_eq!(b, vec![0, 30, 50, 70, 100]);
    }

    #[test]
    fn bad_input_is_reported() {
        let v = DMatrix::zeros(10, 2);
        let params = Stage1Params {
            criteria: vec![Criterion {
                column: 5,
                hysteresis: 0.0,
            }],
            min_section: 1,
        };
        assert!(matches!(
            section_boundaries(&v, &v, &params),
            Err(EngineError::InvalidParameter(_))
        ));
        let th = DMatrix::zeros(9, 2);
        assert!(matches!(
            section_boundaries(
                &v,
                &th,
                &Stage1Params {
                    criteria: vec![],
                    min_section: 1
                }
            ),
            Err(EngineError::ShapeMismatch(_))
        ));
        let e = DMatrix::zeros(0, 2);
        assert!(matches!(
            section_boundaries(
                &e,
                &e,
                &Stage1Params {
                    criteria: vec![],
                    min_section: 1
                }
            ),
            Err(EngineError::EmptySequence(_))
        ));
        assert!(crossings(&[1.0], &[1.0], -1.0).is_err());
    }

    #[test]
    fn no_crossing_gives_one_section() {
        let v = DMatrix::zeros(10, 1);
        let params = Stage1Params {
            criteria: vec![Criterion {
                column: 0,
                hysteresis: 0.0,
            }],
            min_section: 3,
        };
        assert_eq!(section_boundaries(&v, &v, &params).unwrap(), vec![0, 10]);
    }
}
