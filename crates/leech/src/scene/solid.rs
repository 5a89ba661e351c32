//! The two kinds of solid and the checks that make them well formed.

use super::{MAX_COORDINATE_M, MAX_VERTICES, UNIT_TOLERANCE};
use crate::error::InputError;
use crate::geom::{cross, dot, norm, sub, Vec2};

/// One solid of a scene (m).
#[derive(Clone, Debug, PartialEq)]
pub enum Solid {
    /// Everything behind the line through `point_m` with unit outward `normal`
    /// is solid: the points `x` with `(x - point_m) . normal < 0`.
    HalfPlane {
        /// A point on the surface line (m).
        point_m: Vec2,
        /// Unit normal pointing out of the solid, into free space.
        normal: Vec2,
    },
    /// A simple polygon, solid inside, vertices counter-clockwise (the inside
    /// on the left of each edge), convex or concave. The first vertex is not
    /// repeated at the end: the last edge closes back to it.
    Polygon {
        /// The vertices (m).
        points_m: Vec<Vec2>,
    },
}

/// A point as the file writes it.
pub(super) fn show(p: Vec2) -> String {
    format!("[{}, {}]", crate::error::Num(p[0]), crate::error::Num(p[1]))
}

/// Checks a point is finite and within [`MAX_COORDINATE_M`].
fn check_point(field: &str, p: Vec2) -> Result<(), InputError> {
    if p.iter().all(|c| c.is_finite() && c.abs() <= MAX_COORDINATE_M) {
        Ok(())
    } else {
        Err(InputError::Invalid {
            field: field.into(),
            value: show(p),
            allowed: format!("finite coordinates within +-{MAX_COORDINATE_M} m"),
        })
    }
}

impl Solid {
    /// Checks the solid; `field` names it (`polygon[1]`).
    pub(super) fn validate(&self, field: &str) -> Result<(), InputError> {
        match self {
            Solid::HalfPlane { point_m, normal } => {
                check_point(&format!("{field}.point_m"), *point_m)?;
                let length = norm(*normal);
                // `!(<=)` also rejects NaN components, whose length is NaN.
                if !((length - 1.0).abs() <= UNIT_TOLERANCE) {
                    return Err(InputError::Invalid {
                        field: format!("{field}.normal"),
                        value: format!("{} (length {})", show(*normal), crate::error::Num(length)),
                        allowed: format!("a unit vector (length 1 within {UNIT_TOLERANCE})"),
                    });
                }
                Ok(())
            }
            Solid::Polygon { points_m } => validate_polygon(field, points_m),
        }
    }
}

/// Checks size, coordinates, repeats, simplicity and orientation, in that order
/// so that each message names the first thing wrong.
fn validate_polygon(field: &str, points: &[Vec2]) -> Result<(), InputError> {
    let n = points.len();
    if !(3..=MAX_VERTICES).contains(&n) {
        return Err(InputError::Invalid {
            field: format!("{field}.points_m"),
            value: format!("{n} points"),
            allowed: format!("3 to {MAX_VERTICES} points"),
        });
    }
    for (i, &p) in points.iter().enumerate() {
        check_point(&format!("{field}.points_m[{i}]"), p)?;
    }
    for i in 1..n {
        if points[i] == points[i - 1] {
            return Err(InputError::Invalid {
                field: format!("{field}.points_m[{i}]"),
                value: format!("{} (the same as points_m[{}])", show(points[i]), i - 1),
                allowed: "a point different from the one before it".into(),
            });
        }
    }
    if points[n - 1] == points[0] {
        return Err(InputError::Invalid {
            field: format!("{field}.points_m[{}]", n - 1),
            value: format!("{} (the same as points_m[0])", show(points[0])),
            allowed: "a point different from points_m[0]: the polygon closes by itself".into(),
        });
    }
    if let Some((e, f)) = first_crossing(points) {
        let name = |i: usize| format!("{i} (points_m[{i}] to points_m[{}])", (i + 1) % n);
        return Err(InputError::Invalid {
            field: format!("{field}.points_m"),
            value: format!("edges {} and {} crossing or touching", name(e), name(f)),
            allowed: "a simple polygon (edges meet only at their shared vertices)".into(),
        });
    }
    let area = signed_area(points);
    if !(area > 0.0) {
        return Err(InputError::Invalid {
            field: format!("{field}.points_m"),
            value: format!("clockwise order (signed area {area:e} m^2)"),
            allowed: "counter-clockwise order (positive area)".into(),
        });
    }
    Ok(())
}

