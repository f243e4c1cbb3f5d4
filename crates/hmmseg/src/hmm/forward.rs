//! The recursions on a precomputed emission table `logb[t * n + j] = ln p(x_t | j)`:
//! forward (total and every prefix), forward-backward (posteriors and expected transitions)
//! and Viterbi.
//!
//! Fast path: probabilities scaled per step, emissions divided by their per-step maximum.
//! If a step underflows (`c_t` below the smallest normal number) or the backward pass
//! overflows, the sequence is redone in log space, which cannot underflow.

use super::emission::logsumexp;
use super::simd::exp_nonpos_in_place;

/// The Markov chain of a model: start and transition probabilities and their logs.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Chain {
    pub n: usize,
    pub start: Vec<f64>,
    /// Row-major `n * n`: `trans[i * n + j] = P(j | i)`.
    pub trans: Vec<f64>,
    pub log_start: Vec<f64>,
    pub log_trans: Vec<f64>,
    /// True if only `i -> i` and `i -> i + 1` transitions are non-zero (a left-right chain).
    pub left_right: bool,
    /// Non-zero transitions by target (left-right models have ~2n instead of n^2):
    /// the predecessors of `j` are `pred_from[pred_start[j]..pred_start[j + 1]]`.
    pred_start: Vec<usize>,
    pred_from: Vec<usize>,
    pred_p: Vec<f64>,
    pred_logp: Vec<f64>,
}

impl Chain {
    pub fn new(start: Vec<f64>, trans: Vec<f64>) -> Self {
        let n = start.len();
        let log_start = start.iter().map(|p| p.ln()).collect();
        let log_trans = trans.iter().map(|p| p.ln()).collect();
        let mut pred_start = vec![0];
        let (mut pred_from, mut pred_p, mut pred_logp) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..n {
            for i in 0..n {
                let p = trans[i * n + j];
                if p != 0.0 {
                    pred_from.push(i);
                    pred_p.push(p);
                    pred_logp.push(p.ln());
                }
            }
            pred_start.push(pred_from.len());
        }
        let left_right =
            (0..n).all(|i| (0..n).all(|j| j == i || j == i + 1 || trans[i * n + j] == 0.0));
        Self {
            n,
            start,
            trans,
            log_start,
            log_trans,
            left_right,
            pred_start,
            pred_from,
            pred_p,
            pred_logp,
        }
    }

    /// `(from, P(j | from), ln P(j | from))` of the non-zero transitions into `j`.
    #[inline]
    fn preds(&self, j: usize) -> (&[usize], &[f64], &[f64]) {
        let r = self.pred_start[j]..self.pred_start[j + 1];
        (
            &self.pred_from[r.clone()],
            &self.pred_p[r.clone()],
            &self.pred_logp[r],
        )
    }
}

/// Reusable buffers, so a recursion allocates nothing per time step.
#[derive(Default)]
pub(crate) struct Workspace {
    /// Per-component log-densities (filled by the emission code).
    pub comp: Vec<f64>,
    /// `ln p(x_t | j)`, `T * n`.
    pub logb: Vec<f64>,
    /// State posteriors `T * n` after [`forward_backward`].
    pub gamma: Vec<f64>,
    b: Vec<f64>,
    shift: Vec<f64>,
    alpha: Vec<f64>,
    beta: Vec<f64>,
    c: Vec<f64>,
}

/// `b[t*n + j] = exp(logb - max_j logb)`; `shift[t]` = that maximum. False if a row is all `-inf`.
fn scale_rows(logb: &[f64], n: usize, b: &mut Vec<f64>, shift: &mut Vec<f64>) -> bool {
    let t_len = logb.len() / n;
    b.clear();
    b.resize(logb.len(), 0.0);
    shift.clear();
    shift.resize(t_len, 0.0);
    for ((row, out), s) in logb
        .chunks_exact(n)
        .zip(b.chunks_exact_mut(n))
        .zip(shift.iter_mut())
    {
        let hi = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !hi.is_finite() {
            return false;
        }
        *s = hi;
        for (o, &v) in out.iter_mut().zip(row) {
            *o = v - hi;
        }
    }
    // One flat pass, so the branch-free exp vectorises.
    exp_nonpos_in_place(b);
    true
}

