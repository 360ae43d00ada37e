//! The components of an actor. Plain data: behaviour lives in systems and kernels.

use crate::math::{Mat3, Quat, Scalar, Vector};
use crate::model::mesh::MeshId;

/// Row of the actor in every per-step array, and its place in output files (scene order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ActorIndex(pub u32);

/// The actor's unique name from the scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Name(pub String);

/// World pose of the centre of mass: `p_world = position + orientation · p_body`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Centre of mass [m].
    pub position: Vector,
    /// Unit quaternion, body → world.
    pub orientation: Quat,
}

impl Pose {
    /// At the origin, unrotated.
    pub const IDENTITY: Self = Self { position: Vector::ZERO, orientation: Quat::IDENTITY };

    /// At `position`, unrotated.
    #[must_use]
    pub fn from_position(position: Vector) -> Self {
        Self { position, orientation: Quat::IDENTITY }
    }

    /// A body-frame point in world coordinates.
    #[must_use]
    pub fn transform_point(&self, p: Vector) -> Vector {
        self.position + self.orientation * p
    }
}

/// World-frame velocities of the centre of mass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Velocity {
    /// Linear velocity [m/s].
    pub linear: Vector,
    /// Angular velocity ω [rad/s], world frame.
    pub angular: Vector,
}

/// Mass and inertia about the centre of mass, body frame, with inverses. A fixed actor keeps
/// its nominal `mass` and `inertia` for output but has zero inverses (docs/physics.md §0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProps {
    /// Mass [kg].
    pub mass: Scalar,
    /// 1/mass [1/kg], 0 when fixed.
    pub inv_mass: Scalar,
    /// Inertia tensor about the centre of mass, body axes [kg·m²].
    pub inertia: Mat3,
    /// Its inverse, zero when fixed [1/(kg·m²)].
    pub inv_inertia: Mat3,
    /// Principal moments [kg·m²] (docs/physics.md §3.4), in the order of `principal_axes`' columns.
    pub principal_moments: Vector,
    /// Rotation P from the principal frame to the body frame: `inertia = P diag(moments) Pᵀ`.
    pub principal_axes: Quat,
}

impl MassProps {
    /// Mass properties of a free body from its mass and body inertia.
    #[must_use]
    pub fn dynamic(mass: Scalar, inertia: Mat3) -> Self {
        Self { inv_mass: 1.0 / mass, inv_inertia: inertia.inverse(), ..Self::fixed(mass, inertia) }
    }

    /// A fixed body: infinite effective mass, but the nominal values are kept for output.
    #[must_use]
    pub fn fixed(mass: Scalar, inertia: Mat3) -> Self {
        let (principal_moments, axes) = crate::model::mass::principal_axes(inertia);
        let principal_axes = Quat::from_mat3(&axes).normalize();
        Self { mass, inv_mass: 0.0, inertia, inv_inertia: Mat3::ZERO, principal_moments, principal_axes }
    }

    /// True for fixed actors.
    #[must_use]
    pub fn is_fixed(&self) -> bool {
        self.inv_mass == 0.0
    }
}

/// Surface properties; a pair uses the mean of its two actors (docs/scenes.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Coefficient of restitution, 0..=1.
    pub restitution: Scalar,
    /// Coulomb friction coefficient, ≥ 0.
    pub friction: Scalar,
}

/// Bounding-sphere radius about the centre of mass [m] (docs/physics.md §1.2, erratum E1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingSphere {
    /// `max |p_body|` over the mesh's vertices [m].
    pub radius: Scalar,
}

/// The actor's convex mesh, shared with every actor of the same shape.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Its place in the simulation's `MeshTable` (the body arrays and exports refer to it).
    pub id: MeshId,
    /// The mesh itself (body frame, about the centre of mass).
    pub shape: std::sync::Arc<crate::model::mesh::ConvexMesh>,
}