/// Twice the signed area of triangle `a, b, c`: positive when it turns left.
pub(super) fn orient(a: Vec2, b: Vec2, c: Vec2) -> f64 {
    cross(sub(b, a), sub(c, a))
}

/// Whether `p`, already on the line through `a` and `b`, lies within the segment.
fn within_box(a: Vec2, b: Vec2, p: Vec2) -> bool {
    p[0] >= a[0].min(b[0]) && p[0] <= a[0].max(b[0]) && p[1] >= a[1].min(b[1]) && p[1] <= a[1].max(b[1])
}

/// Whether closed segments `p1-p2` and `p3-p4` share a point.
fn segments_meet(p1: Vec2, p2: Vec2, p3: Vec2, p4: Vec2) -> bool {
    let (d1, d2) = (orient(p3, p4, p1), orient(p3, p4, p2));
    let (d3, d4) = (orient(p1, p2, p3), orient(p1, p2, p4));
    if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
        return true;
    }
    (d1 == 0.0 && within_box(p3, p4, p1))
        || (d2 == 0.0 && within_box(p3, p4, p2))
        || (d3 == 0.0 && within_box(p1, p2, p3))
        || (d4 == 0.0 && within_box(p1, p2, p4))
}

/// The first pair of edges that cross, touch, or (for neighbours) fold back
/// over each other. Quadratic, which [`MAX_VERTICES`] keeps affordable.
fn first_crossing(points: &[Vec2]) -> Option<(usize, usize)> {
    let n = points.len();
    let end = |i: usize| points[(i + 1) % n];
    for i in 0..n {
        // Neighbours share a vertex; they only overlap if the second runs back
        // along the first.
        let (u, s, w) = (points[i], end(i), end((i + 1) % n));
        if orient(u, s, w) == 0.0 && dot(sub(u, s), sub(w, s)) > 0.0 {
            return Some(if i + 1 == n { (0, i) } else { (i, i + 1) });
        }
    }
    for i in 0..n {
        // Skip i's neighbours: i + 1 and, for edge 0, edge n - 1.
        let last = if i == 0 { n - 1 } else { n };
        for j in i + 2..last {
            if segments_meet(points[i], end(i), points[j], end(j)) {
                return Some((i, j));
            }
        }
    }
    None
}

/// Signed area (m^2), positive for counter-clockwise vertices (shoelace formula).
pub(super) fn signed_area(points: &[Vec2]) -> f64 {
    let n = points.len();
    (0..n).map(|i| cross(points[i], points[(i + 1) % n])).sum::<f64>() / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn polygon(points: &[Vec2]) -> Result<(), InputError> {
        Solid::Polygon { points_m: points.to_vec() }.validate("polygon[1]")
    }

    #[test]
    fn simple_counter_clockwise_polygons_pass() {
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert!(polygon(&square).is_ok());
        assert!((signed_area(&square) - 1.0).abs() < 1e-15);
        // An L: concave, still simple.
        let l = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
        assert!(polygon(&l).is_ok());
        assert!((signed_area(&l) - 3.0).abs() < 1e-15);
    }

    #[test]
    fn folds_and_touches_are_crossings() {
        // A triangle folded flat: edges 1 and 2 run back over each other.
        let e = polygon(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]).unwrap_err().to_string();
        assert!(e.contains("edges 1") && e.contains("and 2"), "{e}");
        // A vertex touching a non-neighbouring edge.
        let touch = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.0], [0.0, 2.0]];
        let e = polygon(&touch).unwrap_err().to_string();
        assert!(e.contains("simple polygon"), "{e}");
        assert_eq!(first_crossing(&touch), Some((0, 2)));
        // The closing edge folding back over edge 0.
        assert_eq!(first_crossing(&[[0.0, 0.0], [2.0, 0.0], [1.0, 1.0], [1.0, 0.0]]), Some((0, 3)));
    }

    #[test]
    fn segments_meet_at_ends_and_crossings_only() {
        let o = [0.0, 0.0];
        assert!(segments_meet(o, [1.0, 1.0], [0.0, 1.0], [1.0, 0.0]));
        assert!(segments_meet(o, [1.0, 0.0], [1.0, 0.0], [2.0, 5.0]));
        assert!(segments_meet(o, [2.0, 0.0], [1.0, 0.0], [3.0, 0.0]));
        assert!(!segments_meet(o, [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]));
        assert!(!segments_meet(o, [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]));
    }
}
