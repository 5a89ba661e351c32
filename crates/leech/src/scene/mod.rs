//! Scenes: the rigid surroundings a robot climbs on (floors, walls, steps,
//! thin walls, ceilings), and the geometric queries a contact solver asks.
//!
//! ## Rules and units
//!
//! * Lengths in m, angles in rad counter-clockwise from +x. World x is
//!   horizontal, y points up (gravity acts along -y, as in [`crate::robot`]).
//! * A scene is a union of solids; free space is everything else. Solids may
//!   overlap.
//! * [`Solid::HalfPlane`]: everything behind the line through `point_m` with
//!   unit outward `normal` is solid; the normal points into free space.
//! * [`Solid::Polygon`]: a simple polygon (no crossing or touching edges),
//!   vertices counter-clockwise, convex or concave, solid inside. Edge `i` runs
//!   from vertex `i` to vertex `i + 1`, the last edge back to vertex 0; the
//!   inside is on the left of each edge, so its outward normal is on its right.
//! * Normals are outward: out of the solid, into free space. Signed distances
//!   are positive in free space and negative inside a solid.
//! * The surface direction at a point is the tangent with free space on its
//!   left: the outward normal is the tangent turned a quarter turn
//!   counter-clockwise. On a floor it is 0 (+x), on a wall whose free side is
//!   -x it is pi/2 (up), on a ceiling pi (-x). This matches the robot file's
//!   `base_angle_deg` (0 along a floor, 90 up a wall): a suction cup placed
//!   with this angle faces the surface from the free side.
//! * Join a polygon to a floor (or to another solid) by burying its base in
//!   it, not by letting the two share a face: inside a solid the depth is
//!   measured to that solid's own boundary, and a shared face would be an
//!   internal boundary that depth and normals could point through.
//!
//! ## Files
//!
//! Scene files are TOML ([`Scene::from_toml_str`]); unknown keys are errors and
//! every value is checked (one-line [`InputError`]s naming the field, the value
//! and what is allowed):
//!
//! ```
//! use leech::scene::Scene;
//! let scene = Scene::from_toml_str(r#"
//! name = "thin wall"
//! [start]                   # optional: where the robot starts by default
//! rear_cup_m = [0.0, 0.0]   # the centre of the rear cup's face, on a surface
//! direction_deg = 0.0       # the clamp direction; the cups lie to its right
//! [[half_plane]]            # everything behind the line is solid
//! point_m = [0.0, 0.0]
//! normal = [0.0, 1.0]       # unit outward normal, into free space
//! [[polygon]]               # a convex or concave solid, vertices counter-clockwise
//! points_m = [[0.30, -0.05], [0.32, -0.05], [0.32, 0.25], [0.30, 0.25]]
//! "#, "example").unwrap();
//! let (d, _, normal, _) = scene.signed_distance([0.29, 0.1]);
//! assert!((d - 0.01).abs() < 1e-12 && normal == [-1.0, 0.0]);
//! assert_eq!(scene.start.unwrap().rear_cup_m, [0.0, 0.0]);
//! ```
//!
//! Built-in scenes ([`Scene::builtin`], [`BUILTIN_SCENES`]) are such files,
//! under `crates/leech/scenes/`. 3D scene files (half-spaces and boxes for
//! the 3D body) are read by [`SceneFile3`].

mod builtin;
pub(crate) mod file;
mod file3;
mod query;
mod solid;
mod solid3;

pub use builtin::{BuiltinScene, BUILTIN_SCENES};
pub use file3::{is_scene3, SceneFile3, Start3};
pub use query::{Candidate, Corner, Overlap};
pub use solid::Solid;
pub use solid3::{Plane3, Scene3, Solid3};

use crate::error::InputError;

/// Most solids in one scene.
pub const MAX_SOLIDS: usize = 256;

/// Most vertices in one polygon (its self-intersection check is quadratic).
pub const MAX_VERTICES: usize = 1024;

