//! Gaussian-mixture emissions with everything that does not depend on the data precomputed:
//! log weights, log normalisers, inverse variances (diag) or inverse Cholesky factors (full).

use std::f64::consts::PI;

use nalgebra::DMatrix;
#[cfg(test)]
use nalgebra::DVector;

use super::config::CovarianceType;
use super::fastexp::exp_nonpos_k;
use super::simd::{dispatch, Kernel};
use crate::error::{EngineError, Result};

/// Precomputed constants of the `n_states * n_mix` Gaussian components, stored flat.
/// Component `k = state * n_mix + mix`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Emission {
    pub n_states: usize,
    pub n_mix: usize,
    pub n_features: usize,
    pub covariance: CovarianceType,
    /// `ln w_k`, length `K` (may be `-inf` for a zero weight).
    log_weights: Vec<f64>,
    /// Means, `K * F`.
    means: Vec<f64>,
    /// Diag: inverse variances `K * F`. Full: inverse Cholesky factor `L^-1` (lower
    /// triangular, row-major) `K * F * F`, so that `|L^-1 (x - mu)|^2` is the Mahalanobis term.
    precision: Vec<f64>,
    /// `-(F ln 2 pi + ln det Sigma) / 2`, length `K`.
    log_norm: Vec<f64>,
}

impl Emission {
    /// Precompute from validated shapes; checks that every covariance is SPD.
    pub fn new(
        weights: &DMatrix<f64>,
        means: &[DMatrix<f64>],
        covars: &[Vec<DMatrix<f64>>],
        covariance: CovarianceType,
    ) -> Result<Self> {
        let (n_states, n_mix) = weights.shape();
        let n_features = means.first().map_or(0, DMatrix::ncols);
        let k_total = n_states * n_mix;
        let f = n_features;
        let mut e = Self {
            n_states,
            n_mix,
            n_features,
            covariance,
            log_weights: Vec::with_capacity(k_total),
            means: Vec::with_capacity(k_total * f),
            precision: Vec::with_capacity(
                k_total
                    * f
                    * if covariance == CovarianceType::Full {
                        f
                    } else {
                        1
                    },
            ),
            log_norm: Vec::with_capacity(k_total),
        };
        let ln2pi = (2.0 * PI).ln();
        for j in 0..n_states {
            for m in 0..n_mix {
                e.log_weights.push(weights[(j, m)].ln());
                e.means.extend(means[j].row(m).iter());
                let c = &covars[j][m];
                let what = format!("covariance of state {j}, component {m}");
                let log_det = match covariance {
                    CovarianceType::Diag => diag_precision(c, &what, &mut e.precision)?,
                    CovarianceType::Full => full_precision(c, &what, &mut e.precision)?,
                };
                e.log_norm.push(-0.5 * (f as f64 * ln2pi + log_det));
            }
        }
        Ok(e)
    }

    /// Number of components `n_states * n_mix`.
    pub fn n_components(&self) -> usize {
        self.n_states * self.n_mix
    }

    /// `comp[k * T + t] = ln w_k + ln N(x_t | mu_k, Sigma_k)` for every component `k`.
    pub fn component_log_probs(&self, x: &DMatrix<f64>, comp: &mut Vec<f64>) {
        let t_len = x.nrows();
        comp.clear();
        comp.resize(self.n_components() * t_len, 0.0);
        self.component_block(x.as_slice(), t_len, 0, t_len, comp);
    }

