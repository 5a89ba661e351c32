//! Scenes in 3D: the solids the 3D body ([`crate::body3`]) rests on or
//! leans against, and the one query its contact rows ask: the plane a point
//! is measured against.
//!
//! ## Rules and units
//!
//! * Lengths in m; world x horizontal, y up, `z = x cross y` (as
//!   [`crate::body3`]). A scene is a union of solids; free space is the rest.
//! * [`Solid3::HalfSpace`]: the points `x` with `(x - point_m) . normal < 0`
//!   are solid; `normal` (unit) points out, into free space.
//! * [`Solid3::Box`]: the points `x` with `|(frame^T (x - centre_m))_a| <
//!   h_a` for every axis `a` (`h = half_extents_m`, `frame` a rotation whose
//!   columns are the box's axes).
//! * [`Solid3::Prism`]: a planar polygon (its cross-section in the x-y plane,
//!   checked by [`crate::scene`]'s rules) extruded without end along z. This
//!   is how a planar scene file is read in 3D ([`Scene3::from_planar`]): a
//!   half-plane becomes a half-space with its normal `(n_x, n_y, 0)`, a
//!   polygon a prism, so that every z-section of the 3D scene is the planar
//!   scene.
//!
//! ## The contact plane
//!
//! A contact row of the 3D body measures a point `p` against a plane, the
//! face of the solid nearest to it ([`Scene3::plane`]):
//!
//! ```text
//! g(p) = n . (p - x0)      (m),   positive in free space
//! ```
//!
//! A half-space is its own plane. For a box, with `q = frame^T (p - centre)`,
//! the face is the axis `a` with the largest `|q_a| - h_a` (the face the point
//! is most outside of, or least inside): `n = sign(q_a) frame e_a`,
//! `x0 = centre + sign(q_a) h_a frame e_a`. Beyond an edge or a corner the
//! face's gap is below the true distance (the row is conservative there). For
//! a prism, the plane is the tangent plane at the closest point of the
//! cross-section ([`Scene::signed_distance`]), normal `(n_x, n_y, 0)`.
//! Frozen while a row is active, the plane makes every contact row linear in
//! the point, so that its second derivatives stay within each link (docs/model3d.md section 12).

use super::{Scene, Solid, MAX_COORDINATE_M, MAX_SOLIDS, UNIT_TOLERANCE};
use crate::error::{InputError, Num};
use crate::geom3::{apply, apply_t, axpy, dot, Mat3, Vec3};

/// A solid of a 3D scene (module doc).
#[derive(Clone, Debug, PartialEq)]
pub enum Solid3 {
    /// Everything behind the plane through `point_m` with unit outward `normal`.
    HalfSpace {
        /// A point on the surface (m).
        point_m: Vec3,
        /// Unit normal out of the solid.
        normal: Vec3,
    },
    /// A box, centred at `centre_m`, its axes the columns of `frame`.
    Box {
        /// The centre (m).
        centre_m: Vec3,
        /// Half the edge lengths along the box's axes (m), each above zero.
        half_extents_m: Vec3,
        /// A rotation: columns the box's axes in world coordinates.
        frame: Mat3,
    },
    /// A polygon in the x-y plane extruded along z without end: `section`
    /// holds it as a one-solid planar scene, whose queries it reuses.
    Prism {
        /// The cross-section.
        section: Scene,
    },
}

/// A plane a point is measured against: `g(p) = normal . (p - point_m)` (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane3 {
    /// A point on the plane (m).
    pub point_m: Vec3,
    /// Unit normal into free space.
    pub normal: Vec3,
}

impl Plane3 {
    /// The gap of `p` (m): positive in free space, negative inside.
    pub fn gap(&self, p: Vec3) -> f64 {
        dot(self.normal, axpy(-1.0, self.point_m, p))
    }
}

/// A checked scene of 3D solids.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene3 {
    /// Display name.
    pub name: String,
    /// The solids.
    pub solids: Vec<Solid3>,
}

fn check_point(field: &str, p: Vec3) -> Result<(), InputError> {
    if p.iter().all(|c| c.is_finite() && c.abs() <= MAX_COORDINATE_M) {
        return Ok(());
    }
    Err(InputError::Invalid {
        field: field.into(),
        value: show(p),
        allowed: format!("finite coordinates within +-{MAX_COORDINATE_M} m"),
    })
}

fn show(p: Vec3) -> String {
    format!("[{}, {}, {}]", Num(p[0]), Num(p[1]), Num(p[2]))
}

