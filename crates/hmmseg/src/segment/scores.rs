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

/// The runs of consecutive data sections a segment may span.
///
/// Run `i..j` (`0 <= i < j <= K`, samples `b_i .. b_j`) is admissible if it lasts at most
/// `max_len` samples; the single section `i..i + 1` always is (a section longer than `max_len`
/// is still a candidate on its own). The boundaries increase, so the admissible ends of start
/// section `i` form the contiguous range `i + 1 ..= last_end(i)` and `last_end` never decreases:
/// the runs are stored start by start (an offset per start section and a dense band of ends),
/// `N ~ K * (sections per max_len)` of them instead of `K (K + 1)`.
///
/// Run `r` of the flat layout is `(i, j)` with `offsets[i] <= r < offsets[i + 1]` and
/// `j = i + 1 + r - offsets[i]`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Band {
    boundaries: Vec<usize>,
    max_len: usize,
    /// `offsets[i]..offsets[i + 1]`: the runs starting at section `i` (`K + 1` entries).
    offsets: Vec<usize>,
}

impl Band {
    /// The band of runs of at most `max_len` samples over `boundaries` (`[b_0, ..., b_K]`,
    /// strictly increasing); `max_len = 0`: no bound (every run `i < j`).
    pub fn new(boundaries: Vec<usize>, max_len: usize) -> Result<Self> {
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
        let k = boundaries.len() - 1;
        let limit = if max_len == 0 { usize::MAX } else { max_len };
        let mut offsets = Vec::with_capacity(k + 1);
        offsets.push(0);
        // the longest run from i that fits (at least one section); it never ends before the
        // previous start's, so one sweep finds them all
        let mut last = 1;
        for i in 0..k {
            last = last.max(i + 1);
            while last < k && boundaries[last + 1] - boundaries[i] <= limit {
                last += 1;
            }
            offsets.push(offsets[i] + last - i);
        }
        Ok(Self {
            boundaries,
            max_len,
            offsets,
        })
    }

    /// Number of data sections `K`.
    pub fn n_sections(&self) -> usize {
        self.boundaries.len() - 1
    }

    /// Section boundaries `[b_0, ..., b_K]` (sample indices).
    pub fn boundaries(&self) -> &[usize] {
        &self.boundaries
    }

    /// The bound on a run's length in samples (0: none).
    pub fn max_len(&self) -> usize {
        self.max_len
    }

    /// Number of admissible runs `N`.
    pub fn n_runs(&self) -> usize {
        self.offsets[self.offsets.len() - 1]
    }

    /// `offsets[i]..offsets[i + 1]` are the flat indices of the runs starting at section `i`.
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// The last admissible end section of the runs starting at section `i < K`.
    pub fn last_end(&self, i: usize) -> usize {
        i + self.offsets[i + 1] - self.offsets[i]
    }

    /// The admissible end sections of the runs starting at section `i < K`.
    pub fn ends(&self, i: usize) -> Range<usize> {
        i + 1..self.last_end(i) + 1
    }

    /// The admissible start sections of the runs ending at section `0 < j <= K`.
    pub fn starts(&self, j: usize) -> Range<usize> {
        // last_end is non-decreasing and last_end(j - 1) >= j: binary search the first start
        // that reaches j
        let (mut lo, mut hi) = (0, j - 1);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if self.last_end(mid) >= j {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        lo..j
    }

    /// Flat index of run `i..j`, `None` outside the band.
    pub fn index(&self, i: usize, j: usize) -> Option<usize> {
        (i < j && j <= self.n_sections() && j <= self.last_end(i))
            .then(|| self.offsets[i] + j - i - 1)
    }

    /// Every admissible run `(i, j)`, in flat order.
    pub fn runs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.n_sections()).flat_map(move |i| self.ends(i).map(move |j| (i, j)))
    }
}

/// Summed log-likelihoods of the admissible section runs and every skill.
///
/// Entry `(i, j, s)` is the log-likelihood of sections `i..j` (samples `b_i .. b_j`) under skill
/// `s`, summed over features; `-inf` where not computed or excluded, and for every run outside
/// the table's [`Band`] (longer than the maximum segment length), which is not stored: memory
/// is `N * n_skills`, linear in the demonstration's length for a bounded band.
///
/// The entries are owned (`V = Vec<f64>`, the default) or borrowed (`&[f64]`, `Cow<[f64]>`:
/// a search reads a table its caller holds without copying it, see [`Self::from_entries`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScoreTable<V = Vec<f64>> {
    band: Band,
    n_skills: usize,
    /// Row-major `(N, n_skills)` over the band's runs.
    total: V,
}

