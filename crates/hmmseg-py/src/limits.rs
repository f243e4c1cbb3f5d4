//! Absurd sizes are refused before anything is allocated.
//!
//! Rust aborts the whole process when an allocation fails, so a request such as
//! `Hmm.sample(10**12)` or `n_mix=2**40` must never reach the allocator. Every entry point
//! whose memory grows with an argument (not with the size of an input array) checks the
//! largest table it will build here: the product of its dimensions (overflow included) must
//! fit in [`budget_bytes`], half the machine's physical memory (8 GiB where that is unknown).

use std::sync::OnceLock;

use pyo3::prelude::*;

use crate::errors::invalid;

/// Bytes one engine table may take: half the physical memory, or 8 GiB if unknown.
pub fn budget_bytes() -> u128 {
    static BUDGET: OnceLock<u128> = OnceLock::new();
    *BUDGET.get_or_init(|| physical_memory().map_or(8 << 30, |b| b / 2))
}

/// Total physical memory from `/proc/meminfo` (Linux), `None` elsewhere.
fn physical_memory() -> Option<u128> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u128 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

fn human(bytes: u128) -> String {
    const UNITS: [&str; 5] = ["B", "KB", "MB", "GB", "TB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1000.0 && u < UNITS.len() - 1 {
        v /= 1000.0;
        u += 1;
    }
    if v >= 1000.0 {
        format!("{v:.1e} {}", UNITS[u])
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Refuse a table of `dims` elements of `elem_bytes` bytes each if it exceeds the budget.
/// `what` names the table and where its size comes from, e.g. `"n_samples x n_features"`.
pub fn check_table(py: Python<'_>, what: &str, dims: &[usize], elem_bytes: usize) -> PyResult<()> {
    let bytes = dims
        .iter()
        .try_fold(elem_bytes as u128, |acc, &d| acc.checked_mul(d as u128));
    let budget = budget_bytes();
    match bytes {
        Some(b) if b <= budget => Ok(()),
        _ => {
            let shape: Vec<String> = dims.iter().map(ToString::to_string).collect();
            let need = bytes.map_or_else(|| "more than 2**128 bytes".to_string(), human);
            Err(invalid(
                py,
                format!(
                    "{what} = {} needs {need}; one table may use at most {} (half the \
                     machine's memory)",
                    shape.join(" x "),
                    human(budget)
                ),
            ))
        }
    }
}

/// The tables Baum-Welch builds for `n_states` states of `n_mix` components over sequences of
/// at most `max_len` samples and `n_features` features.
pub fn check_hmm(
    py: Python<'_>,
    n_states: usize,
    n_mix: usize,
    n_features: usize,
    full: bool,
    max_len: usize,
) -> PyResult<()> {
    check_table(
        py,
        "n_states x n_states (transitions)",
        &[n_states, n_states],
        8,
    )?;
    if full {
        check_table(
            py,
            "n_states x n_mix x n_features x n_features (full covariances)",
            &[n_states, n_mix, n_features, n_features],
            8,
        )?;
    } else {
        check_table(
            py,
            "n_states x n_mix x n_features (means)",
            &[n_states, n_mix, n_features],
            8,
        )?;
    }
    check_table(
        py,
        "longest sequence x n_states x n_mix (posteriors)",
        &[max_len, n_states, n_mix],
        8,
    )
}
