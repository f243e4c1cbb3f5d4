//! Fast score tables for template sets: emissions computed once per skill x feature over the
//! whole demonstration, then one scaled forward pass per (start section, skill, feature).
//!
//! Two scores per prefix are available ([`EndState`]):
//! * [`EndState::Any`]: `ln P(x_0..=t)` (Eq. 3, the model may be in any state at `t`);
//! * [`EndState::Final`]: `ln P(x_0..=t, q_t = last state)`: the prefix must be a *complete*
//!   execution of the skill, which for left-right templates stops a fragment of a skill (only
//!   the reach of a Pick up, say) from scoring as well as the whole skill.

use std::ops::Range;

use nalgebra::DMatrix;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::scores::{check_score_inputs, Band, ScoreTable};
use crate::error::{EngineError, Result};
#[cfg(test)]
use crate::hmm::CovarianceType;
use crate::hmm::{Emission, Hmm};

/// Which states may end a segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum EndState {
    /// Any state (the plain forward likelihood).
    Any,
    /// Only the last state of the left-right chain.
    #[default]
    Final,
}

crate::option_enum!(EndState, "end", [Any => "any", Final => "final"]);

/// An [`Hmm`] prepared for fast scoring.
#[derive(Debug, Clone)]
pub struct CompiledHmm {
    n: usize,
    start: Vec<f64>,
    /// `trans[j * n + i] = P(j | i)` (column-major transition matrix: row `j` holds the
    /// probabilities of entering `j`).
    trans: Vec<f64>,
    /// The model's emission constants (Cholesky factors, inverses and log-determinants are
    /// computed once, by the engine's [`Hmm`]).
    emission: Emission,
    /// For each state `j`, the range `lo..hi` of states `i` with `P(j | i) > 0` (left-right
    /// chains are banded).
    band: Vec<(usize, usize)>,
}

impl CompiledHmm {
    /// Precompute the constants of `hmm` (the emission constants are shared with it).
    pub fn new(hmm: &Hmm) -> Result<Self> {
        let n = hmm.n_states();
        let emission = hmm.emission.clone();
        let trans: Vec<f64> = hmm.transmat().iter().copied().collect();
        let band = (0..n)
            .map(|j| {
                let row = &trans[j * n..(j + 1) * n];
                let lo = row.iter().position(|&p| p > 0.0).unwrap_or(0);
                let hi = row.iter().rposition(|&p| p > 0.0).map_or(0, |i| i + 1);
                (lo, hi.max(lo))
            })
            .collect();
        Ok(Self {
            n,
            start: hmm.startprob().iter().copied().collect(),
            trans,
            emission,
            band,
        })
    }

    /// `ln p(x_t | state)` for every row of `x` (only the `cols` columns), row-major `T x n`.
    #[cfg(test)]
    fn log_emissions(&self, x: &DMatrix<f64>, cols: &Range<usize>) -> Vec<f64> {
        let sub = x.columns(cols.start, cols.len()).into_owned();
        let (mut comp, mut logb) = (Vec::new(), Vec::new());
        self.emission.log_emissions(&sub, &mut comp, &mut logb);
        logb
    }

    /// Prefix scores of the sequence whose emission table is `logb` (`T x n`, row-major).
    ///
    /// Scaled forward recursion: each step's emissions are divided by their maximum; if that
    /// underflows (every reachable state far less likely than an unreachable one), the step is
    /// redone with the maximum taken over `ln b_j + ln pred_j`, which cannot underflow.
    #[cfg(test)]
    fn prefix(&self, logb: &[f64], end: EndState, out: &mut Vec<f64>) {
        let n = self.n;
        let t_len = logb.len() / n;
        out.clear();
        let mut alpha = vec![0.0; n];
        let mut pred = vec![0.0; n];
        let mut next = vec![0.0; n];
        let mut log_scale = 0.0;
        for t in 0..t_len {
            let row = &logb[t * n..(t + 1) * n];
            if t == 0 {
                pred.copy_from_slice(&self.start);
            } else {
                for (j, p) in pred.iter_mut().enumerate() {
                    let tr = &self.trans[j * n..(j + 1) * n];
                    *p = alpha.iter().zip(tr).map(|(a, q)| a * q).sum();
                }
            }
            let mut hi = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let mut sum = 0.0;
            if hi.is_finite() {
                for j in 0..n {
                    next[j] = pred[j] * (row[j] - hi).exp();
                }
                sum = next.iter().sum();
            }
            if !(sum > 1e-250 && sum.is_finite()) {
                hi = (0..n)
                    .filter(|&j| pred[j] > 0.0)
                    .map(|j| row[j] + pred[j].ln())
                    .fold(f64::NEG_INFINITY, f64::max);
                if !hi.is_finite() {
                    out.resize(t_len, f64::NEG_INFINITY);
                    return;
                }
                for j in 0..n {
                    next[j] = if pred[j] > 0.0 {
                        (row[j] + pred[j].ln() - hi).exp()
                    } else {
                        0.0
                    };
                }
                sum = next.iter().sum();
            }
            log_scale += hi + sum.ln();
            for j in 0..n {
                alpha[j] = next[j] / sum;
            }
            out.push(match end {
                EndState::Any => log_scale,
                EndState::Final => log_scale + alpha[n - 1].ln(),
            });
        }
    }

