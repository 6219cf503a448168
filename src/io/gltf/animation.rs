//! glTF animations: the channels that move the skin's joints, as [`Animation`] clips.

use std::collections::HashMap;
use std::path::Path;

use glam::Mat4;
use gltf::accessor::Dimensions;
use gltf::animation::{Interpolation as GltfInterpolation, Property as GltfProperty};

use super::accessor::read_floats;
use super::container::{load_buffers, parse_document};
use super::geometry::is_triangle_mode;
use super::read::LoadOptions;
use super::skin::{decompose, read_skin, NodeGraph};
use super::Reason;
use crate::pose::skin::{AnimatedNode, Animation, Channel, Interpolation, Property, Skeleton};
use crate::{Error, Result};

/// Loads every animation of a glTF / GLB file as clips over the skeleton that
/// [`load_gltf`](super::load_gltf) returns for the same file (the skin of the node holding the
/// first triangle mesh; the clips' joint indices are that skeleton's).
///
/// Rotation, translation and scale channels on the skin's joints are kept with their
/// interpolation (`STEP`, `LINEAR`, `CUBICSPLINE`); channels on other nodes and morph-weight
/// channels are skipped and counted in [`Animation::ignored_other_channels`]. A clip keeps its
/// place (and name) even when all its channels are skipped. Errors: [`Error::Io`], and [`Error::Format`]
/// when the file has no skinned mesh or an animation is malformed (times not increasing or not
/// finite, value counts that do not match the keys, unsupported accessor types).
///
/// The file is read under [`LoadOptions::default`]'s limits, as [`load_gltf`](super::load_gltf)
/// reads it; [`load_animations_with_options`] takes other limits.
pub fn load_animations(path: impl AsRef<Path>) -> Result<Vec<Animation>> {
    load_animations_with_options(path, &LoadOptions::default())
}

/// [`load_animations`] under the given limits (which buffers may be read, and how large).
pub fn load_animations_with_options(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Vec<Animation>> {
    let path = path.as_ref();
    let bytes = crate::io::read_regular_file(path, options.max_file_bytes, "a glTF or GLB file", super::read::TRUSTED)?;
    let format = |reason: String| Error::Format { path: path.to_path_buf(), reason };
    let (document, blob) = parse_document(&bytes).map_err(format)?;
    let buffers = load_buffers(&document, path, blob, options)?;
    check_animation_json(document.as_json()).map_err(format)?;
    // The `gltf` crate unwraps fields that validation left unchecked in places; the check above
    // covers the ones known (paths, interpolations, indices). Any other panic in it is caught and
    // reported as an invalid file rather than taking the caller down.
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read_animations(&document, &buffers))) {
        Ok(result) => result.map_err(format),
        Err(_) => Err(format("not a valid glTF file: an animation failed validation".into())),
    }
}

/// Checks what [`read_animations`] reaches through the `gltf` crate's unchecked accessors: every
/// channel's target path and every sampler's interpolation are known values, and every index a
/// channel or sampler holds (sampler, node, input and output accessors) is in range.
fn check_animation_json(root: &gltf::json::Root) -> Reason<()> {
    use gltf::json::validation::Checked;
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            if channel.sampler.value() >= animation.samplers.len() || channel.target.node.value() >= root.nodes.len() {
                return Err(format!("animation {a}, channel {c}: its sampler or node index is out of range"));
            }
            if !matches!(channel.target.path, Checked::Valid(_)) {
                return Err(format!("animation {a}, channel {c}: its target path is not one glTF defines"));
            }
        }
        for (k, sampler) in animation.samplers.iter().enumerate() {
            if sampler.input.value() >= root.accessors.len() || sampler.output.value() >= root.accessors.len() {
                return Err(format!("animation {a}, sampler {k}: its input or output accessor is out of range"));
            }
            if !matches!(sampler.interpolation, Checked::Valid(_)) {
                return Err(format!(
                    "animation {a}, sampler {k}: its interpolation is not STEP, LINEAR or CUBICSPLINE"
                ));
            }
        }
    }
    Ok(())
}

fn read_animations(document: &gltf::Document, buffers: &[Vec<u8>]) -> Reason<Vec<Animation>> {
    let mesh = document
        .meshes()
        .find(|m| m.primitives().any(|p| is_triangle_mode(p.mode())))
        .ok_or("the file has no triangle mesh")?;
    let skin = document
        .nodes()
        .find(|n| n.mesh().is_some_and(|m| m.index() == mesh.index()))
        .and_then(|n| n.skin())
        .ok_or("the file's mesh has no skin, so its animations move no skeleton")?;
    let graph = NodeGraph::new(document)?;
    let (skeleton, new_index) = read_skin(&skin, &graph, buffers)?;
    let joint_of_node: HashMap<usize, usize> =
        skin.joints().enumerate().map(|(k, node)| (node.index(), usize::from(new_index[k]))).collect();
    let nodes = animated_nodes(&skeleton, &skin, &graph, &joint_of_node)?;
    document.animations().map(|animation| read_animation(&animation, buffers, &joint_of_node, &nodes)).collect()
}