/// One scaled forward step: `next_j = b_j * sum_i prev_i A_ij`; returns the sum of `next`.
#[inline]
fn step(prev: &[f64], chain: &Chain, b: &[f64], next: &mut [f64]) -> f64 {
    let mut sum = 0.0;
    for (j, (nx, &bj)) in next.iter_mut().zip(b).enumerate() {
        let (from, p, _) = chain.preds(j);
        let acc: f64 = from.iter().zip(p).map(|(&i, &a)| prev[i] * a).sum();
        *nx = acc * bj;
        sum += *nx;
    }
    sum
}

/// Scaled forward storing every normalised `alpha_t` and scale `c_t`. False on underflow.
fn forward_scaled(chain: &Chain, ws: &mut Workspace) -> bool {
    let n = chain.n;
    let t_len = ws.b.len() / n;
    ws.alpha.clear();
    ws.alpha.resize(t_len * n, 0.0);
    ws.c.clear();
    ws.c.resize(t_len, 0.0);
    let mut sum = 0.0;
    for j in 0..n {
        ws.alpha[j] = chain.start[j] * ws.b[j];
        sum += ws.alpha[j];
    }
    for t in 0..t_len {
        if t > 0 {
            let (done, rest) = ws.alpha.split_at_mut(t * n);
            sum = step(
                &done[(t - 1) * n..],
                chain,
                &ws.b[t * n..(t + 1) * n],
                &mut rest[..n],
            );
        }
        if !(sum >= f64::MIN_POSITIVE && sum.is_finite()) {
            return false;
        }
        ws.c[t] = sum;
        let inv = 1.0 / sum;
        ws.alpha[t * n..(t + 1) * n]
            .iter_mut()
            .for_each(|a| *a *= inv);
    }
    true
}

/// Log-space forward, normalised per step so that no value grows with the sequence:
/// `alpha[t*n + j] = ln P(x_0..=t, s_t = j) - m_0 - ... - m_t` with `max_j alpha[t*n + j] = 0`
/// and `shift[t] = m_t` (`-inf` from the first step at which every state is impossible).
/// Posteriors are differences of these values, which stay small even when the log-densities
/// are astronomically large (observations of 1e150).
fn forward_log(chain: &Chain, logb: &[f64], alpha: &mut Vec<f64>, shift: &mut Vec<f64>) {
    let n = chain.n;
    let t_len = logb.len() / n;
    alpha.clear();
    alpha.resize(logb.len(), f64::NEG_INFINITY);
    shift.clear();
    shift.resize(t_len, f64::NEG_INFINITY);
    let mut tmp = vec![0.0; n];
    for t in 0..t_len {
        for j in 0..n {
            alpha[t * n + j] = if t == 0 {
                chain.log_start[j] + logb[j]
            } else {
                for i in 0..n {
                    tmp[i] = alpha[(t - 1) * n + i] + chain.log_trans[i * n + j];
                }
                logsumexp(&tmp) + logb[t * n + j]
            };
        }
        let row = &mut alpha[t * n..(t + 1) * n];
        let hi = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !hi.is_finite() {
            // Every state impossible (or a log-density below the range of doubles): the
            // likelihood of this and every later prefix is -inf; callers report it.
            row.fill(f64::NEG_INFINITY);
            return;
        }
        shift[t] = hi;
        for v in row.iter_mut() {
            *v -= hi;
        }
    }
}

/// Log-space backward, normalised per step like [`forward_log`]: `beta[t*n + i]` is
/// `ln P(x_t+1.. | s_t = i)` up to a per-step constant, with `max_i beta[t*n + i] = 0`.
fn backward_log(chain: &Chain, logb: &[f64], beta: &mut Vec<f64>) {
    let n = chain.n;
    let t_len = logb.len() / n;
    beta.clear();
    beta.resize(logb.len(), 0.0);
    let mut tmp = vec![0.0; n];
    for t in (0..t_len.saturating_sub(1)).rev() {
        for i in 0..n {
            for j in 0..n {
                tmp[j] = chain.log_trans[i * n + j] + logb[(t + 1) * n + j] + beta[(t + 1) * n + j];
            }
            beta[t * n + i] = logsumexp(&tmp);
        }
        let row = &mut beta[t * n..(t + 1) * n];
        let hi = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if hi.is_finite() {
            for v in row.iter_mut() {
                *v -= hi;
            }
        }
    }
}

