//! The starting model of [`crate::hmm::Hmm::fit`]: states from seeded k-means (ergodic) or
//! from a uniform segmentation of every sequence (left-right), mixture components from
//! k-means inside each state, covariances floored.

use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::config::{FitConfig, Topology};
use super::kmeans::kmeans;
use super::model::Hmm;
use super::moments::{floor_covariance, mean_cov};
use crate::error::{EngineError, Result};

/// Build the initial model from validated sequences with `f` features.
pub(crate) fn initial_model(seqs: &[DMatrix<f64>], f: usize, config: &FitConfig) -> Result<Hmm> {
    let n = config.n_states;
    let total: usize = seqs.iter().map(DMatrix::nrows).sum();
    if total < n {
        return Err(EngineError::InvalidParameter(format!(
            "more states ({n}) than training samples ({total})"
        )));
    }
    // All samples, row-major, in sequence order.
    let mut data = Vec::with_capacity(total * f);
    for x in seqs {
        for t in 0..x.nrows() {
            data.extend(x.row(t).iter());
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let labels = state_labels(seqs, &data, f, config, &mut rng);
    let cov = config.covariance;
    let all: Vec<usize> = (0..total).collect();
    let global = mean_cov(&data, f, &all, cov)
        .ok_or_else(|| EngineError::EmptySequence("no samples".into()))?;

    let m_count = config.n_mix;
    let weights = DMatrix::from_element(n, m_count, 1.0 / m_count as f64);
    let mut means = Vec::with_capacity(n);
    let mut covars = Vec::with_capacity(n);
    for j in 0..n {
        let idx: Vec<usize> = (0..total).filter(|&i| labels[i] == j).collect();
        let (mu, cs) = state_mixture(&data, f, &idx, &global, config, &mut rng);
        means.push(mu);
        covars.push(cs);
    }
    let (startprob, transmat) = match config.topology {
        Topology::LeftRight => left_right_chain(n, total as f64 / seqs.len() as f64),
        Topology::Ergodic => label_transitions(seqs, &labels, n),
    };
    Hmm::from_params(startprob, transmat, weights, means, covars, cov)
}

/// The state of every sample (row of `data`): seeded k-means (ergodic) or a uniform
/// segmentation of every sequence into `n_states` runs (left-right).
fn state_labels(
    seqs: &[DMatrix<f64>],
    data: &[f64],
    f: usize,
    config: &FitConfig,
    rng: &mut ChaCha8Rng,
) -> Vec<usize> {
    let n = config.n_states;
    match config.topology {
        Topology::Ergodic => kmeans(data, f, n, rng),
        Topology::LeftRight => seqs
            .iter()
            .flat_map(|x| {
                let t_len = x.nrows();
                (0..t_len).map(move |t| t * n / t_len)
            })
            .collect(),
    }
}

/// The mixture of one state from its samples `idx`: component means and covariances from
/// k-means inside the state; a component (or state) with too few samples borrows the state's
/// (or all samples') covariance; covariances floored.
fn state_mixture(
    data: &[f64],
    f: usize,
    idx: &[usize],
    global: &(Vec<f64>, DMatrix<f64>),
    config: &FitConfig,
    rng: &mut ChaCha8Rng,
) -> (DMatrix<f64>, Vec<DMatrix<f64>>) {
    let (m_count, cov) = (config.n_mix, config.covariance);
    let (state_mean, state_cov) = match mean_cov(data, f, idx, cov) {
        Some(mc) if idx.len() >= 2 => mc,
        Some((mean, _)) => (mean, global.1.clone()),
        None => global.clone(),
    };
    let comp_labels = if m_count > 1 && !idx.is_empty() {
        let pts: Vec<f64> = idx
            .iter()
            .flat_map(|&i| data[i * f..(i + 1) * f].iter().copied())
            .collect();
        kmeans(&pts, f, m_count, rng)
    } else {
        vec![0; idx.len()]
    };
    let mut mu = DMatrix::zeros(m_count, f);
    let mut cs = Vec::with_capacity(m_count);
    for m in 0..m_count {
        let members: Vec<usize> = idx
            .iter()
            .zip(&comp_labels)
            .filter(|(_, &l)| l == m)
            .map(|(&i, _)| i)
            .collect();
        let enough =
            members.len() >= 2 && (cov == super::CovarianceType::Diag || members.len() > f);
        let (mean, mut c) = match mean_cov(data, f, &members, cov) {
            Some((mean, c)) if enough => (mean, c),
            Some((mean, _)) => (mean, state_cov.clone()),
            None => (state_mean.clone(), state_cov.clone()),
        };
        floor_covariance(&mut c, config.covariance_floor, cov);
        mu.row_mut(m).copy_from_slice(&mean);
        cs.push(c);
    }
    (mu, cs)
}

/// A left-right chain starting in state 0 whose expected stay per state spreads a sequence of
/// `mean_len` samples evenly over the `n` states (stay probability clamped to [0.5, 0.99]).
fn left_right_chain(n: usize, mean_len: f64) -> (DVector<f64>, DMatrix<f64>) {
    let stay = (1.0 - n as f64 / mean_len).clamp(0.5, 0.99);
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n {
        if i + 1 < n {
            a[(i, i)] = stay;
            a[(i, i + 1)] = 1.0 - stay;
        } else {
            a[(i, i)] = 1.0;
        }
    }
    let mut pi = DVector::zeros(n);
    pi[0] = 1.0;
    (pi, a)
}

/// Start and transition probabilities from the label counts along the sequences, with one
/// pseudo-count everywhere.
fn label_transitions(
    seqs: &[DMatrix<f64>],
    labels: &[usize],
    n: usize,
) -> (DVector<f64>, DMatrix<f64>) {
    let mut pi = DVector::from_element(n, 1.0);
    let mut a = DMatrix::from_element(n, n, 1.0);
    let mut offset = 0;
    for x in seqs {
        pi[labels[offset]] += 1.0;
        for t in 1..x.nrows() {
            a[(labels[offset + t - 1], labels[offset + t])] += 1.0;
        }
        offset += x.nrows();
    }
    let s = pi.sum();
    pi /= s;
    for i in 0..n {
        let s = a.row(i).sum();
        a.row_mut(i).iter_mut().for_each(|v| *v /= s);
    }
    (pi, a)
}
