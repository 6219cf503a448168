//! The node graph and the skin: joints, rest transforms, inverse bind matrices.

use std::collections::HashMap;

use glam::{Mat4, Quat, Vec3};
use gltf::accessor::Dimensions;
use gltf::scene::Transform;

use super::accessor::read_floats;
use super::Reason;
use crate::pose::skin::{JointRest, Skeleton};

/// The node tree: parents, local matrices and (for TRS nodes) the TRS as written.
pub(super) struct NodeGraph {
    pub(super) parent: Vec<Option<usize>>,
    pub(super) local: Vec<Mat4>,
    pub(super) trs: Vec<Option<JointRest>>,
    pub(super) names: Vec<String>,
}

impl NodeGraph {
    pub(super) fn new(document: &gltf::Document) -> Reason<NodeGraph> {
        let count = document.nodes().len();
        let mut parent = vec![None; count];
        let (mut local, mut trs, mut names) = (Vec::new(), Vec::new(), Vec::new());
        for node in document.nodes() {
            let i = node.index();
            for child in node.children() {
                let c = child.index();
                if c == i || parent[c].is_some() {
                    return Err(format!(
                        "node {c} has more than one parent or is its own child: the node hierarchy must be a tree"
                    ));
                }
                parent[c] = Some(i);
            }
            let (matrix, rest) = match node.transform() {
                Transform::Matrix { matrix } => (Mat4::from_cols_array_2d(&matrix), None),
                Transform::Decomposed { translation, rotation, scale } => {
                    let rest = JointRest {
                        translation: Vec3::from(translation),
                        rotation: unit_quaternion(rotation).ok_or_else(|| {
                            format!("node {i} has a rotation {rotation:?} that is not a unit quaternion")
                        })?,
                        scale: Vec3::from(scale),
                    };
                    (Mat4::from_scale_rotation_translation(rest.scale, rest.rotation, rest.translation), Some(rest))
                }
            };
            if !matrix.is_finite() {
                return Err(format!("node {i} has a non-finite transform"));
            }
            local.push(matrix);
            trs.push(rest);
            names.push(node.name().unwrap_or_default().to_string());
        }
        for start in 0..count {
            let (mut node, mut steps) = (start, 0);
            while let Some(p) = parent[node] {
                node = p;
                steps += 1;
                if steps > count {
                    return Err(format!("the node hierarchy has a cycle through node {start}"));
                }
            }
        }
        Ok(NodeGraph { parent, local, trs, names })
    }

    /// World transform of a node (its local transform under all its ancestors').
    pub(super) fn world(&self, node: usize) -> Mat4 {
        let mut world = self.local[node];
        let mut up = self.parent[node];
        while let Some(p) = up {
            world = self.local[p] * world;
            up = self.parent[p];
        }
        world
    }
}

/// A quaternion normalised if it is off unit length by more than rounding; `None` if it cannot be.
pub(super) fn unit_quaternion(xyzw: [f32; 4]) -> Option<Quat> {
    let q = Quat::from_array(xyzw);
    let length_squared = q.length_squared();
    if !q.is_finite() || length_squared < 1e-12 {
        None
    } else if (length_squared - 1.0).abs() > 1e-6 {
        Some(q.normalize())
    } else {
        Some(q)
    }
}

/// A matrix as translation / rotation / scale, if it has no shear.
pub(super) fn decompose(m: Mat4) -> Option<JointRest> {
    let (scale, rotation, translation) = m.to_scale_rotation_translation();
    let back = Mat4::from_scale_rotation_translation(scale, rotation, translation);
    let magnitude = m.to_cols_array().iter().fold(1.0f32, |a, x| a.max(x.abs()));
    let exact = back.abs_diff_eq(m, 1e-5 * magnitude) && scale.is_finite() && rotation.is_finite();
    exact.then(|| JointRest { translation, rotation: rotation.normalize(), scale })
}

