//! What is rendered, and from where: meshes and their shared topology, cameras, images, and a few
//! built-in shapes. Plain data with validation; nothing here renders.

pub mod camera;
pub mod image;
pub mod mesh;
pub mod orbit;
pub mod shapes;
