//! Poses and shapes as JSON text.

use glam::Vec3;
use gltf::json::Value;

use super::Pose;
use crate::{Error, Result};

/// The `format` field of the JSON [`Pose::to_json`] writes.
pub const POSE_JSON_FORMAT: &str = "diffsil-pose-1";

fn vec3(v: Vec3) -> Value {
    Value::from(v.to_array().map(f64::from).to_vec())
}

impl Pose {
    /// The pose and shape coefficients as a JSON object:
    ///
    /// ```text
    /// {"format": "diffsil-pose-1",
    ///  "joint_rotations": [[x, y, z], …],      axis–angle per joint, radians
    ///  "joint_translations": [[x, y, z], …],   only when the pose has them
    ///  "joint_scales": [[x, y, z], …],         only when the pose has them
    ///  "orientation": [x, y, z], "translation": [x, y, z],
    ///  "betas": [β_0, …]}                      shape coefficients (may be empty)
    /// ```
    ///
    /// Numbers are written so that [`Pose::from_json`] reads back the same `f32` values.
    pub fn to_json(&self, betas: &[f32]) -> String {
        let mut object = Value::Object(Default::default());
        if let Value::Object(map) = &mut object {
            map.insert("format".into(), Value::from(POSE_JSON_FORMAT));
            map.insert(
                "joint_rotations".into(),
                Value::from(self.joint_rotations.iter().map(|&r| vec3(r)).collect::<Vec<_>>()),
            );
            if self.has_joint_translations() {
                let list: Vec<Value> = self.joint_translations.iter().map(|&t| vec3(t)).collect();
                map.insert("joint_translations".into(), Value::from(list));
            }
            if self.has_joint_scales() {
                let list: Vec<Value> = self.joint_scales.iter().map(|&s| vec3(s)).collect();
                map.insert("joint_scales".into(), Value::from(list));
            }
            map.insert("orientation".into(), vec3(self.orientation));
            map.insert("translation".into(), vec3(self.translation));
            map.insert("betas".into(), Value::from(betas.iter().map(|&b| f64::from(b)).collect::<Vec<_>>()));
        }
        gltf::json::serialize::to_string_pretty(&object).unwrap_or_default()
    }

    /// Reads what [`Pose::to_json`] writes: the pose (checked with [`Pose::validate`] against its
    /// own joint count) and the shape coefficients. Errors ([`Error::InvalidSettings`]) name the
    /// field that is missing or malformed.
    pub fn from_json(text: &str) -> Result<(Pose, Vec<f32>)> {
        let bad = |why: String| Error::InvalidSettings(format!("pose JSON: {why}"));
        let value: Value = gltf::json::deserialize::from_str(text).map_err(|e| bad(format!("not JSON: {e}")))?;
        let format = value.get("format").and_then(Value::as_str);
        if format != Some(POSE_JSON_FORMAT) {
            return Err(bad(format!("`format` is {format:?}, expected \"{POSE_JSON_FORMAT}\"")));
        }
        let number = |v: &Value, field: &str| -> Result<f32> {
            v.as_f64()
                .map(|x| x as f32)
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("`{field}` holds {v}, not a finite number")))
        };
        let triple = |v: &Value, field: &str| -> Result<Vec3> {
            let list = v
                .as_array()
                .filter(|l| l.len() == 3)
                .ok_or_else(|| bad(format!("`{field}` holds {v}, not [x, y, z]")))?;
            Ok(Vec3::new(number(&list[0], field)?, number(&list[1], field)?, number(&list[2], field)?))
        };
        let list = |field: &str, required: bool| -> Result<Vec<Value>> {
            match value.get(field) {
                Some(v) => v.as_array().cloned().ok_or_else(|| bad(format!("`{field}` is not a list"))),
                None if required => Err(bad(format!("`{field}` is missing"))),
                None => Ok(Vec::new()),
            }
        };
        let field = |name: &str| value.get(name).ok_or_else(|| bad(format!("`{name}` is missing")));
        let pose = Pose {
            joint_rotations: list("joint_rotations", true)?
                .iter()
                .map(|v| triple(v, "joint_rotations"))
                .collect::<Result<_>>()?,
            joint_translations: list("joint_translations", false)?
                .iter()
                .map(|v| triple(v, "joint_translations"))
                .collect::<Result<_>>()?,
            joint_scales: list("joint_scales", false)?
                .iter()
                .map(|v| triple(v, "joint_scales"))
                .collect::<Result<_>>()?,
            orientation: triple(field("orientation")?, "orientation")?,
            translation: triple(field("translation")?, "translation")?,
        };
        pose.validate(pose.joint_count())?;
        let betas = list("betas", false)?.iter().map(|v| number(v, "betas")).collect::<Result<_>>()?;
        Ok((pose, betas))
    }
}
