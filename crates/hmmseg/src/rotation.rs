//! Rotations as unit quaternions `(x, y, z, w)`, the operations of the preprocessing with
//! scipy's formulas (`scipy.spatial.transform.Rotation` and `Slerp`): conversion from and to
//! rotation matrices and extrinsic x-y-z Euler angles, composition, inverse, application to
//! vectors, rotation vectors and slerp over many times.
//!
//! Many rotations are row-major slices: `n x 4` quaternions, `n x 9` matrices (row by row),
//! `n x 3` vectors or angles. A row with a NaN (or infinite) entry gives a NaN row (a tracking
//! gap stays a gap); a finite quaternion of zero norm is an error. Results agree with scipy
//! to a few units in the last place (most of them bit for bit); a matrix that is not
//! orthogonal to 1e-12 is first replaced by the nearest rotation (`U V^T` of its SVD), as scipy
//! does.

// Exact float comparisons and index loops are deliberate: they reproduce scipy's (and
// LAPACK's) operations one by one, so the results agree to the bit.
#![allow(clippy::float_cmp, clippy::needless_range_loop)]

use nalgebra::Matrix3;

use crate::error::{EngineError, Result};

/// A quaternion `(x, y, z, w)`.
pub type Quat = [f64; 4];

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn check_rows(v: &[f64], width: usize, what: &str) -> Result<usize> {
    if v.len() % width != 0 {
        return Err(EngineError::ShapeMismatch(format!(
            "{what}: {} values are not rows of {width}",
            v.len()
        )));
    }
    Ok(v.len() / width)
}

/// `q / |q|` (the norm summed in order x, y, z, w).
///
/// # Errors
/// [`EngineError::InvalidParameter`] for a zero quaternion.
pub fn normalize(q: Quat) -> Result<Quat> {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n == 0.0 {
        return Err(EngineError::InvalidParameter(
            "found a zero norm quaternion".into(),
        ));
    }
    Ok([q[0] / n, q[1] / n, q[2] / n, q[3] / n])
}

/// `p * q` (apply `q`, then `p`), not normalised.
pub fn compose_raw(p: Quat, q: Quat) -> Quat {
    let cross = [
        p[1] * q[2] - p[2] * q[1],
        p[2] * q[0] - p[0] * q[2],
        p[0] * q[1] - p[1] * q[0],
    ];
    [
        p[3] * q[0] + q[3] * p[0] + cross[0],
        p[3] * q[1] + q[3] * p[1] + cross[1],
        p[3] * q[2] + q[3] * p[2] + cross[2],
        p[3] * q[3] - p[0] * q[0] - p[1] * q[1] - p[2] * q[2],
    ]
}

/// `p * q`, normalised (`Rotation.__mul__`).
///
/// # Errors
/// [`EngineError::InvalidParameter`] for a zero product (zero input).
pub fn compose(p: Quat, q: Quat) -> Result<Quat> {
    normalize(compose_raw(p, q))
}

/// The inverse rotation `(-x, -y, -z, w)`.
pub fn inverse(q: Quat) -> Quat {
    [-q[0], -q[1], -q[2], q[3]]
}

/// The rotation matrix (row-major `[r00, r01, r02, r10, ...]`) of a unit quaternion.
pub fn to_matrix(q: Quat) -> [f64; 9] {
    let [x, y, z, w] = q;
    let (x2, y2, z2, w2) = (x * x, y * y, z * z, w * w);
    let (xy, zw, xz, yw, yz, xw) = (x * y, z * w, x * z, y * w, y * z, x * w);
    [
        x2 - y2 - z2 + w2,
        2.0 * (xy - zw),
        2.0 * (xz + yw),
        2.0 * (xy + zw),
        -x2 + y2 - z2 + w2,
        2.0 * (yz - xw),
        2.0 * (xz - yw),
        2.0 * (yz + xw),
        -x2 - y2 + z2 + w2,
    ]
}

