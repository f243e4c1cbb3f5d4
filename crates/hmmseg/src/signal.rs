//! Signal processing of the preprocessing: Butterworth low-pass design, zero-phase filtering
//! (`filtfilt` with odd-extension padding), not-a-knot cubic splines and tridiagonal solves.
//!
//! Every function reproduces the scipy routine named in its documentation operation by
//! operation (same formulas, same order of floating-point operations), so the results agree
//! with scipy to the last bit or within a few units in the last place: a 4th-order low-pass at
//! a small fraction of the sampling rate has ill-conditioned transfer-function coefficients,
//! and one unit in the last place of `a` moves a filtered signal by up to 1e-7.
//!
//! Multi-column signals are row-major `(n, c)` slices (`x[i * c + j]` is sample `i` of column
//! `j`), filtered or interpolated along the rows, each column on its own.

// Exact float comparisons and index loops are deliberate: they reproduce scipy's (and
// LAPACK's) operations one by one, so the results agree to the bit.
#![allow(clippy::float_cmp, clippy::needless_range_loop)]

use rayon::prelude::*;

use crate::error::{EngineError, Result};
use crate::limits::{at_most, MAX_COEFFICIENTS};

/// A complex number with numpy's arithmetic (multiplication without fused operations, Smith's
/// division as numpy's `divide` loop).
#[derive(Clone, Copy, Debug, PartialEq)]
struct C {
    re: f64,
    im: f64,
}

impl C {
    const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }

    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }

    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }

    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }

    fn neg(self) -> Self {
        Self::new(-self.re, -self.im)
    }

    /// numpy's complex division (`npy_cdivide`: Smith's algorithm with a reciprocal scale).
    fn div(self, o: Self) -> Self {
        let (ar, ai, br, bi) = (self.re, self.im, o.re, o.im);
        if br.abs() >= bi.abs() {
            if br == 0.0 && bi == 0.0 {
                return Self::new(ar / br.abs(), ai / br.abs());
            }
            let rat = bi / br;
            let scl = 1.0 / (br + bi * rat);
            Self::new((ar + ai * rat) * scl, (ai - ar * rat) * scl)
        } else {
            let rat = br / bi;
            let scl = 1.0 / (bi + br * rat);
            Self::new((ar * rat + ai) * scl, (ai * rat - ar) * scl)
        }
    }

    /// `exp(z)` as C's `cexp` for a finite argument.
    fn exp(self) -> Self {
        let e = self.re.exp();
        Self::new(e * self.im.cos(), e * self.im.sin())
    }
}

/// Coefficients `(b, a)` of a digital Butterworth low-pass of `order` with cut-off `cutoff`
/// (Hz) at sampling rate `fs` (Hz): `scipy.signal.butter(order, cutoff, fs=fs)`.
///
/// # Errors
/// [`EngineError::InvalidParameter`] unless `1 <= order <= 20`, `fs > 0` and
/// `0 < cutoff < fs / 2` (all finite).
pub fn butter_lowpass(order: usize, cutoff: f64, fs: f64) -> Result<(Vec<f64>, Vec<f64>)> {
    if !(1..=20).contains(&order) {
        return Err(EngineError::InvalidParameter(format!(
            "filter order must be between 1 and 20, got {order}"
        )));
    }
    if !(fs.is_finite() && fs > 0.0) {
        return Err(EngineError::InvalidParameter(format!(
            "sampling rate must be positive, got {fs}"
        )));
    }
    // scipy: Wn = Wn / (fs / 2), then pre-warped with fs = 2
    let wn = cutoff / (fs / 2.0);
    if !(wn > 0.0 && wn < 1.0) {
        return Err(EngineError::InvalidParameter(format!(
            "cut-off {cutoff} Hz must be between 0 and the Nyquist frequency {} Hz",
            fs / 2.0
        )));
    }
    let n = order as f64;
    let warped = 2.0 * 2.0 * (std::f64::consts::PI * wn / 2.0).tan();
    // buttap: p = -exp(1j * pi * m / (2 * N)), m = -N+1, -N+3, ..., N-1
    let j_pi = C::new(0.0, std::f64::consts::PI);
    let poles: Vec<C> = (0..order)
        .map(|i| {
            let m = -n + 1.0 + 2.0 * i as f64;
            j_pi.mul(C::new(m, 0.0))
                .div(C::new(2.0 * n, 0.0))
                .exp()
                .neg()
        })
        .collect();
    // lp2lp_zpk: p * wo, k = wo ** degree
    let wo = C::new(warped, 0.0);
    let poles: Vec<C> = poles.iter().map(|&p| wo.mul(p)).collect();
    let k = warped.powf(n);
    // bilinear_zpk with fs = 2: fs2 = 4
    let fs2 = C::new(4.0, 0.0);
    let pz: Vec<C> = poles.iter().map(|&p| fs2.add(p).div(fs2.sub(p))).collect();
    let den = poles
        .iter()
        .fold(C::new(1.0, 0.0), |acc, &p| acc.mul(fs2.sub(p)));
    // prod(fs2 - z) over no zeros is 1.0 (real), divided by a complex product
    let kz = k * C::new(1.0, 0.0).div(den).re;
    // zpk2tf: b = k * poly(-1, ..., -1), a = poly(pz)
    let ones = vec![C::new(-1.0, 0.0); order];
    let b: Vec<f64> = poly(&ones).iter().map(|c| kz * c.re).collect();
    let a: Vec<f64> = poly(&pz).iter().map(|c| c.re).collect();
    Ok((b, a))
}

/// `np.poly` of complex roots: the coefficients of `prod (x - r)`, highest power first, by
/// repeated convolution with `[1, -r]`. Each output is numpy's complex `dot` of at most two
/// products, which BLAS (`zdotu`) sums as real and imaginary parts of like products:
/// `re = (a0r b0r + a1r b1r) - (a0i b0i + a1i b1i)`.
fn poly(roots: &[C]) -> Vec<C> {
    let mut a = vec![C::new(1.0, 0.0)];
    for &r in roots {
        let v = [C::new(1.0, 0.0), r.neg()];
        let mut out = vec![C::new(0.0, 0.0); a.len() + 1];
        for (i, o) in out.iter_mut().enumerate() {
            // out[i] = sum_j a[j] * v[i - j] over 0 <= i - j <= 1
            let terms: Vec<(C, C)> = (i.saturating_sub(1)..=i.min(a.len() - 1))
                .map(|j| (a[j], v[i - j]))
                .collect();
            *o = match terms.as_slice() {
                [(x, y)] => x.mul(*y),
                [(x0, y0), (x1, y1)] => C::new(
                    (x0.re * y0.re + x1.re * y1.re) - (x0.im * y0.im + x1.im * y1.im),
                    (x0.re * y0.im + x1.re * y1.im) + (x0.im * y0.re + x1.im * y1.re),
                ),
                _ => C::new(0.0, 0.0),
            };
        }
        a = out;
    }
    a
}

