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
use crate::hmm::simd::{dispatch, Kernel};
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
/// at a time: `ln P(x_0..=t, q_t = j) = log_acc + ln alpha[j]`. The forward vector is
/// renormalised only when its mass falls below [`RENORM`] (one division and one `ln` every
/// few dozen samples instead of every sample); `mass` is its sum. The state of every scorer
/// sweep, so the numerics exist once. `N` is the capacity in states; with `EXACT` the model has
/// exactly `N` states (the loops are unrolled), otherwise at most `N`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Forward<const N: usize, const EXACT: bool> {
    alpha: [f64; N],
    log_acc: f64,
    mass: f64,
    /// Samples consumed.
    steps: usize,
    /// Every state impossible: the prefix score is `-inf` from now on.
    dead: bool,
}

/// The forward vector is renormalised when its mass falls below this: far above the
/// underflow of a step (a step whose mass falls below `1e-250` is redone in log space), so a
/// step takes the log-space fallback only where the normalised recursion would too (its mass
/// relative to the vector's below about `1e-220`).
const RENORM: f64 = 1e-30;

/// [`Forward`] for any template (at most [`MAX_STATES`] states).
pub(crate) type ForwardState = Forward<MAX_STATES, false>;

impl<const N: usize, const EXACT: bool> Default for Forward<N, EXACT> {
    fn default() -> Self {
        Self {
            alpha: [0.0; N],
            log_acc: 0.0,
            mass: 1.0,
            steps: 0,
            dead: false,
        }
    }
}

impl<const N: usize, const EXACT: bool> Forward<N, EXACT> {
    #[inline]
    fn n(m: &CompiledHmm) -> usize {
        if EXACT {
            N
        } else {
            m.n
        }
    }

    /// Consume one sample: `bt` its scaled emissions (`n` values), `shift` their scale.
    #[inline]
    pub(crate) fn step(&mut self, m: &CompiledHmm, bt: &[f64], shift: f64) {
        if self.dead {
            return;
        }
        let n = Self::n(m);
        let mut pred = [0.0f64; N];
        let mut next = [0.0f64; N];
        let (alpha, pred, next) = (&mut self.alpha[..n], &mut pred[..n], &mut next[..n]);
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
        let bt = &bt[..n];
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
        alpha.copy_from_slice(next);
        self.mass = sum;
        if sum < RENORM {
            let inv = 1.0 / sum;
            for a in alpha.iter_mut() {
                *a *= inv;
            }
            self.log_acc += sum.ln();
            self.mass = 1.0;
        }
    }

    /// [`Self::step`] over sample `t` of `em`.
    #[inline]
    fn advance(&mut self, m: &CompiledHmm, em: &Scaled, t: usize) {
        let n = Self::n(m);
        self.step(m, &em.b[t * n..(t + 1) * n], em.shift[t]);
    }

    /// The prefix score of the samples consumed so far (`-inf` once impossible).
    #[inline]
    pub(crate) fn value(&self, m: &CompiledHmm, end: EndState) -> f64 {
        if self.dead {
            return f64::NEG_INFINITY;
        }
        match end {
            EndState::Any => self.log_acc + self.mass.ln(),
            EndState::Final => self.log_acc + self.alpha[Self::n(m) - 1].ln(),
        }
    }

    /// No state possible any more.
    pub(crate) fn is_dead(&self) -> bool {
        self.dead
    }
}

/// At most this many states per template HMM.
const MAX_STATES: usize = 16;

impl CompiledHmm {
    /// Prefix scores at the requested ends only: `ends` are sample offsets (ascending) from
    /// `start`; adds the score at each end to `sums`. `ln` is taken only at the ends. (One run
    /// at a time: the reference of [`sweep`], which advances all runs of a block together.)
    #[cfg(test)]
    fn add_prefix_at(
        &self,
        em: &Scaled,
        start: usize,
        ends: &[usize],
        end: EndState,
        sums: &mut [f64],
    ) {
        let Some(&last) = ends.last() else { return };
        let mut st = ForwardState::default();
        let mut e = 0;
        for k in 0..=last {
            st.advance(self, em, start + k);
            if st.is_dead() {
                for slot in &mut sums[e..] {
                    *slot = f64::NEG_INFINITY;
                }
                return;
            }
            while e < ends.len() && ends[e] == k {
                sums[e] += st.value(self, end);
                e += 1;
            }
        }
    }
}