/// The unit quaternion of a rotation matrix (row-major): `Rotation.from_matrix`.
///
/// # Errors
/// [`EngineError::InvalidParameter`] for a matrix of non-positive determinant.
pub fn from_matrix(m: [f64; 9]) -> Result<Quat> {
    let mut mat = Matrix3::from_row_slice(&m);
    if mat.determinant() <= 0.0 {
        return Err(EngineError::InvalidParameter(format!(
            "non-positive determinant (left-handed or null coordinate frame) in rotation \
             matrix {m:?}"
        )));
    }
    let gram = mat * mat.transpose();
    let orthogonal = (0..3).all(|i| {
        (0..3).all(|j| {
            let e = if i == j { 1.0 } else { 0.0 };
            (gram[(i, j)] - e).abs() <= 1e-12 + 1e-5 * e
        })
    });
    if !orthogonal {
        let svd = mat.svd(true, true);
        match (svd.u, svd.v_t) {
            (Some(u), Some(v_t)) => mat = u * v_t,
            _ => return Err(EngineError::NotConverged("SVD of a rotation matrix".into())),
        }
    }
    let m = |i: usize, j: usize| mat[(i, j)];
    let trace = m(0, 0) + m(1, 1) + m(2, 2);
    let decision = [m(0, 0), m(1, 1), m(2, 2), trace];
    let mut choice = 0;
    for (k, &d) in decision.iter().enumerate() {
        if d > decision[choice] {
            choice = k;
        }
    }
    let mut q = [0.0; 4];
    if choice == 3 {
        q = [
            m(2, 1) - m(1, 2),
            m(0, 2) - m(2, 0),
            m(1, 0) - m(0, 1),
            1.0 + trace,
        ];
    } else {
        let i = choice;
        let j = (i + 1) % 3;
        let k = (j + 1) % 3;
        q[i] = 1.0 - trace + 2.0 * m(i, i);
        q[j] = m(j, i) + m(i, j);
        q[k] = m(k, i) + m(i, k);
        q[3] = m(k, j) - m(j, k);
    }
    normalize(q)
}

/// Extrinsic x-y-z Euler angles (radians, each in `[-pi, pi]`) of a unit quaternion:
/// `Rotation.as_euler("xyz")` (the quaternion method of Bernardes and Viollet; at gimbal lock
/// the third angle is 0).
pub fn to_euler_xyz(q: Quat) -> [f64; 3] {
    use std::f64::consts::PI;
    let [x, y, z, w] = q;
    // i, j, k = 0, 1, 2: not symmetric, sign = 1
    let (a, b, c, d) = (w - y, x + z, y + w, z - x);
    let mut e = [0.0; 3];
    e[1] = 2.0 * c.hypot(d).atan2(a.hypot(b));
    let half_sum = b.atan2(a);
    let half_diff = d.atan2(c);
    let eps = 1e-7;
    if e[1].abs() <= eps {
        e[0] = 2.0 * half_sum;
    } else if (e[1] - PI).abs() <= eps {
        e[0] = -2.0 * half_diff;
    } else {
        e[0] = half_sum - half_diff;
        e[2] = half_sum + half_diff;
    }
    e[1] -= PI / 2.0;
    for v in &mut e {
        if *v < -PI {
            *v += 2.0 * PI;
        } else if *v > PI {
            *v -= 2.0 * PI;
        }
    }
    e
}

/// The quaternion of extrinsic x-y-z Euler angles: `Rotation.from_euler("xyz", e)` (the
/// elementary rotations composed, not normalised).
pub fn from_euler_xyz(e: [f64; 3]) -> Quat {
    let elementary = |axis: usize, angle: f64| {
        let mut q = [0.0; 4];
        q[3] = (angle / 2.0).cos();
        q[axis] = (angle / 2.0).sin();
        q
    };
    let q = elementary(0, e[0]);
    let q = compose_raw(elementary(1, e[1]), q);
    compose_raw(elementary(2, e[2]), q)
}