    /// Log-space forward (reference for the tests).
    #[cfg(test)]
    fn prefix_log(&self, logb: &[f64], end: EndState, out: &mut Vec<f64>) {
        let n = self.n;
        let t_len = logb.len() / n;
        out.clear();
        let log_start: Vec<f64> = self.start.iter().map(|p| p.ln()).collect();
        let log_trans: Vec<f64> = self.trans.iter().map(|p| p.ln()).collect();
        let mut alpha: Vec<f64> = (0..n).map(|j| log_start[j] + logb[j]).collect();
        let mut tmp = vec![0.0; n];
        for t in 0..t_len {
            if t > 0 {
                let mut next = vec![0.0; n];
                for j in 0..n {
                    for i in 0..n {
                        tmp[i] = alpha[i] + log_trans[j * n + i];
                    }
                    next[j] = logsumexp(&tmp) + logb[t * n + j];
                }
                alpha = next;
            }
            out.push(match end {
                EndState::Any => logsumexp(&alpha),
                EndState::Final => alpha[n - 1],
            });
        }
    }
}

/// Emissions of one model over a whole demonstration, scaled for the forward recursion:
/// `b[t * n + j] = exp(logb - shift[t])`, `shift[t] = max_j logb[t * n + j]`.
struct Scaled {
    b: Vec<f64>,
    shift: Vec<f64>,
}

impl Scaled {
    /// From an emission log table (`T x n`).
    #[cfg(test)]
    fn new(logb: &[f64], n: usize) -> Self {
        let t_len = logb.len() / n;
        let mut b = vec![0.0; logb.len()];
        let mut shift = vec![0.0; t_len];
        for t in 0..t_len {
            let row = &logb[t * n..(t + 1) * n];
            let hi = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            shift[t] = hi;
            if hi.is_finite() {
                for j in 0..n {
                    b[t * n + j] = (row[j] - hi).exp();
                }
            }
        }
        Self { b, shift }
    }

    /// Directly from the model, for the samples `rows` of `x` (entry `t` is sample
    /// `rows.start + t`): `b[t, j] = sum_m exp(ln w_jm N_jm(x_t) - shift[t])` with `shift[t]` the
    /// largest component term, so no logarithm is taken per sample ([`Emission::scaled_block`],
    /// vectorised). Each sample's entries depend on that sample only.
    fn direct(m: &CompiledHmm, x: &DMatrix<f64>, rows: Range<usize>, cols: &Range<usize>) -> Self {
        let (t_all, t_len, n) = (x.nrows(), rows.len(), m.n);
        let data = &x.as_slice()[cols.start * t_all..cols.end * t_all];
        let mut b = vec![0.0; t_len * n];
        let mut shift = vec![0.0; t_len];
        if t_len == 0 {
            return Self { b, shift };
        }
        let mut comp = vec![0.0; m.emission.n_components() * t_len];
        let mut sm = vec![0.0; t_len * n];
        m.emission.scaled_block(
            data, t_all, rows.start, t_len, &mut comp, &mut sm, &mut shift,
        );
        for (j, col) in sm.chunks_exact(t_len).enumerate() {
            for (t, &v) in col.iter().enumerate() {
                b[t * n + j] = v;
            }
        }
        Self { b, shift }
    }
}

/// The scaled forward recursion of one [`CompiledHmm`] from a start sample, advanced one sample
/// at a time: the state of the batch pass ([`CompiledHmm::add_prefix_at`]) and of the online
/// segmenter (`super::online`), so both compute the same numbers.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ForwardState {
    alpha: [f64; 16],
    log_acc: f64,
    prod: f64,
    /// Samples consumed.
    steps: usize,
    /// Every state impossible: the prefix score is `-inf` from now on.
    dead: bool,
}

