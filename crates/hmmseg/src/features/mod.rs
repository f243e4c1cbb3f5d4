//! The eight features of Table I (paper Sec. III-B.1) and target-object labelling (Sec. III-B.3).
//!
//! Input is a [`Scene`]: the hand (TCP, fingertip opening) and `k` tracked objects on one
//! clock with a uniform period `dt`. Output is a [`FeatureSet`]: an `n x 10` matrix whose
//! columns are [`FEATURE_NAMES`] (Table I's *TCP position in object frame* takes three columns),
//! the per-sample thresholds of Table I in the same layout, and the target object of each
//! sample. Input must be NaN-free: the preprocessing marks tracking gaps with NaN, and features
//! are computed only on valid samples (crop to a valid span first); NaN is rejected with an
//! error naming the array and index.

mod compute;
mod kinematics;
mod params;
mod target;

use nalgebra::{DMatrix, DVector};

pub use self::compute::compute_features;
pub use self::params::{FeatureParams, SizeMeasure};
pub use self::target::label_targets;

/// Number of feature columns.
pub const N_FEATURES: usize = 10;

/// Column names of [`FeatureSet::values`] and [`FeatureSet::thresholds`], in order.
pub const FEATURE_NAMES: [&str; N_FEATURES] = [
    "fingertip_distance",
    "tcp_rise_fall",
    "object_proximity",
    "object_distance",
    "object_height",
    "tcp_in_object_x",
    "tcp_in_object_y",
    "tcp_in_object_z",
    "object_velocity",
    "hand_velocity",
];

/// The eight features of Table I as column ranges of [`FEATURE_NAMES`] (one HMM per feature:
/// `tcp_in_object` is three-dimensional, the others one-dimensional).
pub const FEATURE_GROUPS: [(&str, std::ops::Range<usize>); 8] = [
    ("fingertip_distance", 0..1),
    ("tcp_rise_fall", 1..2),
    ("object_proximity", 2..3),
    ("object_distance", 3..4),
    ("object_height", 4..5),
    ("tcp_in_object", 5..8),
    ("object_velocity", 8..9),
    ("hand_velocity", 9..10),
];

/// Column index of a feature name, `None` if unknown.
pub fn feature_index(name: &str) -> Option<usize> {
    FEATURE_NAMES.iter().position(|f| *f == name)
}

/// A demonstration on one clock, as the features need it. `n` samples, `k` objects.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Tool centre point `(I + T) / 2`, `n x 3`, metres, world frame with `z` up from the table.
    pub tcp: DMatrix<f64>,
    /// Fingertip distance `|I - T|`, `n`, metres.
    pub opening: DVector<f64>,
    /// Object centres, `k` tracks of `n x 3`, metres.
    pub object_position: Vec<DMatrix<f64>>,
    /// Object orientations, `k` tracks of `n x 4` quaternions `(x, y, z, w)` (normalised here).
    pub object_quaternion: Vec<DMatrix<f64>>,
    /// Box extents in each object's own frame, `k x 3`, metres.
    pub object_size: DMatrix<f64>,
    /// Sample period, seconds.
    pub dt: f64,
}

/// The result of [`compute_features`].
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureSet {
    /// `n x 10` feature values, columns in [`FEATURE_NAMES`] order.
    pub values: DMatrix<f64>,
    /// `n x 10` thresholds of Table I (for `tcp_in_object_*` the half-width of the `+-` band).
    pub thresholds: DMatrix<f64>,
    /// Target object index of each sample.
    pub target: Vec<usize>,
}

impl FeatureSet {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.values.nrows()
    }

    /// True if there are no samples.
    pub fn is_empty(&self) -> bool {
        self.values.nrows() == 0
    }

    /// The values of one named column, `None` if the name is unknown.
    pub fn column(&self, name: &str) -> Option<DVector<f64>> {
        feature_index(name).map(|c| self.values.column(c).into_owned())
    }

    /// Rows `start..end` of the columns of one Table I feature (see [`FEATURE_GROUPS`]), e.g.
    /// the observation sequence of a segment for that feature's HMM.
    pub fn group(&self, feature: usize, start: usize, end: usize) -> Option<DMatrix<f64>> {
        let (_, cols) = FEATURE_GROUPS.get(feature)?;
        if start > end || end > self.len() {
            return None;
        }
        Some(
            self.values
                .view((start, cols.start), (end - start, cols.len()))
                .into_owned(),
        )
    }
}