/// `ln P(x_0..=t)` from the normalised log-space forward of step `t` and the running sum of
/// its shifts.
fn log_prefix(shift_sum: f64, alpha_row: &[f64]) -> f64 {
    if shift_sum == f64::NEG_INFINITY {
        return f64::NEG_INFINITY;
    }
    shift_sum + logsumexp(alpha_row)
}

/// `ln P(x)` of the sequence whose emission table is `ws.logb`.
pub(crate) fn log_likelihood(chain: &Chain, ws: &mut Workspace) -> f64 {
    let n = chain.n;
    if scale_rows(&ws.logb, n, &mut ws.b, &mut ws.shift) && forward_scaled(chain, ws) {
        return ws.shift.iter().zip(&ws.c).map(|(s, c)| s + c.ln()).sum();
    }
    forward_log(chain, &ws.logb, &mut ws.alpha, &mut ws.c);
    let t_len = ws.logb.len() / n;
    log_prefix(ws.c.iter().sum(), &ws.alpha[(t_len - 1) * n..])
}

/// `out[t] = ln P(x_0..=t)` for every `t`, in one forward pass.
pub(crate) fn prefix_log_likelihoods(chain: &Chain, ws: &mut Workspace) -> Vec<f64> {
    let n = chain.n;
    if scale_rows(&ws.logb, n, &mut ws.b, &mut ws.shift) && forward_scaled(chain, ws) {
        let mut acc = 0.0;
        return ws
            .shift
            .iter()
            .zip(&ws.c)
            .map(|(s, c)| {
                acc += s + c.ln();
                acc
            })
            .collect();
    }
    forward_log(chain, &ws.logb, &mut ws.alpha, &mut ws.c);
    let mut acc = 0.0;
    ws.alpha
        .chunks_exact(n)
        .zip(&ws.c)
        .map(|(row, m)| {
            acc += m;
            log_prefix(acc, row)
        })
        .collect()
}

/// Forward-backward: fills `ws.gamma` (`T * n`, rows sum to 1), adds the expected transition
/// counts to `xi_sum` (`n * n`, row-major) if given, and returns `ln P(x)`.
pub(crate) fn forward_backward(
    chain: &Chain,
    ws: &mut Workspace,
    xi_sum: Option<&mut [f64]>,
) -> f64 {
    let n = chain.n;
    let mut xi = vec![0.0; n * n];
    let ll = if let Some(ll) = forward_backward_scaled(chain, ws, xi_sum.is_some(), &mut xi) {
        ll
    } else {
        xi.fill(0.0);
        forward_backward_log(chain, ws, xi_sum.is_some(), &mut xi)
    };
    if let Some(acc) = xi_sum {
        for (a, (x, p)) in acc.iter_mut().zip(xi.iter().zip(&chain.trans)) {
            *a += x * p;
        }
    }
    ll
}

/// Scaled forward-backward; `xi[i*n + j] = sum_t alpha_t(i) b_t+1(j) beta_t+1(j) / c_t+1`
/// (times `A_ij` later, so forbidden transitions stay exact zeros). None on under/overflow.
fn forward_backward_scaled(
    chain: &Chain,
    ws: &mut Workspace,
    want_xi: bool,
    xi: &mut [f64],
) -> Option<f64> {
    let n = chain.n;
    if !(scale_rows(&ws.logb, n, &mut ws.b, &mut ws.shift) && forward_scaled(chain, ws)) {
        return None;
    }
    let t_len = ws.c.len();
    ws.beta.clear();
    ws.beta.resize(t_len * n, 1.0);
    let mut v = vec![0.0; n];
    for t in (0..t_len - 1).rev() {
        let inv_c = 1.0 / ws.c[t + 1];
        let (b_next, beta_next) = (
            &ws.b[(t + 1) * n..(t + 2) * n],
            &ws.beta[(t + 1) * n..(t + 2) * n],
        );
        for ((vj, b), be) in v.iter_mut().zip(b_next).zip(beta_next) {
            *vj = b * be * inv_c;
        }
        for i in 0..n {
            let row = &chain.trans[i * n..(i + 1) * n];
            ws.beta[t * n + i] = row.iter().zip(&v).map(|(a, b)| a * b).sum();
        }
        if want_xi {
            for i in 0..n {
                let a = ws.alpha[t * n + i];
                for (x, &vj) in xi[i * n..(i + 1) * n].iter_mut().zip(&v) {
                    *x += a * vj;
                }
            }
        }
    }
    ws.gamma.clear();
    ws.gamma
        .extend(ws.alpha.iter().zip(&ws.beta).map(|(a, b)| a * b));
    if !normalise_rows(&mut ws.gamma, n) || xi.iter().any(|x| !x.is_finite()) {
        return None;
    }
    Some(ws.shift.iter().zip(&ws.c).map(|(s, c)| s + c.ln()).sum())
}