/// Normalised, equally long copies of `b` and `a` (`a[0] = 1`), as scipy's filters use them;
/// more than [`MAX_COEFFICIENTS`] of either is an [`EngineError::InvalidParameter`].
fn normalized(b: &[f64], a: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
    at_most(
        b.len(),
        MAX_COEFFICIENTS,
        "the number of filter coefficients b",
    )?;
    at_most(
        a.len(),
        MAX_COEFFICIENTS,
        "the number of filter coefficients a",
    )?;
    let first = a.iter().position(|&v| v != 0.0).ok_or_else(|| {
        EngineError::InvalidParameter("there must be at least one nonzero `a` coefficient".into())
    })?;
    if b.is_empty() {
        return Err(EngineError::EmptySequence("filter numerator b".into()));
    }
    if let Some(v) = b.iter().chain(a).find(|v| !v.is_finite()) {
        return Err(EngineError::NonFinite(format!("filter coefficient {v}")));
    }
    let mut a = a[first..].to_vec();
    let mut b = b.to_vec();
    if a[0] != 1.0 {
        let a0 = a[0];
        for v in &mut b {
            *v /= a0;
        }
        for v in &mut a {
            *v /= a0;
        }
    }
    let n = a.len().max(b.len());
    a.resize(n, 0.0);
    b.resize(n, 0.0);
    Ok((b, a))
}

/// Initial conditions of the steady state of the step response: `scipy.signal.lfilter_zi`
/// (the system `(I - companion(a)^T) zi = b[1:] - a[1:] b[0]`, solved by LU with partial
/// pivoting).
///
/// # Errors
/// [`EngineError::InvalidParameter`] for an all-zero `a` or a singular system,
/// [`EngineError::NonFinite`] for non-finite coefficients.
pub fn lfilter_zi(b: &[f64], a: &[f64]) -> Result<Vec<f64>> {
    let (b, a) = normalized(b, a)?;
    let m = a.len() - 1;
    if m == 0 {
        return Ok(Vec::new());
    }
    // companion(a): first row -a[1:] / a[0], ones on the sub-diagonal; IminusA = I - C^T
    let mut mat = nalgebra::DMatrix::<f64>::identity(m, m);
    for i in 0..m {
        mat[(i, 0)] -= -a[i + 1];
        if i + 1 < m {
            mat[(i, i + 1)] -= 1.0;
        }
    }
    let rhs = nalgebra::DVector::from_iterator(m, (0..m).map(|i| b[i + 1] - a[i + 1] * b[0]));
    let zi = lu_solve(mat, rhs)?;
    Ok(zi.iter().copied().collect())
}

/// `A x = y` by Gaussian elimination with partial pivoting (LAPACK `dgesv`'s pivot choice:
/// the first largest magnitude; the column below the pivot scaled by its reciprocal).
fn lu_solve(
    mut a: nalgebra::DMatrix<f64>,
    mut y: nalgebra::DVector<f64>,
) -> Result<nalgebra::DVector<f64>> {
    let n = a.nrows();
    for k in 0..n {
        let mut p = k;
        for i in k + 1..n {
            if a[(i, k)].abs() > a[(p, k)].abs() {
                p = i;
            }
        }
        if a[(p, k)] == 0.0 {
            return Err(EngineError::InvalidParameter(
                "singular linear system (lfilter_zi)".into(),
            ));
        }
        if p != k {
            a.swap_rows(p, k);
            y.swap_rows(p, k);
        }
        let r = 1.0 / a[(k, k)];
        for i in k + 1..n {
            a[(i, k)] *= r;
        }
        for j in k + 1..n {
            for i in k + 1..n {
                a[(i, j)] -= a[(i, k)] * a[(k, j)];
            }
        }
    }
    for k in 0..n {
        for i in k + 1..n {
            y[i] -= a[(i, k)] * y[k];
        }
    }
    for k in (0..n).rev() {
        y[k] /= a[(k, k)];
        for i in 0..k {
            y[i] -= a[(i, k)] * y[k];
        }
    }
    Ok(y)
}

/// Direct form II transposed filter of one column `x` in place from the state `z`
/// (`len - 1` values; updated): scipy's `lfilter` loop (`y = z[0] + b[0] x`,
/// `z[k] = z[k + 1] + x b[k + 1] - y a[k + 1]`, `z[last] = x b[last] - y a[last]`).
fn lfilter_inplace(b: &[f64], a: &[f64], x: &mut [f64], z: &mut [f64]) {
    let len = b.len();
    if len == 1 {
        for v in x.iter_mut() {
            *v *= b[0];
        }
        return;
    }
    for v in x.iter_mut() {
        let xn = *v;
        let yn = z[0] + b[0] * xn;
        for k in 0..len - 2 {
            z[k] = z[k + 1] + xn * b[k + 1] - yn * a[k + 1];
        }
        z[len - 2] = xn * b[len - 1] - yn * a[len - 1];
        *v = yn;
    }
}

/// [`filtfilt`] of one column into `ext` (`x.len() > padlen`, coefficients normalised, `zi`
/// of them).
fn filtfilt_column(b: &[f64], a: &[f64], zi: &[f64], x: &[f64], padlen: usize, ext: &mut Vec<f64>) {
    let n = x.len();
    // odd extension: 2 x[0] - x[padlen..0], x, 2 x[n-1] - x[n-2..n-2-padlen]
    ext.clear();
    ext.extend((0..padlen).map(|i| 2.0 * x[0] - x[padlen - i]));
    ext.extend_from_slice(x);
    ext.extend((0..padlen).map(|i| 2.0 * x[n - 1] - x[n - 2 - i]));
    let mut z: Vec<f64> = zi.iter().map(|&v| v * ext[0]).collect();
    lfilter_inplace(b, a, ext, &mut z);
    ext.reverse();
    let mut z: Vec<f64> = zi.iter().map(|&v| v * ext[0]).collect();
    lfilter_inplace(b, a, ext, &mut z);
    ext.reverse();
    ext.truncate(padlen + n);
    ext.drain(..padlen);
}

/// Zero-phase filtering of the rows of `x` (`n x c`, row-major), each column on its own:
/// `scipy.signal.filtfilt(b, a, x, axis=0, padtype="odd", padlen=padlen)` (odd extension of
/// `padlen` samples at both ends, `lfilter_zi` initial conditions scaled by the first sample of
/// each pass).
///
/// # Errors
/// [`EngineError::ShapeMismatch`] if `x.len() != n * c`, [`EngineError::InvalidParameter`]
/// unless `n > padlen`, and the errors of [`lfilter_zi`].
pub fn filtfilt(
    b: &[f64],
    a: &[f64],
    x: &[f64],
    n: usize,
    c: usize,
    padlen: usize,
) -> Result<Vec<f64>> {
    if x.len() != n * c {
        return Err(EngineError::ShapeMismatch(format!(
            "{} values for a signal of {n} samples x {c} columns",
            x.len()
        )));
    }
    if n <= padlen {
        return Err(EngineError::InvalidParameter(format!(
            "the signal of {n} samples must be longer than padlen = {padlen}"
        )));
    }
    let zi = lfilter_zi(b, a)?;
    let (b, a) = normalized(b, a)?;
    let mut out = vec![0.0; n * c];
    // LANES columns per block, a block per thread at a time, written back in column order
    let starts: Vec<usize> = (0..c).step_by(LANES).collect();
    for round in starts.chunks(rayon::current_num_threads().max(1)) {
        let done: Vec<Vec<[f64; LANES]>> = round
            .par_iter()
            .map(|&j0| {
                let mut ext = Vec::new();
                filtfilt_lanes(&b, &a, &zi, x, c, j0, padlen, &mut ext);
                ext
            })
            .collect();
        for (&j0, ext) in round.iter().zip(done) {
            let width = LANES.min(c - j0);
            for (row, e) in out.chunks_exact_mut(c).zip(&ext[padlen..padlen + n]) {
                row[j0..j0 + width].copy_from_slice(&e[..width]);
            }
        }
    }
    Ok(out)
}

