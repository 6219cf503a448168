//! The one error type of the crate.

use std::path::PathBuf;

/// Everything that can go wrong in `diffsil`. Each message says what was wrong and what to do.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate {value:?}: every coordinate must be a finite number")]
    NonFiniteVertex {
        /// Index of the offending vertex.
        vertex: usize,
        /// Its coordinates as given.
        value: [f32; 3],
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} uses vertex index {index}, but the mesh has only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Index of the offending triangle.
        triangle: usize,
        /// The out-of-range vertex index.
        index: u32,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// A buffer of per-vertex or per-pixel values has the wrong length.
    #[error("{what}: expected {expected} values, got {got}")]
    LengthMismatch {
        /// What the buffer is.
        what: &'static str,
        /// The length that was needed.
        expected: usize,
        /// The length that was given.
        got: usize,
    },
    /// An image (target, gradient) does not have the size of the rendered view.
    #[error("{what}: expected a {expected_width}x{expected_height} image, got {width}x{height}; resize it to the camera's resolution")]
    SizeMismatch {
        /// What the image is.
        what: &'static str,
        /// Width the view renders at.
        expected_width: u32,
        /// Height the view renders at.
        expected_height: u32,
        /// Width that was given.
        width: u32,
        /// Height that was given.
        height: u32,
    },
    /// A resolution of zero or beyond what the renderer supports.
    #[error("resolution {width}x{height} is not supported: width and height must be between 1 and {max}")]
    InvalidResolution {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// Largest supported side.
        max: u32,
    },
    /// A supersampling factor outside the supported range.
    #[error("supersampling factor {0} is not supported: use 1 (no anti-aliasing) to 16 samples per pixel side")]
    InvalidSupersample(u32),
    /// A camera that cannot form an image.
    #[error("invalid camera: {0}")]
    InvalidCamera(String),
    /// Rendering parameters that are not usable (e.g. non-finite pixel values).
    #[error("invalid settings: {0}")]
    InvalidSettings(String),
    /// Several views and per-view inputs whose counts disagree.
    #[error("{what}: expected one per view ({views}), got {got}")]
    ViewCountMismatch {
        /// What the per-view input is.
        what: &'static str,
        /// Number of views rendered.
        views: usize,
        /// Number given.
        got: usize,
    },
    /// A frame passed to `backward` that cannot be differentiated this way.
    #[error("invalid frame: {0}")]
    InvalidFrame(String),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A mesh or image file could not be parsed or has content this crate does not support.
    #[error("{path}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// No GPU adapter matched the request.
    #[error("no GPU adapter found ({0}); install a Vulkan/Metal/DX12 driver (e.g. `apt-get install mesa-vulkan-drivers` for lavapipe) or use the CPU backend")]
    NoAdapter(String),
    /// A mesh or image exceeds a device limit and cannot be split.
    #[error("the GPU limit `{limit}` is {max}, but this needs {needed}; use a smaller mesh or resolution, or the CPU backend")]
    GpuLimit {
        /// The wgpu limit's name.
        limit: &'static str,
        /// What was needed.
        needed: u64,
        /// What the device allows.
        max: u64,
    },
    /// A render whose per-pixel buffers would exceed the memory budget
    /// ([`MAX_FRAME_BYTES`](crate::MAX_FRAME_BYTES)); refused before anything is allocated.
    #[error(
        "{what} needs {needed} bytes ({:.2} GiB) of coverage masks and images, above the limit of {limit} bytes \
         ({:.2} GiB); lower the resolution, the supersampling factor or the number of views per call",
        *needed as f64 / (1u64 << 30) as f64,
        *limit as f64 / (1u64 << 30) as f64
    )]
    MemoryLimit {
        /// What was asked for (views, largest size, supersampling).
        what: String,
        /// Bytes it would need.
        needed: u64,
        /// The budget, bytes.
        limit: u64,
    },
    /// More views in one GPU call than a GPU frame holds.
    #[error("{views} views were given to the GPU engine, but one GPU frame holds at most {max}; render the views in batches of at most {max}")]
    TooManyViews {
        /// Views given.
        views: usize,
        /// Views one GPU frame holds.
        max: usize,
    },
    /// A batch with no instance.
    #[error("a batch needs at least one instance")]
    EmptyBatch,
    /// An instance of a batch whose mesh does not share the batch's topology.
    #[error("instance {instance} of the batch has another topology than instance 0: every instance must share one `Arc<Topology>`; make the meshes with `Mesh::with_topology(positions, first.topology().clone())`")]
    TopologyMismatch {
        /// The instance.
        instance: usize,
    },
    /// The GPU device reported an error.
    #[error("GPU error: {0}")]
    Gpu(String),
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
