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
//! 3. **approaching**: the object of the first *event* at or after `t`. An event is the start
//!    of an object's motion (that object: the reach before a pick up or push) or a *dwell*: a
//!    run of samples where the hand is slower than `dwell_speed` and its smallest clearance is
//!    at most `approach_radius` — the hand pausing near an object without moving it (locate);
//!    the whole pause targets the nearest object at the pause's closest sample. Fast passes
//!    near other objects on the way are not dwells;
//! 4. **after the last event**: the object with the smallest clearance at the next approach,
//!    and after the last approach that approach's object.
//!
//! Approaches (rule 4) are the significant minima of the smallest clearance over time, found
//! with a hysteresis of `approach_margin` (noise below the margin makes no minimum). On the
//! simulated sample recordings a locate pauses at a clearance of 0.10-0.13 m below 0.05 m/s,
//! while passes near other objects run at 0.27-0.5 m/s.

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
    // The smallest clearance and its object, and its significant minima (approaches).
    let best: Vec<(f64, usize)> = (0..n)
        .map(|t| {
            (0..k)
                .map(|j| (clearance(t, j), j))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap_or((0.0, 0))
        })
        .collect();
    let clear: Vec<f64> = best.iter().map(|b| b.0).collect();
    let minima = approach_minima(&clear, params.approach_margin);
    // Dwells: runs where the hand is slow and near an object. The event is the run's last
    // sample (the whole pause belongs to it), its object the nearest at the closest sample.
    let hand_speed = speed(tcp, dt);
    let mut dwell: Vec<Option<usize>> = vec![None; n];
    let mut t = 0;
    while t < n {
        let slow_near =
            |u: usize| hand_speed[u] <= params.dwell_speed && clear[u] <= params.approach_radius;
        if !slow_near(t) {
            t += 1;
            continue;
        }
        let end = (t..n).find(|&u| !slow_near(u)).unwrap_or(n);
        let closest = (t..end)
            .min_by(|&a, &b| clear[a].total_cmp(&clear[b]))
            .unwrap_or(t);
        dwell[end - 1] = Some(best[closest].1);
        t = end;
    }
    // next_event[t] = object of the first motion start or dwell at or after t.
    let mut next_event = vec![None; n];
    let mut next = None;
    for t in (0..n).rev() {
        if !starts[t].is_empty() {
            next = nearest(t, &mut starts[t].iter().copied());
        } else if dwell[t].is_some() {
            next = dwell[t];
        }
        next_event[t] = next;
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
        target[t] = releasing.or(next_event[t]);
    }

    // Rule 4 on the remaining samples (after the last event): the next approach of any kind,
    // and after the last approach its object.
    let mut upcoming = minima.iter().peekable();
    let last = minima.last().copied().unwrap_or(0);
    for (t, slot) in target.iter_mut().enumerate() {
        while upcoming.peek().is_some_and(|&&m| m < t) {
            upcoming.next();
        }
        let m = upcoming.peek().map_or(last, |&&m| m);
        slot.get_or_insert(best[m].1);
    }
    target.into_iter().map(|o| o.unwrap_or(0)).collect()
}

/// Indices of the significant minima of `d`: a zigzag with hysteresis `margin` (a minimum is
/// followed by a rise of more than `margin` or by the end, and preceded by a fall of more than
/// `margin` or by the start). Never empty for non-empty `d`.
pub(crate) fn approach_minima(d: &[f64], margin: f64) -> Vec<usize> {
    #[derive(PartialEq)]
    enum Dir {
        Unknown,
        Up,
        Down,
    }
    let mut out = Vec::new();
    let (mut lo, mut hi) = (0, 0);
    let mut dir = Dir::Unknown;
    for (u, &v) in d.iter().enumerate().skip(1) {
        match dir {
            Dir::Unknown => {
                if v > d[lo] + margin {
                    out.push(lo);
                    (dir, hi) = (Dir::Up, u);
                } else if v < d[hi] - margin {
                    (dir, lo) = (Dir::Down, u);
                } else {
                    if v < d[lo] {
                        lo = u;
                    }
                    if v > d[hi] {
                        hi = u;
                    }
                }
            }
            Dir::Up => {
                if v > d[hi] {
                    hi = u;
                } else if v < d[hi] - margin {
                    (dir, lo) = (Dir::Down, u);
                }
            }
            Dir::Down => {
                if v < d[lo] {
                    lo = u;
                } else if v > d[lo] + margin {
                    out.push(lo);
                    (dir, hi) = (Dir::Up, u);
                }
            }
        }
    }
    if dir != Dir::Up && !d.is_empty() {
        out.push(lo);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::approach_minima;

    #[test]
    fn minima_with_hysteresis() {
        // Noise smaller than the margin does not create minima.
        let d = [
            5.0, 4.0, 3.0, 3.2, 2.0, 4.0, 6.0, 5.9, 6.0, 3.0, 1.0, 1.5, 4.0,
        ];
        assert_eq!(approach_minima(&d, 1.0), vec![4, 10]);
        assert_eq!(approach_minima(&[1.0, 2.0, 3.0], 0.5), vec![0]);
        assert_eq!(approach_minima(&[3.0, 2.0, 1.0], 0.5), vec![2]);
        assert_eq!(approach_minima(&[1.0, 1.1, 1.0], 0.5), vec![0]);
        assert_eq!(approach_minima(&[1.0, 3.0, 1.0, 2.8], 0.5), vec![0, 2]);
    }
}
