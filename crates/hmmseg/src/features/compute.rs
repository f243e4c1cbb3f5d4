//! The eight features of Table I, per sample, for a given target object per sample.

use nalgebra::{DMatrix, Quaternion, UnitQuaternion, Vector3};

use super::kinematics::{
    check_dt, check_finite, check_len, check_shape, gradient, motion_intervals, row_norms,
    samples_for, speed,
};
use super::params::FeatureParams;
use super::target::{label_checked, object_positions, object_sizes};
use super::{FeatureSet, Scene, N_FEATURES};
use crate::error::{EngineError, Result};

/// Checked inputs: `(n, k, sizes)`.
fn validate(scene: &Scene, params: &FeatureParams) -> Result<(usize, usize, Vec<[f64; 3]>)> {
    params.validate()?;
    check_dt(scene.dt)?;
    let n = scene.tcp.nrows();
    check_len(n)?;
    check_shape(&scene.tcp, n, 3, "tcp")?;
    check_finite(&scene.tcp, "tcp")?;
    if scene.opening.len() != n {
        return Err(EngineError::ShapeMismatch(format!(
            "opening has {} samples, tcp has {n}",
            scene.opening.len()
        )));
    }
    if let Some(i) = scene.opening.iter().position(|v| !v.is_finite()) {
        return Err(EngineError::NonFinite(format!(
            "opening[{i}] = {} (features need NaN-free input: crop the trajectory to valid \
             samples)",
            scene.opening[i]
        )));
    }
    object_positions(&scene.object_position, n)?;
    let k = scene.object_position.len();
    if scene.object_quaternion.len() != k {
        return Err(EngineError::ShapeMismatch(format!(
            "{k} object position tracks but {} quaternion tracks",
            scene.object_quaternion.len()
        )));
    }
    for (i, q) in scene.object_quaternion.iter().enumerate() {
        let name = format!("object_quaternion[{i}]");
        check_shape(q, n, 4, &name)?;
        check_finite(q, &name)?;
        if let Some(t) = q.row_iter().position(|r| r.norm() < 1e-9) {
            return Err(EngineError::InvalidParameter(format!(
                "{name}[{t}] is a zero quaternion"
            )));
        }
    }
    let sizes = object_sizes(&scene.object_size, k)?;
    Ok((n, k, sizes))
}

/// Resting height of each object: the median `z` over its initial rest, i.e. the samples before
/// its first motion (speed above `v_th` for at least `min_motion_s`); `z[0]` if it moves at once.
fn resting_heights(
    positions: &[DMatrix<f64>],
    speeds: &[Vec<f64>],
    dt: f64,
    params: &FeatureParams,
) -> Vec<f64> {
    let min_len = samples_for(params.min_motion_s, dt);
    positions
        .iter()
        .zip(speeds)
        .map(|(p, s)| {
            let first = motion_intervals(s, params.v_th, min_len)
                .first()
                .map_or(p.nrows(), |iv| iv.0);
            let mut z: Vec<f64> = (0..first.max(1)).map(|t| p[(t, 2)]).collect();
            z.sort_by(f64::total_cmp);
            let h = z.len() / 2;
            if z.len() % 2 == 1 {
                z[h]
            } else {
                0.5 * (z[h - 1] + z[h])
            }
        })
        .collect()
}

