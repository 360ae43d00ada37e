//! Collision geometry the detection systems share: meshes posed in the world, contacts and
//! candidate pairs, and the clipped manifolds that resting contact holds.

pub mod boxes;
pub mod contact;
pub mod gjk;
pub mod hull;
pub mod manifold;
pub mod planes;
pub mod posed;
pub mod toi;