/// The rotation vector (axis times angle, angle in `[0, pi]`) of a unit quaternion:
/// `Rotation.as_rotvec`.
pub fn to_rotvec(q: Quat) -> [f64; 3] {
    let q = if q[3] < 0.0
        || (q[3] == 0.0
            && (q[0] < 0.0 || (q[0] == 0.0 && (q[1] < 0.0 || (q[1] == 0.0 && q[2] < 0.0)))))
    {
        [-q[0], -q[1], -q[2], -q[3]]
    } else {
        q
    };
    let norm = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
    let angle = 2.0 * norm.atan2(q[3]);
    let scale = if angle <= 1e-3 {
        let a2 = angle * angle;
        2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0
    } else {
        angle / (angle / 2.0).sin()
    };
    [scale * q[0], scale * q[1], scale * q[2]]
}

/// The unit quaternion of a rotation vector: `Rotation.from_rotvec`.
pub fn from_rotvec(v: [f64; 3]) -> Quat {
    let angle = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let scale = if angle <= 1e-3 {
        let a2 = angle * angle;
        0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    } else {
        (angle / 2.0).sin() / angle
    };
    [
        scale * v[0],
        scale * v[1],
        scale * v[2],
        (angle / 2.0).cos(),
    ]
}

/// `R(q) v`, or `R(q)^T v` with `inverse` (`Rotation.apply`, through the matrix).
pub fn apply(q: Quat, v: [f64; 3], inverse: bool) -> [f64; 3] {
    let m = to_matrix(q);
    let at = |i: usize, j: usize| if inverse { m[j * 3 + i] } else { m[i * 3 + j] };
    [0, 1, 2].map(|i| at(i, 0) * v[0] + at(i, 1) * v[1] + at(i, 2) * v[2])
}

/// Apply `f` to every row of `width_in` values, giving rows of `width_out`; a non-finite row
/// gives a NaN row.
fn map_rows<const I: usize, const O: usize>(
    v: &[f64],
    what: &str,
    f: impl Fn([f64; I]) -> Result<[f64; O]>,
) -> Result<Vec<f64>> {
    check_rows(v, I, what)?;
    let mut out = Vec::with_capacity(v.len() / I * O);
    for row in v.chunks_exact(I) {
        if finite(row) {
            let mut a = [0.0; I];
            a.copy_from_slice(row);
            out.extend_from_slice(&f(a)?);
        } else {
            out.extend_from_slice(&[f64::NAN; O]);
        }
    }
    Ok(out)
}

/// [`normalize`] of many quaternions (`n x 4`).
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for a length not a multiple of 4, and those of [`normalize`].
pub fn normalize_many(q: &[f64]) -> Result<Vec<f64>> {
    map_rows::<4, 4>(q, "quaternions", normalize)
}

/// Rotation matrices (`n x 9`) of quaternions (`n x 4`, normalised first as
/// `Rotation.from_quat`).
///
/// # Errors
/// As [`normalize_many`].
pub fn to_matrix_many(q: &[f64]) -> Result<Vec<f64>> {
    map_rows::<4, 9>(q, "quaternions", |q| Ok(to_matrix(normalize(q)?)))
}

/// [`from_matrix`] of many matrices (`n x 9`).
///
/// # Errors
/// As [`from_matrix`].
pub fn from_matrix_many(m: &[f64]) -> Result<Vec<f64>> {
    map_rows::<9, 4>(m, "matrices", from_matrix)
}

/// Extrinsic x-y-z Euler angles (`n x 3`) of rotation matrices (`n x 9`).
///
/// # Errors
/// As [`from_matrix`].
pub fn euler_xyz_from_matrix_many(m: &[f64]) -> Result<Vec<f64>> {
    map_rows::<9, 3>(m, "matrices", |m| Ok(to_euler_xyz(from_matrix(m)?)))
}

/// Rotation matrices (`n x 9`) of extrinsic x-y-z Euler angles (`n x 3`).
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for a length not a multiple of 3.
pub fn matrix_from_euler_xyz_many(e: &[f64]) -> Result<Vec<f64>> {
    map_rows::<3, 9>(e, "Euler angles", |e| Ok(to_matrix(from_euler_xyz(e))))
}

