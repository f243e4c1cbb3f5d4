//! Table I features on hand-computed cases, invariance to the scene's placement, and target
//! labelling on constructed scenes.

use std::f64::consts::{FRAC_1_SQRT_2, PI};

use hmmseg::features::{
    compute_features, feature_index, label_targets, FeatureParams, Scene, FEATURE_GROUPS,
    FEATURE_NAMES,
};
use hmmseg::EngineError;
use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};

const A: usize = 0;
const B: usize = 1;

fn col(name: &str) -> usize {
    feature_index(name).unwrap()
}

fn track(n: usize, f: impl Fn(usize) -> [f64; 3]) -> DMatrix<f64> {
    DMatrix::from_fn(n, 3, |t, c| f(t)[c])
}

fn identity_quats(n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(n, 4, |_, c| if c == 3 { 1.0 } else { 0.0 })
}

fn lerp(p: [f64; 3], q: [f64; 3], s: f64) -> [f64; 3] {
    let s = s.clamp(0.0, 1.0);
    [0, 1, 2].map(|c| p[c] + s * (q[c] - p[c]))
}

#[test]
fn hand_computed_values_and_thresholds() {
    let n = 5;
    let dt = 0.5;
    let z = [0.1, 0.2, 0.4, 0.4, 0.3];
    // A at (0.5, 0, 0) turned 90 degrees about z; B at (0.5, 0.3, 0).
    let q_a = DMatrix::from_fn(n, 4, |_, c| [0.0, 0.0, FRAC_1_SQRT_2, FRAC_1_SQRT_2][c]);
    let scene = Scene {
        tcp: track(n, |t| [0.1 * t as f64, 0.0, z[t]]),
        opening: DVector::from_element(n, 0.07),
        object_position: vec![track(n, |_| [0.5, 0.0, 0.0]), track(n, |_| [0.5, 0.3, 0.0])],
        object_quaternion: vec![q_a, identity_quats(n)],
        object_size: DMatrix::from_row_slice(2, 3, &[0.04, 0.08, 0.02, 0.05, 0.05, 0.05]),
        dt,
    };
    let p = FeatureParams::default();
    let f = compute_features(&scene, Some(&[A; 5]), &p).unwrap();
    assert_eq!(f.values.shape(), (5, 10));
    assert_eq!(f.target, vec![A; 5]);
    let rise = [0.2, 0.3, 0.2, -0.1, -0.2];
    for t in 0..n {
        let x = 0.1 * t as f64;
        let want = [
            0.07,
            rise[t],
            ((x - 0.5).powi(2) + z[t] * z[t]).sqrt(),
            0.3,
            0.0,
            0.0,     // R^T (x - 0.5, 0, z) = (0, 0.5 - x, z) for a 90 degree yaw
            0.5 - x, // ...
            z[t],
            0.0,
            (0.04 + rise[t] * rise[t]).sqrt(),
        ];
        for (c, w) in want.iter().enumerate() {
            let got = f.values[(t, c)];
            assert!(
                (got - w).abs() < 1e-12,
                "t={t} {}: {got} != {w}",
                FEATURE_NAMES[c]
            );
        }
        // d_A = largest horizontal extent = 0.08; gamma = 0.02; v_th = 0.05.
        let th = [0.1, 0.0, 0.06, 0.08, 0.02, 0.04, 0.06, 0.03, 0.05, 0.05];
        for (c, w) in th.iter().enumerate() {
            assert!(
                (f.thresholds[(t, c)] - w).abs() < 1e-12,
                "threshold {}",
                FEATURE_NAMES[c]
            );
        }
    }
    // Target B: distance to A, B's frame is the world frame.
    let g = compute_features(&scene, Some(&[B; 5]), &p).unwrap();
    assert!((g.values[(2, col("object_distance"))] - 0.3).abs() < 1e-12);
    assert!((g.values[(2, col("tcp_in_object_y"))] + 0.3).abs() < 1e-12);
    assert!((g.thresholds[(2, col("fingertip_distance"))] - 0.07).abs() < 1e-12);
    // The group view of tcp_in_object is three columns wide.
    let (name, _) = &FEATURE_GROUPS[5];
    assert_eq!(*name, "tcp_in_object");
    assert_eq!(g.group(5, 1, 4).unwrap().shape(), (3, 3));
    assert!(g.group(5, 3, 9).is_none());
}