/// Compute the features of Table I (columns in [`super::FEATURE_NAMES`] order) and their
/// per-sample thresholds.
///
/// `target` gives each sample's target object `i` (length `n`, entries `< k`); `None` labels the
/// targets with [`super::label_targets`]. With `d_i = params.size_measure.of(size_i)`, `p_i`
/// the target's centre, `R_i` its rotation, `gamma` and `v_th` from `params`:
///
/// | column | value | threshold |
/// |---|---|---|
/// | fingertip_distance | `opening = |I - T|` | `d_i + gamma` |
/// | tcp_rise_fall | `d TCP_z / dt` (central differences) | `0` |
/// | object_proximity | `|TCP - p_i|` | `d_i / 2 + gamma` |
/// | object_distance | `min_{j != i} |p_i - p_j|` (`lone_object_distance` if `k == 1`) | `d_i` |
/// | object_height | `p_i . e_z` | resting height of `i` + `gamma` |
/// | tcp_in_object_{x,y,z} | `R_i^T (TCP - p_i)` | `size_i[axis] / 2 + gamma` (the band is `+-` it) |
/// | object_velocity | `|d p_i / dt|` | `v_th` |
/// | hand_velocity | `|d TCP / dt|` | `v_th` |
///
/// Heights and `z` are relative to the world frame, whose `z = 0` is the table (the reference
/// marker on the workspace plane). Every value is invariant to translating the scene in `x, y`
/// and rotating it about `z`; a vertical shift moves `object_height` and its threshold
/// together.
///
/// # Errors
/// [`EngineError::EmptySequence`] for `n < 2` or no objects, [`EngineError::ShapeMismatch`] for
/// inconsistent shapes or a `target` of the wrong length, [`EngineError::NonFinite`] (naming
/// the array and index: the input must be NaN-free, i.e. cropped to valid samples),
/// [`EngineError::InvalidParameter`] for `dt <= 0`, a target index `>= k`, zero quaternions,
/// non-positive sizes or bad `params`.
pub fn compute_features(
    scene: &Scene,
    target: Option<&[usize]>,
    params: &FeatureParams,
) -> Result<FeatureSet> {
    let (n, k, sizes) = validate(scene, params)?;
    let dt = scene.dt;
    let speeds: Vec<Vec<f64>> = scene.object_position.iter().map(|p| speed(p, dt)).collect();
    let target = match target {
        Some(t) => {
            if t.len() != n {
                return Err(EngineError::ShapeMismatch(format!(
                    "target has {} samples, tcp has {n}",
                    t.len()
                )));
            }
            if let Some(i) = t.iter().position(|&j| j >= k) {
                return Err(EngineError::InvalidParameter(format!(
                    "target[{i}] = {} but there are only {k} objects",
                    t[i]
                )));
            }
            t.to_vec()
        }
        None => label_checked(
            &scene.tcp,
            &scene.object_position,
            &sizes,
            &speeds,
            dt,
            params,
        ),
    };
    let tcp_vel = gradient(&scene.tcp, dt);
    let hand_speed = row_norms(&tcp_vel);
    let rest = resting_heights(&scene.object_position, &speeds, dt, params);
    let g = params.gamma;

    let mut values = DMatrix::zeros(n, N_FEATURES);
    let mut thresholds = DMatrix::zeros(n, N_FEATURES);
    for (t, &i) in target.iter().enumerate() {
        let p = &scene.object_position;
        let tcp = Vector3::new(scene.tcp[(t, 0)], scene.tcp[(t, 1)], scene.tcp[(t, 2)]);
        let pi = Vector3::new(p[i][(t, 0)], p[i][(t, 1)], p[i][(t, 2)]);
        let d = params.size_measure.of(sizes[i]);
        let others = (0..k)
            .filter(|&j| j != i)
            .map(|j| (p[j].row(t) - p[i].row(t)).norm())
            .fold(f64::INFINITY, f64::min);
        let q = &scene.object_quaternion[i];
        let rot = UnitQuaternion::from_quaternion(Quaternion::new(
            q[(t, 3)],
            q[(t, 0)],
            q[(t, 1)],
            q[(t, 2)],
        ));
        let local = rot.inverse_transform_vector(&(tcp - pi));
        let row = [
            (scene.opening[t], d + g),
            (tcp_vel[(t, 2)], 0.0),
            ((tcp - pi).norm(), 0.5 * d + g),
            (
                if k == 1 {
                    params.lone_object_distance
                } else {
                    others
                },
                d,
            ),
            (pi.z, rest[i] + g),
            (local.x, 0.5 * sizes[i][0] + g),
            (local.y, 0.5 * sizes[i][1] + g),
            (local.z, 0.5 * sizes[i][2] + g),
            (speeds[i][t], params.v_th),
            (hand_speed[t], params.v_th),
        ];
        for (c, (v, th)) in row.into_iter().enumerate() {
            values[(t, c)] = v;
            thresholds[(t, c)] = th;
        }
    }
    Ok(FeatureSet {
        values,
        thresholds,
        target,
    })
}
