//! Seeded k-means (k-means++ start, Lloyd iterations) on row-major points.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Cluster the `n = data.len() / f` points into `k` clusters; returns one label per point.
/// Deterministic for a given `rng` state. Works for `k > n` (some clusters stay empty).
pub(crate) fn kmeans(data: &[f64], f: usize, k: usize, rng: &mut ChaCha8Rng) -> Vec<usize> {
    let n = data.len() / f;
    if n == 0 || k == 0 {
        return Vec::new();
    }
    let point = |i: usize| &data[i * f..(i + 1) * f];
    // k-means++ seeding.
    let mut centers: Vec<f64> = Vec::with_capacity(k * f);
    centers.extend_from_slice(point(rng.random_range(0..n)));
    let mut d2: Vec<f64> = (0..n).map(|i| dist2(point(i), &centers[..f])).collect();
    for _ in 1..k {
        let total: f64 = d2.iter().sum();
        let pick = if total > 0.0 && total.is_finite() {
            let mut u = rng.random::<f64>() * total;
            let mut chosen = n - 1;
            for (i, &d) in d2.iter().enumerate() {
                if u < d {
                    chosen = i;
                    break;
                }
                u -= d;
            }
            chosen
        } else {
            rng.random_range(0..n)
        };
        let c0 = centers.len();
        centers.extend_from_slice(point(pick));
        for (i, d) in d2.iter_mut().enumerate() {
            *d = d.min(dist2(point(i), &centers[c0..c0 + f]));
        }
    }
    // Lloyd iterations.
    let mut labels = vec![usize::MAX; n];
    let mut counts = vec![0usize; k];
    for _ in 0..100 {
        let mut changed = false;
        for (i, label) in labels.iter_mut().enumerate() {
            let p = point(i);
            let (mut best, mut arg) = (f64::INFINITY, 0);
            for c in 0..k {
                let d = dist2(p, &centers[c * f..(c + 1) * f]);
                if d < best {
                    best = d;
                    arg = c;
                }
            }
            if *label != arg {
                *label = arg;
                changed = true;
            }
        }
        if !changed {
            break;
        }
        centers.fill(0.0);
        counts.fill(0);
        for (i, &l) in labels.iter().enumerate() {
            counts[l] += 1;
            for (c, v) in centers[l * f..(l + 1) * f].iter_mut().zip(point(i)) {
                *c += v;
            }
        }
        for c in 0..k {
            if counts[c] > 0 {
                let inv = 1.0 / counts[c] as f64;
                centers[c * f..(c + 1) * f]
                    .iter_mut()
                    .for_each(|v| *v *= inv);
            } else if k <= n {
                // Empty cluster: restart it at the point farthest from its own center.
                let far = (0..n)
                    .map(|i| {
                        (
                            i,
                            dist2(point(i), &centers[labels[i] * f..(labels[i] + 1) * f]),
                        )
                    })
                    .fold((0, -1.0), |a, b| if b.1 > a.1 { b } else { a })
                    .0;
                let src = point(far).to_vec();
                centers[c * f..(c + 1) * f].copy_from_slice(&src);
            }
        }
    }
    labels
}

#[cfg(test)]
#[allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]
mod tests {
    use rand::SeedableRng;

    use super::*;

    #[test]
    fn separates_two_blobs_deterministically() {
        let data: Vec<f64> = (0..20)
            .map(|i| {
                if i < 10 {
                    i as f64 * 0.01
                } else {
                    5.0 + i as f64 * 0.01
                }
            })
            .collect();
        let a = kmeans(&data, 1, 2, &mut ChaCha8Rng::seed_from_u64(3));
        let b = kmeans(&data, 1, 2, &mut ChaCha8Rng::seed_from_u64(3));
        assert_eq!(a, b);
        assert!(a[..10].iter().all(|&l| l == a[0]));
        assert!(a[10..].iter().all(|&l| l == a[10]));
        assert_ne!(a[0], a[10]);
    }

    #[test]
    fn more_clusters_than_points() {
        let data = [1.0, 1.0];
        let l = kmeans(&data, 1, 4, &mut ChaCha8Rng::seed_from_u64(0));
        assert_eq!(l.len(), 2);
        assert!(l.iter().all(|&x| x < 4));
    }
}