/// Pick A and carry it aside, then pick B and carry it aside, then retreat (dt = 0.05 s).
fn two_picks() -> Scene {
    let dt = 0.05;
    let n = 201;
    let time = |t: usize| t as f64 * dt;
    let (a0, a1) = ([0.3, 0.0, 0.025], [0.3, 0.3, 0.025]);
    let (b0, b1) = ([0.6, 0.0, 0.025], [0.6, -0.3, 0.025]);
    let carried = |p: [f64; 3], q: [f64; 3], s: f64| {
        let mut r = lerp(p, q, s);
        r[2] += 0.1 * (PI * s.clamp(0.0, 1.0)).sin();
        r
    };
    let pos_a = move |s: f64| carried(a0, a1, (s - 2.0) / 2.0);
    let pos_b = move |s: f64| carried(b0, b1, (s - 6.0) / 2.0);
    let tcp = move |s: f64| match s {
        s if s < 2.0 => lerp([0.0, 0.0, 0.3], a0, s / 2.0),
        s if s < 4.5 => pos_a(s),
        s if s < 6.0 => lerp(a1, b0, (s - 4.5) / 1.5),
        s if s < 8.0 => pos_b(s),
        s => lerp(b1, [0.6, -0.3, 0.4], (s - 8.0) / 2.0),
    };
    Scene {
        tcp: track(n, |t| tcp(time(t))),
        opening: DVector::from_fn(n, |t, _| 0.03 + 0.02 * (time(t)).sin()),
        object_position: vec![track(n, |t| pos_a(time(t))), track(n, |t| pos_b(time(t)))],
        object_quaternion: vec![identity_quats(n), identity_quats(n)],
        object_size: DMatrix::from_row_slice(2, 3, &[0.05; 6]),
        dt,
    }
}

#[test]
fn targets_follow_object_motion() {
    let s = two_picks();
    let p = FeatureParams::default();
    let lab = label_targets(&s.tcp, &s.object_position, &s.object_size, s.dt, &p).unwrap();
    // A moves on samples 40..=80, B on 120..=160 (central differences blur one sample).
    assert!(
        lab[..=80].iter().all(|&o| o == A),
        "approach and carry A: {lab:?}"
    );
    assert!(lab[81..=90].iter().all(|&o| o == A), "release A: {lab:?}");
    assert!(
        lab[95..].iter().all(|&o| o == B),
        "approach, carry B, retreat: {lab:?}"
    );
    // compute_features(None) uses the same labels.
    let f = compute_features(&s, None, &p).unwrap();
    assert_eq!(f.target, lab);
    // While carrying, the object speed is above v_th and the object is above its rest height.
    let t = 60;
    assert!(f.values[(t, col("object_velocity"))] > p.v_th);
    assert!(f.values[(t, col("object_height"))] > f.thresholds[(t, col("object_height"))]);
    assert!((f.thresholds[(t, col("object_height"))] - 0.045).abs() < 1e-12);
    assert!(f.values[(t, col("object_proximity"))] < 1e-12);
}

#[test]
fn targets_without_motion_follow_approaches() {
    // Locate A (hover above it 2-3 s), then locate B (5-6 s), then retreat upwards.
    let n = 181;
    let (a, b) = ([0.3, 0.0, 0.025], [0.6, 0.2, 0.025]);
    let (hover_a, hover_b) = ([0.3, 0.0, 0.08], [0.6, 0.2, 0.08]);
    let tcp = path(
        n,
        &[
            (0.0, [0.0, 0.0, 0.3]),
            (2.0, hover_a),
            (3.0, hover_a),
            (5.0, hover_b),
            (6.0, hover_b),
            (9.0, [0.6, 0.2, 0.4]),
        ],
    );
    let pos = vec![track(n, |_| a), track(n, |_| b)];
    let sizes = DMatrix::from_row_slice(2, 3, &[0.05; 6]);
    let lab = label_targets(&tcp, &pos, &sizes, 0.05, &FeatureParams::default()).unwrap();
    assert!(lab[..=40].iter().all(|&o| o == A), "{lab:?}");
    assert!(lab[61..].iter().all(|&o| o == B), "{lab:?}");
    // Without pauses there are no dwells: every approach counts (rule 4).
    let tcp = path(
        n,
        &[
            (0.0, [0.0, 0.0, 0.3]),
            (2.0, hover_a),
            (5.0, hover_b),
            (8.0, [0.6, 0.2, 0.4]),
        ],
    );
    let p = FeatureParams {
        dwell_speed: 0.0,
        ..FeatureParams::default()
    };
    let lab = label_targets(&tcp, &pos, &sizes, 0.05, &p).unwrap();
    assert!(lab[..=40].iter().all(|&o| o == A), "{lab:?}");
    assert!(lab[41..].iter().all(|&o| o == B), "{lab:?}");
}

