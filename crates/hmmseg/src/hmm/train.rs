//! Baum-Welch (EM) over several sequences of different lengths.
//!
//! E-step: scaled forward-backward per sequence (log-space fallback), in parallel when the
//! work is large; the per-sequence statistics are summed in input order, so results do not
//! depend on the number of threads. M-step: maximum likelihood with the covariance floor as a
//! constraint. Transitions that are exactly zero stay exactly zero.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::config::{CovarianceType, FitConfig, FitReport};
use super::forward::{forward_backward, Workspace};
use super::init::initial_model;
use super::model::Hmm;
use super::moments::floor_covariance;
use super::validate::check_sequences;
use crate::error::{EngineError, Result};

/// Below this expected count a component keeps its previous mean and covariance.
const MIN_POSTERIOR: f64 = 1e-280;
/// Total `T * n * (n + n_mix * f)` above which the E-step runs sequences in parallel.
const PARALLEL_WORK: usize = 50_000;

/// Sufficient statistics of one or more sequences. Component sums are centred on the
/// component's current mean `c` for numerical stability: `obs = sum r (x - c)`,
/// `obs2 = sum r (x - c)(x - c)^T` (diag: only the diagonal).
struct Stats {
    ll: f64,
    start: Vec<f64>,
    trans: Vec<f64>,
    post: Vec<f64>,
    obs: Vec<f64>,
    obs2: Vec<f64>,
}

impl Stats {
    fn zeros(model: &Hmm) -> Self {
        let (n, k, f) = (
            model.n_states(),
            model.n_states() * model.n_mix(),
            model.n_features(),
        );
        let f2 = if model.covariance() == CovarianceType::Full {
            f * f
        } else {
            f
        };
        Self {
            ll: 0.0,
            start: vec![0.0; n],
            trans: vec![0.0; n * n],
            post: vec![0.0; k],
            obs: vec![0.0; k * f],
            obs2: vec![0.0; k * f2],
        }
    }