/// Largest coordinate magnitude (m): a robot of 0.3 m tubes never needs more,
/// and bounded coordinates keep the geometry's rounding small.
pub const MAX_COORDINATE_M: f64 = 1e3;

/// Largest scene file (bytes) worth reading; [`Scene::from_toml_str`] rejects
/// longer text too, so whoever reads a file can stop at this size.
pub const MAX_SCENE_BYTES: usize = 1 << 20;

/// How far a half-plane's normal may be from unit length.
pub const UNIT_TOLERANCE: f64 = 1e-9;

/// Distance (m) within which a polygon corner counts as on another solid's
/// surface, so not exposed (see [`Scene::convex_corners`]).
pub const ON_SURFACE_M: f64 = 1e-9;

/// How far (m) a face resting on a surface or a corner may go past it in a
/// step and still count as touching, not crossing
/// ([`Scene::face_sweep_clear`]). A face turning on a nosing meets it in a
/// row that Newton's steps follow only to first order: a step leaves the
/// face up to the square of its turn (times the face's size) past the
/// corner, which the next step takes back. A micrometre is far below any
/// solid's thickness, so no face passes through a solid within it.
pub const FACE_SWEEP_SLACK_M: f64 = 1e-6;

/// A validated scene: a union of rigid solids (m).
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Display name.
    pub name: String,
    /// The solids; [`Feature`]s refer to them by index.
    pub solids: Vec<Solid>,
    /// Where the robot starts, when the scene says (file: `[start]`).
    pub start: Option<Start>,
}

/// Where a scene puts the robot by default: the centre of the rear cup's
/// face on a surface, and the direction the robot faces along it (the
/// clamp direction `phi0`; the cups lie on chain B's side, to its right).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Start {
    /// Centre of the rear cup's face (m).
    pub rear_cup_m: crate::geom::Vec2,
    /// The clamp direction (rad, counter-clockwise from +x).
    pub direction_rad: f64,
}

/// A piece of a scene's surface: what a point's closest surface point lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    /// The line of half-plane `solid`.
    HalfPlane {
        /// Index into [`Scene::solids`].
        solid: usize,
    },
    /// The inside of edge `edge` (from vertex `edge` to the next) of polygon `solid`.
    Edge {
        /// Index into [`Scene::solids`].
        solid: usize,
        /// Edge index.
        edge: usize,
    },
    /// Vertex `vertex` of polygon `solid`.
    Vertex {
        /// Index into [`Scene::solids`].
        solid: usize,
        /// Vertex index.
        vertex: usize,
    },
}

impl Scene {
    /// A checked scene.
    pub fn new(name: impl Into<String>, solids: Vec<Solid>) -> Result<Scene, InputError> {
        let scene = Scene { name: name.into(), solids, start: None };
        scene.validate()?;
        Ok(scene)
    }

    /// Checks every solid; call it again after changing fields by hand.
    ///
    /// Fields are named as in the file: `half_plane[i]` and `polygon[i]` count
    /// each kind separately, in order.
    pub fn validate(&self) -> Result<(), InputError> {
        crate::error::printable("name", &self.name)?;
        let count = self.solids.len();
        if !(1..=MAX_SOLIDS).contains(&count) {
            return Err(InputError::Invalid {
                field: "half_plane, polygon".into(),
                value: format!("{count} solids in all"),
                allowed: format!("1 to {MAX_SOLIDS} solids"),
            });
        }
        let (mut half_planes, mut polygons) = (0, 0);
        for solid in &self.solids {
            let field = match solid {
                Solid::HalfPlane { .. } => {
                    half_planes += 1;
                    format!("half_plane[{}]", half_planes - 1)
                }
                Solid::Polygon { .. } => {
                    polygons += 1;
                    format!("polygon[{}]", polygons - 1)
                }
            };
            solid.validate(&field)?;
        }
        Ok(())
    }
}