impl Solid3 {
    /// Checks the solid; `field` names it (`solids[2]`).
    pub fn validate(&self, field: &str) -> Result<(), InputError> {
        match self {
            Solid3::HalfSpace { point_m, normal } => {
                check_point(&format!("{field}.point_m"), *point_m)?;
                let length = dot(*normal, *normal).sqrt();
                // `!(<=)` also rejects NaN components.
                if !((length - 1.0).abs() <= UNIT_TOLERANCE) {
                    return Err(InputError::Invalid {
                        field: format!("{field}.normal"),
                        value: format!("{} (length {})", show(*normal), Num(length)),
                        allowed: format!("a unit vector (length 1 within {UNIT_TOLERANCE})"),
                    });
                }
                Ok(())
            }
            Solid3::Box { centre_m, half_extents_m, frame } => {
                check_point(&format!("{field}.centre_m"), *centre_m)?;
                if !half_extents_m.iter().all(|h| *h > 0.0 && *h <= MAX_COORDINATE_M) {
                    return Err(InputError::Invalid {
                        field: format!("{field}.half_extents_m"),
                        value: show(*half_extents_m),
                        allowed: format!("three lengths above 0 and at most {MAX_COORDINATE_M} m"),
                    });
                }
                if !crate::geom3::is_rotation(frame) {
                    return Err(InputError::Invalid {
                        field: format!("{field}.frame"),
                        value: format!("{frame:?}"),
                        allowed: "a rotation matrix (orthonormal to 1e-9, determinant +1)".into(),
                    });
                }
                Ok(())
            }
            Solid3::Prism { section } => match section.solids.as_slice() {
                [Solid::Polygon { .. }] => section.validate(),
                _ => Err(InputError::Invalid {
                    field: format!("{field}.section"),
                    value: format!("{} solids", section.solids.len()),
                    allowed: "one polygon".into(),
                }),
            },
        }
    }

    /// The plane `p` is measured against (module doc).
    pub fn plane(&self, p: Vec3) -> Plane3 {
        match self {
            Solid3::HalfSpace { point_m, normal } => Plane3 { point_m: *point_m, normal: *normal },
            Solid3::Box { centre_m, half_extents_m, frame } => {
                let q = apply_t(frame, axpy(-1.0, *centre_m, p));
                let a = (0..3)
                    .max_by(|&a, &b| (q[a].abs() - half_extents_m[a]).total_cmp(&(q[b].abs() - half_extents_m[b])))
                    .unwrap_or(0);
                let sign = if q[a] < 0.0 { -1.0 } else { 1.0 };
                let mut axis = [0.0; 3];
                axis[a] = sign;
                let normal = apply(frame, axis);
                Plane3 { point_m: axpy(half_extents_m[a], normal, *centre_m), normal }
            }
            Solid3::Prism { section } => {
                let (_, _, n, closest) = section.signed_distance([p[0], p[1]]);
                Plane3 { point_m: [closest[0], closest[1], p[2]], normal: [n[0], n[1], 0.0] }
            }
        }
    }

    /// Signed distance (m): positive outside (the exact distance), negative
    /// inside (minus the depth to the nearest face).
    pub fn signed_distance(&self, p: Vec3) -> f64 {
        match self {
            Solid3::HalfSpace { .. } => self.plane(p).gap(p),
            Solid3::Box { centre_m, half_extents_m, frame } => {
                let q = apply_t(frame, axpy(-1.0, *centre_m, p));
                let d = [0, 1, 2].map(|a| q[a].abs() - half_extents_m[a]);
                let outside = d.map(|x| x.max(0.0));
                let inside = d[0].max(d[1]).max(d[2]).min(0.0);
                dot(outside, outside).sqrt() + inside
            }
            Solid3::Prism { section } => section.signed_distance([p[0], p[1]]).0,
        }
    }
}

impl Scene3 {
    /// A checked scene: 1 to [`MAX_SOLIDS`] solids, each valid.
    pub fn new(name: impl Into<String>, solids: Vec<Solid3>) -> Result<Scene3, InputError> {
        let scene = Scene3 { name: name.into(), solids };
        crate::error::printable("name", &scene.name)?;
        if !(1..=MAX_SOLIDS).contains(&scene.solids.len()) {
            return Err(InputError::Invalid {
                field: "solids".into(),
                value: format!("{} solids", scene.solids.len()),
                allowed: format!("1 to {MAX_SOLIDS} solids"),
            });
        }
        for (i, solid) in scene.solids.iter().enumerate() {
            solid.validate(&format!("solids[{i}]"))?;
        }
        Ok(scene)
    }

