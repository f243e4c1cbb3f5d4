//! The score table of stage 2: `c^{r,s} = sum_f log P(O_f^r | lambda_f^s)` (paper Eq. 3) for every
//! run of consecutive data sections `r = i..j` and every skill `s`.
//!
//! One forward pass per (start section, skill, feature) yields the log-likelihood of every prefix
//! at once ([`PrefixScorer`]), so the whole table costs `K * S * F` passes, never one per prefix.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{EngineError, Result};

/// Anything that scores every prefix of an observation sequence in one pass:
/// `out[t] = log P(x[0..=t])`.
pub trait PrefixScorer: Sync {
    /// Prefix log-likelihoods of `x` (`n_samples x n_dims`), length `n_samples`.
    fn prefix_scores(&self, x: &DMatrix<f64>) -> Result<DVector<f64>>;
}

/// Summed log-likelihoods of every section run and skill.
///
/// Entry `(i, j, s)` with `0 <= i < j <= K` is the log-likelihood of sections `i..j` (samples
/// `b_i .. b_j`) under skill `s`, summed over features; `-inf` where not computed (longer than
/// the maximum segment length) or excluded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScoreTable {
    boundaries: Vec<usize>,
    n_skills: usize,
    total: Vec<f64>,
}

impl ScoreTable {
    /// An empty table (all `-inf`) over the given section `boundaries` (`[0, ..., n]`).
    pub fn new(boundaries: Vec<usize>, n_skills: usize) -> Result<Self> {
        if boundaries.len() < 2 {
            return Err(EngineError::EmptySequence(
                "need at least one data section".into(),
            ));
        }
        if boundaries.windows(2).any(|w| w[1] <= w[0]) {
            return Err(EngineError::InvalidParameter(
                "section boundaries must be strictly increasing".into(),
            ));
        }
        if n_skills == 0 {
            return Err(EngineError::EmptySequence("need at least one skill".into()));
        }
        let k = boundaries.len() - 1;
        Ok(Self {
            boundaries,
            n_skills,
            total: vec![f64::NEG_INFINITY; k * (k + 1) * n_skills],
        })
    }

    fn index(&self, i: usize, j: usize, s: usize) -> usize {
        let k = self.n_sections();
        debug_assert!(i < j && j <= k && s < self.n_skills);
        (i * (k + 1) + j) * self.n_skills + s
    }

    /// Number of data sections `K`.
    pub fn n_sections(&self) -> usize {
        self.boundaries.len() - 1
    }

    /// Number of skills.
    pub fn n_skills(&self) -> usize {
        self.n_skills
    }

    /// Section boundaries `[0, ..., n]` (sample indices).
    pub fn boundaries(&self) -> &[usize] {
        &self.boundaries
    }

    /// Number of samples in sections `i..j`.
    pub fn len(&self, i: usize, j: usize) -> usize {
        self.boundaries[j] - self.boundaries[i]
    }

    /// True if the table covers no samples (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.boundaries.last() == self.boundaries.first()
    }

    /// Summed log-likelihood of sections `i..j` under skill `s`.
    pub fn total(&self, i: usize, j: usize, s: usize) -> f64 {
        self.total[self.index(i, j, s)]
    }

    /// Length-normalised score: summed log-likelihood per sample.
    pub fn mean(&self, i: usize, j: usize, s: usize) -> f64 {
        self.total(i, j, s) / self.len(i, j) as f64
    }

    /// Set the summed log-likelihood of sections `i..j` under skill `s`.
    pub fn set(&mut self, i: usize, j: usize, s: usize, value: f64) {
        let ix = self.index(i, j, s);
        self.total[ix] = value;
    }

    /// Build a table from a function of `(i, j, s)` (mainly for tests and tools).
    pub fn from_fn(
        boundaries: Vec<usize>,
        n_skills: usize,
        f: impl Fn(usize, usize, usize) -> f64,
    ) -> Result<Self> {
        let mut t = Self::new(boundaries, n_skills)?;
        let k = t.n_sections();
        for i in 0..k {
            for j in i + 1..=k {
                for s in 0..n_skills {
                    t.set(i, j, s, f(i, j, s));
                }
            }
        }
        Ok(t)
    }

    /// The raw entries, row-major `(K, K + 1, n_skills)`.
    pub fn as_slice(&self) -> &[f64] {
        &self.total
    }
}