/// Columns filtered together by [`filtfilt_lanes`].
const LANES: usize = 8;

/// [`filtfilt_column`] of the columns `j0..j0 + LANES` (those that exist; the other lanes are
/// zeros) of the row-major `x` of `c` columns, at once: `ext` becomes the filtered odd extension,
/// a row of lanes per sample. Every lane runs the operations of [`filtfilt_column`] in its order
/// (the same values, bit for bit); together the latency-bound recursions interleave.
#[allow(clippy::too_many_arguments)]
fn filtfilt_lanes(
    b: &[f64],
    a: &[f64],
    zi: &[f64],
    x: &[f64],
    c: usize,
    j0: usize,
    padlen: usize,
    ext: &mut Vec<[f64; LANES]>,
) {
    let n = x.len() / c;
    let width = LANES.min(c - j0);
    let row = |i: usize| -> [f64; LANES] {
        let mut r = [0.0; LANES];
        r[..width].copy_from_slice(&x[i * c + j0..i * c + j0 + width]);
        r
    };
    let (first, last) = (row(0), row(n - 1));
    // odd extension: 2 x[0] - x[padlen..0], x, 2 x[n-1] - x[n-2..n-2-padlen]
    ext.clear();
    ext.reserve(n + 2 * padlen);
    for i in 0..padlen {
        let r = row(padlen - i);
        ext.push(std::array::from_fn(|l| 2.0 * first[l] - r[l]));
    }
    ext.extend((0..n).map(row));
    for i in 0..padlen {
        let r = row(n - 2 - i);
        ext.push(std::array::from_fn(|l| 2.0 * last[l] - r[l]));
    }
    let len = b.len();
    let mut z = vec![[0.0; LANES]; len.saturating_sub(1)];
    // one pass of lfilter_inplace over the rows in `order`, from the state zi * (first row)
    let mut pass = |ext: &mut [[f64; LANES]], backward: bool| {
        let x0 = if backward { ext[ext.len() - 1] } else { ext[0] };
        for (zk, &v) in z.iter_mut().zip(zi) {
            *zk = std::array::from_fn(|l| v * x0[l]);
        }
        let step = |v: &mut [f64; LANES], z: &mut [[f64; LANES]]| {
            if len == 1 {
                for e in v.iter_mut() {
                    *e *= b[0];
                }
                return;
            }
            let xn = *v;
            let yn: [f64; LANES] = std::array::from_fn(|l| z[0][l] + b[0] * xn[l]);
            for k in 0..len - 2 {
                for l in 0..LANES {
                    z[k][l] = z[k + 1][l] + xn[l] * b[k + 1] - yn[l] * a[k + 1];
                }
            }
            for l in 0..LANES {
                z[len - 2][l] = xn[l] * b[len - 1] - yn[l] * a[len - 1];
            }
            *v = yn;
        };
        if backward {
            for v in ext.iter_mut().rev() {
                step(v, &mut z);
            }
        } else {
            for v in ext.iter_mut() {
                step(v, &mut z);
            }
        }
    };
    pass(ext, false);
    pass(ext, true);
}

/// Half-open `(start, stop)` ranges of the runs of true in `mask`.
pub fn runs(mask: impl IntoIterator<Item = bool>) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    let mut i = 0;
    for v in mask {
        match (v, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                out.push((s, i));
                start = None;
            }
            _ => {}
        }
        i += 1;
    }
    if let Some(s) = start {
        out.push((s, i));
    }
    out
}

/// A filtered signal and the `(start, stop)` of its runs left unfiltered.
pub type FilteredRuns = (Vec<f64>, Vec<(usize, usize)>);

/// [`filtfilt`] of a signal with gaps: each column's runs of `ok` samples are filtered on
/// their own, a run of at most `padlen` samples is left unfiltered, and samples that are not
/// `ok` become NaN. Returns the filtered signal and the `(start, stop)` of the runs left
/// unfiltered, each once, in order of the first column that has it.
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for lengths other than `n * c`, and those of [`filtfilt`].
pub fn filtfilt_runs(
    b: &[f64],
    a: &[f64],
    x: &[f64],
    ok: &[bool],
    n: usize,
    c: usize,
    padlen: usize,
) -> Result<FilteredRuns> {
    if x.len() != n * c || ok.len() != n * c {
        return Err(EngineError::ShapeMismatch(format!(
            "{} values and {} flags for a signal of {n} samples x {c} columns",
            x.len(),
            ok.len()
        )));
    }
    let zi = lfilter_zi(b, a)?;
    let (bn, an) = normalized(b, a)?;
    let mut out: Vec<f64> = x
        .iter()
        .zip(ok)
        .map(|(&v, &k)| if k { v } else { f64::NAN })
        .collect();
    let mut short: Vec<(usize, usize)> = Vec::new();
    let column = |j: usize| -> Column {
        let (mut too_short, mut filtered) = (Vec::new(), Vec::new());
        for (s, e) in runs((0..n).map(|i| ok[i * c + j])) {
            if e - s <= padlen {
                too_short.push((s, e));
                continue;
            }
            let col: Vec<f64> = (s..e).map(|i| x[i * c + j]).collect();
            let mut ext = Vec::new();
            filtfilt_column(&bn, &an, &zi, &col, padlen, &mut ext);
            ext.truncate(e - s);
            filtered.push((s, ext));
        }
        (too_short, filtered)
    };
    // a few columns per thread at a time, written back in column order
    let columns: Vec<usize> = (0..c).collect();
    for round in columns.chunks(4 * rayon::current_num_threads().max(1)) {
        let done: Vec<Column> = round.par_iter().map(|&j| column(j)).collect();
        for (&j, (too_short, filtered)) in round.iter().zip(done) {
            for run in too_short {
                if !short.contains(&run) {
                    short.push(run);
                }
            }
            for (s, values) in filtered {
                for (i, v) in (s..).zip(values) {
                    out[i * c + j] = v;
                }
            }
        }
    }
    Ok((out, short))
}

/// Solve the tridiagonal system with sub-diagonal `dl` (`m - 1`), diagonal `d` (`m`) and
/// super-diagonal `du` (`m - 1`) for the `c` right-hand sides `rhs` (`m x c`, row-major):
/// LAPACK `dgtsv` (Gaussian elimination with partial pivoting), what
/// `scipy.linalg.solve_banded((1, 1), ...)` calls.
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for inconsistent lengths, [`EngineError::InvalidParameter`]
/// for a singular matrix, [`EngineError::NonFinite`] for NaN or infinite input.
pub fn solve_tridiagonal(
    dl: &[f64],
    d: &[f64],
    du: &[f64],
    rhs: &[f64],
    c: usize,
) -> Result<Vec<f64>> {
    let m = d.len();
    if m == 0 {
        return Err(EngineError::EmptySequence("tridiagonal system".into()));
    }
    if dl.len() + 1 != m || du.len() + 1 != m || rhs.len() != m * c {
        return Err(EngineError::ShapeMismatch(format!(
            "tridiagonal system of {m} rows with {} sub-, {} super-diagonal entries and {} \
             right-hand side values for {c} columns",
            dl.len(),
            du.len(),
            rhs.len()
        )));
    }
    if let Some(v) = dl
        .iter()
        .chain(d)
        .chain(du)
        .chain(rhs)
        .find(|v| !v.is_finite())
    {
        return Err(EngineError::NonFinite(format!(
            "tridiagonal system value {v}"
        )));
    }
    let mut b = rhs.to_vec();
    gtsv_inplace(
        &mut dl.to_vec(),
        &mut d.to_vec(),
        &mut du.to_vec(),
        &mut b,
        c,
    )?;
    Ok(b)
}