    fn add(&mut self, o: &Self) {
        self.ll += o.ll;
        for (a, b) in [
            (&mut self.start, &o.start),
            (&mut self.trans, &o.trans),
            (&mut self.post, &o.post),
            (&mut self.obs, &o.obs),
            (&mut self.obs2, &o.obs2),
        ] {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
    }
}

/// E-step of one sequence.
fn accumulate(model: &Hmm, x: &DMatrix<f64>, ws: &mut Workspace) -> Stats {
    let (n, m_count, f) = (model.n_states(), model.n_mix(), model.n_features());
    let t_len = x.nrows();
    let mut st = Stats::zeros(model);
    model.emission.log_emissions(x, &mut ws.comp, &mut ws.logb);
    st.ll = forward_backward(&model.chain, ws, Some(&mut st.trans));
    st.start.copy_from_slice(&ws.gamma[..n]);
    let data = x.as_slice();
    let mut r = vec![0.0; t_len];
    let mut diff = vec![0.0; f];
    for j in 0..n {
        for m in 0..m_count {
            let k = j * m_count + m;
            for (t, rt) in r.iter_mut().enumerate() {
                let g = ws.gamma[t * n + j];
                *rt = if m_count == 1 {
                    g
                } else {
                    let lb = ws.logb[t * n + j];
                    if g > 0.0 && lb.is_finite() {
                        g * (ws.comp[k * t_len + t] - lb).exp()
                    } else {
                        0.0
                    }
                };
            }
            st.post[k] = r.iter().sum();
            let c = model.emission.mean(k);
            match model.covariance() {
                CovarianceType::Diag => {
                    for d in 0..f {
                        let col = &data[d * t_len..(d + 1) * t_len];
                        let (mut s1, mut s2) = (0.0, 0.0);
                        for (&v, &rt) in col.iter().zip(&r) {
                            let z = v - c[d];
                            s1 += rt * z;
                            s2 += rt * z * z;
                        }
                        st.obs[k * f + d] = s1;
                        st.obs2[k * f + d] = s2;
                    }
                }
                CovarianceType::Full => {
                    let o2 = &mut st.obs2[k * f * f..(k + 1) * f * f];
                    for (t, &rt) in r.iter().enumerate() {
                        if rt == 0.0 {
                            continue;
                        }
                        for d in 0..f {
                            diff[d] = data[d * t_len + t] - c[d];
                            st.obs[k * f + d] += rt * diff[d];
                        }
                        for a in 0..f {
                            let ra = rt * diff[a];
                            for b in 0..=a {
                                o2[a * f + b] += ra * diff[b];
                            }
                        }
                    }
                }
            }
        }
    }
    st
}

/// E-step over all sequences, summed in input order.
fn e_step(model: &Hmm, seqs: &[DMatrix<f64>]) -> Stats {
    let work: usize = seqs.iter().map(DMatrix::nrows).sum::<usize>()
        * model.n_states()
        * (model.n_states() + model.n_mix() * model.n_features());
    let parts: Vec<Stats> = if seqs.len() > 1 && work > PARALLEL_WORK {
        seqs.par_iter()
            .map_init(Workspace::default, |ws, x| accumulate(model, x, ws))
            .collect()
    } else {
        let mut ws = Workspace::default();
        seqs.iter().map(|x| accumulate(model, x, &mut ws)).collect()
    };
    let mut total = Stats::zeros(model);
    for p in &parts {
        total.add(p);
    }
    total
}

/// M-step: the new model from the statistics (maximum likelihood under the floor).
fn m_step(model: &Hmm, st: &Stats, floor: f64) -> Result<Hmm> {
    let (n, m_count, f) = (model.n_states(), model.n_mix(), model.n_features());
    let cov_type = model.covariance();
    let s: f64 = st.start.iter().sum();
    let startprob = if s > 0.0 {
        DVector::from_iterator(n, st.start.iter().map(|v| v / s))
    } else {
        model.startprob().clone()
    };
    let mut transmat = model.transmat().clone();
    let mut weights = model.weights().clone();
    for i in 0..n {
        let row = &st.trans[i * n..(i + 1) * n];
        let s: f64 = row.iter().sum();
        if s > 0.0 {
            for j in 0..n {
                transmat[(i, j)] = row[j] / s;
            }
        }
        let post = &st.post[i * m_count..(i + 1) * m_count];
        let s: f64 = post.iter().sum();
        if s > 0.0 {
            for m in 0..m_count {
                weights[(i, m)] = post[m] / s;
            }
        }
    }
    let mut means = model.means().to_vec();
    let mut covars = model.covars().to_vec();
    for j in 0..n {
        for m in 0..m_count {
            let k = j * m_count + m;
            let post = st.post[k];
            if post < MIN_POSTERIOR {
                continue;
            }
            let c = model.emission.mean(k);
            let shift: Vec<f64> = (0..f).map(|d| st.obs[k * f + d] / post).collect();
            for d in 0..f {
                means[j][(m, d)] = c[d] + shift[d];
            }
            let cov = &mut covars[j][m];
            match cov_type {
                CovarianceType::Diag => {
                    for d in 0..f {
                        cov[(d, d)] = st.obs2[k * f + d] / post - shift[d] * shift[d];
                    }
                }
                CovarianceType::Full => {
                    let o2 = &st.obs2[k * f * f..(k + 1) * f * f];
                    for a in 0..f {
                        for b in 0..=a {
                            let v = o2[a * f + b] / post - shift[a] * shift[b];
                            cov[(a, b)] = v;
                            cov[(b, a)] = v;
                        }
                    }
                }
            }
            floor_covariance(cov, floor, cov_type);
        }
    }
    Hmm::from_params(startprob, transmat, weights, means, covars, cov_type).map_err(|e| {
        EngineError::NotConverged(format!(
            "the M-step produced invalid parameters ({e}); try a larger covariance_floor"
        ))
    })
}

/// EM iterations from `model` (hmmlearn's order: E-step, M-step, then the convergence test).
fn em(mut model: Hmm, seqs: &[DMatrix<f64>], config: &FitConfig) -> Result<(Hmm, FitReport)> {
    let mut report = FitReport {
        log_likelihood_history: Vec::new(),
        n_iter: 0,
        converged: false,
    };
    for _ in 0..config.max_iter {
        let stats = e_step(&model, seqs);
        if !stats.ll.is_finite() {
            return Err(EngineError::NotConverged(format!(
                "training log-likelihood became {} at iteration {}",
                stats.ll, report.n_iter
            )));
        }
        model = m_step(&model, &stats, config.covariance_floor)?;
        let h = &mut report.log_likelihood_history;
        h.push(stats.ll);
        report.n_iter += 1;
        if h.len() >= 2 && h[h.len() - 1] - h[h.len() - 2] < config.tol {
            report.converged = true;
            break;
        }
    }
    Ok((model, report))
}

impl Hmm {
    /// Train a new model on `sequences` (each `(n_samples, n_features)`, lengths may differ):
    /// seeded initialisation ([`FitConfig::topology`] decides how), then Baum-Welch.
    pub fn fit(sequences: &[DMatrix<f64>], config: &FitConfig) -> Result<(Hmm, FitReport)> {
        config.validate()?;
        let f = check_sequences(sequences, None)?;
        let total = sequences.iter().map(DMatrix::nrows).sum();
        let longest = sequences.iter().map(DMatrix::nrows).max().unwrap_or(0);
        config.validate_sizes(total, longest, f)?;
        let init = initial_model(sequences, f, config)?;
        em(init, sequences, config)
    }

    /// Baum-Welch starting from this model's parameters (no re-initialisation). Only
    /// `max_iter`, `tol` and `covariance_floor` of `config` are used.
    pub fn refit(
        &self,
        sequences: &[DMatrix<f64>],
        config: &FitConfig,
    ) -> Result<(Hmm, FitReport)> {
        config.validate_em()?;
        check_sequences(sequences, Some(self.n_features()))?;
        for x in sequences {
            self.check_work(x.nrows())?;
        }
        em(self.clone(), sequences, config)
    }

    /// One EM iteration: the updated model and the total log-likelihood of `sequences` under
    /// `self` (before the update).
    pub fn baum_welch_step(
        &self,
        sequences: &[DMatrix<f64>],
        covariance_floor: f64,
    ) -> Result<(Hmm, f64)> {
        let config = FitConfig {
            max_iter: 1,
            tol: f64::NEG_INFINITY,
            covariance_floor,
            ..FitConfig::default()
        };
        let (model, report) = self.refit(sequences, &config)?;
        Ok((model, report.log_likelihood_history[0]))
    }
}