/// Log-space forward-backward on the normalised recursions: every posterior row and every
/// step's expected transitions are normalised on their own, so they are exact to rounding
/// whatever the magnitude of the log-densities. Returns `ln P(x)` (`-inf` or NaN if it is
/// below the range of doubles; `gamma` is then not meaningful and callers report an error).
fn forward_backward_log(chain: &Chain, ws: &mut Workspace, want_xi: bool, xi: &mut [f64]) -> f64 {
    let n = chain.n;
    forward_log(chain, &ws.logb, &mut ws.alpha, &mut ws.c);
    backward_log(chain, &ws.logb, &mut ws.beta);
    let t_len = ws.logb.len() / n;
    let ll = log_prefix(ws.c.iter().sum(), &ws.alpha[(t_len - 1) * n..]);
    if !ll.is_finite() {
        ws.gamma.clear();
        ws.gamma.resize(t_len * n, f64::NAN);
        return ll;
    }
    ws.gamma.clear();
    ws.gamma
        .extend(ws.alpha.iter().zip(&ws.beta).map(|(a, b)| a + b));
    for row in ws.gamma.chunks_exact_mut(n) {
        let hi = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for v in row.iter_mut() {
            *v = (*v - hi).exp();
        }
    }
    normalise_rows(&mut ws.gamma, n);
    if want_xi {
        let mut e = vec![0.0; n * n];
        for t in 0..t_len - 1 {
            // xi_t(i, j) = exp(e_ij + ln A_ij - z_t), sum over (i, j) = 1; the transition factor
            // is applied by the caller, so only exp(e_ij - z_t) is accumulated.
            let mut z = f64::NEG_INFINITY;
            for i in 0..n {
                let a = ws.alpha[t * n + i];
                for j in 0..n {
                    let v = a + ws.logb[(t + 1) * n + j] + ws.beta[(t + 1) * n + j];
                    e[i * n + j] = v;
                    z = z.max(v + chain.log_trans[i * n + j]);
                }
            }
            let total: f64 = e
                .iter()
                .zip(&chain.log_trans)
                .map(|(v, lt)| (v + lt - z).exp())
                .sum();
            let z = z + total.ln();
            for (x, v) in xi.iter_mut().zip(&e) {
                let w = (v - z).exp();
                if w.is_finite() {
                    *x += w;
                }
            }
        }
    }
    ll
}

/// Divide every row by its sum; false if a row sum is not a positive finite number.
fn normalise_rows(m: &mut [f64], n: usize) -> bool {
    let mut ok = true;
    for row in m.chunks_exact_mut(n) {
        let s: f64 = row.iter().sum();
        if s > 0.0 && s.is_finite() {
            let inv = 1.0 / s;
            for v in row.iter_mut() {
                *v *= inv;
            }
        } else {
            ok = false;
        }
    }
    ok
}

