//! What an actor is made of: its components, the convex meshes they share, the built-in
//! shapes, and exact mass properties.

pub mod clusters;
pub mod components;
pub mod mass;
pub mod mesh;
pub mod quickhull;
pub mod shapes;
