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

use super::scores::ScoreTable;
use crate::error::{EngineError, Result};
use crate::hmm::{CovarianceType, Hmm};

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

/// One Gaussian component with its precomputed constants.
#[derive(Debug, Clone)]
struct Component {
    /// `ln w - 0.5 (d ln 2 pi + ln det S)`.
    log_c: f64,
    mean: Vec<f64>,
    /// Lower-triangular `L^-1` with `S = L L^T`, row-major `d x d` (diag: only the diagonal
    /// `1 / sigma` is used).
    inv_chol: Vec<f64>,
    diag: bool,
}

impl Component {
    fn log_pdf(&self, x: &[f64]) -> f64 {
        let d = self.mean.len();
        let mut q = 0.0;
        if self.diag {
            for (k, (xk, mk)) in x.iter().zip(&self.mean).enumerate() {
                let z = (xk - mk) * self.inv_chol[k * d + k];
                q += z * z;
            }
        } else {
            for r in 0..d {
                let row = &self.inv_chol[r * d..=r * d + r];
                let z: f64 = row
                    .iter()
                    .zip(x)
                    .zip(&self.mean)
                    .map(|((l, xk), mk)| l * (xk - mk))
                    .sum();
                q += z * z;
            }
        }
        self.log_c - 0.5 * q
    }
}

/// An [`Hmm`] prepared for fast scoring.
#[derive(Debug, Clone)]
pub struct CompiledHmm {
    n: usize,
    start: Vec<f64>,
    /// `trans[j * n + i] = P(j | i)` (column-major transition matrix: row `j` holds the
    /// probabilities of entering `j`).
    trans: Vec<f64>,
    /// `n` states x `n_mix` components.
    comps: Vec<Vec<Component>>,
}

impl CompiledHmm {
    /// Precompute the constants of `hmm`.
    pub fn new(hmm: &Hmm) -> Result<Self> {
        let n = hmm.n_states();
        let d = hmm.n_features();
        let diag = hmm.covariance() == CovarianceType::Diag;
        let mut comps = Vec::with_capacity(n);
        for s in 0..n {
            let mut row = Vec::with_capacity(hmm.n_mix());
            for m in 0..hmm.n_mix() {
                let w = hmm.weights()[(s, m)];
                let cov = &hmm.covars()[s][m];
                let chol = cov.clone().cholesky().ok_or_else(|| {
                    EngineError::NotPositiveDefinite(format!("state {s} component {m}"))
                })?;
                let l = chol.l();
                let inv = l.clone().try_inverse().ok_or_else(|| {
                    EngineError::NotPositiveDefinite(format!("state {s} component {m}"))
                })?;
                let log_det: f64 = 2.0 * (0..d).map(|k| l[(k, k)].ln()).sum::<f64>();
                let mut inv_chol = vec![0.0; d * d];
                for r in 0..d {
                    for c in 0..d {
                        inv_chol[r * d + c] = inv[(r, c)];
                    }
                }
                row.push(Component {
                    log_c: w.ln() - 0.5 * (d as f64 * (2.0 * std::f64::consts::PI).ln() + log_det),
                    mean: hmm.means()[s].row(m).iter().copied().collect(),
                    inv_chol,
                    diag,
                });
            }
            comps.push(row);
        }
        Ok(Self {
            n,
            start: hmm.startprob().iter().copied().collect(),
            trans: hmm.transmat().iter().copied().collect(),
            comps,
        })
    }

    /// `ln p(x_t | state)` for every row of `x` (only the `cols` columns), row-major `T x n`.
    fn log_emissions(&self, x: &DMatrix<f64>, cols: &Range<usize>) -> Vec<f64> {
        let t_len = x.nrows();
        let mut out = vec![0.0; t_len * self.n];
        let mut row = vec![0.0; cols.len()];
        let mut tmp = Vec::new();
        for t in 0..t_len {
            for (k, c) in cols.clone().enumerate() {
                row[k] = x[(t, c)];
            }
            for s in 0..self.n {
                tmp.clear();
                tmp.extend(self.comps[s].iter().map(|c| c.log_pdf(&row)));
                out[t * self.n + s] = logsumexp(&tmp);
            }
        }
        out
    }

    /// Prefix scores of the sequence whose emission table is `logb` (`T x n`, row-major).
    fn prefix(&self, logb: &[f64], end: EndState, out: &mut Vec<f64>) {
        let n = self.n;
        let t_len = logb.len() / n;
        out.clear();
        let mut alpha = vec![0.0; n];
        let mut next = vec![0.0; n];
        let mut log_scale = 0.0;
        for t in 0..t_len {
            let row = &logb[t * n..(t + 1) * n];
            let hi = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if !hi.is_finite() {
                out.resize(t_len, f64::NEG_INFINITY);
                return;
            }
            if t == 0 {
                for j in 0..n {
                    next[j] = self.start[j] * (row[j] - hi).exp();
                }
            } else {
                for j in 0..n {
                    let tr = &self.trans[j * n..(j + 1) * n];
                    let s: f64 = alpha.iter().zip(tr).map(|(a, p)| a * p).sum();
                    next[j] = s * (row[j] - hi).exp();
                }
            }
            let sum: f64 = next.iter().sum();
            if !(sum > 1e-280 && sum.is_finite()) {
                // underflow: the rest of this run is (numerically) impossible; redo in log space
                self.prefix_log(logb, end, out);
                return;
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

    /// Log-space forward (slow path).
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
    let (n, nc) = observations.shape();
    if models.iter().any(|m| m.len() != groups.len()) || groups.iter().any(|g| g.end > nc) {
        return Err(EngineError::ShapeMismatch(format!(
            "models / feature groups do not fit {nc} observation columns"
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
    let mut table = ScoreTable::new(boundaries.to_vec(), models.len())?;
    let k = table.n_sections();
    let max_len = if max_len == 0 { n } else { max_len };
    // emissions once per (skill, feature) over the whole demonstration
    let pairs: Vec<(usize, usize)> = (0..models.len())
        .flat_map(|s| (0..groups.len()).map(move |f| (s, f)))
        .collect();
    let logb: Vec<Vec<f64>> = pairs
        .par_iter()
        .map(|&(s, f)| models[s][f].log_emissions(observations, &groups[f]))
        .collect();
    let jobs: Vec<(usize, usize)> = (0..k)
        .flat_map(|i| (0..models.len()).map(move |s| (i, s)))
        .collect();
    let results: Vec<(usize, usize, Vec<f64>)> = jobs
        .par_iter()
        .map(|&(i, s)| {
            let start = boundaries[i];
            let mut last = i + 1;
            while last < k && boundaries[last + 1] - start <= max_len {
                last += 1;
            }
            let len = boundaries[last] - start;
            let mut sums = vec![0.0; last - i];
            let mut out = Vec::with_capacity(len);
            for f in 0..groups.len() {
                let m = &models[s][f];
                let lb = &logb[s * groups.len() + f][start * m.n..(start + len) * m.n];
                m.prefix(lb, end, &mut out);
                for (slot, j) in sums.iter_mut().zip(i + 1..=last) {
                    *slot += out[boundaries[j] - start - 1];
                }
            }
            (i, s, sums)
        })
        .collect();
    for (i, s, sums) in results {
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
            let x = DMatrix::from_fn(40, d, |t, k| (t as f64 / 9.0).sin() + 0.1 * k as f64);
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
            // a 3-state left-right chain cannot be in its last state after one sample
            assert!(fin[0].is_infinite() || fin[0] < got[0]);
        }
    }
}