/// The scores of model `m` for every run of the band starting at sections `starts` (whose
/// samples `lo..` are `em`'s rows `0..`), written to `out[r - offsets[starts.start]]` for run
/// `r` of the band. The forward passes of all runs that cover a sample advance together, so
/// the independent recursions interleave (the passes are latency-bound one at a time).
fn sweep(
    m: &CompiledHmm,
    em: &Scaled,
    band: &Band,
    starts: Range<usize>,
    lo: usize,
    end: EndState,
    out: &mut [f64],
) {
    macro_rules! soa {
        ($n:literal) => {
            dispatch(SoaSweep::<$n> {
                m,
                em,
                band,
                starts,
                lo,
                end,
                out,
            })
        };
    }
    // every state reachable from some state: the structure-of-arrays sweep applies
    if m.band.iter().all(|&(a, b)| a < b) {
        match m.n {
            1 => return soa!(1),
            2 => return soa!(2),
            3 => return soa!(3),
            4 => return soa!(4),
            5 => return soa!(5),
            6 => return soa!(6),
            _ => {}
        }
    }
    sweep_runs(m, em, band, starts, lo, end, out);
}

/// [`sweep`] for models of exactly `N` states, with the runs' forward vectors stored state by
/// state (`alpha[j * R + r]`), so each step is a few vector operations over all active runs
/// (compiled for AVX2 where the CPU has it; no fused operations, so every entry is bitwise the
/// one [`ForwardState`] computes). A run whose step would underflow takes the scalar
/// [`Forward::step`] (its log-space fallback) for that step.
struct SoaSweep<'a, const N: usize> {
    m: &'a CompiledHmm,
    em: &'a Scaled,
    band: &'a Band,
    starts: Range<usize>,
    lo: usize,
    end: EndState,
    out: &'a mut [f64],
}