impl ScoreTable {
    /// An empty table (all `-inf`) over every run of the given section `boundaries`
    /// (`[0, ..., n]`), without a length bound (`K (K + 1) / 2` runs: for small tables and
    /// tests; see [`Self::with_band`]).
    pub fn new(boundaries: Vec<usize>, n_skills: usize) -> Result<Self> {
        Self::with_band(Band::new(boundaries, 0)?, n_skills)
    }

    /// An empty table (all `-inf`) over the runs of `band`.
    pub fn with_band(band: Band, n_skills: usize) -> Result<Self> {
        let len = band.n_runs() * n_skills;
        Self::from_entries(band, n_skills, vec![f64::NEG_INFINITY; len])
    }

    /// Set the summed log-likelihood of sections `i..j` under skill `s`.
    ///
    /// # Panics
    /// If `i..j` lies outside the band and `value` is not `-inf` (what the table holds there).
    pub fn set(&mut self, i: usize, j: usize, s: usize, value: f64) {
        assert!(s < self.n_skills, "skill {s} of {}", self.n_skills);
        match self.band.index(i, j) {
            Some(r) => self.total[r * self.n_skills + s] = value,
            None => assert!(
                value == f64::NEG_INFINITY,
                "run {i}..{j} lies outside the score table's band"
            ),
        }
    }

    /// Build a table over every run from a function of `(i, j, s)` (mainly for tests and tools).
    pub fn from_fn(
        boundaries: Vec<usize>,
        n_skills: usize,
        f: impl Fn(usize, usize, usize) -> f64,
    ) -> Result<Self> {
        Self::from_band_fn(Band::new(boundaries, 0)?, n_skills, f)
    }

    /// Build a table over the runs of `band` from a function of `(i, j, s)`.
    pub fn from_band_fn(
        band: Band,
        n_skills: usize,
        f: impl Fn(usize, usize, usize) -> f64,
    ) -> Result<Self> {
        let mut t = Self::with_band(band, n_skills)?;
        let mut r = 0;
        for i in 0..t.n_sections() {
            for j in t.band.ends(i) {
                for s in 0..n_skills {
                    t.total[r * n_skills + s] = f(i, j, s);
                }
                r += 1;
            }
        }
        Ok(t)
    }

    /// The raw entries (see [`Self::as_slice`]), taken out of the table without a copy.
    pub fn into_values(self) -> Vec<f64> {
        self.total
    }
}

impl<V: AsRef<[f64]>> ScoreTable<V> {
    /// A table over the runs of `band` from its entries, row-major `(N, n_skills)` (owned or
    /// borrowed).
    pub fn from_entries(band: Band, n_skills: usize, total: V) -> Result<Self> {
        if n_skills == 0 {
            return Err(EngineError::EmptySequence("need at least one skill".into()));
        }
        let len = band.n_runs() * n_skills;
        if total.as_ref().len() != len {
            return Err(EngineError::ShapeMismatch(format!(
                "a banded score table of {} runs x {n_skills} skills has {len} entries, got {}",
                band.n_runs(),
                total.as_ref().len()
            )));
        }
        Ok(Self {
            band,
            n_skills,
            total,
        })
    }

    /// The admissible runs.
    pub fn band(&self) -> &Band {
        &self.band
    }

    /// Number of data sections `K`.
    pub fn n_sections(&self) -> usize {
        self.band.n_sections()
    }

    /// Number of skills.
    pub fn n_skills(&self) -> usize {
        self.n_skills
    }

    /// Section boundaries `[0, ..., n]` (sample indices).
    pub fn boundaries(&self) -> &[usize] {
        self.band.boundaries()
    }

    /// Number of samples in sections `i..j`.
    pub fn len(&self, i: usize, j: usize) -> usize {
        self.band.boundaries[j] - self.band.boundaries[i]
    }