/// Extrinsic x-y-z Euler angles (`n x 3`) of quaternions (`n x 4`, normalised first).
///
/// # Errors
/// As [`normalize_many`].
pub fn euler_xyz_from_quat_many(q: &[f64]) -> Result<Vec<f64>> {
    map_rows::<4, 3>(q, "quaternions", |q| Ok(to_euler_xyz(normalize(q)?)))
}

/// Quaternions (`n x 4`) of extrinsic x-y-z Euler angles (`n x 3`).
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for a length not a multiple of 3.
pub fn quat_from_euler_xyz_many(e: &[f64]) -> Result<Vec<f64>> {
    map_rows::<3, 4>(e, "Euler angles", |e| Ok(from_euler_xyz(e)))
}

/// Pair rows of `p` and `q` (`n x 4` each, or one of them a single row broadcast).
fn pairs(p: &[f64], q: &[f64]) -> Result<(usize, usize, usize)> {
    let (np, nq) = (
        check_rows(p, 4, "quaternions p")?,
        check_rows(q, 4, "quaternions q")?,
    );
    let n = broadcast(np, nq).ok_or_else(|| {
        EngineError::ShapeMismatch(format!("cannot pair {np} rotations with {nq} rotations"))
    })?;
    Ok((n, usize::from(np != 1), usize::from(nq != 1)))
}

/// Rows of the result of pairing `a` rows with `b` rows (numpy broadcasting: equal counts, or
/// one of them a single row, which pairs with every row of the other, none included).
fn broadcast(a: usize, b: usize) -> Option<usize> {
    match (a, b) {
        (a, b) if a == b => Some(a),
        (1, b) => Some(b),
        (a, 1) => Some(a),
        _ => None,
    }
}

fn row4(v: &[f64], i: usize) -> Quat {
    [v[i * 4], v[i * 4 + 1], v[i * 4 + 2], v[i * 4 + 3]]
}

/// `p * q` row by row (normalised inputs and product; a single row is broadcast).
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for row counts that do not pair, and those of [`normalize`].
pub fn compose_many(p: &[f64], q: &[f64]) -> Result<Vec<f64>> {
    let (n, sp, sq) = pairs(p, q)?;
    let mut out = Vec::with_capacity(n * 4);
    for i in 0..n {
        let (a, b) = (row4(p, i * sp), row4(q, i * sq));
        if finite(&a) && finite(&b) {
            out.extend_from_slice(&compose(normalize(a)?, normalize(b)?)?);
        } else {
            out.extend_from_slice(&[f64::NAN; 4]);
        }
    }
    Ok(out)
}

/// `R(q_i) v_i` (or the inverse rotation) row by row (`n x 4` and `n x 3`, or one of them a
/// single row broadcast).
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for row counts that do not pair, and those of [`normalize`].
pub fn apply_many(q: &[f64], v: &[f64], inverse: bool) -> Result<Vec<f64>> {
    let (nq, nv) = (
        check_rows(q, 4, "quaternions")?,
        check_rows(v, 3, "vectors")?,
    );
    let n = broadcast(nq, nv).ok_or_else(|| {
        EngineError::ShapeMismatch(format!("cannot apply {nq} rotations to {nv} vectors"))
    })?;
    let mut out = Vec::with_capacity(n * 3);
    for i in 0..n {
        let a = row4(q, if nq == 1 { 0 } else { i });
        let j = if nv == 1 { 0 } else { i };
        let b = [v[j * 3], v[j * 3 + 1], v[j * 3 + 2]];
        if finite(&a) && finite(&b) {
            out.extend_from_slice(&apply(normalize(a)?, b, inverse));
        } else {
            out.extend_from_slice(&[f64::NAN; 3]);
        }
    }
    Ok(out)
}