    /// `comp[k * len + i] = ln w_k + ln N(x_(start + i) | k)` for `i < len`. `data` holds the
    /// observations column-major (`t_len` rows, feature `d` at `data[d * t_len..]`);
    /// `comp` has at least `n_components() * len` entries. A log-density below the range of
    /// doubles is `-inf` (never NaN).
    #[allow(clippy::inline_always)] // must be compiled inside the AVX2 function (simd)
    #[inline(always)]
    pub(crate) fn component_block(
        &self,
        data: &[f64],
        t_len: usize,
        start: usize,
        len: usize,
        comp: &mut [f64],
    ) {
        if len == 0 {
            return;
        }
        let f = self.n_features;
        let col = |d: usize| &data[d * t_len + start..d * t_len + start + len];
        match self.covariance {
            CovarianceType::Diag => {
                for (k, out) in comp
                    .chunks_exact_mut(len)
                    .take(self.n_components())
                    .enumerate()
                {
                    let c0 = self.log_weights[k] + self.log_norm[k];
                    // The first feature initialises (no zero-fill pass).
                    let (mu, half_iv) = (self.means[k * f], 0.5 * self.precision[k * f]);
                    for (o, &v) in out.iter_mut().zip(col(0)) {
                        let z = v - mu;
                        *o = c0 - half_iv * z * z;
                    }
                    for d in 1..f {
                        let mu = self.means[k * f + d];
                        let half_iv = 0.5 * self.precision[k * f + d];
                        for (o, &v) in out.iter_mut().zip(col(d)) {
                            let z = v - mu;
                            *o -= half_iv * z * z;
                        }
                    }
                }
            }
            CovarianceType::Full => {
                let mut diff = vec![0.0; f];
                for (k, out) in comp
                    .chunks_exact_mut(len)
                    .take(self.n_components())
                    .enumerate()
                {
                    let c0 = self.log_weights[k] + self.log_norm[k];
                    let mu = &self.means[k * f..(k + 1) * f];
                    let li = &self.precision[k * f * f..(k + 1) * f * f];
                    for (i, o) in out.iter_mut().enumerate() {
                        for d in 0..f {
                            diff[d] = data[d * t_len + start + i] - mu[d];
                        }
                        let mut quad = 0.0;
                        for r in 0..f {
                            let row = &li[r * f..=r * f + r];
                            let y: f64 = row.iter().zip(&diff).map(|(a, b)| a * b).sum();
                            quad += y * y;
                        }
                        // inf - inf in an astronomically distant sample: density 0.
                        if quad.is_nan() {
                            quad = f64::INFINITY;
                        }
                        *o = c0 - 0.5 * quad;
                    }
                }
            }
        }
    }

    /// Emission probabilities of samples `start..start + len`, scaled per sample so that no
    /// logarithm or per-state `exp` beyond one per component is needed:
    /// `hi[i] = max_k comp[k][i]` and `b[j * len + i] = sum_m exp(comp[j, m][i] - hi[i])`
    /// (so `ln p(x | j) = hi[i] + ln b[j * len + i]`, and the largest component gives 1).
    /// `comp` is scratch of `n_components() * len` entries (unused with one component per
    /// state), `b` has `n_states * len`, `hi` `len`. If every component of a sample is `-inf`,
    /// `hi` is `-inf` and `b` is 0. Vectorised with runtime CPU dispatch (see `simd`).
    pub(crate) fn scaled_block(
        &self,
        data: &[f64],
        t_len: usize,
        start: usize,
        len: usize,
        comp: &mut [f64],
        b: &mut [f64],
        hi: &mut [f64],
    ) {
        struct Block<'a> {
            e: &'a Emission,
            data: &'a [f64],
            t_len: usize,
            start: usize,
            len: usize,
            comp: &'a mut [f64],
            b: &'a mut [f64],
            hi: &'a mut [f64],
        }
        impl Kernel for Block<'_> {
            type Output = ();
            #[allow(clippy::inline_always)] // must be compiled inside the AVX2 function (simd)
            #[inline(always)]
            fn run<const FMA: bool>(self) {
                let Block {
                    e,
                    data,
                    t_len,
                    start,
                    len,
                    comp,
                    b,
                    hi,
                } = self;
                let hi = &mut hi[..len];
                let k_total = e.n_components();
                if e.n_mix == 1 {
                    exp_shifted::<FMA>(e, data, t_len, start, &mut b[..k_total * len], hi);
                    return;
                }
                let src = &mut comp[..k_total * len];
                exp_shifted::<FMA>(e, data, t_len, start, src, hi);
                let m = e.n_mix;
                for (j, out) in b.chunks_exact_mut(len).take(e.n_states).enumerate() {
                    out.copy_from_slice(&src[j * m * len..(j * m + 1) * len]);
                    for col in src[(j * m + 1) * len..(j + 1) * m * len].chunks_exact(len) {
                        for (o, &v) in out.iter_mut().zip(col) {
                            *o += v;
                        }
                    }
                }
            }
        }
        /// `out[k][i] = exp(comp[k][i] - hi[i])` with `hi[i] = max_k comp[k][i]`.
        #[allow(clippy::inline_always)] // must be compiled inside the AVX2 function (simd)
        #[inline(always)]
        fn exp_shifted<const FMA: bool>(
            e: &Emission,
            data: &[f64],
            t_len: usize,
            start: usize,
            out: &mut [f64],
            hi: &mut [f64],
        ) {
            let len = hi.len();
            e.component_block(data, t_len, start, len, out);
            hi.copy_from_slice(&out[..len]);
            for col in out.chunks_exact(len).skip(1) {
                for (h, &v) in hi.iter_mut().zip(col) {
                    *h = h.max(v);
                }
            }
            for col in out.chunks_exact_mut(len) {
                for (v, &h) in col.iter_mut().zip(hi.iter()) {
                    *v = exp_nonpos_k::<FMA>(*v - h);
                }
            }
        }
        dispatch(Block {
            e: self,
            data,
            t_len,
            start,
            len,
            comp,
            b,
            hi,
        });
    }

    /// `logb[t * N + j] = ln p(x_t | state j)` (log-sum-exp over the state's components).
    /// `comp` receives the per-component values of [`Self::component_log_probs`].
    pub fn log_emissions(&self, x: &DMatrix<f64>, comp: &mut Vec<f64>, logb: &mut Vec<f64>) {
        let t_len = x.nrows();
        let (n, m_count) = (self.n_states, self.n_mix);
        logb.clear();
        logb.resize(t_len * n, 0.0);
        self.component_log_probs(x, comp);
        if m_count == 1 {
            for (j, col) in comp.chunks_exact(t_len).enumerate() {
                for (t, &v) in col.iter().enumerate() {
                    logb[t * n + j] = v;
                }
            }
            return;
        }
        for j in 0..n {
            let block = &comp[j * m_count * t_len..(j + 1) * m_count * t_len];
            for t in 0..t_len {
                let mut hi = f64::NEG_INFINITY;
                for m in 0..m_count {
                    hi = hi.max(block[m * t_len + t]);
                }
                let v = if hi == f64::NEG_INFINITY {
                    hi
                } else {
                    let s: f64 = (0..m_count)
                        .map(|m| (block[m * t_len + t] - hi).exp())
                        .sum();
                    hi + s.ln()
                };
                logb[t * n + j] = v;
            }
        }
    }

    /// Mean of component `k` (length `F`).
    pub fn mean(&self, k: usize) -> &[f64] {
        &self.means[k * self.n_features..(k + 1) * self.n_features]
    }
}