/// Hand path through `waypoints` `(time, position)` (linear between them), at dt = 0.05 s.
fn path(n: usize, waypoints: &[(f64, [f64; 3])]) -> DMatrix<f64> {
    track(n, |t| {
        let s = t as f64 * 0.05;
        let k = waypoints.iter().rposition(|w| w.0 <= s).unwrap_or(0);
        match waypoints.get(k + 1) {
            Some(&(t1, p1)) => lerp(
                waypoints[k].1,
                p1,
                (s - waypoints[k].0) / (t1 - waypoints[k].0),
            ),
            None => waypoints[k].1,
        }
    })
}

#[test]
fn a_dwell_near_an_object_before_another_is_picked_targets_it() {
    // Locate B (hover 8 cm above it, pause 1-2 s), then reach A (3-4 s) and carry it (4-6 s).
    let n = 161;
    let (a, b) = ([0.3, 0.0, 0.025], [0.6, 0.2, 0.025]);
    let hover_b = [0.6, 0.2, 0.13];
    let tcp = path(
        n,
        &[
            (0.0, [0.4, 0.4, 0.3]),
            (1.0, hover_b),
            (2.0, hover_b),
            (4.0, a),
            (6.0, [0.3, -0.3, 0.025]),
        ],
    );
    let pos_a = path(n, &[(0.0, a), (4.0, a), (6.0, [0.3, -0.3, 0.025])]);
    let pos = vec![pos_a, track(n, |_| b)];
    let sizes = DMatrix::from_row_slice(2, 3, &[0.05; 6]);
    let lab = label_targets(&tcp, &pos, &sizes, 0.05, &FeatureParams::default()).unwrap();
    assert!(lab[..=40].iter().all(|&o| o == B), "{lab:?}");
    assert!(lab[41..].iter().all(|&o| o == A), "{lab:?}");
}

#[test]
fn a_fast_pass_near_another_object_is_not_a_dwell() {
    // On the way to A the hand sweeps past B at 0.5 m/s, 5 cm above it.
    let n = 121;
    let (a, b) = ([0.3, 0.0, 0.025], [0.6, 0.0, 0.025]);
    let tcp = path(
        n,
        &[
            (0.0, [0.9, 0.0, 0.1]),
            (0.6, [0.6, 0.0, 0.1]),
            (1.2, [0.3, 0.0, 0.1]),
            (3.0, a),
            (5.0, [0.3, -0.3, 0.025]),
        ],
    );
    let pos_a = path(n, &[(0.0, a), (3.0, a), (5.0, [0.3, -0.3, 0.025])]);
    let pos = vec![pos_a, track(n, |_| b)];
    let sizes = DMatrix::from_row_slice(2, 3, &[0.05; 6]);
    let lab = label_targets(&tcp, &pos, &sizes, 0.05, &FeatureParams::default()).unwrap();
    assert!(lab.iter().all(|&o| o == A), "{lab:?}");
}

#[test]
fn simultaneous_motion_takes_the_object_in_hand() {
    // The hand pushes A into B; both slide together. A is the target.
    let n = 40;
    let dt = 0.05;
    let x = |t: usize| 0.005 * t as f64;
    let tcp = track(n, |t| [x(t) - 0.03, 0.0, 0.02]);
    let pos = vec![
        track(n, |t| [x(t), 0.0, 0.025]),
        track(n, |t| [x(t) + 0.06, 0.0, 0.025]),
    ];
    let sizes = DMatrix::from_row_slice(2, 3, &[0.05; 6]);
    let lab = label_targets(&tcp, &pos, &sizes, dt, &FeatureParams::default()).unwrap();
    assert!(lab.iter().all(|&o| o == A), "{lab:?}");
}

/// Rotate the whole scene by `yaw` about the world z axis and shift it by `shift`.
fn transform(s: &Scene, yaw: f64, shift: [f64; 3]) -> Scene {
    let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
    let move_track = |p: &DMatrix<f64>| {
        let mut out = p.clone();
        for t in 0..p.nrows() {
            let v = rot * Vector3::new(p[(t, 0)], p[(t, 1)], p[(t, 2)]);
            for c in 0..3 {
                out[(t, c)] = v[c] + shift[c];
            }
        }
        out
    };
    let turn = |q: &DMatrix<f64>| {
        let mut out = q.clone();
        for t in 0..q.nrows() {
            let qt = nalgebra::Quaternion::new(q[(t, 3)], q[(t, 0)], q[(t, 1)], q[(t, 2)]);
            let r = rot.quaternion() * qt;
            out.row_mut(t).copy_from_slice(&[r.i, r.j, r.k, r.w]);
        }
        out
    };
    Scene {
        tcp: move_track(&s.tcp),
        opening: s.opening.clone(),
        object_position: s.object_position.iter().map(move_track).collect(),
        object_quaternion: s.object_quaternion.iter().map(turn).collect(),
        object_size: s.object_size.clone(),
        dt: s.dt,
    }
}