/// Spherical linear interpolation of key rotations `q` (`m x 4`, normalised) at strictly
/// increasing `times` (`m >= 2`), evaluated at `at`: `Slerp(times, Rotation.from_quat(q))(at)`,
/// `n x 4` (`r_i * exp(alpha * log(r_i^-1 r_(i+1)))`; NaN at a NaN time). The keys must be
/// finite.
///
/// # Errors
/// [`EngineError::InvalidParameter`] for fewer than 2 keys, times not strictly increasing or
/// a time of `at` outside `[times[0], times[m - 1]]`; [`EngineError::NonFinite`] for NaN keys;
/// [`EngineError::ShapeMismatch`] if `q` does not have `m` rows of 4.
pub fn slerp(times: &[f64], q: &[f64], at: &[f64]) -> Result<Vec<f64>> {
    let m = times.len();
    if check_rows(q, 4, "key rotations")? != m {
        return Err(EngineError::ShapeMismatch(format!(
            "{} key rotations for {m} times",
            q.len() / 4
        )));
    }
    if m < 2 {
        return Err(EngineError::InvalidParameter(
            "slerp needs at least 2 key rotations".into(),
        ));
    }
    if !finite(times) || !finite(q) {
        return Err(EngineError::NonFinite(
            "slerp key times or rotations".into(),
        ));
    }
    if times.windows(2).any(|w| w[1] <= w[0]) {
        return Err(EngineError::InvalidParameter(
            "slerp times must be strictly increasing".into(),
        ));
    }
    let keys: Vec<Quat> = (0..m)
        .map(|i| normalize(row4(q, i)))
        .collect::<Result<_>>()?;
    let rotvecs: Vec<[f64; 3]> = keys
        .windows(2)
        .map(|w| Ok(to_rotvec(compose(inverse(w[0]), w[1])?)))
        .collect::<Result<_>>()?;
    let mut out = Vec::with_capacity(at.len() * 4);
    for &t in at {
        if t.is_nan() {
            out.extend_from_slice(&[f64::NAN; 4]);
            continue;
        }
        if t < times[0] || t > times[m - 1] {
            return Err(EngineError::InvalidParameter(format!(
                "interpolation time {t} is outside [{}, {}]",
                times[0],
                times[m - 1]
            )));
        }
        // searchsorted(times, t, "left") - 1, with t == times[0] in the first interval
        let i = times.partition_point(|&v| v < t).max(1) - 1;
        let alpha = (t - times[i]) / (times[i + 1] - times[i]);
        let rv = rotvecs[i].map(|v| v * alpha);
        out.extend_from_slice(&compose(keys[i], from_rotvec(rv))?);
    }
    Ok(out)
}