impl Default for ForwardState {
    fn default() -> Self {
        Self {
            alpha: [0.0; 16],
            log_acc: 0.0,
            prod: 1.0,
            steps: 0,
            dead: false,
        }
    }
}

impl ForwardState {
    /// Consume one sample: `bt` its scaled emissions (`n` values), `shift` their scale.
    pub(crate) fn step(&mut self, m: &CompiledHmm, bt: &[f64], shift: f64) {
        if self.dead {
            return;
        }
        let n = m.n;
        let mut next = [0.0f64; 16];
        let mut pred = [0.0f64; 16];
        let (alpha, next, pred) = (&mut self.alpha[..n], &mut next[..n], &mut pred[..n]);
        if self.steps == 0 {
            pred.copy_from_slice(&m.start);
        } else {
            for (j, p) in pred.iter_mut().enumerate() {
                let (lo, hi) = m.band[j];
                let tr = &m.trans[j * n + lo..j * n + hi];
                *p = alpha[lo..hi].iter().zip(tr).map(|(a, q)| a * q).sum();
            }
        }
        self.steps += 1;
        let mut sum = 0.0;
        for j in 0..n {
            next[j] = pred[j] * bt[j];
            sum += next[j];
        }
        let mut hi = shift;
        if !(sum > 1e-250 && sum.is_finite()) {
            // ln b_j (relative to shift) + ln pred_j; b_j = 0 counts as impossible
            let row: Vec<f64> = bt.iter().map(|v| shift + v.ln()).collect();
            hi = (0..n)
                .filter(|&j| pred[j] > 0.0 && bt[j] > 0.0)
                .map(|j| row[j] + pred[j].ln())
                .fold(f64::NEG_INFINITY, f64::max);
            if !hi.is_finite() {
                self.dead = true;
                return;
            }
            sum = 0.0;
            for j in 0..n {
                next[j] = if pred[j] > 0.0 {
                    (row[j] + pred[j].ln() - hi).exp()
                } else {
                    0.0
                };
                sum += next[j];
            }
        }
        self.log_acc += hi;
        let inv = 1.0 / sum;
        for j in 0..n {
            alpha[j] = next[j] * inv;
        }
        self.prod *= sum;
        if !(1e-200..=1e200).contains(&self.prod) {
            self.log_acc += self.prod.ln();
            self.prod = 1.0;
        }
    }

    /// The prefix score of the samples consumed so far (`-inf` once impossible).
    pub(crate) fn value(&self, m: &CompiledHmm, end: EndState) -> f64 {
        if self.dead {
            return f64::NEG_INFINITY;
        }
        let base = self.log_acc + self.prod.ln();
        match end {
            EndState::Any => base,
            EndState::Final => base + self.alpha[m.n - 1].ln(),
        }
    }

    /// No state possible any more.
    pub(crate) fn is_dead(&self) -> bool {
        self.dead
    }
}

impl CompiledHmm {
    /// Number of states.
    pub(crate) fn n_states(&self) -> usize {
        self.n
    }

    /// Scaled emissions (`b`, `n` values) and their scale (`shift`) of one sample, `x` its
    /// observation columns (the per-sample entries of [`Scaled::direct`]).
    /// `comp` is scratch.
    pub(crate) fn scaled_emission(&self, x: &[f64], b: &mut [f64], comp: &mut Vec<f64>) -> f64 {
        let mut shift = [0.0];
        comp.resize(self.emission.n_components(), 0.0);
        self.emission
            .scaled_block(x, 1, 0, 1, comp, &mut b[..self.n], &mut shift);
        shift[0]
    }

    /// Prefix scores at the requested ends only: `ends` are sample offsets (ascending) from
    /// `start`; adds the score at each end to `sums`. `ln` is taken only at the ends.
    fn add_prefix_at(
        &self,
        em: &Scaled,
        start: usize,
        ends: &[usize],
        end: EndState,
        sums: &mut [f64],
    ) {
        let n = self.n;
        let Some(&last) = ends.last() else { return };
        let mut state = ForwardState::default();
        let mut e = 0;
        for k in 0..=last {
            let t = start + k;
            state.step(self, &em.b[t * n..(t + 1) * n], em.shift[t]);
            if state.is_dead() {
                for slot in &mut sums[e..] {
                    *slot = f64::NEG_INFINITY;
                }
                return;
            }
            while e < ends.len() && ends[e] == k {
                sums[e] += state.value(self, end);
                e += 1;
            }
        }
    }
}

