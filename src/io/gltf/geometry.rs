//! Triangle primitives: positions, indices and skin influences, welded.

use glam::Vec3;
use gltf::accessor::Dimensions;
use gltf::mesh::{Mode, Semantic};

use super::accessor::{read_floats, read_indices, read_joints};
use super::Reason;

pub(super) fn is_triangle_mode(mode: Mode) -> bool {
    matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)
}

/// The merged triangle primitives of a mesh, before welding.
#[derive(Default)]
pub(super) struct Geometry {
    pub(super) positions: Vec<Vec3>,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) joints: Vec<[u16; 4]>,
    pub(super) weights: Vec<[f32; 4]>,
    /// Morph target POSITION deltas, per target, per vertex (zeros where a target has none).
    pub(super) targets: Vec<Vec<Vec3>>,
    pub(super) skipped_primitives: usize,
}

/// How the primitives' skin data is checked and remapped: the file's joint count and the map from
/// its joint indices to the skeleton's.
pub(super) struct SkinMap<'a> {
    pub(super) joint_count: usize,
    pub(super) new_index: &'a [u16],
}

pub(super) fn read_geometry(mesh: &gltf::Mesh, buffers: &[Vec<u8>], skin: Option<&SkinMap>) -> Reason<Geometry> {
    let m = mesh.index();
    let mut geometry = Geometry::default();
    let mut target_count = None;
    for primitive in mesh.primitives() {
        let mode = primitive.mode();
        if !is_triangle_mode(mode) {
            geometry.skipped_primitives += 1;
            continue;
        }
        let at = format!("mesh {m} primitive {}", primitive.index());
        let accessor = primitive.get(&Semantic::Positions).ok_or_else(|| format!("{at} has no POSITION attribute"))?;
        let positions: Vec<[f32; 3]> =
            read_floats(&accessor, buffers, &format!("{at} POSITION"), Dimensions::Vec3, false)?;
        if let Some((v, p)) = positions.iter().enumerate().find(|(_, p)| !p.iter().all(|x| x.is_finite())) {
            return Err(format!("{at}: vertex {v} has a non-finite position {p:?}"));
        }
        let count = positions.len();
        let indices = match primitive.indices() {
            Some(accessor) => read_indices(&accessor, buffers, &format!("{at} indices"))?,
            None => (0..count as u32).collect(),
        };
        if let Some((k, bad)) = indices.iter().enumerate().find(|(_, &i)| i as usize >= count) {
            return Err(format!("{at}: index {k} is {bad}, out of range for its {count} vertices"));
        }
        let base = u32::try_from(geometry.positions.len())
            .ok()
            .filter(|&b| u32::try_from(count).is_ok_and(|c| b.checked_add(c).is_some()))
            .ok_or_else(|| format!("{at}: too many vertices for 32-bit indices"))?;
        let corner = |k: usize| indices[k] + base;
        let n = indices.len();
        match mode {
            Mode::TriangleStrip => geometry.triangles.extend((2..n).map(|k| {
                if k % 2 == 0 {
                    [corner(k - 2), corner(k - 1), corner(k)]
                } else {
                    [corner(k - 1), corner(k - 2), corner(k)]
                }
            })),
            Mode::TriangleFan => geometry.triangles.extend((2..n).map(|k| [corner(0), corner(k - 1), corner(k)])),
            _ if n % 3 != 0 => return Err(format!("{at}: {n} triangle indices is not a multiple of 3")),
            _ => geometry.triangles.extend((0..n / 3).map(|t| [corner(3 * t), corner(3 * t + 1), corner(3 * t + 2)])),
        }
        geometry.positions.extend(positions.iter().map(|&p| Vec3::from(p)));
        read_targets(&primitive, buffers, &at, count, &mut target_count, &mut geometry)?;
        if let Some(skin) = skin {
            read_influences(&primitive, buffers, &at, count, skin, &mut geometry)?;
        }
    }
    if geometry.triangles.is_empty() {
        return Err(format!("mesh {m} has no triangles"));
    }
    Ok(geometry)
}