impl<const N: usize> Kernel for SoaSweep<'_, N> {
    type Output = ();

    // inline: compiled inside the AVX2 function; bitwise tests: branch-free over the runs;
    // too_many_lines: the sweep's hot loop, one body so its state stays in registers
    #[allow(
        clippy::inline_always,
        clippy::too_many_lines,
        clippy::needless_bitwise_bool,
        clippy::manual_range_contains
    )]
    #[inline(always)]
    fn run<const FMA: bool>(self) {
        let SoaSweep {
            m,
            em,
            band,
            starts,
            lo,
            end,
            out,
        } = self;
        if starts.is_empty() {
            return;
        }
        let nr = starts.len();
        let b = band.boundaries();
        let off0 = band.offsets()[starts.start];
        let t_end = b[band.last_end(starts.end - 1)];
        let last_j: Vec<usize> = starts.clone().map(|i| band.last_end(i)).collect();
        let base: Vec<usize> = starts.clone().map(|i| band.offsets()[i] - off0).collect();
        let mut next_j: Vec<usize> = starts.clone().map(|i| i + 1).collect();
        let mut alpha = vec![0.0f64; N * nr];
        let mut next = vec![0.0f64; N * nr];
        let mut sum = vec![0.0f64; nr];
        let mut log_acc = vec![0.0f64; nr];
        let mut mass = vec![1.0f64; nr];
        let mut dead = vec![false; nr];
        let gather = |alpha: &[f64], log_acc: &[f64], mass: &[f64], r: usize| {
            let mut st = Forward::<N, true>::default();
            for j in 0..N {
                st.alpha[j] = alpha[j * nr + r];
            }
            st.log_acc = log_acc[r];
            st.mass = mass[r];
            st.steps = 1;
            st
        };
        // one step of run r by the scalar recursion (a new run, or its log-space fallback)
        let scalar = |mut st: Forward<N, true>,
                      r: usize,
                      alpha: &mut [f64],
                      log_acc: &mut [f64],
                      mass: &mut [f64],
                      dead: &mut [bool],
                      tt: usize| {
            st.advance(m, em, tt);
            if st.is_dead() {
                dead[r] = true;
                return true;
            }
            for j in 0..N {
                alpha[j * nr + r] = st.alpha[j];
            }
            log_acc[r] = st.log_acc;
            mass[r] = st.mass;
            false
        };
        let (mut head, mut tail) = (0usize, 0usize);
        let mut next_b = starts.start;
        for t in b[starts.start]..t_end {
            let tt = t - lo;
            let mut died = false;
            // 1. the runs started before t, together
            if head < tail {
                let (h, z) = (head, tail);
                let bt = &em.b[tt * N..(tt + 1) * N];
                let s = &mut sum[h..z];
                // per state j, one pass over the lanes: next_j = (sum_i alpha_i q_ij) b_j (i in
                // the band of j, in order), added to the mass (the states in order): the
                // scalar recursion's operations, in its order
                for j in 0..N {
                    let (blo, bhi) = m.band[j];
                    let (nj, _) = next[j * nr + h..].split_at_mut(z - h);
                    let row = &m.trans[j * N..(j + 1) * N];
                    let bj = bt[j];
                    let a0 = &alpha[blo * nr + h..blo * nr + z];
                    if bhi - blo == 2 {
                        // a left-right chain: the state itself and the one before
                        let a1 = &alpha[(blo + 1) * nr + h..(blo + 1) * nr + z];
                        let (q0, q1) = (row[blo], row[blo + 1]);
                        for ((o, &x0), &x1) in nj.iter_mut().zip(a0).zip(a1) {
                            *o = (x0 * q0 + x1 * q1) * bj;
                        }
                    } else {
                        let q0 = row[blo];
                        for (o, &a) in nj.iter_mut().zip(a0) {
                            *o = a * q0;
                        }
                        for i in blo + 1..bhi {
                            let q = row[i];
                            for (o, &a) in nj.iter_mut().zip(&alpha[i * nr + h..i * nr + z]) {
                                *o += a * q;
                            }
                        }
                        for o in nj.iter_mut() {
                            *o *= bj;
                        }
                    }
                    if j == 0 {
                        for (o, &v) in s.iter_mut().zip(nj.iter()) {
                            *o = v;
                        }
                    } else {
                        for (o, &v) in s.iter_mut().zip(nj.iter()) {
                            *o += v;
                        }
                    }
                }
                // every sum in (1e-250, inf) (NaN fails both): no run needs the fallback
                let all_ok = s
                    .iter()
                    .fold(true, |acc, &v| acc & (v > 1e-250) & (v < f64::INFINITY));
                let shift = em.shift[tt];
                if all_ok {
                    for a in &mut log_acc[h..z] {
                        *a += shift;
                    }
                    // the new vectors are `next` (lanes h..z; the others are finished or not
                    // started, and a run's lanes are written when it starts)
                    // and the masses `sum` (likewise)
                    let low = s.iter().fold(false, |acc, &v| acc | (v < RENORM));
                    std::mem::swap(&mut alpha, &mut next);
                    std::mem::swap(&mut mass, &mut sum);
                    if low {
                        for r in h..z {
                            if mass[r] < RENORM {
                                let w = 1.0 / mass[r];
                                for j in 0..N {
                                    alpha[j * nr + r] *= w;
                                }
                                log_acc[r] += mass[r].ln();
                                mass[r] = 1.0;
                            }
                        }
                    }
                } else {
                    for r in h..z {
                        if !dead[r] {
                            let st = gather(&alpha, &log_acc, &mass, r);
                            died |=
                                scalar(st, r, &mut alpha, &mut log_acc, &mut mass, &mut dead, tt);
                        }
                    }
                }
            }
            // 2. the run starting at t
            if tail < nr && b[starts.start + tail] == t {
                let st = Forward::<N, true>::default();
                died |= scalar(st, tail, &mut alpha, &mut log_acc, &mut mass, &mut dead, tt);
                tail += 1;
            }
            // runs found impossible: every later end is -inf
            for r in (head..tail).filter(|_| died) {
                if dead[r] && next_j[r] <= last_j[r] {
                    for j in next_j[r]..=last_j[r] {
                        out[base[r] + j - (starts.start + r) - 1] = f64::NEG_INFINITY;
                    }
                    next_j[r] = last_j[r] + 1;
                }
            }
            // 3. the runs ending at t (run i..j covers samples b[i]..b[j]): runs end only at
            // section boundaries
            while next_b < b.len() && b[next_b] <= t {
                next_b += 1;
            }
            if next_b == b.len() || b[next_b] != t + 1 {
                continue;
            }
            for r in head..tail {
                while next_j[r] <= last_j[r] && b[next_j[r]] == t + 1 {
                    out[base[r] + next_j[r] - (starts.start + r) - 1] = match end {
                        EndState::Any => log_acc[r] + mass[r].ln(),
                        EndState::Final => log_acc[r] + alpha[(N - 1) * nr + r].ln(),
                    };
                    next_j[r] += 1;
                }
            }
            while head < tail && next_j[head] > last_j[head] {
                head += 1;
            }
        }
    }
}

