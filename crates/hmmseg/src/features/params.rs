//! Configuration of the feature computation and target-object labelling (serde, JSON).

use serde::{Deserialize, Serialize};

use crate::error::{EngineError, Result};

/// Which dimension of an object's bounding box is the `d_i` of Table I.
///
/// `d_i` enters the fingertip-distance threshold `d_i + gamma`, the proximity threshold
/// `d_i / 2 + gamma` and the object-distance threshold `d_i`. (The TCP-in-object thresholds use
/// the box extent along each object axis instead, see [`crate::features::compute_features`].)
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SizeMeasure {
    /// `max(size_x, size_y)`: the largest horizontal extent in the object frame (default). A hand
    /// opened wider than this can enclose the object from any approach direction.
    #[default]
    MaxHorizontal,
    /// `min(size_x, size_y)`: the narrowest grasp width.
    MinHorizontal,
    /// `max(size_x, size_y, size_z)`: the largest extent.
    Max,
}

crate::option_enum!(SizeMeasure, "size_measure", [
    MaxHorizontal => "max_horizontal",
    MinHorizontal => "min_horizontal",
    Max => "max",
]);

impl SizeMeasure {
    /// `d_i` of a box with extents `size = [x, y, z]` in its own frame.
    pub fn of(self, size: [f64; 3]) -> f64 {
        match self {
            Self::MaxHorizontal => size[0].max(size[1]),
            Self::MinHorizontal => size[0].min(size[1]),
            Self::Max => size[0].max(size[1]).max(size[2]),
        }
    }
}

/// Parameters of the eight features of Table I and of [`crate::features::label_targets`].
///
/// All lengths are in metres, speeds in metres per second, durations in seconds. Missing JSON
/// fields take their defaults; unknown fields are an error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FeatureParams {
    /// The small offset `gamma` of Table I (default 0.02 m).
    pub gamma: f64,
    /// The velocity threshold `v_th` of Table I for the object and hand speeds, also the speed
    /// above which an object counts as moving when labelling targets (default 0.05 m/s: above
    /// tracking noise after low-pass filtering, well below a human reaching motion of 0.3-1 m/s).
    pub v_th: f64,
    /// Which box dimension is `d_i` (default: the largest horizontal extent).
    pub size_measure: SizeMeasure,
    /// Object motions (speed above `v_th`) shorter than this are ignored as noise when labelling
    /// targets and when finding an object's resting height (default 0.1 s).
    pub min_motion_s: f64,
    /// Hysteresis of the approaches used in target labelling: minima of the hand's clearance
    /// from the nearest object must be flanked by changes of more than this (default 0.05 m).
    pub approach_margin: f64,
    /// The hand dwells near an object (e.g. locate) where its clearance `|TCP - p| - d / 2`
    /// from the nearest object is at most this (default 0.15 m)...
    pub approach_radius: f64,
    /// ... and it is slower than this (default 0.1 m/s).
    pub dwell_speed: f64,
    /// The object-distance feature of a scene with a single object, where no other object
    /// exists (default 1.0 m: "far away", keeps the feature finite).
    pub lone_object_distance: f64,
}

impl Default for FeatureParams {
    fn default() -> Self {
        Self {
            gamma: 0.02,
            v_th: 0.05,
            size_measure: SizeMeasure::MaxHorizontal,
            min_motion_s: 0.1,
            approach_margin: 0.05,
            approach_radius: 0.15,
            dwell_speed: 0.1,
            lone_object_distance: 1.0,
        }
    }
}

impl FeatureParams {
    /// Parse from JSON (missing fields take defaults) and validate. Text that is not a JSON
    /// object is an [`EngineError::Format`] error; an unknown field, a wrong type or a bad
    /// value (e.g. an unknown `size_measure`) is an [`EngineError::InvalidParameter`] error.
    pub fn from_json(text: &str) -> Result<Self> {
        let mut de = serde_json::Deserializer::from_str(text);
        let p: Self = serde_path_to_error::deserialize(&mut de).map_err(|e| {
            // the message names the field: `feature parameter size_measure: unknown variant ...`
            let path = e.path().to_string();
            let inner = e.into_inner();
            let msg = if path == "." {
                format!("feature parameters: {inner}")
            } else {
                format!("feature parameter {path}: {inner}")
            };
            if inner.classify() == serde_json::error::Category::Data {
                EngineError::InvalidParameter(msg)
            } else {
                EngineError::Format(msg)
            }
        })?;
        de.end()
            .map_err(|e| EngineError::Format(format!("feature parameters: {e}")))?;
        p.validate()?;
        Ok(p)
    }

    /// Serialise to JSON.
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(self)
            .map_err(|e| EngineError::Format(format!("feature parameters: {e}")))
    }

    /// Check that every value is finite and in range.
    pub fn validate(&self) -> Result<()> {
        let checks = [
            ("gamma", self.gamma, self.gamma >= 0.0),
            ("v_th", self.v_th, self.v_th > 0.0),
            ("min_motion_s", self.min_motion_s, self.min_motion_s >= 0.0),
            (
                "approach_margin",
                self.approach_margin,
                self.approach_margin > 0.0,
            ),
            (
                "lone_object_distance",
                self.lone_object_distance,
                self.lone_object_distance > 0.0,
            ),
        ];
        for (name, value, ok) in checks {
            if !value.is_finite() || !ok {
                return Err(EngineError::InvalidParameter(format!(
                    "feature parameter {name} = {value} is out of range"
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_roundtrip_and_defaults() {
        let p = FeatureParams::from_json(r#"{"gamma": 0.03, "size_measure": "max"}"#).unwrap();
        assert!((p.gamma - 0.03).abs() < 1e-15);
        assert_eq!(p.size_measure, SizeMeasure::Max);
        assert!((p.v_th - 0.05).abs() < 1e-15);
        assert_eq!(FeatureParams::from_json(&p.to_json().unwrap()).unwrap(), p);
    }

    #[test]
    fn rejects_bad_values() {
        assert!(matches!(
            FeatureParams::from_json(r#"{"gama": 1}"#),
            Err(EngineError::InvalidParameter(_))
        ));
        assert!(matches!(
            FeatureParams::from_json(r#"{"size_measure": "widest"}"#),
            Err(EngineError::InvalidParameter(_))
        ));
        assert!(matches!(
            FeatureParams::from_json(r#"{"gamma": "#),
            Err(EngineError::Format(_))
        ));
        assert!(matches!(
            FeatureParams::from_json(r#"{"v_th": 0}"#),
            Err(EngineError::InvalidParameter(_))
        ));
        let p = FeatureParams {
            gamma: f64::NAN,
            ..FeatureParams::default()
        };
        assert!(p.validate().is_err());
    }

    #[test]
    fn size_measures() {
        let s = [0.04, 0.06, 0.1];
        assert!((SizeMeasure::MaxHorizontal.of(s) - 0.06).abs() < 1e-15);
        assert!((SizeMeasure::MinHorizontal.of(s) - 0.04).abs() < 1e-15);
        assert!((SizeMeasure::Max.of(s) - 0.1).abs() < 1e-15);
    }
}
