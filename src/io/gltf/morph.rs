//! Morph target names (`mesh.extras.targetNames`) and joint offsets
//! (`skins[0].extras.morphJointOffsets`), from the JSON extras.

use glam::Vec3;
use gltf::json::Value;

use super::Reason;

/// The `extras` object of a glTF object, parsed; `None` when absent.
fn extras(raw: &gltf::json::Extras) -> Reason<Option<Value>> {
    raw.as_ref()
        .map(|raw| gltf::json::deserialize::from_str::<Value>(raw.get()).map_err(|e| format!("invalid extras: {e}")))
        .transpose()
}

/// The names of a mesh's `count` morph targets: `extras.targetNames` when it is a list of
/// `count` strings, `target_k` otherwise.
pub(super) fn target_names(mesh: &gltf::Mesh, count: usize) -> Reason<Vec<String>> {
    let extras = extras(mesh.extras()).map_err(|e| format!("mesh {}: {e}", mesh.index()))?;
    let names: Option<Vec<String>> = extras
        .as_ref()
        .and_then(|e| e.get("targetNames"))
        .and_then(Value::as_array)
        .filter(|list| list.len() == count)
        .and_then(|list| list.iter().map(|v| v.as_str().map(str::to_string)).collect());
    Ok(names.unwrap_or_else(|| (0..count).map(|k| format!("target_{k}")).collect()))
}

/// The skin's `extras.morphJointOffsets` (target name → one `[x, y, z]` per joint of the skin, in
/// the file's joint order) as one list per target in the skeleton's joint order (`new_index` maps
/// the file's joint index to the skeleton's). `None` when the skin has no such extras; a target
/// the map does not name gets zero offsets; names of no target are ignored.
pub(super) fn joint_offsets(skin: &gltf::Skin, names: &[String], new_index: &[u16]) -> Reason<Option<Vec<Vec<Vec3>>>> {
    let s = skin.index();
    let extras = extras(skin.extras()).map_err(|e| format!("skin {s}: {e}"))?;
    let Some(map) = extras.as_ref().and_then(|e| e.get("morphJointOffsets")) else {
        return Ok(None);
    };
    let map = map.as_object().ok_or_else(|| format!("skin {s}: extras.morphJointOffsets is not an object"))?;
    let joint_count = new_index.len();
    let mut offsets = vec![vec![Vec3::ZERO; joint_count]; names.len()];
    for (k, name) in names.iter().enumerate() {
        let Some(list) = map.get(name) else { continue };
        let what = format!("skin {s}: extras.morphJointOffsets.{name}");
        let list = list.as_array().filter(|l| l.len() == joint_count).ok_or_else(|| {
            format!("{what} must be a list of {joint_count} [x, y, z] offsets, one per joint of the skin")
        })?;
        for (file_joint, entry) in list.iter().enumerate() {
            let xyz: Option<Vec<f32>> = entry
                .as_array()
                .filter(|a| a.len() == 3)
                .and_then(|a| a.iter().map(|x| x.as_f64().map(|x| x as f32)).collect());
            let xyz = xyz
                .filter(|v| v.iter().all(|x| x.is_finite()))
                .ok_or_else(|| format!("{what}[{file_joint}] is not a finite [x, y, z]"))?;
            offsets[k][usize::from(new_index[file_joint])] = Vec3::new(xyz[0], xyz[1], xyz[2]);
        }
    }
    Ok(Some(offsets))
}