/// The input checks shared by the score-table builders: one model per feature group for every
/// skill, groups inside the observation columns, boundaries from 0 to the number of samples,
/// finite observations.
pub(super) fn check_score_inputs(
    models_per_skill: &[usize],
    groups: &[std::ops::Range<usize>],
    observations: &DMatrix<f64>,
    boundaries: &[usize],
) -> Result<()> {
    let (n, nc) = observations.shape();
    if models_per_skill.is_empty() {
        return Err(EngineError::EmptySequence("no skill models".into()));
    }
    if let Some(s) = models_per_skill.iter().position(|&m| m != groups.len()) {
        return Err(EngineError::ShapeMismatch(format!(
            "skill {s} has {} feature models but there are {} feature groups",
            models_per_skill[s],
            groups.len()
        )));
    }
    if let Some(g) = groups.iter().find(|g| g.is_empty() || g.end > nc) {
        return Err(EngineError::ShapeMismatch(format!(
            "feature group {g:?} does not fit {nc} observation columns"
        )));
    }
    if boundaries.first() != Some(&0) || boundaries.last() != Some(&n) {
        return Err(EngineError::ShapeMismatch(format!(
            "boundaries must start at 0 and end at the number of samples {n}"
        )));
    }
    if observations.iter().any(|v| !v.is_finite()) {
        return Err(EngineError::NonFinite(
            "observations contain NaN or infinity".into(),
        ));
    }
    Ok(())
}

/// Compute the score table.
///
/// * `models[s][g]` scores the columns `groups[g]` of the observations for skill `s` (one HMM per
///   Table I feature; a feature may span several columns, e.g. the TCP position in the object
///   frame);
/// * `observations` is `(n_samples, n_columns)`, finite, already normalised;
/// * `boundaries` are the stage-1 section boundaries `[0, ..., n_samples]`;
/// * `max_len` (samples) bounds the length of a segment (longer runs stay `-inf`); `0` = no bound.
pub fn score_table<M: PrefixScorer>(
    models: &[Vec<M>],
    groups: &[Range<usize>],
    observations: &DMatrix<f64>,
    boundaries: &[usize],
    max_len: usize,
) -> Result<ScoreTable> {
    let counts: Vec<usize> = models.iter().map(Vec::len).collect();
    check_score_inputs(&counts, groups, observations, boundaries)?;
    let n = observations.nrows();
    let mut table = ScoreTable::new(boundaries.to_vec(), models.len())?;
    let k = table.n_sections();
    let max_len = if max_len == 0 { n } else { max_len };
    let jobs: Vec<(usize, usize)> = (0..k)
        .flat_map(|i| (0..models.len()).map(move |s| (i, s)))
        .collect();
    let results: Vec<Result<(usize, usize, Vec<f64>)>> = jobs
        .par_iter()
        .map(|&(i, s)| {
            let start = boundaries[i];
            // the longest run from section i that fits in max_len (at least one section)
            let mut last = i + 1;
            while last < k && boundaries[last + 1] - start <= max_len {
                last += 1;
            }
            let len = boundaries[last] - start;
            let mut sums = vec![0.0; last - i];
            for (g, model) in groups.iter().zip(&models[s]) {
                let x = observations
                    .view((start, g.start), (len, g.len()))
                    .into_owned();
                let prefix = model.prefix_scores(&x)?;
                if prefix.len() != len {
                    return Err(EngineError::ShapeMismatch(format!(
                        "prefix scorer returned {} values for {len} samples",
                        prefix.len()
                    )));
                }
                for (slot, j) in sums.iter_mut().zip(i + 1..=last) {
                    *slot += prefix[boundaries[j] - start - 1];
                }
            }
            Ok((i, s, sums))
        })
        .collect();
    for r in results {
        let (i, s, sums) = r?;
        for (off, v) in sums.into_iter().enumerate() {
            table.set(
                i,
                i + 1 + off,
                s,
                if v.is_nan() { f64::NEG_INFINITY } else { v },
            );
        }
    }
    Ok(table)
}

/// Parameters of the TCP rise/fall decision (paper Fig. 5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RiseParams {
    /// A run is "rising" if the TCP height climbs at least this much (metres) in one go: the
    /// largest rise `max z[t] - z[s]` over `s <= t` inside the run (robust to tremor, which
    /// would add up in a sum of positive steps)...
    pub min_rise: f64,
    /// ...and its summed climb is at least `dominance` times its summed descent (0 disables).
    pub dominance: f64,
}

impl Default for RiseParams {
    fn default() -> Self {
        Self {
            min_rise: 0.02,
            dominance: 0.0,
        }
    }
}