/// Per skeleton joint: the node's own TRS and the non-joint transforms between it and its parent
/// joint (folded into the skeleton's rest transform, so an animated node is folded the same way).
fn animated_nodes(
    skeleton: &Skeleton,
    skin: &gltf::Skin,
    graph: &NodeGraph,
    joint_of_node: &HashMap<usize, usize>,
) -> Reason<Vec<AnimatedNode>> {
    let mut nodes = vec![AnimatedNode { node_rest: Default::default(), above: Mat4::IDENTITY }; skeleton.joint_count()];
    for joint_node in skin.joints() {
        let node = joint_node.index();
        let (mut between, mut up, mut has_parent) = (Mat4::IDENTITY, graph.parent[node], false);
        while let Some(p) = up {
            if joint_of_node.contains_key(&p) {
                has_parent = true;
                break;
            }
            between = graph.local[p] * between;
            up = graph.parent[p];
        }
        let node_rest = graph.trs[node]
            .or_else(|| decompose(graph.local[node]))
            .ok_or_else(|| format!("joint node {node}: its matrix has shear"))?;
        let above = if has_parent { between } else { Mat4::IDENTITY };
        nodes[joint_of_node[&node]] = AnimatedNode { node_rest, above };
    }
    Ok(nodes)
}

fn read_animation(
    animation: &gltf::Animation,
    buffers: &[Vec<u8>],
    joint_of_node: &HashMap<usize, usize>,
    nodes: &[AnimatedNode],
) -> Reason<Animation> {
    let a = animation.index();
    let mut clip = Animation {
        name: animation.name().map_or_else(|| format!("animation_{a}"), str::to_string),
        channels: Vec::new(),
        nodes: nodes.to_vec(),
        duration: 0.0,
        ignored_other_channels: 0,
    };
    for channel in animation.channels() {
        let at = format!("animation {a} (`{}`) channel {}", clip.name, channel.index());
        let target = channel.target();
        let Some(&joint) = joint_of_node.get(&target.node().index()) else {
            clip.ignored_other_channels += 1;
            continue;
        };
        let (property, dimensions) = match target.property() {
            GltfProperty::Rotation => (Property::Rotation, Dimensions::Vec4),
            GltfProperty::Translation => (Property::Translation, Dimensions::Vec3),
            GltfProperty::Scale => (Property::Scale, Dimensions::Vec3),
            GltfProperty::MorphTargetWeights => {
                clip.ignored_other_channels += 1;
                continue;
            }
        };
        let sampler = channel.sampler();
        let interpolation = match sampler.interpolation() {
            GltfInterpolation::Step => Interpolation::Step,
            GltfInterpolation::Linear => Interpolation::Linear,
            GltfInterpolation::CubicSpline => Interpolation::CubicSpline,
        };
        let times: Vec<[f32; 1]> =
            read_floats(&sampler.input(), buffers, &format!("{at} input (times)"), Dimensions::Scalar, false)?;
        let times: Vec<f32> = times.into_iter().map(|[t]| t).collect();
        let what = format!("{at} output (values)");
        let values: Vec<[f32; 4]> = match dimensions {
            Dimensions::Vec4 => read_floats(&sampler.output(), buffers, &what, dimensions, true)?,
            _ => read_floats::<3>(&sampler.output(), buffers, &what, dimensions, false)?
                .into_iter()
                .map(|[x, y, z]| [x, y, z, 0.0])
                .collect(),
        };
        let channel = Channel { joint, property, interpolation, times, values };
        // The checks of `Animation::validate`, reported with the file's names.
        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        if channel.times.is_empty() || channel.values.len() != per_key * channel.times.len() {
            return Err(format!(
                "{at}: {} key times but {} values ({per_key} per key expected for {interpolation:?})",
                channel.times.len(),
                channel.values.len()
            ));
        }
        if channel.times.iter().any(|t| !t.is_finite()) || channel.times.windows(2).any(|w| w[1] <= w[0]) {
            return Err(format!("{at}: key times must be finite and strictly increasing"));
        }
        if channel.values.iter().flatten().any(|v| !v.is_finite()) {
            return Err(format!("{at}: a key value is not finite"));
        }
        if property == Property::Rotation
            && channel.values.iter().skip(per_key / 2).step_by(per_key).any(|q| q.iter().all(|&x| x == 0.0))
        {
            return Err(format!("{at}: a rotation key is the zero quaternion"));
        }
        clip.duration = clip.duration.max(*channel.times.last().unwrap_or(&0.0));
        clip.channels.push(channel);
    }
    Ok(clip)
}