/// [`sweep`] one run at a time (any model of at most [`MAX_STATES`] states).
fn sweep_runs(
    m: &CompiledHmm,
    em: &Scaled,
    band: &Band,
    starts: Range<usize>,
    lo: usize,
    end: EndState,
    out: &mut [f64],
) {
    struct Run {
        st: ForwardState,
        /// start section
        i: usize,
        /// the next end section to score, and the last
        next_j: usize,
        last_j: usize,
        /// `out` index of run `i..i + 1`
        base: usize,
    }
    if starts.is_empty() {
        return;
    }
    let b = band.boundaries();
    let off0 = band.offsets()[starts.start];
    let t_end = b[band.last_end(starts.end - 1)];
    let mut active: Vec<Run> = Vec::new();
    let mut next = starts.start;
    for t in b[starts.start]..t_end {
        if next < starts.end && b[next] == t {
            active.push(Run {
                st: ForwardState::default(),
                i: next,
                next_j: next + 1,
                last_j: band.last_end(next),
                base: band.offsets()[next] - off0,
            });
            next += 1;
        }
        active.retain_mut(|r| {
            r.st.advance(m, em, t - lo);
            if r.st.is_dead() {
                for j in r.next_j..=r.last_j {
                    out[r.base + j - r.i - 1] = f64::NEG_INFINITY;
                }
                return false;
            }
            // run i..j covers samples b[i]..b[j]
            while r.next_j <= r.last_j && b[r.next_j] == t + 1 {
                out[r.base + r.next_j - r.i - 1] = r.st.value(m, end);
                r.next_j += 1;
            }
            r.next_j <= r.last_j
        });
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
    if models.iter().flatten().any(|m| m.n > MAX_STATES) {
        return Err(EngineError::InvalidParameter(
            "at most 16 states per template HMM".into(),
        ));
    }
    let band = Band::new(boundaries.to_vec(), max_len)?;
    let k = band.n_sections();
    let mut table = ScoreTable::with_band(band.clone(), models.len())?;
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
        let (r0, r1) = (band.offsets()[i0], band.offsets()[i1]);
        // per (skill, feature): the emissions of the block's samples, then every run's score
        let per_pair: Vec<Vec<f64>> = pairs
            .par_iter()
            .map(|&(s, f)| {
                let em = Scaled::direct(&models[s][f], observations, lo..hi, &groups[f]);
                let mut out = vec![0.0; r1 - r0];
                sweep(&models[s][f], &em, &band, i0..i1, lo, end, &mut out);
                out
            })
            .collect();
        let n_groups = groups.len();
        table.set_band_rows(r0..r1, |r, s| {
            let mut acc = 0.0;
            for scores in &per_pair[s * n_groups..(s + 1) * n_groups] {
                acc += scores[r - r0];
            }
            acc
        });
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
        model_n(cov, d, 3, Topology::LeftRight)
    }

    fn model_n(cov: CovarianceType, d: usize, n_states: usize, topology: Topology) -> Hmm {
        let seqs: Vec<DMatrix<f64>> = (0..5)
            .map(|k| {
                DMatrix::from_fn(30 + k, d, |t, c| {
                    (t as f64 / 10.0).sin() + 0.1 * c as f64 + 0.01 * ((t * 7 + k * 3) % 5) as f64
                })
            })
            .collect();
        let cfg = FitConfig {
            n_states,
            n_mix: 2,
            covariance: cov,
            topology,
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

    #[test]
    fn lazily_renormalised_forward_matches_log_space() {
        // 3000 samples: the vector's mass falls below RENORM many times (and an outlier forces
        // the log-space step); every prefix score equals the log-space recursion's
        for end in [EndState::Any, EndState::Final] {
            for (cov, d) in [(CovarianceType::Diag, 1), (CovarianceType::Full, 2)] {
                let c = CompiledHmm::new(&model(cov, d)).unwrap();
                let x = DMatrix::from_fn(3000, d, |t, k| {
                    (t as f64 / 37.0).sin() + 0.1 * k as f64 + if t == 1234 { 40.0 } else { 0.0 }
                });
                let lb = c.log_emissions(&x, &(0..d));
                let mut want = Vec::new();
                c.prefix_log(&lb, end, &mut want);
                assert!(want[2999] < 10.0 * RENORM.ln(), "{}", want[2999]);
                let em = Scaled::direct(&c, &x, 0..x.nrows(), &(0..d));
                let ends: Vec<usize> = (0..3000).step_by(7).collect();
                let mut got = vec![0.0; ends.len()];
                c.add_prefix_at(&em, 0, &ends, end, &mut got);
                for (&t, g) in ends.iter().zip(&got) {
                    let w = want[t];
                    let close = (g.is_infinite() && g.to_bits() == w.to_bits())
                        || (g - w).abs() < 1e-9 * w.abs().max(1.0);
                    assert!(close, "{end:?} t={t}: {g} {w}");
                }
            }
        }
    }

    #[test]
    fn sweep_equals_one_run_at_a_time() {
        // two feature groups (sums in feature order), far outliers, one impossible sample;
        // left-right models of 3 and 5 states (the vectorised sweep), an ergodic one and one
        // of 7 states (the one-run-at-a-time sweep)
        let c = |m: Hmm| CompiledHmm::new(&m).unwrap();
        let (diag, full) = (CovarianceType::Diag, CovarianceType::Full);
        let models = vec![
            vec![c(model(diag, 2)), c(model(full, 2))],
            vec![
                c(model(full, 2)),
                c(model_n(diag, 2, 5, Topology::LeftRight)),
            ],
            vec![
                c(model_n(diag, 2, 7, Topology::LeftRight)),
                c(model_n(full, 2, 4, Topology::Ergodic)),
            ],
        ];
        let x = DMatrix::from_fn(260, 4, |t, k| {
            let far = match t % 89 {
                3 => 40.0,
                50 => 1e200,
                _ => 0.0,
            };
            (t as f64 / (9.0 + k as f64)).sin() + 0.1 * k as f64 + far
        });
        let g: Vec<Range<usize>> = vec![0..2, 2..4];
        let mut b: Vec<usize> = (0..260).filter(|t| t % 5 == 0 || t % 13 == 0).collect();
        b.push(260);
        for max_len in [0, 30, 77] {
            for end in [EndState::Any, EndState::Final] {
                let band = Band::new(b.clone(), max_len).unwrap();
                let t = compiled_score_table(&models, &g, &x, &b, max_len, end).unwrap();
                for (s, row) in models.iter().enumerate() {
                    let ems: Vec<Scaled> = row
                        .iter()
                        .zip(&g)
                        .map(|(m, cols)| Scaled::direct(m, &x, 0..x.nrows(), cols))
                        .collect();
                    for i in 0..band.n_sections() {
                        let ends: Vec<usize> = band.ends(i).map(|j| b[j] - b[i] - 1).collect();
                        let mut sums = vec![0.0; ends.len()];
                        for (m, em) in row.iter().zip(&ems) {
                            m.add_prefix_at(em, b[i], &ends, end, &mut sums);
                        }
                        for (j, want) in band.ends(i).zip(sums) {
                            let want = if want.is_nan() {
                                f64::NEG_INFINITY
                            } else {
                                want
                            };
                            let got = t.total(i, j, s);
                            assert_eq!(got.to_bits(), want.to_bits(), "run {i}..{j} skill {s}");
                        }
                    }
                }
                assert!(t.as_slice().iter().any(|v| v.is_finite()));
                assert!(t.as_slice().iter().any(|v| v.is_infinite()));
            }
        }
    }
}
