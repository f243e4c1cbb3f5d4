//! Fast path of the forward log-likelihood for models with at most 8 states.
//!
//! The sequence is processed in blocks of up to [`BLOCK`] samples: the emission probabilities
//! of a block, scaled per sample by the largest component (one vectorised `exp` per component
//! and sample, no logarithm; see [`Emission::scaled_block`]), then the forward recursion over
//! the block. Buffers are per thread and reused, so a call allocates nothing after the first.
//!
//! The state count is a const generic, so every per-step loop is fully unrolled and works on
//! stack arrays. For left-right models the transition factors are folded into the emission
//! columns first (`c1 = A_jj b_j`, `c2 = A_(j-1)j b_j`, vectorised), which leaves one multiply
//! and one fused add per state on the step-to-step dependency chain. Scaling is lazy: the
//! forward vector is renormalised only when its sum leaves [1e-100, 1e100] (it grows by at
//! most a factor `n_mix` per step: a scaled emission is at most `n_mix` and the rows of the
//! transition matrix sum to 1). Returns `None` when a step
//! underflows anyway; the caller then uses the log-space recursion.

use std::cell::RefCell;

use nalgebra::DMatrix;

use super::emission::Emission;
use super::forward::Chain;

/// Renormalise when the forward vector sums to less than this ...
const RESCALE_BELOW: f64 = 1e-100;
/// ... or more (mixtures: a state's scaled emission is at most `n_mix`).
const RESCALE_ABOVE: f64 = 1e100;
/// Samples per block.
const BLOCK: usize = 256;
/// Scratch for the per-component values of one block; more components than this (with one
/// sample per block) leave the fast path.
const COMP_CAP: usize = 4096;

thread_local! {
    /// `comp` (COMP_CAP), `b` (8 * BLOCK), `hi` (BLOCK).
    static SCRATCH: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// `ln P(x)`, or `None` if this fast path does not apply (more than 8 states, more than
/// [`COMP_CAP`] components) or a step underflowed.
pub(crate) fn log_likelihood_small(chain: &Chain, em: &Emission, x: &DMatrix<f64>) -> Option<f64> {
    let n = chain.n;
    if n == 0 || n > 8 || em.n_components() > COMP_CAP || x.nrows() == 0 {
        return None;
    }
    SCRATCH.with(|cell| {
        let mut owned = Vec::new();
        let mut guard = cell.try_borrow_mut().ok();
        let buf = guard.as_deref_mut().unwrap_or(&mut owned);
        if buf.len() < COMP_CAP + 9 * BLOCK {
            buf.resize(COMP_CAP + 9 * BLOCK, 0.0);
        }
        let (comp, rest) = buf.split_at_mut(COMP_CAP);
        let (b, hi) = rest.split_at_mut(8 * BLOCK);
        let s = Scratch { comp, b, hi };
        match (n, chain.left_right) {
            (1, _) => run::<1, false>(chain, em, x, s),
            (2, false) => run::<2, false>(chain, em, x, s),
            (2, true) => run::<2, true>(chain, em, x, s),
            (3, false) => run::<3, false>(chain, em, x, s),
            (3, true) => run::<3, true>(chain, em, x, s),
            (4, false) => run::<4, false>(chain, em, x, s),
            (4, true) => run::<4, true>(chain, em, x, s),
            (5, false) => run::<5, false>(chain, em, x, s),
            (5, true) => run::<5, true>(chain, em, x, s),
            (6, false) => run::<6, false>(chain, em, x, s),
            (6, true) => run::<6, true>(chain, em, x, s),
            (7, false) => run::<7, false>(chain, em, x, s),
            (7, true) => run::<7, true>(chain, em, x, s),
            (_, false) => run::<8, false>(chain, em, x, s),
            (_, true) => run::<8, true>(chain, em, x, s),
        }
    })
}

struct Scratch<'a> {
    comp: &'a mut [f64],
    b: &'a mut [f64],
    hi: &'a mut [f64],
}

/// The forward pass over all blocks. `BANDED`: only `i -> i` and `i -> i + 1` are non-zero
/// (a left-right model), so the matrix-vector product is two terms per state.
#[allow(clippy::needless_range_loop)] // fixed-size index loops unroll cleanly
fn run<const N: usize, const BANDED: bool>(
    chain: &Chain,
    em: &Emission,
    x: &DMatrix<f64>,
    s: Scratch<'_>,
) -> Option<f64> {
    let Scratch { comp, b, hi } = s;
    let t_len = x.nrows();
    let data = x.as_slice();
    let block = (COMP_CAP / em.n_components()).clamp(1, BLOCK);
    let mut trans = [[0.0; N]; N];
    for (i, row) in trans.iter_mut().enumerate() {
        row.copy_from_slice(&chain.trans[i * N..(i + 1) * N]);
    }
    let mut prev = [0.0; N];
    let mut log_scale = 0.0;
    let mut shift_sum = 0.0;
    let mut start = 0;
    while start < t_len {
        let len = block.min(t_len - start);
        em.scaled_block(data, t_len, start, len, comp, b, hi);
        for &h in &hi[..len] {
            shift_sum += h;
        }
        let mut first = 0;
        if start == 0 {
            let mut sum = 0.0;
            for j in 0..N {
                prev[j] = chain.start[j] * b[j * len];
                sum += prev[j];
            }
            if !rescale(&mut prev, sum, &mut log_scale) {
                return None;
            }
            first = 1;
        }
        if BANDED {
            // c1[j] = A_jj b_j in `b`, c2[j] = A_(j-1)j b_j in `comp` (free by now).
            for j in 0..N {
                let (stay, enter) = (trans[j][j], if j > 0 { trans[j - 1][j] } else { 0.0 });
                let col = &mut b[j * len..(j + 1) * len];
                for (c2, c1) in comp[j * len..(j + 1) * len].iter_mut().zip(col.iter_mut()) {
                    *c2 = enter * *c1;
                    *c1 *= stay;
                }
            }
        }
        let c1: [&[f64]; N] = std::array::from_fn(|j| &b[j * len..(j + 1) * len]);
        let c2: [&[f64]; N] = std::array::from_fn(|j| &comp[j * len..(j + 1) * len]);
        for t in first..len {
            let mut next = [0.0; N];
            if BANDED {
                next[0] = prev[0] * c1[0][t];
                for j in 1..N {
                    next[j] = prev[j] * c1[j][t] + prev[j - 1] * c2[j][t];
                }
            } else {
                for i in 0..N {
                    for j in 0..N {
                        next[j] += prev[i] * trans[i][j];
                    }
                }
                for j in 0..N {
                    next[j] *= c1[j][t];
                }
            }
            let mut sum = 0.0;
            for v in next {
                sum += v;
            }
            prev = next;
            if !rescale(&mut prev, sum, &mut log_scale) {
                return None;
            }
        }
        start += len;
    }
    if !shift_sum.is_finite() {
        return None;
    }
    Some(shift_sum + log_scale + prev.iter().sum::<f64>().ln())
}

/// Renormalise `v` (whose sum is `sum`) if it became small or large; false on underflow,
/// overflow or NaN.
#[inline]
fn rescale<const N: usize>(v: &mut [f64; N], sum: f64, log_scale: &mut f64) -> bool {
    // Also false for NaN.
    if !(sum > f64::MIN_POSITIVE && sum < f64::INFINITY) {
        return false;
    }
    if !(RESCALE_BELOW..=RESCALE_ABOVE).contains(&sum) {
        *log_scale += sum.ln();
        let inv = 1.0 / sum;
        for x in v.iter_mut() {
            *x *= inv;
        }
    }
    true
}