#[test]
fn invariant_to_translation_and_yaw() {
    let mut s = two_picks();
    // Give A a non-trivial, changing orientation so the object frame matters.
    for t in 0..s.tcp.nrows() {
        let q = UnitQuaternion::from_euler_angles(0.1, -0.2, 0.01 * t as f64);
        let c = q.quaternion().coords; // (i, j, k, w)
        s.object_quaternion[A]
            .row_mut(t)
            .copy_from_slice(&[c[0], c[1], c[2], c[3]]);
    }
    let p = FeatureParams::default();
    let f = compute_features(&s, None, &p).unwrap();
    let h = col("object_height");
    for (yaw, shift) in [(0.7, [1.0, -2.0, 0.0]), (-2.5, [0.3, 0.4, 0.5])] {
        let g = compute_features(&transform(&s, yaw, shift), None, &p).unwrap();
        assert_eq!(f.target, g.target);
        for (c, name) in FEATURE_NAMES.iter().enumerate() {
            let dz = if c == h { shift[2] } else { 0.0 };
            for t in 0..f.len() {
                let (v, w) = (f.values[(t, c)], g.values[(t, c)]);
                assert!((v + dz - w).abs() < 1e-9, "{name} at {t}: {v} vs {w}");
                let (v, w) = (f.thresholds[(t, c)], g.thresholds[(t, c)]);
                assert!((v + dz - w).abs() < 1e-9, "threshold {name}");
            }
        }
    }
}

#[test]
fn single_object_uses_lone_distance() {
    let mut s = two_picks();
    s.object_position.truncate(1);
    s.object_quaternion.truncate(1);
    s.object_size = s.object_size.rows(0, 1).into_owned();
    let p = FeatureParams {
        lone_object_distance: 2.5,
        ..FeatureParams::default()
    };
    let f = compute_features(&s, None, &p).unwrap();
    assert!(f.target.iter().all(|&o| o == A));
    assert!(f
        .column("object_distance")
        .unwrap()
        .iter()
        .all(|&d| (d - 2.5).abs() < 1e-15));
    assert!(f.column("no_such_feature").is_none());
}

#[test]
fn bad_input_is_an_error() {
    let s = two_picks();
    let p = FeatureParams::default();
    let err = |s: &Scene, t: Option<&[usize]>| compute_features(s, t, &p).unwrap_err();

    let mut bad = s.clone();
    bad.object_position[1][(17, 2)] = f64::NAN;
    assert!(
        matches!(err(&bad, None), EngineError::NonFinite(m) if m.contains("object_position[1][17, 2]"))
    );
    let mut bad = s.clone();
    bad.opening[3] = f64::NAN;
    assert!(matches!(err(&bad, None), EngineError::NonFinite(m) if m.contains("opening[3]")));
    let mut bad = s.clone();
    bad.dt = 0.0;
    assert!(matches!(err(&bad, None), EngineError::InvalidParameter(_)));
    let mut bad = s.clone();
    bad.object_position.clear();
    bad.object_quaternion.clear();
    bad.object_size = DMatrix::zeros(0, 3);
    assert!(matches!(err(&bad, None), EngineError::EmptySequence(_)));
    let mut bad = s.clone();
    bad.tcp = bad.tcp.rows(0, 100).into_owned();
    assert!(matches!(err(&bad, None), EngineError::ShapeMismatch(_)));
    let mut bad = s.clone();
    bad.object_quaternion[0].row_mut(5).fill(0.0);
    assert!(matches!(err(&bad, None), EngineError::InvalidParameter(_)));
    let mut bad = s.clone();
    bad.object_size[(1, 1)] = 0.0;
    assert!(matches!(err(&bad, None), EngineError::InvalidParameter(_)));
    assert!(matches!(
        err(&s, Some(&[0; 3])),
        EngineError::ShapeMismatch(_)
    ));
    assert!(matches!(
        err(&s, Some(&[2; 201])),
        EngineError::InvalidParameter(_)
    ));
    let one = Scene {
        tcp: s.tcp.rows(0, 1).into_owned(),
        opening: s.opening.rows(0, 1).into_owned(),
        object_position: s
            .object_position
            .iter()
            .map(|p| p.rows(0, 1).into_owned())
            .collect(),
        object_quaternion: s
            .object_quaternion
            .iter()
            .map(|q| q.rows(0, 1).into_owned())
            .collect(),
        object_size: s.object_size.clone(),
        dt: s.dt,
    };
    assert!(matches!(err(&one, None), EngineError::EmptySequence(_)));
    let bad_p = FeatureParams {
        v_th: -1.0,
        ..FeatureParams::default()
    };
    assert!(compute_features(&s, None, &bad_p).is_err());
    assert!(label_targets(&s.tcp, &s.object_position, &s.object_size, f64::NAN, &p).is_err());
}