/// Most likely state path and its log-probability (ties go to the lowest state index).
pub(crate) fn viterbi(chain: &Chain, logb: &[f64]) -> (f64, Vec<usize>) {
    let n = chain.n;
    let t_len = logb.len() / n;
    let mut delta: Vec<f64> = (0..n).map(|j| chain.log_start[j] + logb[j]).collect();
    let mut next = vec![0.0; n];
    let mut back = vec![0usize; t_len * n];
    for t in 1..t_len {
        for j in 0..n {
            let (mut best, mut arg) = (f64::NEG_INFINITY, 0);
            let (from, _, logp) = chain.preds(j);
            for (&i, &lp) in from.iter().zip(logp) {
                let v = delta[i] + lp;
                if v > best {
                    best = v;
                    arg = i;
                }
            }
            next[j] = best + logb[t * n + j];
            back[t * n + j] = arg;
        }
        std::mem::swap(&mut delta, &mut next);
    }
    let (mut best, mut state) = (f64::NEG_INFINITY, 0);
    for (j, &v) in delta.iter().enumerate() {
        if v > best {
            best = v;
            state = j;
        }
    }
    let mut path = vec![0; t_len];
    for t in (0..t_len).rev() {
        path[t] = state;
        state = back[t * n + state];
    }
    (best, path)
}

