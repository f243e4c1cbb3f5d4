//! Criterion benchmarks of DTW: distance only (rolling row) and with path, 1-D and 3-D.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use hmmseg::dtw::{dtw, dtw_distance};
use nalgebra::DMatrix;

fn walk(n: usize, d: usize, seed: u64) -> DMatrix<f64> {
    // A deterministic pseudo-random walk (xorshift), no extra dependencies.
    let mut s = seed | 1;
    let mut acc = vec![0.0; d];
    DMatrix::from_fn(n, d, |_, j| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        acc[j] += (s % 2001) as f64 / 1000.0 - 1.0;
        acc[j]
    })
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("dtw");
    for &(n, d) in &[(200, 1), (200, 3), (1000, 1)] {
        let (a, b) = (walk(n, d, 1), walk(n, d, 2));
        let id = format!("{n}x{d}");
        g.bench_with_input(
            BenchmarkId::new("distance", &id),
            &(&a, &b),
            |bch, (a, b)| {
                bch.iter(|| dtw_distance(black_box(a), black_box(b), None));
            },
        );
        g.bench_with_input(
            BenchmarkId::new("distance_band10", &id),
            &(&a, &b),
            |bch, (a, b)| {
                bch.iter(|| dtw_distance(black_box(a), black_box(b), Some(10)));
            },
        );
        g.bench_with_input(
            BenchmarkId::new("with_path", &id),
            &(&a, &b),
            |bch, (a, b)| {
                bch.iter(|| dtw(black_box(a), black_box(b), None));
            },
        );
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