/// The skin's skeleton (joints reordered parents-first) and the map from the file's joint index
/// to the skeleton's.
pub(super) fn read_skin(skin: &gltf::Skin, graph: &NodeGraph, buffers: &[Vec<u8>]) -> Reason<(Skeleton, Vec<u16>)> {
    let s = skin.index();
    let nodes: Vec<usize> = skin.joints().map(|n| n.index()).collect();
    if nodes.is_empty() {
        return Err(format!("skin {s} has no joints"));
    }
    if nodes.len() > 1 << 16 {
        return Err(format!("skin {s} has {} joints; at most 65536 are supported", nodes.len()));
    }
    let mut joint_of_node = HashMap::with_capacity(nodes.len());
    for (k, &node) in nodes.iter().enumerate() {
        if joint_of_node.insert(node, k).is_some() {
            return Err(format!("skin {s} lists node {node} twice among its joints"));
        }
    }
    let accessor = skin.inverse_bind_matrices().ok_or_else(|| {
        format!(
            "skin {s}: missing inverseBindMatrices; the implicit identity matrices the spec allows are not supported \
             (re-export the rig with inverse bind matrices)"
        )
    })?;
    let ibm: Vec<[f32; 16]> =
        read_floats(&accessor, buffers, &format!("skin {s} inverse bind matrices"), Dimensions::Mat4, false)?;
    if ibm.len() < nodes.len() {
        return Err(format!("skin {s} has {} joints but only {} inverse bind matrices", nodes.len(), ibm.len()));
    }
    if ibm.iter().flatten().any(|x| !x.is_finite()) {
        return Err(format!("skin {s} has a non-finite inverse bind matrix"));
    }

    // In the file's joint order: parent joint, rest transform, root transform.
    let mut parents = Vec::with_capacity(nodes.len());
    let mut rest = Vec::with_capacity(nodes.len());
    let mut root_parent = Vec::with_capacity(nodes.len());
    for &node in &nodes {
        // Walk up to the nearest joint, accumulating the non-joint nodes passed on the way.
        let (mut between, mut up, mut parent) = (Mat4::IDENTITY, graph.parent[node], None);
        while let Some(p) = up {
            if let Some(&j) = joint_of_node.get(&p) {
                parent = Some(j);
                break;
            }
            between = graph.local[p] * between;
            up = graph.parent[p];
        }
        let folded = parent.is_some() && between != Mat4::IDENTITY;
        let joint_rest = match graph.trs[node] {
            Some(trs) if !folded => Some(trs),
            _ if folded => decompose(between * graph.local[node]),
            _ => decompose(graph.local[node]),
        };
        let joint_rest = joint_rest.ok_or_else(|| {
            format!(
                "joint node {node} (`{}`): its transform{} has shear or is singular, so it cannot be written as \
                 translation, rotation and scale",
                graph.names[node],
                if folded { ", combined with the non-joint nodes above it," } else { "" }
            )
        })?;
        parents.push(parent);
        rest.push(joint_rest);
        root_parent.push(if parent.is_none() { between } else { Mat4::IDENTITY });
    }

    let order = parents_first(&parents);
    let mut new_index = vec![0u16; nodes.len()];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new as u16;
    }
    let skeleton = Skeleton {
        names: order.iter().map(|&j| graph.names[nodes[j]].clone()).collect(),
        nodes: order.iter().map(|&j| nodes[j]).collect(),
        parents: order.iter().map(|&j| parents[j].map(|p| usize::from(new_index[p]))).collect(),
        rest: order.iter().map(|&j| rest[j]).collect(),
        root_parent: order.iter().map(|&j| root_parent[j]).collect(),
        inverse_bind: order.iter().map(|&j| Mat4::from_cols_array(&ibm[j])).collect(),
    };
    Ok((skeleton, new_index))
}

/// An order of the joints in which parents come before children, keeping the given order where
/// it already is so (a joint is moved only after ancestors that came later).
fn parents_first(parents: &[Option<usize>]) -> Vec<usize> {
    let mut placed = vec![false; parents.len()];
    let mut order = Vec::with_capacity(parents.len());
    for joint in 0..parents.len() {
        let mut chain = Vec::new();
        let mut next = Some(joint);
        while let Some(j) = next.filter(|&j| !placed[j]) {
            chain.push(j);
            next = parents[j];
        }
        for &j in chain.iter().rev() {
            placed[j] = true;
            order.push(j);
        }
    }
    order
}