/// Is the TCP rising over each section run? Returns a row-major `(K, K + 1)` table, entry
/// `(i, j)` for sections `i..j`, from the TCP height `z` (metres, one value per sample; NaN
/// samples are skipped). Cost `O(K n)`.
pub fn rising_table(z: &[f64], boundaries: &[usize], params: RiseParams) -> Result<Vec<bool>> {
    let n = z.len();
    if boundaries.len() < 2 || boundaries.first() != Some(&0) || boundaries.last() != Some(&n) {
        return Err(EngineError::ShapeMismatch(format!(
            "boundaries must be [0, ..., {n}] with at least one section"
        )));
    }
    if boundaries.windows(2).any(|w| w[1] <= w[0]) {
        return Err(EngineError::InvalidParameter(
            "section boundaries must be strictly increasing".into(),
        ));
    }
    let k = boundaries.len() - 1;
    let mut out = vec![false; k * (k + 1)];
    for i in 0..k {
        let (mut low, mut drawup, mut up, mut down) = (f64::INFINITY, 0.0_f64, 0.0, 0.0);
        let mut prev = f64::NAN;
        let mut j = i + 1;
        for (t, &v) in z.iter().enumerate().skip(boundaries[i]) {
            if v.is_finite() {
                low = low.min(v);
                drawup = drawup.max(v - low);
                if prev.is_finite() {
                    up += (v - prev).max(0.0);
                    down += (prev - v).max(0.0);
                }
                prev = v;
            }
            if t + 1 == boundaries[j] {
                out[i * (k + 1) + j] = drawup >= params.min_rise && up >= params.dominance * down;
                j += 1;
                if j > k {
                    break;
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scores each sample by -(x - mu)^2, so the prefix score is a cumulative sum.
    struct Quadratic(f64);
    impl PrefixScorer for Quadratic {
        fn prefix_scores(&self, x: &DMatrix<f64>) -> Result<DVector<f64>> {
            let mut acc = 0.0;
            Ok(DVector::from_iterator(
                x.nrows(),
                x.column(0).iter().map(|v| {
                    acc -= (v - self.0).powi(2);
                    acc
                }),
            ))
        }
    }

    #[test]
    fn table_matches_direct_sums() {
        let obs = DMatrix::from_fn(12, 2, |t, f| (t as f64) * 0.1 + f as f64);
        let models = vec![
            vec![Quadratic(0.0), Quadratic(1.0)],
            vec![Quadratic(1.0), Quadratic(2.0)],
        ];
        let b = vec![0, 3, 7, 12];
        let groups = [0..1, 1..2];
        let t = score_table(&models, &groups, &obs, &b, 0).unwrap();
        for i in 0..3 {
            for j in i + 1..=3 {
                for (s, m) in models.iter().enumerate() {
                    let direct: f64 = (b[i]..b[j])
                        .map(|r| (0..2).map(|f| -(obs[(r, f)] - m[f].0).powi(2)).sum::<f64>())
                        .sum();
                    assert!((t.total(i, j, s) - direct).abs() < 1e-12);
                }
            }
        }
        // max_len bounds runs: 0..3 (3 samples) fits in 7, 0..7 fits, 0..12 does not
        let t = score_table(&models, &groups, &obs, &b, 7).unwrap();
        assert!(t.total(0, 2, 0).is_finite());
        assert!(t.total(0, 3, 0).is_infinite());
        assert!(t.total(2, 3, 0).is_finite());
    }

    #[test]
    fn table_rejects_bad_input() {
        let obs = DMatrix::from_element(5, 1, f64::NAN);
        let models = vec![vec![Quadratic(0.0)]];
        assert!(matches!(
            score_table(
                &models,
                &std::iter::once(0..1).collect::<Vec<_>>(),
                &obs,
                &[0, 5],
                0
            ),
            Err(EngineError::NonFinite(_))
        ));
        let obs = DMatrix::zeros(5, 2);
        assert!(matches!(
            score_table(&models, &[0..1, 1..2], &obs, &[0, 5], 0),
            Err(EngineError::ShapeMismatch(_))
        ));
        assert!(ScoreTable::new(vec![0, 3, 3], 1).is_err());
    }

    #[test]
    fn rising_needs_net_climb() {
        // rise 0.1 over samples 0..10, flat, then fall 0.1 over 20..30
        let z: Vec<f64> = (0..30)
            .map(|t| match t {
                0..=9 => 0.01 * f64::from(t),
                10..=19 => 0.09,
                _ => 0.09 - 0.01 * f64::from(t - 19),
            })
            .collect();
        let b = [0, 10, 20, 30];
        let p = RiseParams {
            min_rise: 0.03,
            dominance: 1.0,
        };
        let r = rising_table(&z, &b, p).unwrap();
        let at = |i: usize, j: usize| r[i * 4 + j];
        assert!(at(0, 1) && at(0, 2));
        assert!(!at(1, 2) && !at(2, 3));
        // the whole demo climbs 0.09 and falls 0.11: not dominated by the rise
        assert!(!at(0, 3));
        // without the dominance test any run containing the climb is rising
        let r = rising_table(
            &z,
            &b,
            RiseParams {
                min_rise: 0.03,
                dominance: 0.0,
            },
        )
        .unwrap();
        assert!(r[3] && !r[4 + 2]);
        // tremor adds up in a sum of steps but not in the largest single climb
        let tremor: Vec<f64> = (0..200).map(|t| 0.004 * f64::from(t % 2)).collect();
        let r = rising_table(&tremor, &[0, 200], RiseParams::default()).unwrap();
        assert!(!r[1]);
    }
}