/// LAPACK `dgtsv` in place: on return `b` (`m x c`, row-major) holds the solution; the
/// diagonals are overwritten by the factorisation.
fn gtsv_inplace(
    dl: &mut [f64],
    d: &mut [f64],
    du: &mut [f64],
    b: &mut [f64],
    c: usize,
) -> Result<()> {
    let m = d.len();
    let singular = |i: usize| {
        EngineError::InvalidParameter(format!("singular tridiagonal system (pivot {i})"))
    };
    for i in 0..m.saturating_sub(1) {
        if d[i].abs() >= dl[i].abs() {
            if d[i] == 0.0 {
                return Err(singular(i));
            }
            let fact = dl[i] / d[i];
            d[i + 1] -= fact * du[i];
            for j in 0..c {
                b[(i + 1) * c + j] -= fact * b[i * c + j];
            }
            dl[i] = 0.0;
        } else {
            let fact = d[i] / dl[i];
            d[i] = dl[i];
            let temp = d[i + 1];
            d[i + 1] = du[i] - fact * temp;
            if i + 2 < m {
                dl[i] = du[i + 1];
                du[i + 1] = -fact * dl[i];
            }
            du[i] = temp;
            for j in 0..c {
                let t = b[i * c + j];
                b[i * c + j] = b[(i + 1) * c + j];
                b[(i + 1) * c + j] = t - fact * b[(i + 1) * c + j];
            }
        }
    }
    if d[m - 1] == 0.0 {
        return Err(singular(m - 1));
    }
    for j in 0..c {
        b[(m - 1) * c + j] /= d[m - 1];
        if m > 1 {
            b[(m - 2) * c + j] = (b[(m - 2) * c + j] - du[m - 2] * b[(m - 1) * c + j]) / d[m - 2];
        }
        for i in (0..m.saturating_sub(2)).rev() {
            b[i * c + j] =
                (b[i * c + j] - du[i] * b[(i + 1) * c + j] - dl[i] * b[(i + 2) * c + j]) / d[i];
        }
    }
    Ok(())
}

/// A cubic spline through `(t, y)`, `y` of `c` columns, with scipy's not-a-knot end
/// conditions (two knots: the straight line; three: the parabola).
#[derive(Clone, Debug)]
pub struct CubicSpline {
    t: Vec<f64>,
    c: usize,
    /// Coefficients of each interval, highest power first: `coef[k][i * c + j]`.
    coef: [Vec<f64>; 4],
}

impl CubicSpline {
    /// `scipy.interpolate.CubicSpline(t, y, axis=0)` with `y` row-major `(m, c)`.
    ///
    /// # Errors
    /// [`EngineError::InvalidParameter`] for fewer than two knots or times not strictly
    /// increasing, [`EngineError::ShapeMismatch`] if `y.len() != m * c`,
    /// [`EngineError::NonFinite`] for NaN or infinite input.
    pub fn new(t: &[f64], y: &[f64], c: usize) -> Result<Self> {
        let m = t.len();
        if m < 2 {
            return Err(EngineError::InvalidParameter(format!(
                "a cubic spline needs at least 2 knots, got {m}"
            )));
        }
        if y.len() != m * c {
            return Err(EngineError::ShapeMismatch(format!(
                "{} values for {m} knots x {c} columns",
                y.len()
            )));
        }
        if let Some(v) = t.iter().chain(y).find(|v| !v.is_finite()) {
            return Err(EngineError::NonFinite(format!("spline input value {v}")));
        }
        if t.windows(2).any(|w| w[1] <= w[0]) {
            return Err(EngineError::InvalidParameter(
                "spline knots must be strictly increasing".into(),
            ));
        }
        let dx: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        let slope: Vec<f64> = (0..(m - 1) * c)
            .map(|k| {
                let (i, j) = (k / c, k % c);
                (y[(i + 1) * c + j] - y[i * c + j]) / dx[i]
            })
            .collect();
        let s = if m == 2 {
            // not-a-knot with two knots: first derivative = slope at both ends
            let mut s = slope.clone();
            s.extend_from_slice(&slope);
            s
        } else if m == 3 {
            Self::three_knots(&dx, &slope, c)?
        } else {
            let mut dl = vec![0.0; m - 1];
            let mut d = vec![0.0; m];
            let mut du = vec![0.0; m - 1];
            let mut b = vec![0.0; m * c];
            for i in 1..m - 1 {
                d[i] = 2.0 * (dx[i - 1] + dx[i]);
                du[i] = dx[i - 1];
                dl[i - 1] = dx[i];
                for j in 0..c {
                    b[i * c + j] =
                        3.0 * (dx[i] * slope[(i - 1) * c + j] + dx[i - 1] * slope[i * c + j]);
                }
            }
            d[0] = dx[1];
            du[0] = t[2] - t[0];
            let g = t[2] - t[0];
            for j in 0..c {
                b[j] = ((dx[0] + 2.0 * g) * dx[1] * slope[j] + dx[0].powi(2) * slope[c + j]) / g;
            }
            d[m - 1] = dx[m - 3];
            dl[m - 2] = t[m - 1] - t[m - 3];
            let g = t[m - 1] - t[m - 3];
            for j in 0..c {
                b[(m - 1) * c + j] = (dx[m - 2].powi(2) * slope[(m - 3) * c + j]
                    + (2.0 * g + dx[m - 2]) * dx[m - 3] * slope[(m - 2) * c + j])
                    / g;
            }
            solve_tridiagonal(&dl, &d, &du, &b, c)?
        };
        // CubicHermiteSpline coefficients
        let mut coef = [
            vec![0.0; (m - 1) * c],
            vec![0.0; (m - 1) * c],
            vec![0.0; (m - 1) * c],
            vec![0.0; (m - 1) * c],
        ];
        for i in 0..m - 1 {
            for j in 0..c {
                let k = i * c + j;
                let tt = (s[k] + s[k + c] - 2.0 * slope[k]) / dx[i];
                coef[0][k] = tt / dx[i];
                coef[1][k] = (slope[k] - s[k]) / dx[i] - tt;
                coef[2][k] = s[k];
                coef[3][k] = y[k];
            }
        }
        Ok(Self {
            t: t.to_vec(),
            c,
            coef,
        })
    }