    /// A planar scene read in 3D (module doc): half-planes as half-spaces
    /// with their normals in the x-y plane, polygons as prisms along z.
    pub fn from_planar(scene: &Scene) -> Scene3 {
        let solids = scene
            .solids
            .iter()
            .map(|solid| match solid {
                Solid::HalfPlane { point_m, normal } => {
                    Solid3::HalfSpace { point_m: [point_m[0], point_m[1], 0.0], normal: [normal[0], normal[1], 0.0] }
                }
                Solid::Polygon { .. } => Solid3::Prism {
                    section: Scene { name: scene.name.clone(), solids: vec![solid.clone()], start: None },
                },
            })
            .collect();
        Scene3 { name: scene.name.clone(), solids }
    }

    /// The solid `p` is nearest to (or deepest in) and its plane: `(solid
    /// index, plane, signed distance (m))`.
    pub fn nearest(&self, p: Vec3) -> Option<(usize, Plane3, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for (i, solid) in self.solids.iter().enumerate() {
            let d = solid.signed_distance(p);
            if best.is_none_or(|(_, b)| d < b) {
                best = Some((i, d));
            }
        }
        best.map(|(i, d)| (i, self.solids[i].plane(p), d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom3::{exp, rot_z, scale};

    /// `s` times axis `a` of `frame` (a column).
    fn column(frame: &Mat3, a: usize, s: f64) -> Vec3 {
        scale(s, [frame[0][a], frame[1][a], frame[2][a]])
    }

    fn boxed() -> Solid3 {
        Solid3::Box { centre_m: [0.1, -0.2, 0.3], half_extents_m: [0.2, 0.1, 0.05], frame: exp([0.3, -0.5, 0.7]) }
    }

    #[test]
    fn box_distance_and_plane_agree_on_each_face() {
        let b = boxed();
        let Solid3::Box { centre_m, half_extents_m, frame } = &b else { unreachable!() };
        for a in 0..3 {
            for s in [-1.0, 1.0] {
                // A point just outside the middle of a face, then just inside.
                for depth in [0.01, -0.004] {
                    let p = axpy(1.0, column(frame, a, s * (half_extents_m[a] + depth)), *centre_m);
                    let plane = b.plane(p);
                    assert!((plane.gap(p) - depth).abs() < 1e-12, "axis {a} side {s}: {}", plane.gap(p));
                    assert!((b.signed_distance(p) - depth).abs() < 1e-12);
                    assert!((dot(plane.normal, column(frame, a, s)) - 1.0).abs() < 1e-12);
                }
            }
        }
        // Beyond a corner the distance is Euclidean, the face's gap smaller.
        let corner = [0, 1, 2].map(|a| half_extents_m[a] + 0.03);
        let p = axpy(1.0, apply(frame, corner), *centre_m);
        assert!((b.signed_distance(p) - 0.03 * 3f64.sqrt()).abs() < 1e-12);
        assert!(b.plane(p).gap(p) < b.signed_distance(p));
    }

    #[test]
    fn planar_scenes_read_in_3d_keep_every_section() {
        let planar = Scene::builtin("step").unwrap();
        let scene = Scene3::from_planar(&planar);
        assert!(Scene3::new(scene.name.clone(), scene.solids.clone()).is_ok());
        for (i, p) in [[0.3, 0.05], [-0.2, 0.4], [0.9, 0.2], [0.5, -0.01]].iter().enumerate() {
            let (d, _, n, _) = planar.signed_distance(*p);
            for z in [-1.0, 0.0, 2.5] {
                let (_, plane, d3) = scene.nearest([p[0], p[1], z]).unwrap();
                assert!((d3 - d).abs() < 1e-12, "point {i}: {d3} against {d}");
                assert!((plane.gap([p[0], p[1], z]) - d).abs() < 1e-12);
                assert_eq!(plane.normal, [n[0], n[1], 0.0]);
            }
        }
    }

    #[test]
    fn bad_solids_name_the_field() {
        let tilted = Solid3::HalfSpace { point_m: [0.0; 3], normal: [0.0, 2.0, 0.0] };
        let e = Scene3::new("s", vec![boxed(), tilted]).unwrap_err().to_string();
        assert!(e.starts_with("solids[1].normal"), "{e}");
        let flat = Solid3::Box { centre_m: [0.0; 3], half_extents_m: [0.1, 0.0, 0.1], frame: rot_z(0.2) };
        let e = Scene3::new("s", vec![flat]).unwrap_err().to_string();
        assert!(e.starts_with("solids[0].half_extents_m"), "{e}");
        let sheared = Solid3::Box {
            centre_m: [0.0; 3],
            half_extents_m: [0.1; 3],
            frame: [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        };
        assert!(Scene3::new("s", vec![sheared]).unwrap_err().to_string().starts_with("solids[0].frame"));
        assert!(Scene3::new("s", vec![]).is_err());
    }
}
