//! glTF 2.0 meshes: loading static and skinned meshes (with morph targets) and skeletal animations
//! from `.gltf` / `.glb`, and writing skinned and posed meshes as `.glb`.
//!
//! # What [`load_gltf`] reads
//!
//! - **The mesh**: the first mesh (in file order) with a triangle primitive. All its triangle
//!   primitives are merged into one mesh; `TRIANGLE_STRIP` and `TRIANGLE_FAN` primitives are
//!   converted to triangles, `POINTS` and `LINE*` primitives are skipped (counted in
//!   [`LoadInfo::skipped_primitives`]). Attributes read: `POSITION` (float), indices (unsigned
//!   byte, short or int; none = sequential), and for a skinned mesh `JOINTS_0` (unsigned byte or
//!   short) and `WEIGHTS_0` (float, or normalized unsigned byte or short). Normals, texture
//!   coordinates, materials and images are ignored; animations are read by [`load_animations`].
//! - **Morph targets** (skinned meshes only; a static mesh is read without them): each target's
//!   `POSITION` deltas (float; a target without them is all zero), every triangle primitive
//!   having the same number of targets. Names come from `mesh.extras.targetNames` (`target_k`
//!   when absent). Per-joint offsets that make the joints follow the shape come from
//!   `skins[k].extras.morphJointOffsets` (an object mapping a target name to one `[x, y, z]`
//!   world displacement per skin joint, in the skin's joint order, per unit weight), when the
//!   file has it; otherwise the joints stay put when the shape changes. The mesh's default
//!   `weights` are not applied: `β = 0` is the base mesh as stored. See
//!   [`MorphTargets`](crate::pose::skin::MorphTargets).
//! - **The node**: the first node (in file order) that instantiates that mesh. If it has a skin the
//!   result is [`Model::Skinned`], otherwise [`Model::Static`].
//! - **Static meshes** get the node's world transform (its own and its ancestors') applied to the
//!   positions. A mesh no node instantiates is read as is.
//! - **Skinned meshes** keep the bind-pose positions as stored; the mesh node's own transform (and
//!   its ancestors') is ignored, as the glTF spec says for skinned meshes. The skeleton is the
//!   skin's joints with:
//!   - a joint's parent = its nearest ancestor node that is also a joint of the skin; joints are
//!     reordered so parents come before children (keeping the file's order where it already is),
//!     and `JOINTS_0` is remapped to the new order;
//!   - rest translation / rotation / scale = the joint node's TRS (a `matrix` is decomposed, and a
//!     matrix with shear is rejected). Non-joint nodes *between* a joint and its parent joint have
//!     their transform folded into the child's rest transform;
//!   - `root_parent` of a root joint = world transform of its non-joint ancestors;
//!   - inverse bind matrices from `inverseBindMatrices`. A skin without them is **rejected**: the
//!     spec allows implicit identity matrices, but a real rig always has them and a missing
//!     accessor is far more often a broken export.
//!   - Weights must be finite, non-negative and sum to 1 within 1e-3; they are renormalised when
//!     the sum is off by more than 1e-6 (so already-normalised weights come back bit-exact). A
//!     zero-weight influence whose joint index is out of range gets joint 0; a non-zero one is an
//!     error. Non-zero `WEIGHTS_1` (more than 4 influences) is rejected.
//! - **Welding**: exporters split vertices at UV and normal seams. Silhouette rendering needs one
//!   vertex per position (a split seam is an open boundary, i.e. a false silhouette edge), so
//!   vertices with exactly equal positions are merged, keeping the order of first occurrences
//!   (like [`crate::io::weld_by_position`]). A merged vertex keeps the skin influences of its first
//!   occurrence; duplicates whose influences differ from it by more than 1e-4 (per joint) are
//!   counted in [`LoadInfo::weight_conflicts`]. A merged vertex also keeps the morph deltas of its
//!   first occurrence.
//! - **Joint identity**: each joint keeps its node's name ([`Skeleton::names`]) and node index
//!   ([`Skeleton::nodes`]).
//!
//! # Errors
//!
//! [`Error::Io`](crate::Error::Io) when the file (or an external buffer file) cannot be read; [`Error::Format`](crate::Error::Format),
//! naming the file and what is wrong, for anything malformed or unsupported: not glTF, truncated
//! GLB, invalid JSON or glTF structure, required extensions that change geometry
//! (`KHR_draco_mesh_compression`, `KHR_mesh_quantization`, `EXT_meshopt_compression`, …), sparse
//! accessors, accessors that overrun their buffers, indices out of range, non-finite positions,
//! no triangles, bad weights, a skin without inverse bind matrices. Nothing panics on bad input.
//!
//! # Writing
//!
//! [`save_glb`] writes a [`SkinnedMesh`] (with its morph targets and joint offsets) as a
//! self-contained GLB 2.0 that [`load_gltf`] (and other glTF tools) read back to the same data; [`save_mesh_glb`] writes a
//! static mesh, such as a posed, shaped body.

mod accessor;
mod animation;
mod bytes;
mod container;
mod geometry;
mod morph;
mod read;
mod skin;
mod write;
mod write_mesh;

pub use animation::load_animations;
pub use bytes::load_gltf_bytes;
pub use read::{load_gltf, load_gltf_with_info, load_mesh};
pub use write::save_glb;
pub use write_mesh::save_mesh_glb;

#[cfg(doc)]
use crate::pose::skin::Skeleton;
use crate::pose::skin::SkinnedMesh;
use crate::Mesh;

/// Inner results carry the reason only; the public functions add the path.
type Reason<T> = std::result::Result<T, String>;

/// What [`load_gltf`] found in a glTF file.
// One value per loaded file: boxing the skinned variant would only make matching on it clumsier.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Model {
    /// A mesh whose node has no skin, in world space (the node's world transform is applied).
    Static(Mesh),
    /// A skinned mesh: bind-pose positions as stored, its skeleton and per-vertex influences.
    Skinned(SkinnedMesh),
}

impl Model {
    /// The mesh: world-space positions for [`Model::Static`], bind-pose positions (as stored in
    /// the file, before skinning) for [`Model::Skinned`].
    pub fn mesh(&self) -> &Mesh {
        match self {
            Model::Static(mesh) => mesh,
            Model::Skinned(skinned) => &skinned.mesh,
        }
    }
}

/// Facts about one [`load_gltf_with_info`] call, for reports and diagnostics.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadInfo {
    /// Index of the mesh that was read.
    pub mesh: usize,
    /// Its name, if it has one.
    pub mesh_name: Option<String>,
    /// Index of the node that instantiates it (`None` if no node does).
    pub node: Option<usize>,
    /// Vertices over the merged triangle primitives, before welding.
    pub file_vertices: usize,
    /// Vertices after welding equal positions.
    pub welded_vertices: usize,
    /// Triangles (after converting strips and fans).
    pub triangles: usize,
    /// Duplicate vertices whose skin influences differed from the kept first occurrence by more
    /// than 1e-4; always 0 for a static mesh.
    pub weight_conflicts: usize,
    /// Primitives of the mesh that were skipped because they are points or lines.
    pub skipped_primitives: usize,
}