/// Diagonal covariance: push inverse variances, return `ln det`.
fn diag_precision(c: &DMatrix<f64>, what: &str, out: &mut Vec<f64>) -> Result<f64> {
    let f = c.nrows();
    let mut log_det = 0.0;
    for r in 0..f {
        for s in 0..f {
            let v = c[(r, s)];
            if !v.is_finite() {
                return Err(EngineError::NonFinite(format!("{what} contains {v}")));
            }
            if r != s && v != 0.0 {
                return Err(EngineError::InvalidParameter(format!(
                    "{what}: a diag model needs diagonal covariances, entry ({r}, {s}) is {v}"
                )));
            }
        }
        let v = c[(r, r)];
        if v <= 0.0 {
            return Err(EngineError::NotPositiveDefinite(format!(
                "{what}: variance {r} is {v} (must be > 0)"
            )));
        }
        let iv = 1.0 / v;
        if !iv.is_finite() {
            return Err(EngineError::NotPositiveDefinite(format!(
                "{what}: variance {r} is {v}, too small to invert in double precision"
            )));
        }
        log_det += v.ln();
        out.push(iv);
    }
    Ok(log_det)
}

/// Full covariance: push `L^-1` (row-major lower triangular), return `ln det`.
fn full_precision(c: &DMatrix<f64>, what: &str, out: &mut Vec<f64>) -> Result<f64> {
    let f = c.nrows();
    if let Some(v) = c.iter().find(|v| !v.is_finite()) {
        return Err(EngineError::NonFinite(format!("{what} contains {v}")));
    }
    for r in 0..f {
        for s in 0..r {
            let (a, b) = (c[(r, s)], c[(s, r)]);
            if (a - b).abs() > 1e-9 * (1.0 + a.abs().max(b.abs())) {
                return Err(EngineError::NotPositiveDefinite(format!(
                    "{what} is not symmetric: ({r}, {s}) = {a} but ({s}, {r}) = {b}"
                )));
            }
        }
    }
    let sym = (c + c.transpose()) * 0.5;
    let not_pd = || EngineError::NotPositiveDefinite(format!("{what} is not positive definite"));
    let chol = sym.cholesky().ok_or_else(not_pd)?;
    let l = chol.l();
    let log_det = 2.0 * l.diagonal().iter().map(|v| v.ln()).sum::<f64>();
    let linv = l
        .solve_lower_triangular(&DMatrix::identity(f, f))
        .ok_or_else(not_pd)?;
    if !log_det.is_finite() || linv.iter().any(|v| !v.is_finite()) {
        return Err(not_pd());
    }
    for r in 0..f {
        for s in 0..f {
            out.push(linv[(r, s)]);
        }
    }
    Ok(log_det)
}

/// Stable `ln sum exp(v)` of a slice (`-inf` for an empty slice or all `-inf`).
pub(crate) fn logsumexp(v: &[f64]) -> f64 {
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if hi == f64::NEG_INFINITY || hi.is_nan() {
        return hi;
    }
    hi + v.iter().map(|x| (x - hi).exp()).sum::<f64>().ln()
}