    /// The slopes of the 3-knot not-a-knot spline (one parabola): scipy's dense 3 x 3 solve.
    fn three_knots(dx: &[f64], slope: &[f64], c: usize) -> Result<Vec<f64>> {
        let a = nalgebra::DMatrix::from_row_slice(
            3,
            3,
            &[
                1.0,
                1.0,
                0.0,
                dx[1],
                2.0 * (dx[0] + dx[1]),
                dx[0],
                0.0,
                1.0,
                1.0,
            ],
        );
        let mut s = vec![0.0; 3 * c];
        for j in 0..c {
            let rhs = nalgebra::DVector::from_vec(vec![
                2.0 * slope[j],
                3.0 * (dx[0] * slope[c + j] + dx[1] * slope[j]),
                2.0 * slope[c + j],
            ]);
            let v = lu_solve(a.clone(), rhs)?;
            for i in 0..3 {
                s[i * c + j] = v[i];
            }
        }
        Ok(s)
    }

    /// Number of columns.
    pub fn columns(&self) -> usize {
        self.c
    }

    /// Values at `at` (extrapolated beyond the knots with the end polynomials; NaN at a NaN
    /// time), row-major `(at.len(), c)`: scipy's `PPoly.__call__`.
    pub fn eval(&self, at: &[f64]) -> Vec<f64> {
        let (c, nt) = (self.c, self.t.len());
        let mut out = vec![0.0; at.len() * c];
        for (r, &x) in at.iter().enumerate() {
            let row = &mut out[r * c..(r + 1) * c];
            if x.is_nan() {
                row.fill(f64::NAN);
                continue;
            }
            // x[i] <= x < x[i + 1]; the last interval is closed; extrapolate at the ends
            let i = self.t.partition_point(|&v| v <= x).clamp(1, nt - 1) - 1;
            let s = x - self.t[i];
            for (j, o) in row.iter_mut().enumerate() {
                let k = i * c + j;
                let mut res = 0.0;
                let mut z = 1.0;
                for (p, cf) in [&self.coef[3], &self.coef[2], &self.coef[1], &self.coef[0]]
                    .iter()
                    .enumerate()
                {
                    res += cf[k] * z;
                    if p < 3 {
                        z *= s;
                    }
                }
                *o = res;
            }
        }
        out
    }
}

/// A reusable not-a-knot cubic spline of `g` columns on the same knots: [`CubicSpline`] with
/// `c = g` (the same operations, so the same numbers for each column), its buffers kept from
/// one group of columns to the next.
#[derive(Default)]
struct ColumnSpline {
    g: usize,
    dx: Vec<f64>,
    slope: Vec<f64>,
    dl: Vec<f64>,
    d: Vec<f64>,
    du: Vec<f64>,
    s: Vec<f64>,
    /// `[c0, c1, c2, c3]` of each interval and column (row-major, `(m - 1) x g`), highest
    /// power first.
    coef: Vec<[f64; 4]>,
}

impl ColumnSpline {
    /// Fit `(t, y)`: `t` strictly increasing (at least 2 knots), `y` row-major `m x g`, all
    /// finite.
    fn fit(&mut self, t: &[f64], y: &[f64], g: usize) -> Result<()> {
        let m = t.len();
        self.g = g;
        self.dx.clear();
        self.dx.extend(t.windows(2).map(|w| w[1] - w[0]));
        let dx = &self.dx;
        self.slope.clear();
        self.slope
            .extend((0..(m - 1) * g).map(|ik| (y[ik + g] - y[ik]) / dx[ik / g]));
        let slope = &self.slope;
        self.s.clear();
        if m == 2 {
            self.s.extend_from_slice(slope);
            self.s.extend_from_slice(slope);
        } else if m == 3 {
            self.s.extend(CubicSpline::three_knots(dx, slope, g)?);
        } else {
            self.dl.clear();
            self.dl.resize(m - 1, 0.0);
            self.d.clear();
            self.d.resize(m, 0.0);
            self.du.clear();
            self.du.resize(m - 1, 0.0);
            self.s.resize(m * g, 0.0);
            let (dl, d, du, b) = (&mut self.dl, &mut self.d, &mut self.du, &mut self.s);
            for i in 1..m - 1 {
                d[i] = 2.0 * (dx[i - 1] + dx[i]);
                du[i] = dx[i - 1];
                dl[i - 1] = dx[i];
                for k in 0..g {
                    b[i * g + k] =
                        3.0 * (dx[i] * slope[(i - 1) * g + k] + dx[i - 1] * slope[i * g + k]);
                }
            }
            d[0] = dx[1];
            let g0 = t[2] - t[0];
            du[0] = g0;
            for k in 0..g {
                b[k] = ((dx[0] + 2.0 * g0) * dx[1] * slope[k] + dx[0].powi(2) * slope[g + k]) / g0;
            }
            d[m - 1] = dx[m - 3];
            let g1 = t[m - 1] - t[m - 3];
            dl[m - 2] = g1;
            for k in 0..g {
                b[(m - 1) * g + k] = (dx[m - 2].powi(2) * slope[(m - 3) * g + k]
                    + (2.0 * g1 + dx[m - 2]) * dx[m - 3] * slope[(m - 2) * g + k])
                    / g1;
            }
            gtsv_inplace(dl, d, du, b, g)?;
        }
        let s = &self.s;
        self.coef.clear();
        self.coef.extend((0..(m - 1) * g).map(|ik| {
            let i = ik / g;
            let tt = (s[ik] + s[ik + g] - 2.0 * slope[ik]) / dx[i];
            [tt / dx[i], (slope[ik] - s[ik]) / dx[i] - tt, s[ik], y[ik]]
        }));
        Ok(())
    }

    /// The values of the `g` columns at `x` into `out` (`t` the knots of the last fit), in
    /// the interval before knot `upper` (its [`upper_index`]).
    fn eval(&self, t: &[f64], x: f64, upper: usize, out: &mut [f64]) {
        let i = upper - 1;
        let s = x - t[i];
        for (o, c) in out.iter_mut().zip(&self.coef[i * self.g..(i + 1) * self.g]) {
            let mut res = 0.0;
            let mut z = 1.0;
            for p in 0..4 {
                res += c[3 - p] * z;
                if p < 3 {
                    z *= s;
                }
            }
            *o = res;
        }
    }
}

/// Where a target time is interpolated from the sorted source times `tk`: inside their span
/// and not inside an interval longer than `max_gap` (a target on a sample always is).
/// `lfd.preprocessing.resample.gap_mask`.
pub fn gap_mask(tk: &[f64], td: &[f64], max_gap: f64) -> Vec<bool> {
    let mut out = Vec::with_capacity(td.len());
    gap_mask_into(tk, td, max_gap, &mut out);
    out
}

/// The index `i` in `1..m` with `tk[i - 1] <= t < tk[i]` (clamped to the ends), found from
/// the previous answer `hint` first (targets in increasing order take a step or two).
#[allow(clippy::needless_bitwise_bool)] // bitwise on purpose: no branch (see below)
fn upper_index(tk: &[f64], t: f64, hint: usize) -> usize {
    let m = tk.len();
    if hint >= 1 && hint < m && tk[hint - 1] <= t {
        // up to two steps forward without a branch (which way a step goes is a coin toss when
        // the targets and the samples come at the same rate)
        let last = m - 1;
        let mut i = hint;
        i += usize::from((i < last) & (tk[i] <= t));
        i += usize::from((i < last) & (tk[i] <= t));
        if t < tk[i] || i == last {
            return i;
        }
    }
    tk.partition_point(|&v| v <= t).clamp(1, m - 1)
}