    /// True if the table covers no samples (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.band.boundaries.last() == self.band.boundaries.first()
    }

    /// Summed log-likelihood of sections `i..j` under skill `s`; `-inf` outside the band.
    pub fn total(&self, i: usize, j: usize, s: usize) -> f64 {
        assert!(s < self.n_skills, "skill {s} of {}", self.n_skills);
        self.band.index(i, j).map_or(f64::NEG_INFINITY, |r| {
            self.total.as_ref()[r * self.n_skills + s]
        })
    }

    /// Length-normalised score: summed log-likelihood per sample.
    pub fn mean(&self, i: usize, j: usize, s: usize) -> f64 {
        self.total(i, j, s) / self.len(i, j) as f64
    }

    /// The raw entries, row-major `(N, n_skills)` in the band's run order.
    pub fn as_slice(&self) -> &[f64] {
        self.total.as_ref()
    }

    /// The entries as a dense row-major `(K, K + 1, n_skills)` table, `-inf` outside the band
    /// (quadratic in `K`: for small tables and tools).
    pub fn to_dense(&self) -> Vec<f64> {
        let (k, ns) = (self.n_sections(), self.n_skills);
        let mut out = vec![f64::NEG_INFINITY; k * (k + 1) * ns];
        for (r, (i, j)) in self.band.runs().enumerate() {
            let at = (i * (k + 1) + j) * ns;
            out[at..at + ns].copy_from_slice(&self.total.as_ref()[r * ns..(r + 1) * ns]);
        }
        out
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
/// * `max_len` (samples) bounds the length of a segment: only the runs of the [`Band`] of
///   `max_len` are scored and stored (longer runs read `-inf`); `0` = no bound.
pub fn score_table<M: PrefixScorer>(
    models: &[Vec<M>],
    groups: &[Range<usize>],
    observations: &DMatrix<f64>,
    boundaries: &[usize],
    max_len: usize,
) -> Result<ScoreTable> {
    let counts: Vec<usize> = models.iter().map(Vec::len).collect();
    check_score_inputs(&counts, groups, observations, boundaries)?;
    let band = Band::new(boundaries.to_vec(), max_len)?;
    let k = band.n_sections();
    let jobs: Vec<(usize, usize)> = (0..k)
        .flat_map(|i| (0..models.len()).map(move |s| (i, s)))
        .collect();
    let results: Vec<Result<(usize, usize, Vec<f64>)>> = jobs
        .par_iter()
        .map(|&(i, s)| {
            let start = boundaries[i];
            let last = band.last_end(i);
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
    let mut table = ScoreTable::with_band(band, models.len())?;
    for r in results {
        let (i, s, sums) = r?;
        table.set_band_row(i, s, sums);
    }
    Ok(table)
}

impl ScoreTable {
    /// Store `sum(r, s)` for the rows `rows` and every skill `s` (NaN -> `-inf`), the rows
    /// shared out among the threads.
    pub(super) fn set_band_rows(
        &mut self,
        rows: Range<usize>,
        sum: impl Fn(usize, usize) -> f64 + Sync,
    ) {
        const CHUNK: usize = 4096;
        let ns = self.n_skills;
        self.total[rows.start * ns..rows.end * ns]
            .par_chunks_mut(CHUNK * ns)
            .enumerate()
            .for_each(|(c, chunk)| {
                for (k, row) in chunk.chunks_exact_mut(ns).enumerate() {
                    let r = rows.start + c * CHUNK + k;
                    for (s, out) in row.iter_mut().enumerate() {
                        let v = sum(r, s);
                        *out = if v.is_nan() { f64::NEG_INFINITY } else { v };
                    }
                }
            });
    }

    /// Store the sums of the runs `i..i + 1 ..= last_end(i)` of skill `s` (NaN -> `-inf`).
    pub(super) fn set_band_row(&mut self, i: usize, s: usize, sums: Vec<f64>) {
        let first = self.band.offsets[i];
        debug_assert_eq!(sums.len(), self.band.offsets[i + 1] - first);
        for (off, v) in sums.into_iter().enumerate() {
            self.total[(first + off) * self.n_skills + s] =
                if v.is_nan() { f64::NEG_INFINITY } else { v };
        }
    }
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
/// samples are skipped). Cost `O(K n)` and `K (K + 1)` entries: for small inputs; the
/// segmentation uses [`rising_band`].
pub fn rising_table(z: &[f64], boundaries: &[usize], params: RiseParams) -> Result<Vec<bool>> {
    check_rise_boundaries(z.len(), boundaries)?;
    let band = Band::new(boundaries.to_vec(), 0)?;
    let k = band.n_sections();
    let mut out = vec![false; k * (k + 1)];
    for ((i, j), r) in band.runs().zip(rising_band(z, &band, params)?) {
        out[i * (k + 1) + j] = r;
    }
    Ok(out)
}

fn check_rise_boundaries(n: usize, boundaries: &[usize]) -> Result<()> {
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
    Ok(())
}

/// Is the TCP rising over each run of `band` (flat run order, `N` entries)? See
/// [`rising_table`]; cost `O(N + sum of the runs' longest lengths)`, linear in the
/// demonstration's length for a bounded band.
pub fn rising_band(z: &[f64], band: &Band, params: RiseParams) -> Result<Vec<bool>> {
    let boundaries = band.boundaries();
    check_rise_boundaries(z.len(), boundaries)?;
    let mut out = vec![false; band.n_runs()];
    for i in 0..band.n_sections() {
        let mut rise = RiseState::default();
        let (first, last) = (band.offsets()[i], band.last_end(i));
        let mut j = i + 1;
        for (t, &v) in z.iter().enumerate().skip(boundaries[i]) {
            rise.push(v);
            if t + 1 == boundaries[j] {
                out[first + j - i - 1] = rise.rising(params);
                j += 1;
                if j > last {
                    break;
                }
            }
        }
    }
    Ok(out)
}

/// The TCP rise decision of a run growing one sample at a time (the state of [`rising_band`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct RiseState {
    low: f64,
    drawup: f64,
    up: f64,
    down: f64,
    prev: f64,
}

impl Default for RiseState {
    fn default() -> Self {
        Self {
            low: f64::INFINITY,
            drawup: 0.0,
            up: 0.0,
            down: 0.0,
            prev: f64::NAN,
        }
    }
}

impl RiseState {
    /// Add the TCP height of the next sample (NaN is skipped).
    pub(crate) fn push(&mut self, v: f64) {
        if v.is_finite() {
            self.low = self.low.min(v);
            self.drawup = self.drawup.max(v - self.low);
            if self.prev.is_finite() {
                self.up += (v - self.prev).max(0.0);
                self.down += (self.prev - v).max(0.0);
            }
            self.prev = v;
        }
    }

    /// Is the run so far rising?
    pub(crate) fn rising(&self, params: RiseParams) -> bool {
        self.drawup >= params.min_rise && self.up >= params.dominance * self.down
    }
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
        // the raw entries, taken out of the table, are its slice
        let raw = t.as_slice().to_vec();
        assert_eq!(t.into_values(), raw);
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

    #[test]
    fn band_holds_the_runs_that_fit() {
        // sections of 3, 4, 5, 2 samples; max 7: 0..2 (7) fits, 0..3 (12) not; 2..3 (5) alone;
        // 2..4 (7) fits
        let band = Band::new(vec![0, 3, 7, 12, 14], 7).unwrap();
        assert_eq!(band.n_sections(), 4);
        let ends: Vec<_> = (0..4).map(|i| band.ends(i)).collect();
        assert_eq!(ends, vec![1..3, 2..3, 3..5, 4..5]);
        assert_eq!(band.n_runs(), 6);
        assert_eq!(band.offsets(), &[0, 2, 3, 5, 6]);
        let runs: Vec<_> = band.runs().collect();
        assert_eq!(runs, vec![(0, 1), (0, 2), (1, 2), (2, 3), (2, 4), (3, 4)]);
        for (r, &(i, j)) in runs.iter().enumerate() {
            assert_eq!(band.index(i, j), Some(r));
        }
        assert_eq!(band.index(0, 3), None);
        assert_eq!(band.index(1, 1), None);
        assert_eq!(band.index(2, 1), None);
        assert_eq!(band.index(3, 5), None);
        assert_eq!(band.starts(1), 0..1);
        assert_eq!(band.starts(2), 0..2);
        assert_eq!(band.starts(3), 2..3); // 1..3 (9 samples) is too long
        assert_eq!(band.starts(4), 2..4);
        // a section longer than the bound is still a run on its own
        let b = Band::new(vec![0, 10, 11], 5).unwrap();
        assert_eq!(b.runs().collect::<Vec<_>>(), vec![(0, 1), (1, 2)]);
        // no bound: every run
        let all = Band::new(vec![0, 3, 7, 12, 14], 0).unwrap();
        assert_eq!(all.n_runs(), 10);
        assert!(Band::new(vec![0], 3).is_err());
        assert!(Band::new(vec![0, 2, 2], 3).is_err());
    }

    #[test]
    fn table_reads_minus_infinity_outside_its_band() {
        let band = Band::new(vec![0, 3, 7, 12, 14], 7).unwrap();
        let mut t =
            ScoreTable::from_band_fn(band.clone(), 2, |i, j, s| (10 * i + j + s) as f64).unwrap();
        assert_eq!(t.as_slice().len(), 6 * 2);
        assert_eq!(t.total(2, 4, 1).to_bits(), 25.0f64.to_bits());
        assert_eq!(t.total(0, 3, 0).to_bits(), f64::NEG_INFINITY.to_bits());
        assert_eq!(t.total(3, 2, 0).to_bits(), f64::NEG_INFINITY.to_bits());
        t.set(0, 3, 0, f64::NEG_INFINITY); // what it holds there: allowed
        t.set(0, 2, 1, -1.5);
        assert_eq!(t.total(0, 2, 1).to_bits(), (-1.5f64).to_bits());
        let dense = t.to_dense();
        assert_eq!(dense.len(), 4 * 5 * 2);
        assert_eq!(dense[(2 * 5 + 4) * 2 + 1].to_bits(), 25.0f64.to_bits());
        assert_eq!(dense[(5 + 4) * 2].to_bits(), f64::NEG_INFINITY.to_bits());
        let back = ScoreTable::from_entries(band.clone(), 2, t.as_slice().to_vec()).unwrap();
        assert_eq!(back, t);
        assert!(matches!(
            ScoreTable::from_entries(band, 2, vec![0.0; 5]),
            Err(EngineError::ShapeMismatch(_))
        ));
    }

    #[test]
    #[should_panic(expected = "outside the score table's band")]
    fn setting_a_score_outside_the_band_panics() {
        let mut t = ScoreTable::with_band(Band::new(vec![0, 3, 7, 12], 7).unwrap(), 1).unwrap();
        t.set(0, 3, 0, -1.0);
    }

    /// The dense `(K, K + 1, S)` table as `score_table` built it before the band (reference).
    fn dense_reference<M: PrefixScorer>(
        models: &[Vec<M>],
        groups: &[Range<usize>],
        obs: &DMatrix<f64>,
        b: &[usize],
        max_len: usize,
    ) -> Vec<f64> {
        let (n, k, ns) = (obs.nrows(), b.len() - 1, models.len());
        let max_len = if max_len == 0 { n } else { max_len };
        let mut out = vec![f64::NEG_INFINITY; k * (k + 1) * ns];
        for i in 0..k {
            for (s, row) in models.iter().enumerate() {
                let mut last = i + 1;
                while last < k && b[last + 1] - b[i] <= max_len {
                    last += 1;
                }
                let len = b[last] - b[i];
                let mut sums = vec![0.0; last - i];
                for (g, model) in groups.iter().zip(row) {
                    let x = obs.view((b[i], g.start), (len, g.len())).into_owned();
                    let prefix = model.prefix_scores(&x).unwrap();
                    for (slot, j) in sums.iter_mut().zip(i + 1..=last) {
                        *slot += prefix[b[j] - b[i] - 1];
                    }
                }
                for (off, v) in sums.into_iter().enumerate() {
                    out[(i * (k + 1) + i + 1 + off) * ns + s] = v;
                }
            }
        }
        out
    }

    /// The dense rise table as `rising_table` computed it before the band (reference).
    fn dense_rising(z: &[f64], b: &[usize], p: RiseParams) -> Vec<bool> {
        let k = b.len() - 1;
        let mut out = vec![false; k * (k + 1)];
        for i in 0..k {
            let (mut low, mut drawup, mut up, mut down) = (f64::INFINITY, 0.0_f64, 0.0, 0.0);
            let mut prev = f64::NAN;
            let mut j = i + 1;
            for (t, &v) in z.iter().enumerate().skip(b[i]) {
                if v.is_finite() {
                    low = low.min(v);
                    drawup = drawup.max(v - low);
                    if prev.is_finite() {
                        up += (v - prev).max(0.0);
                        down += (prev - v).max(0.0);
                    }
                    prev = v;
                }
                if t + 1 == b[j] {
                    out[i * (k + 1) + j] = drawup >= p.min_rise && up >= p.dominance * down;
                    j += 1;
                    if j > k {
                        break;
                    }
                }
            }
        }
        out
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]

        /// The banded table holds exactly the dense table's entries (bit for bit), reads
        /// `-inf` everywhere else, and the rise decisions and both searches agree with the
        /// unbounded (dense) layout.
        #[test]
        fn banded_table_matches_the_dense_reference(
            lens in proptest::collection::vec(1usize..9, 1..28),
            max_len in 0usize..40,
            mus in proptest::collection::vec(-1.0f64..2.0, 14),
            seed in 0u64..1000,
            dominance in 0.0f64..2.0,
            penalty in 0.0f64..5.0,
            enforce in proptest::bool::ANY,
        ) {
            use crate::segment::grammar::tests::paper_grammar;
            use crate::segment::{dp::dp, greedy::greedy, GrammarMode};
            let mut b = vec![0];
            for l in &lens {
                b.push(b[b.len() - 1] + l);
            }
            let (n, k) = (b[b.len() - 1], lens.len());
            let obs = DMatrix::from_fn(n, 2, |t, c| {
                (((t as u64 * 7919 + c as u64 * 104_729 + seed) % 1000) as f64) / 500.0
            });
            let models: Vec<Vec<Quadratic>> = (0..7)
                .map(|s| vec![Quadratic(mus[2 * s]), Quadratic(mus[2 * s + 1])])
                .collect();
            let groups = [0..1, 1..2];
            let t = score_table(&models, &groups, &obs, &b, max_len).unwrap();
            let want = dense_reference(&models, &groups, &obs, &b, max_len);
            proptest::prop_assert_eq!(t.to_dense(), want.clone());
            for i in 0..=k {
                for j in 0..=k {
                    for s in 0..7 {
                        let w = if i < j { want[(i * (k + 1) + j) * 7 + s] } else { f64::NEG_INFINITY };
                        proptest::prop_assert_eq!(t.total(i, j, s).to_bits(), w.to_bits());
                    }
                }
            }
            // memory: the band's runs, never more than every run
            proptest::prop_assert!(t.as_slice().len() <= k * (k + 1) / 2 * 7);
            if max_len > 0 {
                let fits = (0..k)
                    .flat_map(|i| (i + 1..=k).map(move |j| (i, j)))
                    .filter(|&(i, j)| j == i + 1 || b[j] - b[i] <= max_len)
                    .count();
                proptest::prop_assert_eq!(t.band().n_runs(), fits);
            }
            // the rise decision on the band is the dense one's
            let z: Vec<f64> = (0..n)
                .map(|x| if (x as u64 + seed) % 11 == 0 { f64::NAN } else { obs[(x, 0)] * 0.05 })
                .collect();
            let p = RiseParams { min_rise: 0.02, dominance };
            let dense_r = dense_rising(&z, &b, p);
            proptest::prop_assert_eq!(rising_table(&z, &b, p).unwrap(), dense_r.clone());
            let banded_r = rising_band(&z, t.band(), p).unwrap();
            let runs: Vec<(usize, usize)> = t.band().runs().collect();
            for (&(i, j), &r) in runs.iter().zip(&banded_r) {
                proptest::prop_assert_eq!(r, dense_r[i * (k + 1) + j]);
            }
            // the searches see the same candidates in both layouts
            let full = ScoreTable::from_fn(b.clone(), 7, |i, j, s| want[(i * (k + 1) + j) * 7 + s]).unwrap();
            let full_r: Vec<bool> = full.band().runs().map(|(i, j)| dense_r[i * (k + 1) + j]).collect();
            let g = paper_grammar();
            let mode = if enforce { GrammarMode::Enforce } else { GrammarMode::Warn };
            for rising in [false, true] {
                let (rb, rf) = if rising {
                    (Some(banded_r.as_slice()), Some(full_r.as_slice()))
                } else {
                    (None, None)
                };
                proptest::prop_assert_eq!(
                    dp(&t, &g, rb, mode, penalty).unwrap(),
                    dp(&full, &g, rf, mode, penalty).unwrap()
                );
                for lookahead in [false, true] {
                    proptest::prop_assert_eq!(
                        greedy(&t, &g, rb, mode, lookahead).unwrap(),
                        greedy(&full, &g, rf, mode, lookahead).unwrap()
                    );
                }
            }
        }
    }
}
