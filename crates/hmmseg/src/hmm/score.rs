//! Fast path of the forward log-likelihood for models with at most 8 states.
//!
//! The state count is a const generic, so every per-step loop is fully unrolled and works
//! on stack arrays. Scaling is lazy: the forward vector is renormalised only when its sum
//! drops below 1e-100 (it never grows, because emissions are divided by their per-step
//! maximum and the rows of the transition matrix sum to 1). Returns `None` when a step
//! underflows anyway; the caller then uses the log-space recursion.

use super::fastexp::exp_nonpos;
use super::forward::Chain;

/// Renormalise when the forward vector sums to less than this.
const RESCALE_BELOW: f64 = 1e-100;

/// `ln P(x)` from the state-major emission table `sm` (`sm[j * T + t]`, overwritten with
/// scaled probabilities), or `None` if this fast path does not apply (more than 8 states)
/// or underflowed. `hi` is scratch space.
pub(crate) fn log_likelihood_small(
    chain: &Chain,
    sm: &mut [f64],
    hi: &mut Vec<f64>,
) -> Option<f64> {
    let n = chain.n;
    if n == 0 || n > 8 {
        return None;
    }
    let t_len = sm.len() / n;
    // Per-step maximum over states and the scaled probabilities, in flat (vectorised) passes.
    hi.clear();
    hi.extend_from_slice(&sm[..t_len]);
    for col in sm.chunks_exact(t_len).skip(1) {
        for (h, &v) in hi.iter_mut().zip(col) {
            *h = h.max(v);
        }
    }
    let mut shift_sum = 0.0;
    for &h in hi.iter() {
        shift_sum += h;
    }
    if !shift_sum.is_finite() {
        return None;
    }
    for col in sm.chunks_exact_mut(t_len) {
        for (v, &h) in col.iter_mut().zip(hi.iter()) {
            *v = exp_nonpos(*v - h);
        }
    }
    let banded = chain.is_left_right();
    let ll = match (n, banded) {
        (1, _) => run::<1, false>(chain, sm, t_len),
        (2, false) => run::<2, false>(chain, sm, t_len),
        (2, true) => run::<2, true>(chain, sm, t_len),
        (3, false) => run::<3, false>(chain, sm, t_len),
        (3, true) => run::<3, true>(chain, sm, t_len),
        (4, false) => run::<4, false>(chain, sm, t_len),
        (4, true) => run::<4, true>(chain, sm, t_len),
        (5, false) => run::<5, false>(chain, sm, t_len),
        (5, true) => run::<5, true>(chain, sm, t_len),
        (6, false) => run::<6, false>(chain, sm, t_len),
        (6, true) => run::<6, true>(chain, sm, t_len),
        (7, false) => run::<7, false>(chain, sm, t_len),
        (7, true) => run::<7, true>(chain, sm, t_len),
        (_, false) => run::<8, false>(chain, sm, t_len),
        (_, true) => run::<8, true>(chain, sm, t_len),
    }?;
    Some(shift_sum + ll)
}

/// Lazily scaled forward over the scaled probabilities `b[j * T + t]`; returns `ln` of the
/// total relative to the per-step maxima. `BANDED`: only `i -> i` and `i -> i + 1` are
/// non-zero (a left-right model), so the matrix-vector product is two terms per state.
#[allow(clippy::needless_range_loop)] // fixed-size index loops unroll cleanly
fn run<const N: usize, const BANDED: bool>(chain: &Chain, b: &[f64], t_len: usize) -> Option<f64> {
    let mut trans = [[0.0; N]; N];
    for (i, row) in trans.iter_mut().enumerate() {
        row.copy_from_slice(&chain.trans[i * N..(i + 1) * N]);
    }
    let cols: [&[f64]; N] = std::array::from_fn(|j| &b[j * t_len..(j + 1) * t_len]);
    let mut prev = [0.0; N];
    let mut ll = 0.0;
    for t in 0..t_len {
        let mut next = [0.0; N];
        if t == 0 {
            next.copy_from_slice(&chain.start);
        } else if BANDED {
            next[0] = prev[0] * trans[0][0];
            for j in 1..N {
                next[j] = prev[j] * trans[j][j] + prev[j - 1] * trans[j - 1][j];
            }
        } else {
            for i in 0..N {
                for j in 0..N {
                    next[j] += prev[i] * trans[i][j];
                }
            }
        }
        let mut sum = 0.0;
        for j in 0..N {
            next[j] *= cols[j][t];
            sum += next[j];
        }
        // Also true for NaN.
        if sum.partial_cmp(&f64::MIN_POSITIVE) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        if sum < RESCALE_BELOW {
            ll += sum.ln();
            let inv = 1.0 / sum;
            for v in &mut next {
                *v *= inv;
            }
        }
        prev = next;
    }
    Some(ll + prev.iter().sum::<f64>().ln())
}