/// [`gap_mask`] into `out` (cleared first).
fn gap_mask_into(tk: &[f64], td: &[f64], max_gap: f64, out: &mut Vec<bool>) {
    let mut upper = Vec::new();
    gap_mask_upper(tk, td, max_gap, out, &mut upper);
}

/// [`gap_mask_into`], and in `upper` the [`upper_index`] of every target (0 for a target
/// outside the samples, or with a single sample): the interval a spline over `tk` evaluates it
/// in.
fn gap_mask_upper(
    tk: &[f64],
    td: &[f64],
    max_gap: f64,
    out: &mut Vec<bool>,
    upper: &mut Vec<usize>,
) {
    out.clear();
    upper.clear();
    let m = tk.len();
    if m == 0 {
        out.resize(td.len(), false);
        upper.resize(td.len(), 0);
        return;
    }
    let mut hint = 1;
    for &t in td {
        let inside = t >= tk[0] && t <= tk[m - 1];
        if m == 1 || !inside {
            out.push(inside);
            upper.push(0);
            continue;
        }
        let i = upper_index(tk, t, hint);
        hint = i;
        let gap = tk[i] - tk[i - 1];
        out.push(gap <= max_gap || t == tk[i - 1] || t == tk[i]);
        upper.push(i);
    }
}

/// One column's weighted nodes: `y_i = w_i x_i + (1 - w_i) yhat_i`, `yhat_i` the linear
/// interpolation at `t_i` of the neighbours within `max_gap`
/// (`lfd.preprocessing.resample.weighted_nodes`, the same operations).
///
/// # Errors
/// Those of [`solve_tridiagonal`].
pub fn weighted_nodes(t: &[f64], x: &[f64], w: &[f64], max_gap: f64) -> Result<Vec<f64>> {
    let mut scratch = NodeScratch::default();
    let mut out = Vec::new();
    weighted_nodes_into(t, x, w, 1, max_gap, &mut scratch, &mut out)?;
    Ok(out)
}

/// The buffers of [`weighted_nodes_into`], kept from one column to the next.
#[derive(Default)]
struct NodeScratch {
    alpha: Vec<f64>,
    beta: Vec<f64>,
    lower: Vec<f64>,
    diag: Vec<f64>,
    upper: Vec<f64>,
}

/// [`weighted_nodes`] of `g` columns (`x` row-major `m x g`, one weight per row) into `out`
/// (the solution overwrites the right-hand side in place; each column's numbers are those of
/// the column alone).
fn weighted_nodes_into(
    t: &[f64],
    x: &[f64],
    w: &[f64],
    g: usize,
    max_gap: f64,
    sc: &mut NodeScratch,
    out: &mut Vec<f64>,
) -> Result<()> {
    let m = t.len();
    out.clear();
    if m < 2 || w.iter().all(|&v| v == 1.0) {
        out.extend_from_slice(x);
        return Ok(());
    }
    let near = |i: usize| t[i + 1] - t[i] <= max_gap;
    sc.alpha.clear();
    sc.beta.clear();
    for i in 0..m {
        let has_left = i > 0 && near(i - 1);
        let has_right = i + 1 < m && near(i);
        if has_left && has_right {
            let (left, right) = (t[i] - t[i - 1], t[i + 1] - t[i]);
            let alpha = right / (left + right);
            sc.alpha.push(alpha);
            sc.beta.push(1.0 - alpha);
        } else {
            sc.alpha.push(f64::from(u8::from(has_left)));
            sc.beta.push(f64::from(u8::from(has_right)));
        }
    }
    sc.upper.clear();
    sc.upper
        .extend((0..m - 1).map(|i| -(1.0 - w[i]) * sc.beta[i]));
    sc.lower.clear();
    sc.lower
        .extend((0..m - 1).map(|i| -(1.0 - w[i + 1]) * sc.alpha[i + 1]));
    sc.diag.clear();
    sc.diag.resize(m, 1.0);
    out.extend(x.iter().enumerate().map(|(ik, &xi)| w[ik / g] * xi));
    gtsv_inplace(&mut sc.lower, &mut sc.diag, &mut sc.upper, out, g)
}

/// Cubic-spline resampling of the columns of `x` (`m x c`, row-major, NaN where not observed)
/// from the strictly increasing times `ts` to the times `td`, each column on its own finite
/// samples, through their [`weighted_nodes`] when `weights` (`m x cw`, `cw` dividing `c`:
/// weight column `k` applies to the `c / cw` data columns from `k c / cw` on) are given: what
/// `lfd.preprocessing.resample.resample_positions` computes. Returns the values and the
/// valid flags (`td.len() x c`, row-major); a target outside a column's samples or inside a
/// gap longer than `max_gap` is NaN and invalid.
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for inconsistent lengths, and those of [`CubicSpline::new`].
pub fn resample_columns(
    ts: &[f64],
    x: &[f64],
    c: usize,
    weights: Option<&[f64]>,
    td: &[f64],
    max_gap: f64,
) -> Result<(Vec<f64>, Vec<bool>)> {
    let m = ts.len();
    let cw = weights.map_or(1, |w| w.len().checked_div(m).unwrap_or(1));
    if x.len() != m * c || weights.is_some_and(|w| cw == 0 || w.len() != m * cw || c % cw != 0) {
        return Err(EngineError::ShapeMismatch(format!(
            "{} values and {} weights for {m} times x {c} columns",
            x.len(),
            weights.map_or(0, <[f64]>::len)
        )));
    }
    let per = c.checked_div(cw).unwrap_or(1).max(1);
    // columns sharing a weight column are fitted together; without weights, any neighbours
    let per_block = if weights.is_some() { per } else { 1 };
    let n = td.len();
    let mut values = vec![f64::NAN; n * c];
    let mut valid = vec![false; n * c];
    // the columns of one block, fitted and evaluated with buffers of its own; neighbouring
    // columns observed at the same samples with the same weights (a point's x, y and z) share
    // their knots, gaps, tridiagonal systems and intervals: one fit of several columns
    let width_of = |j0: usize| block_width(per_block).min(c - j0);
    let block = |j0: usize| -> Result<BlockColumns> {
        let width = width_of(j0);
        let (mut tk, mut xk, mut wk) = (Vec::new(), Vec::new(), Vec::new());
        let mut spline = ColumnSpline::default();
        let (mut scratch, mut weighted) = (NodeScratch::default(), Vec::new());
        let (mut xcols, mut wcols) = (Vec::new(), Vec::new());
        let mut vcols: Vec<Vec<f64>> = vec![Vec::new(); width];
        let mut okcols: Vec<Vec<bool>> = vec![Vec::new(); width];
        let (mut ok, mut upper, mut vals) = (Vec::new(), Vec::new(), vec![0.0; width]);
        gather(x, c, |k| j0 + k, width, &mut xcols);
        if let Some(w) = weights {
            gather(w, cw, |k| (j0 + k) / per, width, &mut wcols);
        }
        let same_samples = |a: usize, b: usize| {
            (weights.is_none() || (j0 + a) / per == (j0 + b) / per)
                && xcols[a]
                    .iter()
                    .zip(&xcols[b])
                    .all(|(u, v)| u.is_finite() == v.is_finite())
        };
        let mut k0 = 0;
        while k0 < width {
            let mut g = 1;
            while k0 + g < width && g < GROUP && same_samples(k0, k0 + g) {
                g += 1;
            }
            let group = k0..k0 + g;
            k0 += g;
            tk.clear();
            xk.clear();
            wk.clear();
            for (i, &v) in xcols[group.start].iter().enumerate() {
                if v.is_finite() {
                    tk.push(ts[i]);
                    xk.extend(group.clone().map(|k| xcols[k][i]));
                    if weights.is_some() {
                        wk.push(wcols[group.start][i]);
                    }
                }
            }
            gap_mask_upper(&tk, td, max_gap, &mut ok, &mut upper);
            for k in group.clone() {
                okcols[k].clone_from(&ok);
                vcols[k].clear();
                vcols[k].resize(n, f64::NAN);
            }
            if tk.is_empty() || !ok.iter().any(|&v| v) {
                continue;
            }
            let nodes: &[f64] = if weights.is_some() {
                weighted_nodes_into(&tk, &xk, &wk, g, max_gap, &mut scratch, &mut weighted)?;
                &weighted
            } else {
                &xk
            };
            if tk.len() > 1 {
                if let Some(v) = tk.iter().chain(nodes).find(|v| !v.is_finite()) {
                    return Err(EngineError::NonFinite(format!("spline input value {v}")));
                }
                if tk.windows(2).any(|w| w[1] <= w[0]) {
                    return Err(EngineError::InvalidParameter(
                        "source times must be strictly increasing".into(),
                    ));
                }
                spline.fit(&tk, nodes, g)?;
            }
            let vals = &mut vals[..g];
            for (i, ((&t, &inside), &up)) in td.iter().zip(&ok).zip(&upper).enumerate() {
                if !inside {
                    continue;
                }
                if tk.len() == 1 {
                    vals.copy_from_slice(&nodes[..g]);
                } else {
                    spline.eval(&tk, t, up, vals);
                }
                for (k, &v) in group.clone().zip(vals.iter()) {
                    vcols[k][i] = v;
                }
            }
        }
        Ok((vcols, okcols))
    };
    // one block per thread at a time: the memory in flight stays a few blocks of columns
    let starts: Vec<usize> = (0..c).step_by(block_width(per_block)).collect();
    for round in starts.chunks(rayon::current_num_threads().max(1)) {
        let done: Vec<Result<BlockColumns>> = round.par_iter().map(|&j0| block(j0)).collect();
        for (&j0, result) in round.iter().zip(done) {
            let (vcols, okcols) = result?;
            scatter(&mut values, c, j0, &vcols);
            scatter(&mut valid, c, j0, &okcols);
        }
    }
    Ok((values, valid))
}