/// Appends one primitive's morph target POSITION deltas (zeros for a target without them). Every
/// triangle primitive of the mesh must have the same number of targets (the glTF rule).
fn read_targets(
    primitive: &gltf::Primitive,
    buffers: &[Vec<u8>],
    at: &str,
    count: usize,
    target_count: &mut Option<usize>,
    geometry: &mut Geometry,
) -> Reason<()> {
    let targets: Vec<_> = primitive.morph_targets().collect();
    let expected = *target_count.get_or_insert(targets.len());
    if targets.len() != expected {
        return Err(format!(
            "{at} has {} morph targets but an earlier primitive of the mesh has {expected}; all must have the same",
            targets.len()
        ));
    }
    geometry.targets.resize_with(expected, Vec::new);
    for (k, target) in targets.iter().enumerate() {
        let out = &mut geometry.targets[k];
        // Earlier primitives' vertices are already in `positions`; keep the tables aligned.
        out.resize(geometry.positions.len() - count, Vec3::ZERO);
        match target.positions() {
            Some(accessor) => {
                let what = format!("{at} morph target {k} POSITION");
                let deltas: Vec<[f32; 3]> = read_floats(&accessor, buffers, &what, Dimensions::Vec3, false)?;
                if deltas.len() != count {
                    return Err(format!("{what}: {} deltas for {count} vertices", deltas.len()));
                }
                if let Some((v, d)) = deltas.iter().enumerate().find(|(_, d)| !d.iter().all(|x| x.is_finite())) {
                    return Err(format!("{what}: vertex {v} has a non-finite delta {d:?}"));
                }
                out.extend(deltas.iter().map(|&d| Vec3::from(d)));
            }
            None => out.resize(geometry.positions.len(), Vec3::ZERO),
        }
    }
    Ok(())
}

/// Reads, checks, renormalises and remaps `JOINTS_0` / `WEIGHTS_0` of one primitive.
fn read_influences(
    primitive: &gltf::Primitive,
    buffers: &[Vec<u8>],
    at: &str,
    count: usize,
    skin: &SkinMap,
    geometry: &mut Geometry,
) -> Reason<()> {
    let missing = |name: &str| format!("{at} has no {name} attribute, but its node has a skin");
    let joints_accessor = primitive.get(&Semantic::Joints(0)).ok_or_else(|| missing("JOINTS_0"))?;
    let weights_accessor = primitive.get(&Semantic::Weights(0)).ok_or_else(|| missing("WEIGHTS_0"))?;
    let joints = read_joints(&joints_accessor, buffers, &format!("{at} JOINTS_0"))?;
    let weights: Vec<[f32; 4]> =
        read_floats(&weights_accessor, buffers, &format!("{at} WEIGHTS_0"), Dimensions::Vec4, true)?;
    if joints.len() != count || weights.len() != count {
        return Err(format!(
            "{at}: {count} positions but {} JOINTS_0 and {} WEIGHTS_0 entries",
            joints.len(),
            weights.len()
        ));
    }
    let mut set = 1;
    while let Some(accessor) = primitive.get(&Semantic::Weights(set)) {
        let what = format!("{at} WEIGHTS_{set}");
        let extra: Vec<[f32; 4]> = read_floats(&accessor, buffers, &what, Dimensions::Vec4, true)?;
        if extra.iter().flatten().any(|&w| w != 0.0) {
            return Err(format!(
                "{what} has non-zero weights: more than 4 joint influences per vertex are not supported"
            ));
        }
        set += 1;
    }
    for (v, (j, w)) in joints.into_iter().zip(weights).enumerate() {
        if w.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(format!("{at}: vertex {v} has skin weights {w:?}; weights must be finite and non-negative"));
        }
        let sum: f32 = w.iter().sum();
        if (sum - 1.0).abs() > 1e-3 {
            return Err(format!("{at}: vertex {v} has skin weights {w:?} summing to {sum}, not 1 (within 1e-3)"));
        }
        let scale = if (sum - 1.0).abs() > 1e-6 { 1.0 / sum } else { 1.0 };
        let mut joint = [0u16; 4];
        for k in 0..4 {
            match skin.new_index.get(usize::from(j[k])) {
                Some(&new) => joint[k] = new,
                None if w[k] == 0.0 => joint[k] = 0,
                None => {
                    return Err(format!(
                        "{at}: vertex {v} uses joint {} but the skin has {} joints",
                        j[k], skin.joint_count
                    ))
                }
            }
        }
        geometry.joints.push(joint);
        geometry.weights.push(w.map(|x| x * scale));
    }
    Ok(())
}

/// Whether two vertices' skin influences agree within `tolerance`, joint by joint (weights of a
/// joint listed twice are added; order does not matter). Welding uses it to count conflicts.
pub(super) fn same_influences(a: ([u16; 4], [f32; 4]), b: ([u16; 4], [f32; 4]), tolerance: f32) -> bool {
    let mut per_joint: Vec<(u16, f32)> = Vec::with_capacity(8);
    for (joints, weights, sign) in [(a.0, a.1, 1.0), (b.0, b.1, -1.0)] {
        for (j, w) in joints.into_iter().zip(weights) {
            match per_joint.iter_mut().find(|(k, _)| *k == j) {
                Some((_, sum)) => *sum += sign * w,
                None => per_joint.push((j, sign * w)),
            }
        }
    }
    per_joint.iter().all(|(_, d)| d.abs() <= tolerance)
}