#[cfg(test)]
#[allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::hmm::{CovarianceType, Hmm};

    /// 3 states, 1-D, ergodic with one forbidden transition.
    fn tiny() -> Hmm {
        Hmm::from_params(
            DVector::from_vec(vec![0.6, 0.3, 0.1]),
            DMatrix::from_row_slice(3, 3, &[0.7, 0.2, 0.1, 0.0, 0.6, 0.4, 0.3, 0.3, 0.4]),
            DMatrix::from_element(3, 1, 1.0),
            vec![
                DMatrix::from_element(1, 1, -1.0),
                DMatrix::from_element(1, 1, 0.5),
                DMatrix::from_element(1, 1, 2.0),
            ],
            vec![
                vec![DMatrix::from_element(1, 1, 0.5)],
                vec![DMatrix::from_element(1, 1, 1.0)],
                vec![DMatrix::from_element(1, 1, 2.0)],
            ],
            CovarianceType::Diag,
        )
        .unwrap()
    }

    /// Every state path of length `t_len` with its joint log-probability.
    fn enumerate(h: &Hmm, logb: &[f64], t_len: usize) -> Vec<(Vec<usize>, f64)> {
        let n = h.n_states();
        let mut out = Vec::new();
        for code in 0..n.pow(t_len as u32) {
            let path: Vec<usize> = (0..t_len).map(|t| code / n.pow(t as u32) % n).collect();
            let mut lp = h.chain.log_start[path[0]] + logb[path[0]];
            for t in 1..t_len {
                lp += h.chain.log_trans[path[t - 1] * n + path[t]] + logb[t * n + path[t]];
            }
            out.push((path, lp));
        }
        out
    }

    fn table(h: &Hmm, x: &DMatrix<f64>) -> Workspace {
        let mut ws = Workspace::default();
        h.emissions_into(x, &mut ws, "x").unwrap();
        ws
    }

    #[test]
    fn forward_equals_brute_force_enumeration() {
        let h = tiny();
        let x = DMatrix::from_column_slice(5, 1, &[-0.8, 0.4, 2.2, 1.9, -1.5]);
        let mut ws = table(&h, &x);
        let paths = enumerate(&h, &ws.logb, 5);
        let lps: Vec<f64> = paths.iter().map(|p| p.1).collect();
        let want = logsumexp(&lps);
        assert!((log_likelihood(&h.chain, &mut ws) - want).abs() < 1e-12);
        let (mut alpha, mut shift) = (Vec::new(), Vec::new());
        forward_log(&h.chain, &ws.logb, &mut alpha, &mut shift);
        assert!((log_prefix(shift.iter().sum(), &alpha[4 * 3..]) - want).abs() < 1e-12);
        // The log-space forward-backward agrees with the scaled one.
        let mut xi_log = vec![0.0; 9];
        let ll_log = forward_backward_log(&h.chain, &mut ws, true, &mut xi_log);
        let gamma_log = ws.gamma.clone();
        let mut xi = vec![0.0; 9];
        let ll = forward_backward_scaled(&h.chain, &mut ws, true, &mut xi).unwrap();
        assert!((ll_log - ll).abs() < 1e-12 && (ll - want).abs() < 1e-12);
        for (a, b) in gamma_log.iter().zip(&ws.gamma) {
            assert!((a - b).abs() < 1e-12);
        }
        for (a, b) in xi_log.iter().zip(&xi) {
            assert!((a - b).abs() < 1e-12, "{xi_log:?} {xi:?}");
        }
        let prefix = prefix_log_likelihoods(&h.chain, &mut ws);
        for t in 0..5 {
            let sub = table(&h, &x.rows(0, t + 1).into_owned());
            let lp: Vec<f64> = enumerate(&h, &sub.logb, t + 1)
                .iter()
                .map(|p| p.1)
                .collect();
            assert!((prefix[t] - logsumexp(&lp)).abs() < 1e-12);
        }
    }

    #[test]
    fn viterbi_and_posteriors_equal_enumeration() {
        let h = tiny();
        let x = DMatrix::from_column_slice(4, 1, &[-0.8, 0.4, 2.2, -1.5]);
        let mut ws = table(&h, &x);
        let paths = enumerate(&h, &ws.logb, 4);
        let best = paths.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        let (score, path) = viterbi(&h.chain, &ws.logb);
        assert_eq!(&path, &best.0);
        assert!((score - best.1).abs() < 1e-12);
        let ll = logsumexp(&paths.iter().map(|p| p.1).collect::<Vec<_>>());
        let mut xi = vec![0.0; 9];
        let got_ll = forward_backward(&h.chain, &mut ws, Some(&mut xi));
        assert!((got_ll - ll).abs() < 1e-12);
        for t in 0..4 {
            for j in 0..3 {
                let p: f64 = paths
                    .iter()
                    .filter(|p| p.0[t] == j)
                    .map(|p| (p.1 - ll).exp())
                    .sum();
                assert!((ws.gamma[t * 3 + j] - p).abs() < 1e-12);
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = paths
                    .iter()
                    .map(|p| {
                        let c = (0..3).filter(|&t| p.0[t] == i && p.0[t + 1] == j).count();
                        c as f64 * (p.1 - ll).exp()
                    })
                    .sum();
                assert!(
                    (xi[i * 3 + j] - p).abs() < 1e-12,
                    "xi[{i},{j}] {} vs {p}",
                    xi[i * 3 + j]
                );
            }
        }
        assert_eq!(
            xi[3], 0.0,
            "forbidden transition 1 -> 0 has exactly zero expected count"
        );
    }

    #[test]
    fn log_space_fallback_on_underflow() {
        // Left-right, 2 states; an observation far from the only reachable state underflows
        // the scaled recursion.
        let h = Hmm::from_params(
            DVector::from_vec(vec![1.0, 0.0]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]),
            DMatrix::from_element(2, 1, 1.0),
            vec![
                DMatrix::from_element(1, 1, 0.0),
                DMatrix::from_element(1, 1, 100.0),
            ],
            vec![
                vec![DMatrix::from_element(1, 1, 1.0)],
                vec![DMatrix::from_element(1, 1, 1.0)],
            ],
            CovarianceType::Diag,
        )
        .unwrap();
        let x = DMatrix::from_column_slice(3, 1, &[0.0, 100.0, 0.5]);
        let mut ws = table(&h, &x);
        assert!(
            !(scale_rows(&ws.logb, 2, &mut ws.b, &mut ws.shift)
                && forward_scaled(&h.chain, &mut ws))
        );
        let ln_n = |v: f64| -0.5 * (2.0 * std::f64::consts::PI).ln() - 0.5 * v * v;
        let want = ln_n(0.0) + ln_n(100.0) + ln_n(0.5);
        assert!((log_likelihood(&h.chain, &mut ws) - want).abs() < 1e-9);
        let prefix = prefix_log_likelihoods(&h.chain, &mut ws);
        assert!((prefix[0] - ln_n(0.0)).abs() < 1e-12);
        assert!((prefix[2] - want).abs() < 1e-9);
        forward_backward(&h.chain, &mut ws, None);
        assert_eq!(ws.gamma, vec![1.0, 0.0, 1.0, 0.0, 1.0, 0.0]);
        let (score, path) = viterbi(&h.chain, &ws.logb);
        assert_eq!(path, vec![0, 0, 0]);
        assert!((score - want).abs() < 1e-9);
    }
}