/// One column's runs in [`filtfilt_runs`]: those too short to filter, and the filtered runs
/// with their first sample.
type Column = (Vec<(usize, usize)>, Vec<(usize, Vec<f64>)>);

/// A block's columns in [`resample_columns`]: values and where they are valid, per column.
type BlockColumns = (Vec<Vec<f64>>, Vec<Vec<bool>>);

/// Columns are processed this many at a time: one pass over the rows of a row-major array
/// reads (or writes) them all, a cache line or two of each row (a whole number of 3-D points).
const BLOCK: usize = 12;

/// At most this many columns (a 3-D point's coordinates) are fitted together: the memory of a
/// fit grows with its columns.
const GROUP: usize = 3;

/// The columns of a block of [`resample_columns`] whose weight columns apply to `per` data
/// columns each (1 without weights): [`BLOCK`] rounded up to whole weight columns.
fn block_width(per: usize) -> usize {
    BLOCK.div_ceil(per.max(1)) * per.max(1)
}

/// Columns `col(0), ..., col(width - 1)` of the row-major array `x` of `c` columns into
/// `bufs` (one vector per column), in one pass over the rows.
fn gather(
    x: &[f64],
    c: usize,
    col: impl Fn(usize) -> usize,
    width: usize,
    bufs: &mut Vec<Vec<f64>>,
) {
    bufs.resize_with(width, Vec::new);
    let idx: Vec<usize> = (0..width).map(col).collect();
    for b in bufs.iter_mut() {
        b.clear();
    }
    for row in x.chunks_exact(c) {
        for (b, &j) in bufs.iter_mut().zip(&idx) {
            b.push(row[j]);
        }
    }
}