/// Log-density of one Gaussian evaluated the slow, obvious way (for tests).
#[cfg(test)]
pub(crate) fn gaussian_log_pdf_reference(
    x: &DVector<f64>,
    mu: &DVector<f64>,
    cov: &DMatrix<f64>,
) -> f64 {
    let f = x.len() as f64;
    let inv = cov.clone().try_inverse().unwrap();
    let d = x - mu;
    let quad = (d.transpose() * inv * &d)[(0, 0)];
    -0.5 * (f * (2.0 * PI).ln() + cov.determinant().ln() + quad)
}

#[cfg(test)]
#[allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]
mod tests {
    use super::*;

    fn spd(f: usize, seed: f64) -> DMatrix<f64> {
        let a = DMatrix::from_fn(f, f, |r, c| ((r * 7 + c * 3) as f64 * seed).sin());
        &a * a.transpose() + DMatrix::identity(f, f) * 0.5
    }

    #[test]
    fn component_log_probs_match_reference() {
        for cov_type in [CovarianceType::Diag, CovarianceType::Full] {
            let f = 3;
            let weights = DMatrix::from_row_slice(2, 2, &[0.3, 0.7, 0.5, 0.5]);
            let means = vec![
                DMatrix::from_row_slice(2, 3, &[0.0, 1.0, -1.0, 2.0, 0.5, 0.1]),
                DMatrix::from_row_slice(2, 3, &[-1.0, 0.0, 3.0, 0.2, 0.2, 0.2]),
            ];
            let mk = |s: f64| match cov_type {
                CovarianceType::Diag => DMatrix::from_diagonal(&spd(f, s).diagonal()),
                CovarianceType::Full => spd(f, s),
            };
            let covars = vec![vec![mk(0.3), mk(0.7)], vec![mk(1.1), mk(1.9)]];
            let e = Emission::new(&weights, &means, &covars, cov_type).unwrap();
            let x = DMatrix::from_row_slice(
                4,
                3,
                &[0.1, 0.2, 0.3, -1.0, 2.0, 0.5, 3.0, -2.0, 1.0, 0.0, 0.0, 0.0],
            );
            let (mut comp, mut logb) = (Vec::new(), Vec::new());
            e.log_emissions(&x, &mut comp, &mut logb);
            for t in 0..4 {
                let xt = x.row(t).transpose();
                for j in 0..2 {
                    let mut terms = Vec::new();
                    for m in 0..2 {
                        let mu = means[j].row(m).transpose();
                        let want = weights[(j, m)].ln()
                            + gaussian_log_pdf_reference(&xt, &mu, &covars[j][m]);
                        let got = comp[(j * 2 + m) * 4 + t];
                        assert!((want - got).abs() < 1e-10, "{cov_type:?} {want} {got}");
                        terms.push(want);
                    }
                    assert!((logb[t * 2 + j] - logsumexp(&terms)).abs() < 1e-10);
                }
            }
        }
    }

    #[test]
    fn covariance_errors() {
        let w = DMatrix::from_element(1, 1, 1.0);
        let mu = vec![DMatrix::zeros(1, 2)];
        let case = |c: DMatrix<f64>, t| Emission::new(&w, &mu, &[vec![c]], t).unwrap_err();
        let neg = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        assert!(matches!(
            case(neg.clone(), CovarianceType::Diag),
            EngineError::NotPositiveDefinite(_)
        ));
        assert!(matches!(
            case(neg, CovarianceType::Full),
            EngineError::NotPositiveDefinite(_)
        ));
        let offd = DMatrix::from_row_slice(2, 2, &[1.0, 0.1, 0.1, 1.0]);
        assert!(matches!(
            case(offd, CovarianceType::Diag),
            EngineError::InvalidParameter(_)
        ));
        let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.1, 1.0]);
        assert!(matches!(
            case(asym, CovarianceType::Full),
            EngineError::NotPositiveDefinite(_)
        ));
        let sing = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(matches!(
            case(sing, CovarianceType::Full),
            EngineError::NotPositiveDefinite(_)
        ));
        let inf = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, f64::INFINITY]);
        assert!(matches!(
            case(inf, CovarianceType::Full),
            EngineError::NonFinite(_)
        ));
    }

    #[test]
    fn logsumexp_edge_cases() {
        assert_eq!(logsumexp(&[]), f64::NEG_INFINITY);
        assert_eq!(
            logsumexp(&[f64::NEG_INFINITY, f64::NEG_INFINITY]),
            f64::NEG_INFINITY
        );
        assert!((logsumexp(&[0.0, 0.0]) - 2f64.ln()).abs() < 1e-15);
        assert!((logsumexp(&[-1000.0, -1000.0]) - (-1000.0 + 2f64.ln())).abs() < 1e-12);
    }
}