#[cfg(test)]
fn logsumexp(v: &[f64]) -> f64 {
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !hi.is_finite() {
        return hi;
    }
    hi + v.iter().map(|x| (x - hi).exp()).sum::<f64>().ln()
}

/// The score table of `observations` (normalised, `n x C`) under `models[skill][feature]`
/// reading the column `groups[feature]`; see [`super::scores::score_table`] for the layout.
pub fn compiled_score_table(
    models: &[Vec<CompiledHmm>],
    groups: &[Range<usize>],
    observations: &DMatrix<f64>,
    boundaries: &[usize],
    max_len: usize,
    end: EndState,
) -> Result<ScoreTable> {
    let block = if max_len == 0 {
        usize::MAX
    } else {
        EMISSION_BLOCK.max(4 * max_len)
    };
    blocked_score_table(
        models,
        groups,
        observations,
        boundaries,
        max_len,
        end,
        block,
    )
}

/// [`compiled_score_table`] with start sections scored in blocks of about `block` samples: the
/// emissions of a block's samples (and of the runs reaching past it) are computed once per
/// (skill, feature) and dropped after the block, so memory stays bounded however long the
/// demonstration. The entries do not depend on `block`.
fn blocked_score_table(
    models: &[Vec<CompiledHmm>],
    groups: &[Range<usize>],
    observations: &DMatrix<f64>,
    boundaries: &[usize],
    max_len: usize,
    end: EndState,
    block: usize,
) -> Result<ScoreTable> {
    let counts: Vec<usize> = models.iter().map(Vec::len).collect();
    check_score_inputs(&counts, groups, observations, boundaries)?;
    if models.iter().flatten().any(|m| m.n > 16) {
        return Err(EngineError::InvalidParameter(
            "at most 16 states per template HMM".into(),
        ));
    }
    let band = Band::new(boundaries.to_vec(), max_len)?;
    let k = band.n_sections();
    let mut table = ScoreTable::with_band(band, models.len())?;
    let pairs: Vec<(usize, usize)> = (0..models.len())
        .flat_map(|s| (0..groups.len()).map(move |f| (s, f)))
        .collect();
    let mut i0 = 0;
    while i0 < k {
        let mut i1 = i0 + 1;
        while i1 < k && boundaries[i1] - boundaries[i0] < block {
            i1 += 1;
        }
        // last_end never decreases: the block's last start reaches furthest
        let (lo, hi) = (boundaries[i0], boundaries[table.band().last_end(i1 - 1)]);
        let emissions: Vec<Scaled> = pairs
            .par_iter()
            .map(|&(s, f)| Scaled::direct(&models[s][f], observations, lo..hi, &groups[f]))
            .collect();
        let band = table.band();
        let jobs: Vec<(usize, usize)> = (i0..i1)
            .flat_map(|i| (0..models.len()).map(move |s| (i, s)))
            .collect();
        let results: Vec<(usize, usize, Vec<f64>)> = jobs
            .par_iter()
            .map(|&(i, s)| {
                let start = boundaries[i];
                let ends: Vec<usize> = band.ends(i).map(|j| boundaries[j] - start - 1).collect();
                let mut sums = vec![0.0; ends.len()];
                for f in 0..groups.len() {
                    models[s][f].add_prefix_at(
                        &emissions[s * groups.len() + f],
                        start - lo,
                        &ends,
                        end,
                        &mut sums,
                    );
                }
                (i, s, sums)
            })
            .collect();
        for (i, s, sums) in results {
            table.set_band_row(i, s, sums);
        }
        i0 = i1;
    }
    Ok(table)
}

