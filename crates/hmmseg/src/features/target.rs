//! Target-object labelling (paper Sec. III-B.3): "analyzes all the objects' velocities during
//! the entire demonstration and labels all the data points with an object number".
//!
//! # The rule
//! Object `j` *moves* during every run of at least `min_motion_s` seconds in which its speed
//! `|d p_j / dt|` exceeds `v_th`. Its *clearance* from the hand is `|TCP - p_j| - d_j / 2`
//! (centre distance minus half its `d_j`, so large and small objects compare fairly). The target
//! of sample `t` is, by the first rule that applies:
//!
//! 1. **moving**: the object moving at `t` (if several move, e.g. a push into another object,
//!    the one with the smallest clearance);
//! 2. **releasing**: the object whose motion just ended, for as long as the hand stays within
//!    its proximity zone (clearance `<= gamma`, i.e. `|TCP - p_j| <= d_j / 2 + gamma`) without
//!    interruption — the release and retreat after a place or stack;
//! 3. **approaching**: the object whose next motion starts first after `t` (ties: smallest
//!    clearance at that start) — the reach and grasp before a pick up or push;
//! 4. **no later motion** (after the last motion, or a demonstration without object motion,
//!    e.g. locate): the object with the smallest clearance at the next approach, i.e. at the
//!    first minimum of the smallest clearance after `t` that is followed by a rise of more than
//!    `approach_margin` (or by the end of the demonstration).
//!
//! Rule 3 labels everything between two motions with the object that moves next, so an
//! interaction without object motion (locate) between two motions is attributed to the next
//! moving object; rule 4 handles such interactions only after the last motion.

use nalgebra::DMatrix;

use super::kinematics::{
    check_dt, check_finite, check_len, check_shape, motion_intervals, samples_for, speed,
};
use super::params::FeatureParams;
use crate::error::{EngineError, Result};

/// Checked object sizes (`k x 3`, positive and finite) as `[x, y, z]` arrays.
pub(crate) fn object_sizes(sizes: &DMatrix<f64>, k: usize) -> Result<Vec<[f64; 3]>> {
    check_shape(sizes, k, 3, "object_size")?;
    check_finite(sizes, "object_size")?;
    (0..k)
        .map(|i| {
            let s = [sizes[(i, 0)], sizes[(i, 1)], sizes[(i, 2)]];
            if s.iter().all(|v| *v > 0.0) {
                Ok(s)
            } else {
                Err(EngineError::InvalidParameter(format!(
                    "object_size[{i}] = {s:?} must be positive"
                )))
            }
        })
        .collect()
}

/// Checked object position tracks: `k >= 1` matrices of `n x 3`, finite.
pub(crate) fn object_positions(positions: &[DMatrix<f64>], n: usize) -> Result<()> {
    if positions.is_empty() {
        return Err(EngineError::EmptySequence(
            "no objects: features and targets need at least one object".into(),
        ));
    }
    for (i, p) in positions.iter().enumerate() {
        let name = format!("object_position[{i}]");
        check_shape(p, n, 3, &name)?;
        check_finite(p, &name)?;
    }
    Ok(())
}

/// Label every sample with its target object (see the module docs for the rule).
///
/// # Arguments
/// * `tcp` — `n x 3` tool centre point, metres.
/// * `object_positions` — `k` tracks of `n x 3` object centres on the same clock.
/// * `object_sizes` — `k x 3` box extents in each object's frame.
/// * `dt` — sample period, seconds.
///
/// # Returns
/// `n` object indices in `0..k`.
///
/// # Errors
/// [`EngineError::EmptySequence`] for `n < 2` or `k == 0`, [`EngineError::ShapeMismatch`],
/// [`EngineError::NonFinite`] (naming array and index), [`EngineError::InvalidParameter`] for
/// `dt <= 0`, non-positive sizes or bad `params`.
pub fn label_targets(
    tcp: &DMatrix<f64>,
    object_positions: &[DMatrix<f64>],
    object_sizes: &DMatrix<f64>,
    dt: f64,
    params: &FeatureParams,
) -> Result<Vec<usize>> {
    params.validate()?;
    check_dt(dt)?;
    let n = tcp.nrows();
    check_len(n)?;
    check_shape(tcp, n, 3, "tcp")?;
    check_finite(tcp, "tcp")?;
    self::object_positions(object_positions, n)?;
    let sizes = self::object_sizes(object_sizes, object_positions.len())?;
    let speeds: Vec<Vec<f64>> = object_positions.iter().map(|p| speed(p, dt)).collect();
    Ok(label_checked(
        tcp,
        object_positions,
        &sizes,
        &speeds,
        dt,
        params,
    ))
}

/// [`label_targets`] on checked input, with the object speeds already computed.
pub(crate) fn label_checked(
    tcp: &DMatrix<f64>,
    positions: &[DMatrix<f64>],
    sizes: &[[f64; 3]],
    speeds: &[Vec<f64>],
    dt: f64,
    params: &FeatureParams,
) -> Vec<usize> {
    let n = tcp.nrows();
    let k = positions.len();
    let half: Vec<f64> = sizes
        .iter()
        .map(|s| 0.5 * params.size_measure.of(*s))
        .collect();
    let clearance = |t: usize, j: usize| (tcp.row(t) - positions[j].row(t)).norm() - half[j];
    let nearest = |t: usize, cands: &mut dyn Iterator<Item = usize>| {
        cands
            .map(|j| (clearance(t, j), j))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, j)| j)
    };

    let min_len = samples_for(params.min_motion_s, dt);
    let mut moving: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut starts: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (j, s) in speeds.iter().enumerate() {
        for (a, b) in motion_intervals(s, params.v_th, min_len) {
            starts[a].push(j);
            for m in &mut moving[a..b] {
                m.push(j);
            }
        }
    }
    // next_start[t] = object whose motion starts first after t.
    let mut next_start = vec![None; n];
    let mut next = None;
    for t in (0..n).rev() {
        if t + 1 < n && !starts[t + 1].is_empty() {
            next = nearest(t + 1, &mut starts[t + 1].iter().copied());
        }
        next_start[t] = next;
    }

    let mut target: Vec<Option<usize>> = vec![None; n];
    let mut releasing: Option<usize> = None;
    for t in 0..n {
        if let Some(j) = nearest(t, &mut moving[t].iter().copied()) {
            target[t] = Some(j);
            releasing = Some(j);
            continue;
        }
        releasing = releasing.filter(|&j| clearance(t, j) <= params.gamma);
        target[t] = releasing.or(next_start[t]);
    }

    // Rule 4 on the remaining samples (all after the last motion).
    let best: Vec<(f64, usize)> = (0..n)
        .map(|t| {
            (0..k)
                .map(|j| (clearance(t, j), j))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap_or((0.0, 0))
        })
        .collect();
    let mut t = 0;
    while t < n {
        if target[t].is_some() {
            t += 1;
            continue;
        }
        let (mut low, mut arg) = (best[t].0, t);
        for (u, b) in best.iter().enumerate().skip(t + 1) {
            if b.0 < low {
                (low, arg) = (b.0, u);
            } else if b.0 > low + params.approach_margin {
                break;
            }
        }
        // Every sample up to the minimum sees the same approach (its running minimum is the
        // same from there on), so label them at once.
        for slot in target.iter_mut().take(arg + 1).skip(t) {
            slot.get_or_insert(best[arg].1);
        }
        t = arg + 1;
    }
    target.into_iter().map(|o| o.unwrap_or(0)).collect()
}