/// Flip signs so that consecutive finite quaternions (`n x 4`) have a non-negative dot
/// product, each run of finite rows on its own (the first row of a run keeps its sign).
///
/// # Errors
/// [`EngineError::ShapeMismatch`] for a length not a multiple of 4.
pub fn make_continuous(q: &[f64]) -> Result<Vec<f64>> {
    check_rows(q, 4, "quaternions")?;
    let mut out = q.to_vec();
    let mut prev: Option<Quat> = None;
    for row in out.chunks_exact_mut(4) {
        if !finite(row) {
            prev = None;
            continue;
        }
        if let Some(p) = prev {
            let dot = row[0] * p[0] + row[1] * p[1] + row[2] * p[2] + row[3] * p[3];
            if dot < 0.0 {
                for v in row.iter_mut() {
                    *v = -*v;
                }
            }
        }
        prev = Some([row[0], row[1], row[2], row[3]]);
    }
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn matrix_round_trip_and_euler() {
        let q = normalize([0.1, -0.4, 0.3, 0.8]).unwrap();
        let back = from_matrix(to_matrix(q)).unwrap();
        let sign = if back[3] * q[3] < 0.0 { -1.0 } else { 1.0 };
        assert!(close(&back.map(|v| v * sign), &q, 1e-15));
        let e = [0.3, -0.7, 2.5];
        let q = from_euler_xyz(e);
        assert!(close(&to_euler_xyz(q), &e, 1e-14));
        // 90 degrees about z
        let m = to_matrix(from_euler_xyz([0.0, 0.0, std::f64::consts::FRAC_PI_2]));
        assert!(close(
            &m,
            &[0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            1e-15
        ));
        assert!(from_matrix([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0]).is_err());
        assert!(normalize([0.0; 4]).is_err());
    }

    #[test]
    fn compose_inverse_apply() {
        let p = normalize([0.2, 0.1, -0.5, 0.7]).unwrap();
        let id = compose(inverse(p), p).unwrap();
        assert!(close(&id, &[0.0, 0.0, 0.0, 1.0], 1e-15));
        let v = [0.3, -1.0, 2.0];
        let w = apply(p, v, false);
        assert!(close(&apply(p, w, true), &v, 1e-14));
        assert!(close(
            &to_rotvec(from_rotvec([0.1, 0.2, -0.3])),
            &[0.1, 0.2, -0.3],
            1e-15
        ));
        assert!(close(
            &to_rotvec(from_rotvec([1e-5, 0.0, 0.0])),
            &[1e-5, 0.0, 0.0],
            1e-20
        ));
    }

    #[test]
    fn slerp_ends_and_middle() {
        let a = [0.0, 0.0, 0.0, 1.0];
        let b = from_euler_xyz([0.0, 0.0, 1.0]);
        let keys: Vec<f64> = a.iter().chain(&b).copied().collect();
        let out = slerp(&[0.0, 2.0], &keys, &[0.0, 1.0, 2.0, f64::NAN]).unwrap();
        assert!(close(&out[..4], &a, 1e-15));
        assert!(close(&out[4..8], &from_euler_xyz([0.0, 0.0, 0.5]), 1e-15));
        assert!(close(&out[8..12], &b, 1e-15));
        assert!(out[12].is_nan());
        assert!(slerp(&[0.0, 2.0], &keys, &[3.0]).is_err());
        assert!(slerp(&[0.0, 0.0], &keys, &[0.0]).is_err());
        assert!(slerp(&[0.0], &keys[..4], &[0.0]).is_err());
    }

    #[test]
    fn many_rows_and_continuity() {
        let q = [0.0, 0.0, 0.0, 2.0, f64::NAN, 0.0, 0.0, 1.0];
        let m = to_matrix_many(&q).unwrap();
        assert_eq!(&m[..9], &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        assert!(m[9..].iter().all(|v| v.is_nan()));
        assert!(to_matrix_many(&q[..5]).is_err());
        let flips = [
            0.0,
            0.0,
            0.0,
            1.0,
            0.0,
            0.0,
            0.1,
            -1.0,
            f64::NAN,
            0.0,
            0.0,
            1.0,
        ];
        let c = make_continuous(&flips).unwrap();
        assert_eq!(&c[4..8], &[-0.0, -0.0, -0.1, 1.0]);
        assert!(compose_many(&q, &q[..4]).is_ok());
        assert!(compose_many(&q, &flips).is_err());
    }

    #[test]
    fn a_single_row_broadcasts_over_none() {
        // one rotation paired with no rows gives no rows (found by the binding fuzzer: the
        // vectors were indexed at row 0 of an empty array)
        let one = [0.0, 0.0, 0.0, 1.0];
        assert_eq!(
            apply_many(&[], &[1.0, 2.0, 3.0], false).unwrap(),
            Vec::<f64>::new()
        );
        assert_eq!(apply_many(&one, &[], true).unwrap(), Vec::<f64>::new());
        assert_eq!(compose_many(&one, &[]).unwrap(), Vec::<f64>::new());
        assert_eq!(compose_many(&[], &one).unwrap(), Vec::<f64>::new());
        assert!(apply_many(&[], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], false).is_err());
        assert_eq!(
            apply_many(&one, &[1.0, 2.0, 3.0], false).unwrap(),
            vec![1.0, 2.0, 3.0]
        );
    }
}