/// Start sections are scored in blocks of at least this many samples (and 4 maximum segment
/// lengths), each with the emissions of its own samples only.
const EMISSION_BLOCK: usize = 8192;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hmm::{FitConfig, Topology};

    fn model(cov: CovarianceType, d: usize) -> Hmm {
        let seqs: Vec<DMatrix<f64>> = (0..5)
            .map(|k| {
                DMatrix::from_fn(30 + k, d, |t, c| {
                    (t as f64 / 10.0).sin() + 0.1 * c as f64 + 0.01 * ((t * 7 + k * 3) % 5) as f64
                })
            })
            .collect();
        let cfg = FitConfig {
            n_states: 3,
            n_mix: 2,
            covariance: cov,
            topology: Topology::LeftRight,
            max_iter: 10,
            ..FitConfig::default()
        };
        Hmm::fit(&seqs, &cfg).unwrap().0
    }

    #[test]
    fn any_end_matches_engine_prefix_scores() {
        for (cov, d) in [
            (CovarianceType::Diag, 1),
            (CovarianceType::Diag, 2),
            (CovarianceType::Full, 2),
        ] {
            let hmm = model(cov, d);
            let c = CompiledHmm::new(&hmm).unwrap();
            // a sine with a far outlier at t = 20 (forces the underflow-safe step)
            let x = DMatrix::from_fn(40, d, |t, k| {
                (t as f64 / 9.0).sin() + 0.1 * k as f64 + if t == 20 { 40.0 } else { 0.0 }
            });
            let want = hmm.prefix_log_likelihoods(&x).unwrap();
            let lb = c.log_emissions(&x, &(0..d));
            let mut got = Vec::new();
            c.prefix(&lb, EndState::Any, &mut got);
            for t in 0..40 {
                assert!(
                    (got[t] - want[t]).abs() < 1e-8 * want[t].abs().max(1.0),
                    "{cov:?} t={t}"
                );
            }
            // log-space path agrees, and ending in the last state is never more likely
            let mut slow = Vec::new();
            c.prefix_log(&lb, EndState::Any, &mut slow);
            let mut fin = Vec::new();
            c.prefix(&lb, EndState::Final, &mut fin);
            for t in 0..40 {
                assert!((slow[t] - got[t]).abs() < 1e-8 * got[t].abs().max(1.0));
                assert!(fin[t] <= got[t] + 1e-9);
            }
            // the boundary-only pass gives the same numbers at the ends
            let em = Scaled::direct(&c, &x, 0..x.nrows(), &(0..d));
            let em_ref = Scaled::new(&lb, c.n);
            assert!(em
                .shift
                .iter()
                .zip(&em_ref.shift)
                .all(|(a, b)| (a - b).abs() < 1e-9 * a.abs().max(1.0) + (2.0f64).ln()));
            let ends = [0, 5, 19, 20, 39];
            for kind in [EndState::Any, EndState::Final] {
                let mut full = Vec::new();
                c.prefix(&lb, kind, &mut full);
                let mut sums = vec![0.0; ends.len()];
                c.add_prefix_at(&em, 0, &ends, kind, &mut sums);
                for (e, v) in ends.iter().zip(&sums) {
                    let w = full[*e];
                    assert!(
                        (v - w).abs() < 1e-8 * w.abs().max(1.0)
                            || (v.is_infinite() && w.is_infinite())
                    );
                }
            }
            // a 3-state left-right chain cannot be in its last state after one sample
            assert!(fin[0].is_infinite() || fin[0] < got[0]);
        }
    }

    #[test]
    fn emission_blocks_do_not_change_the_table() {
        let models = vec![
            vec![CompiledHmm::new(&model(CovarianceType::Diag, 2)).unwrap()],
            vec![CompiledHmm::new(&model(CovarianceType::Full, 2)).unwrap()],
        ];
        // a sine with far outliers (the underflow-safe step) over irregular sections
        let x = DMatrix::from_fn(300, 2, |t, k| {
            (t as f64 / 13.0).sin() + 0.1 * k as f64 + if t % 97 == 5 { 30.0 } else { 0.0 }
        });
        let mut b: Vec<usize> = (0..300).filter(|t| t % 7 == 0 || t % 11 == 0).collect();
        b.push(300);
        let bits = |t: &ScoreTable| t.as_slice().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let g: Vec<Range<usize>> = std::iter::once(0..2).collect();
        for max_len in [0, 20, 45] {
            for end in [EndState::Any, EndState::Final] {
                let whole =
                    blocked_score_table(&models, &g, &x, &b, max_len, end, usize::MAX).unwrap();
                assert!(whole.as_slice().iter().any(|v| v.is_finite()));
                for block in [1, 10, 64] {
                    let t = blocked_score_table(&models, &g, &x, &b, max_len, end, block).unwrap();
                    assert_eq!(bits(&t), bits(&whole), "max_len {max_len} block {block}");
                }
                let t = compiled_score_table(&models, &g, &x, &b, max_len, end).unwrap();
                assert_eq!(bits(&t), bits(&whole));
            }
        }
    }
}