/// Write the column vectors `bufs` into columns `j0..` of the row-major `out` of `c` columns.
fn scatter<T: Copy>(out: &mut [T], c: usize, j0: usize, bufs: &[Vec<T>]) {
    for (i, row) in out.chunks_exact_mut(c).enumerate() {
        for (k, b) in bufs.iter().enumerate() {
            row[j0 + k] = b[i];
        }
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn filters_with_too_many_coefficients_are_refused() {
        let long = vec![0.5; MAX_COEFFICIENTS + 1];
        let refused = |r: Result<Vec<f64>>| {
            assert!(
                matches!(&r, Err(EngineError::InvalidParameter(m)) if m.contains("at most 1024")),
                "{r:?}"
            );
        };
        refused(lfilter_zi(&long, &[1.0]));
        refused(lfilter_zi(&[1.0], &long));
        refused(filtfilt(&long, &[1.0], &[0.0; 4], 4, 1, 0));
        refused(filtfilt_runs(&[1.0], &long, &[0.0; 4], &[true; 4], 4, 1, 0).map(|r| r.0));
        let ok = vec![1.0 / MAX_COEFFICIENTS as f64; MAX_COEFFICIENTS];
        assert_eq!(lfilter_zi(&ok, &[1.0]).unwrap().len(), MAX_COEFFICIENTS - 1);
    }

    #[test]
    fn butter_matches_scipy_order_4() {
        // scipy.signal.butter(4, 0.625, fs=30.0)
        let (b, a) = butter_lowpass(4, 0.625, 30.0).unwrap();
        let want_a = [
            1.0,
            -3.658_060_303_6,
            5.031_433_53,
            -3.083_228_30,
            0.710_103_90,
        ];
        for (x, y) in a.iter().zip(want_a) {
            assert!((x - y).abs() < 1e-8, "{a:?}");
        }
        let gain = b.iter().sum::<f64>() / a.iter().sum::<f64>();
        assert!((gain - 1.0).abs() < 1e-9);
        assert!(butter_lowpass(4, 15.0, 30.0).is_err());
        assert!(butter_lowpass(0, 1.0, 30.0).is_err());
        assert!(butter_lowpass(4, 1.0, f64::NAN).is_err());
    }

    #[test]
    fn filtfilt_keeps_constants_and_lines() {
        let (b, a) = butter_lowpass(4, 1.0, 30.0).unwrap();
        let n = 40;
        let x: Vec<f64> = (0..n).flat_map(|_| [3.0, -0.5]).collect();
        let y = filtfilt(&b, &a, &x, n, 2, 12).unwrap();
        for i in 0..n {
            assert!((y[2 * i] - 3.0).abs() < 1e-9, "{y:?}");
            assert!((y[2 * i + 1] + 0.5).abs() < 1e-9);
        }
        assert!(filtfilt(&b, &a, &x[..24], 12, 2, 12).is_err());
        assert!(filtfilt(&b, &a, &x, n, 3, 12).is_err());
    }

    #[test]
    fn filtfilt_lanes_equal_one_column_at_a_time() {
        // every column bit for bit what filtfilt_column gives it alone, whatever the block
        for (order, fc) in [(4, 1.0), (2, 3.0), (1, 0.5)] {
            let (b, a) = butter_lowpass(order, fc, 30.0).unwrap();
            let zi = lfilter_zi(&b, &a).unwrap();
            let (bn, an) = normalized(&b, &a).unwrap();
            for (n, c, padlen) in [
                (40, 1, 12),
                (50, 3, 0),
                (61, 8, 15),
                (33, 13, 9),
                (200, 17, 27),
            ] {
                let x: Vec<f64> = (0..n * c)
                    .map(|k| ((k * 7919 % 1013) as f64 / 97.0).sin() + (k % 5) as f64)
                    .collect();
                let y = filtfilt(&b, &a, &x, n, c, padlen).unwrap();
                for j in 0..c {
                    let col: Vec<f64> = (0..n).map(|i| x[i * c + j]).collect();
                    let mut ext = Vec::new();
                    filtfilt_column(&bn, &an, &zi, &col, padlen, &mut ext);
                    for i in 0..n {
                        assert_eq!(
                            y[i * c + j].to_bits(),
                            ext[i].to_bits(),
                            "n {n} c {c} col {j}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn filtfilt_runs_leaves_short_runs() {
        let (b, a) = butter_lowpass(4, 1.0, 30.0).unwrap();
        let n = 30;
        let x: Vec<f64> = (0..n).map(|i| if i < 5 { i as f64 } else { 2.0 }).collect();
        let ok: Vec<bool> = (0..n).map(|i| i != 5).collect();
        let (y, short) = filtfilt_runs(&b, &a, &x, &ok, n, 1, 12).unwrap();
        assert_eq!(short, vec![(0, 5)]);
        assert_eq!(&y[..5], &x[..5]);
        assert!(y[5].is_nan());
        assert!((y[20] - 2.0).abs() < 1e-9);
    }

    #[test]
    fn tridiagonal_solves_with_and_without_pivots() {
        // [[1, 5, 0], [2, 1, 1], [0, 3, 4]] x = rhs, which needs a row interchange
        let x = solve_tridiagonal(
            &[2.0, 3.0],
            &[1.0, 1.0, 4.0],
            &[5.0, 1.0],
            &[11.0, 7.0, 18.0],
            1,
        )
        .unwrap();
        for (v, w) in x.iter().zip([1.0, 2.0, 3.0]) {
            assert!((v - w).abs() < 1e-12, "{x:?}");
        }
        assert!(solve_tridiagonal(&[0.0], &[0.0, 1.0], &[0.0], &[1.0, 1.0], 1).is_err());
        assert!(solve_tridiagonal(&[1.0], &[1.0], &[], &[1.0], 1).is_err());
    }

    #[test]
    fn resample_keeps_gaps() {
        let ts = [0.0, 1.0, 2.0, 3.0, 10.0, 11.0];
        let x = [0.0, 1.0, 2.0, f64::NAN, 10.0, 11.0];
        let td = [0.5, 2.5, 5.0, 10.5, 12.0];
        let (v, ok) = resample_columns(&ts, &x, 1, None, &td, 1.5).unwrap();
        assert_eq!(ok, vec![true, false, false, true, false]);
        assert!((v[0] - 0.5).abs() < 1e-12 && (v[3] - 10.5).abs() < 1e-12);
        assert!(v[1].is_nan() && v[4].is_nan());
        // weight 1 keeps a sample; a low weight pulls it towards its neighbours
        let y = weighted_nodes(&[0.0, 1.0, 2.0], &[0.0, 5.0, 0.0], &[1.0, 0.5, 1.0], 1.5).unwrap();
        assert_eq!(y, vec![0.0, 2.5, 0.0]);
        assert!(resample_columns(&ts, &x[..5], 1, None, &td, 1.5).is_err());
    }

    /// Pseudo-random numbers in [0, 1) (a test needs no better).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn columns_fitted_together_equal_each_column_alone() {
        // 7 points x 3 coordinates: a point's coordinates hidden together (fitted together),
        // some single coordinates hidden (fitted alone), with and without weights, over
        // lengths that take every branch of the spline (1, 2, 3 and more knots)
        let mut st = 7u64;
        for m in [1usize, 2, 3, 4, 5, 40, 600] {
            let ts: Vec<f64> = (0..m)
                .map(|i| i as f64 / 30.0 + 0.01 * lcg(&mut st))
                .collect();
            let c = 21;
            let mut x: Vec<f64> = (0..m * c).map(|_| lcg(&mut st) - 0.5).collect();
            for i in 0..m {
                for p in 0..7 {
                    if lcg(&mut st) < 0.1 {
                        for k in 0..3 {
                            x[i * c + 3 * p + k] = f64::NAN;
                        }
                    }
                }
                if lcg(&mut st) < 0.05 {
                    x[i * c + (i % c)] = f64::NAN;
                }
            }
            let w: Vec<f64> = (0..m * 7).map(|_| 0.3 + 0.7 * lcg(&mut st)).collect();
            let td: Vec<f64> = (0..3 * m).map(|i| -0.05 + i as f64 / 90.0).collect();
            for weights in [None, Some(w.as_slice())] {
                let (v, ok) = resample_columns(&ts, &x, c, weights, &td, 0.1).unwrap();
                for j in 0..c {
                    let col: Vec<f64> = (0..m).map(|i| x[i * c + j]).collect();
                    let wj: Option<Vec<f64>> =
                        weights.map(|w| (0..m).map(|i| w[i * 7 + j / 3]).collect());
                    let (v1, ok1) =
                        resample_columns(&ts, &col, 1, wj.as_deref(), &td, 0.1).unwrap();
                    for (i, (&a, &b)) in v1.iter().zip(&ok1).enumerate() {
                        assert_eq!(ok[i * c + j], b, "m {m} column {j} target {i}");
                        let got = v[i * c + j];
                        assert!(a.to_bits() == got.to_bits(), "m {m} column {j}: {a} {got}");
                    }
                }
            }
        }
    }

    #[test]
    fn spline_reproduces_cubics() {
        let t = [0.0, 0.5, 1.7, 2.0, 3.1, 4.0];
        let f = |x: f64| 1.0 - 2.0 * x + 0.5 * x * x - 0.25 * x * x * x;
        let y: Vec<f64> = t.iter().map(|&x| f(x)).collect();
        let s = CubicSpline::new(&t, &y, 1).unwrap();
        let at = [0.0, 0.3, 1.0, 2.5, 4.0, 4.5];
        for (v, &x) in s.eval(&at).iter().zip(&at) {
            assert!((v - f(x)).abs() < 1e-10);
        }
        // 3 knots: a parabola; 2 knots: a line
        let s = CubicSpline::new(&[0.0, 1.0, 3.0], &[0.0, 1.0, 9.0], 1).unwrap();
        assert!((s.eval(&[2.0])[0] - 4.0).abs() < 1e-12);
        let s = CubicSpline::new(&[0.0, 2.0], &[1.0, 5.0], 1).unwrap();
        assert_eq!(s.eval(&[1.0])[0], 3.0);
        assert!(CubicSpline::new(&[0.0], &[1.0], 1).is_err());
        assert!(CubicSpline::new(&[0.0, 0.0], &[1.0, 2.0], 1).is_err());
        assert!(CubicSpline::new(&[0.0, 1.0], &[1.0, f64::NAN], 1).is_err());
    }
}
