//! Geometric queries: signed distance, features near a point, exposed convex
//! corners, free-space tests and surface frames for placing cups.
//!
//! Every per-point query runs in O(features) (edges plus half-planes) without
//! allocating, so a contact solver can call it for every node at every step.

use std::f64::consts::PI;

use super::solid::{orient, signed_area};
use super::{Feature, Scene, Solid, FACE_SWEEP_SLACK_M, ON_SURFACE_M};
use crate::geom::{add_scaled, angle_difference, cross, dot, norm, sub, unit, Vec2};

/// A surface feature near a point, as [`Scene::features_near`] reports it.
///
/// Always `p = closest + distance * normal`, so `distance` is the gap to the
/// feature along `normal` and a contact solver can linearize it directly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// The feature.
    pub feature: Feature,
    /// Signed distance (m) from the feature to the point: for an edge or a
    /// half-plane the side of its line (negative behind it); for a vertex the
    /// distance, negative at a reflex (concave) vertex, whose nearby points
    /// are inside.
    pub distance: f64,
    /// The feature's point closest to the query point (m).
    pub closest: Vec2,
    /// The solid's outward unit normal at `closest`.
    pub normal: Vec2,
}

/// Where a rigid outline overlaps the solids ([`Scene::overlap`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Overlap {
    /// The point: a corner inside a solid, a solid's vertex inside the
    /// outline, or where two edges cross (m).
    pub point_m: Vec2,
    /// How deep it lies (m; 0 for a crossing).
    pub depth_m: f64,
}

/// A polygon vertex with an interior angle below 180 deg, not buried in or
/// lying on another solid: a corner that can poke between a tube's nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// Index into [`Scene::solids`].
    pub solid: usize,
    /// Vertex index in the polygon.
    pub vertex: usize,
    /// Where it is (m).
    pub point: Vec2,
    /// Unit vector out of the solid halving the corner's outside angle.
    pub bisector: Vec2,
    /// The solid's angle at the corner (rad, in (0, pi)).
    pub interior_angle_rad: f64,
}

/// The closest surface point of one solid.
#[derive(Clone, Copy)]
struct Hit {
    distance: f64,
    feature: Feature,
    normal: Vec2,
    closest: Vec2,
}

/// The end of edge `i`: the next vertex, wrapping to 0.
#[inline]
fn next(points: &[Vec2], i: usize) -> Vec2 {
    points[if i + 1 == points.len() { 0 } else { i + 1 }]
}

/// The start of edge `i - 1`: the previous vertex, wrapping to the last.
#[inline]
fn prev(points: &[Vec2], i: usize) -> Vec2 {
    points[if i == 0 { points.len() - 1 } else { i - 1 }]
}

/// `v / |v|`.
#[inline]
fn normalized(v: Vec2) -> Vec2 {
    let l = norm(v);
    [v[0] / l, v[1] / l]
}

/// Outward unit normal of the edge from `a` to `b`: the inside of a
/// counter-clockwise polygon is on the edge's left, so outward is its right.
#[inline]
fn outward(a: Vec2, b: Vec2) -> Vec2 {
    normalized([b[1] - a[1], a[0] - b[0]])
}

/// Outward unit bisector at vertex `i`: the mean of its two edges' normals.
fn bisector(points: &[Vec2], i: usize) -> Vec2 {
    let (n_in, n_out) = (outward(prev(points, i), points[i]), outward(points[i], next(points, i)));
    normalized([n_in[0] + n_out[0], n_in[1] + n_out[1]])
}

/// The surface direction whose quarter turn counter-clockwise is `normal`, in
/// (-pi, pi].
#[inline]
fn tangent_angle(normal: Vec2) -> f64 {
    // `0.0 - x` rather than `-x`: a normal with x = 0 must give +0, not -0,
    // which atan2 would turn into -pi on a ceiling.
    (0.0 - normal[0]).atan2(normal[1])
}

/// Parameter in [0, 1] of the point of segment `a-b` closest to `p` (0 for a
/// segment of zero length).
#[inline]
fn closest_parameter(a: Vec2, b: Vec2, p: Vec2) -> f64 {
    let d = sub(b, a);
    let dd = dot(d, d);
    if dd > 0.0 {
        (dot(sub(p, a), d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Whether the ray from `p` towards +x crosses edge `a-b`. Half-open in y, so
/// a ray through a vertex counts it once; an odd count means inside.
#[inline]
fn ray_crosses(a: Vec2, b: Vec2, p: Vec2) -> bool {
    (a[1] > p[1]) != (b[1] > p[1]) && p[0] < a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
}

/// Whether `p` is inside a polygon (ray crossing).
fn polygon_contains(points: &[Vec2], p: Vec2) -> bool {
    (0..points.len()).filter(|&i| ray_crosses(points[i], next(points, i), p)).count() % 2 == 1
}

fn half_plane_hit(solid: usize, point: Vec2, normal: Vec2, p: Vec2) -> Hit {
    let distance = dot(sub(p, point), normal);
    Hit { distance, feature: Feature::HalfPlane { solid }, normal, closest: add_scaled(p, -distance, normal) }
}

/// The closest boundary point of a polygon: the nearest of all edges, signed
/// by a ray-crossing inside test run in the same pass (right for concave
/// polygons, where no single edge's side tells inside from outside).
fn polygon_hit(solid: usize, points: &[Vec2], p: Vec2) -> Hit {
    let (mut best, mut best_edge, mut best_t, mut inside) = (f64::INFINITY, 0, 0.0, false);
    for i in 0..points.len() {
        let (a, b) = (points[i], next(points, i));
        let t = closest_parameter(a, b, p);
        let d = sub(p, add_scaled(a, t, sub(b, a)));
        let d2 = dot(d, d);
        if d2 < best {
            (best, best_edge, best_t) = (d2, i, t);
        }
        inside ^= ray_crosses(a, b, p);
    }
    let sign = if inside { -1.0 } else { 1.0 };
    let (a, b) = (points[best_edge], next(points, best_edge));
    let closest = add_scaled(a, best_t, sub(b, a));
    let distance = sign * best.sqrt();
    if best_t > 0.0 && best_t < 1.0 {
        return Hit { distance, feature: Feature::Edge { solid, edge: best_edge }, normal: outward(a, b), closest };
    }
    let vertex = if best_t <= 0.0 { best_edge } else { (best_edge + 1) % points.len() };
    let (away, r) = (sub(p, closest), distance.abs());
    // Outward: from the vertex towards an outside point, from an inside point
    // towards the vertex; at the vertex itself, the bisector.
    let normal = if r > 0.0 { [sign * away[0] / r, sign * away[1] / r] } else { bisector(points, vertex) };
    Hit { distance, feature: Feature::Vertex { solid, vertex }, normal, closest }
}

/// A polygon's bounding box (lower-left, upper-right corners); none for a half-plane.
fn bounding_box(s: &Solid) -> Option<[Vec2; 2]> {
    let Solid::Polygon { points_m } = s else { return None };
    let fold = |f: fn(f64, f64) -> f64, start: f64| [0, 1].map(|i| points_m.iter().fold(start, |acc, p| f(acc, p[i])));
    Some([fold(f64::min, f64::INFINITY), fold(f64::max, f64::NEG_INFINITY)])
}

fn solid_hit(solid: usize, s: &Solid, p: Vec2) -> Hit {
    match s {
        Solid::HalfPlane { point_m, normal } => half_plane_hit(solid, *point_m, *normal, p),
        Solid::Polygon { points_m } => polygon_hit(solid, points_m, p),
    }
}

/// Appends the edges and vertices of polygon `solid` within `radius` of `p`
/// (see [`Scene::features_near`]).
fn polygon_near(solid: usize, points: &[Vec2], p: Vec2, radius: f64, out: &mut Vec<Candidate>) {
    let start = out.len();
    for i in 0..points.len() {
        let (v, d_in, d_out) = (points[i], sub(points[i], prev(points, i)), sub(next(points, i), points[i]));
        let from_v = sub(p, v);
        let along = dot(from_v, d_out);
        // Edge i, when p projects inside it; its ends belong to the vertices.
        if along > 0.0 && along < dot(d_out, d_out) {
            let normal = outward(v, next(points, i));
            let distance = dot(from_v, normal);
            if distance.abs() <= radius {
                let closest = add_scaled(v, along / dot(d_out, d_out), d_out);
                out.push(Candidate { feature: Feature::Edge { solid, edge: i }, distance, closest, normal });
            }
        }
        // Vertex i, when it is the closest point of both its edges.
        let r = norm(from_v);
        if along <= 0.0 && dot(from_v, d_in) >= 0.0 && r <= radius {
            let sign = if cross(d_in, d_out) >= 0.0 { 1.0 } else { -1.0 };
            let normal = if r > 0.0 { [sign * from_v[0] / r, sign * from_v[1] / r] } else { bisector(points, i) };
            out.push(Candidate {
                feature: Feature::Vertex { solid, vertex: i },
                distance: sign * r,
                closest: v,
                normal,
            });
        }
    }
    // From outside, a feature p is behind is a back face (the far side of a
    // thin wall): not a contact. The inside test runs only when needed.
    if out[start..].iter().any(|c| c.distance < 0.0) && !polygon_contains(points, p) {
        let mut kept = start;
        for k in start..out.len() {
            if out[k].distance >= 0.0 {
                out[kept] = out[k];
                kept += 1;
            }
        }
        out.truncate(kept);
    }
}

/// Whether segment `p0-p1` and edge `a-b` cross each other with every end
/// more than `tol` from the other's line (touching and grazing do not count).
fn crosses_beyond(p0: Vec2, p1: Vec2, a: Vec2, b: Vec2, tol: f64) -> bool {
    let side = |s: Vec2, e: Vec2, q: Vec2| cross(sub(e, s), sub(q, s)) / norm(sub(e, s));
    let opposite = |x: f64, y: f64| (x > tol && y < -tol) || (x < -tol && y > tol);
    opposite(side(a, b, p0), side(a, b, p1)) && opposite(side(p0, p1, a), side(p0, p1, b))
}

/// Whether a face with ends `ends` lies along the surface line through `start`
/// with outward `normal`, and (for an edge) within `length` of `start` along the
/// surface direction.
fn face_on_line(ends: [Vec2; 2], angle: f64, start: Vec2, normal: Vec2, length: Option<f64>, tols: (f64, f64)) -> bool {
    let (distance_tol, angle_tol) = tols;
    let tangent = unit(tangent_angle(normal));
    angle_difference(angle, tangent_angle(normal)).abs() <= angle_tol
        && ends.iter().all(|&e| {
            let s = dot(sub(e, start), tangent);
            dot(sub(e, start), normal).abs() <= distance_tol
                && length.is_none_or(|l| s >= -distance_tol && s <= l + distance_tol)
        })
}

impl Scene {
    /// Signed distance (m) from `p` to the solids, with the closest feature,
    /// the outward unit normal there and the closest surface point:
    /// `(distance, feature, normal, closest)`, with `p = closest + distance * normal`.
    ///
    /// Outside every solid the distance is the exact distance to their union.
    /// Inside, it is minus the depth in the solid `p` is deepest in, measured
    /// to that solid's own boundary (exact where solids do not overlap; see the
    /// module's rule on burying). For a vertex the normal points from the
    /// vertex towards an outside `p` (from an inside `p` towards the vertex).
    ///
    /// # Panics
    /// If the scene has no solids (validation rejects such scenes).
    pub fn signed_distance(&self, p: Vec2) -> (f64, Feature, Vec2, Vec2) {
        let mut best: Option<Hit> = None;
        for (i, solid) in self.solids.iter().enumerate() {
            let hit = solid_hit(i, solid, p);
            if best.is_none_or(|b| hit.distance < b.distance) {
                best = Some(hit);
            }
        }
        let hit = best.expect("signed_distance needs a scene with at least one solid");
        (hit.distance, hit.feature, hit.normal, hit.closest)
    }

    /// Replaces `out` with every feature within `radius` (m) of `p`: edges `p`
    /// projects onto, vertices that are the closest point of both their edges,
    /// and half-planes. Near an inside (concave) corner both faces count.
    ///
    /// Faces `p` sees from behind while outside their solid (the far face of a
    /// thin wall) are left out; inside a solid, all its nearby features count.
    /// Whenever [`Scene::signed_distance`] is within `radius`, its closest
    /// point is among the candidates.
    pub fn features_near(&self, p: Vec2, radius: f64, out: &mut Vec<Candidate>) {
        out.clear();
        for (i, solid) in self.solids.iter().enumerate() {
            match solid {
                Solid::HalfPlane { point_m, normal } => {
                    let hit = half_plane_hit(i, *point_m, *normal, p);
                    if hit.distance.abs() <= radius {
                        out.push(Candidate {
                            feature: hit.feature,
                            distance: hit.distance,
                            closest: hit.closest,
                            normal: hit.normal,
                        });
                    }
                }
                Solid::Polygon { points_m } => polygon_near(i, points_m, p, radius, out),
            }
        }
    }

    /// The exposed convex corners: polygon vertices with an interior angle
    /// below 180 deg that are not inside or on another solid (within
    /// [`ON_SURFACE_M`]), such as a step's nosing or a thin wall's top.
    /// Corners buried in a floor, or resting on it, cannot touch a tube.
    ///
    /// It tests each vertex against every solid: call it once per scene, not
    /// per step.
    pub fn convex_corners(&self) -> impl Iterator<Item = Corner> + '_ {
        // A polygon can bury a vertex only within its bounding box: the boxes
        // spare the exact test for all the others (scenes of many polygons).
        let boxes: std::rc::Rc<[Option<[Vec2; 2]>]> = self.solids.iter().map(bounding_box).collect();
        self.solids.iter().enumerate().flat_map(move |(solid, s)| {
            let points: &[Vec2] = match s {
                Solid::Polygon { points_m } => points_m,
                Solid::HalfPlane { .. } => &[],
            };
            let boxes = std::rc::Rc::clone(&boxes);
            (0..points.len()).filter_map(move |vertex| self.exposed_corner(solid, points, vertex, &boxes))
        })
    }

    /// Vertex `vertex` of polygon `solid` as a [`Corner`], if convex and
    /// exposed; `boxes` the solids' bounding boxes (none for a half-plane).
    fn exposed_corner(
        &self,
        solid: usize,
        points: &[Vec2],
        vertex: usize,
        boxes: &[Option<[Vec2; 2]>],
    ) -> Option<Corner> {
        let point = points[vertex];
        let (d_in, d_out) = (sub(point, prev(points, vertex)), sub(next(points, vertex), point));
        let turn = cross(d_in, d_out);
        if !(turn > 0.0) {
            return None;
        }
        let near = |j: usize| {
            boxes[j].is_none_or(|[lo, hi]| {
                (0..2).all(|i| point[i] >= lo[i] - ON_SURFACE_M && point[i] <= hi[i] + ON_SURFACE_M)
            })
        };
        let buried = self
            .solids
            .iter()
            .enumerate()
            .any(|(j, other)| j != solid && near(j) && solid_hit(j, other, point).distance <= ON_SURFACE_M);
        // The interior angle is what the left turn at the vertex leaves of a half turn.
        let interior_angle_rad = PI - turn.atan2(dot(d_in, d_out));
        (!buried).then(|| Corner { solid, vertex, point, bisector: bisector(points, vertex), interior_angle_rad })
    }

    /// Distance (m) from `corner` to segment `a-b` (a link), the parameter
    /// `s` in [0, 1] of the segment's closest point `a + s (b - a)`, and the
    /// unit normal from the corner towards that point: `(distance, s, normal)`.
    ///
    /// The distance is not signed: which side of the corner the link is on is
    /// the caller's to track (a link that passed through the corner has
    /// `normal` pointing against `corner.bisector`). When the link touches the
    /// corner, the normal is the corner's bisector.
    pub fn segment_corner_distance(a: Vec2, b: Vec2, corner: &Corner) -> (f64, f64, Vec2) {
        let s = closest_parameter(a, b, corner.point);
        let gap = sub(add_scaled(a, s, sub(b, a)), corner.point);
        let distance = norm(gap);
        let normal = if distance > 0.0 { [gap[0] / distance, gap[1] / distance] } else { corner.bisector };
        (distance, s, normal)
    }

    /// Signed distance (m) from `p` to solid `solid` alone (negative inside
    /// it), as [`Scene::signed_distance`] measures it.
    ///
    /// # Panics
    /// If `solid` is not an index into [`Scene::solids`].
    pub fn solid_distance(&self, solid: usize, p: Vec2) -> f64 {
        solid_hit(solid, &self.solids[solid], p).distance
    }

    /// Whether a flat face moving from the segment `was` to the segment
    /// `now` (each rim on a straight line, both ends outside every solid)
    /// stays out of the polygons: no rim's path crosses an edge and no
    /// exposed convex corner lies inside the area the face sweeps (the two
    /// triangles of the quadrilateral `was[0], was[1], now[1], now[0]`), each
    /// by more than [`FACE_SWEEP_SLACK_M`] (a face sliding on a surface or
    /// turning on a corner it rests on touches, it does not cross).
    pub fn face_sweep_clear(&self, was: [Vec2; 2], now: [Vec2; 2], corners: &[Corner]) -> bool {
        let tol = FACE_SWEEP_SLACK_M;
        let paths_clear = self.solids.iter().all(|solid| match solid {
            Solid::Polygon { points_m } => (0..points_m.len()).all(|e| {
                let (a, b) = (points_m[e], next(points_m, e));
                (0..2).all(|i| !crosses_beyond(was[i], now[i], a, b, tol))
            }),
            Solid::HalfPlane { .. } => true,
        });
        let inside = |p: Vec2, t: [Vec2; 3]| {
            let sides = [0, 1, 2].map(|i| {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                let length = norm(sub(b, a));
                if length > 0.0 {
                    cross(sub(b, a), sub(p, a)) / length
                } else {
                    0.0
                }
            });
            sides.iter().all(|d| *d > tol) || sides.iter().all(|d| *d < -tol)
        };
        let swept = |p: Vec2| inside(p, [was[0], was[1], now[1]]) || inside(p, [was[0], now[1], now[0]]);
        paths_clear && !corners.iter().any(|c| swept(c.point))
    }

    /// Whether a disc of radius `clearance` (m) centred at `p` stays out of
    /// every solid (touching allowed). With no solids, everything is free.
    pub fn is_free(&self, p: Vec2, clearance: f64) -> bool {
        self.solids.iter().enumerate().all(|(i, s)| solid_hit(i, s, p).distance >= clearance)
    }

    /// Where a closed convex polygon `outline` (m, either orientation)
    /// overlaps the solids, deeper than `slack` (m): its deepest corner
    /// inside a solid, else a solid's deepest vertex inside it, else the
    /// first crossing of one of its edges with a polygon's edge (a thin wall
    /// through it, no vertex of either inside the other; depth 0). `None`
    /// where it is clear or only touches. Linear in the solids' vertices
    /// times the outline's.
    pub fn overlap(&self, outline: &[Vec2], slack: f64) -> Option<Overlap> {
        if self.solids.is_empty() {
            return None;
        }
        let deeper = |best: Option<Overlap>, point: Vec2, depth: f64| match best {
            Some(b) if b.depth_m >= depth => Some(b),
            _ if depth > slack => Some(Overlap { point_m: point, depth_m: depth }),
            _ => best,
        };
        let corners = outline.iter().fold(None, |best, &c| deeper(best, c, -self.signed_distance(c).0));
        if corners.is_some() {
            return corners;
        }
        let n = outline.len();
        let edge = |k: usize| [outline[k], outline[(k + 1) % n]];
        let inward = signed_area(outline).signum();
        let depth_in_outline = |p: Vec2| {
            (0..n)
                .map(|k| inward * orient(edge(k)[0], edge(k)[1], p) / norm(sub(edge(k)[1], edge(k)[0])))
                .fold(f64::INFINITY, f64::min)
        };
        let polygons = self.solids.iter().filter_map(|s| match s {
            Solid::Polygon { points_m } => Some(points_m),
            Solid::HalfPlane { .. } => None,
        });
        let mut best = None;
        for points in polygons.clone() {
            best = points.iter().fold(best, |best, &v| deeper(best, v, depth_in_outline(v)));
        }
        if best.is_some() {
            return best;
        }
        polygons
            .flat_map(|points| (0..points.len()).map(move |j| [points[j], points[(j + 1) % points.len()]]))
            .find_map(|[c, d]| {
                (0..n).find_map(|k| {
                    let [a, b] = edge(k);
                    let (d1, d2, d3, d4) = (orient(c, d, a), orient(c, d, b), orient(a, b, c), orient(a, b, d));
                    (d1 * d2 < 0.0 && d3 * d4 < 0.0).then(|| {
                        let t = d1 / (d1 - d2);
                        Overlap { point_m: [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])], depth_m: 0.0 }
                    })
                })
            })
    }

    /// Whether `p` is strictly inside a solid (surface points are not).
    pub fn inside(&self, p: Vec2) -> bool {
        self.solids.iter().enumerate().any(|(i, s)| solid_hit(i, s, p).distance < 0.0)
    }

    /// The surface point closest to `p` and the surface direction there (rad):
    /// the tangent with free space on its left, the convention of the robot
    /// file's `base_angle_deg` (0 on a floor, pi/2 up a wall whose free side is
    /// -x). At a corner the direction is square to the line from the corner to
    /// `p`. `None` for a scene without solids.
    pub fn surface_frame(&self, p: Vec2) -> Option<(Vec2, f64)> {
        if self.solids.is_empty() {
            return None;
        }
        let (_, _, normal, closest) = self.signed_distance(p);
        Some((closest, tangent_angle(normal)))
    }

    /// Whether a flat cup face centred at `center`, along direction `angle`
    /// (the [`Scene::surface_frame`] convention: the face's free side on the
    /// left) and `half_width` (m) each way, lies flat on a single edge or
    /// half-plane: its direction within `angle_tol` (rad) of the surface's,
    /// both rims within `distance_tol` (m) of the surface line and, on an
    /// edge, within the edge's ends (with `distance_tol` of slack).
    ///
    /// The face must also be clear of every other solid: a rim inside one
    /// deeper than `distance_tol`, or one of its edges crossing the face, rules
    /// the placement out (a cup straddling the foot of a wall seals on neither).
    pub fn flat_on_one_edge(
        &self,
        center: Vec2,
        angle: f64,
        half_width: f64,
        distance_tol: f64,
        angle_tol: f64,
    ) -> bool {
        let u = unit(angle);
        let ends = [add_scaled(center, -half_width, u), add_scaled(center, half_width, u)];
        let tols = (distance_tol, angle_tol);
        self.solids.iter().enumerate().any(|(i, solid)| {
            let on = match solid {
                Solid::HalfPlane { point_m, normal } => face_on_line(ends, angle, *point_m, *normal, None, tols),
                Solid::Polygon { points_m } => (0..points_m.len()).any(|e| {
                    // The surface direction runs against the edge, from its end back to its start.
                    let (a, b) = (points_m[e], next(points_m, e));
                    face_on_line(ends, angle, b, outward(a, b), Some(norm(sub(b, a))), tols)
                }),
            };
            on && self.face_clear(i, ends, distance_tol)
        })
    }

    /// Whether a face with ends `ends` stays out of every solid but `on`.
    fn face_clear(&self, on: usize, ends: [Vec2; 2], tol: f64) -> bool {
        self.solids.iter().enumerate().filter(|&(j, _)| j != on).all(|(j, solid)| {
            let rims_out = ends.iter().all(|&e| solid_hit(j, solid, e).distance >= -tol);
            rims_out
                && match solid {
                    Solid::HalfPlane { .. } => true,
                    Solid::Polygon { points_m } => (0..points_m.len())
                        .all(|e| !crosses_beyond(ends[0], ends[1], points_m[e], next(points_m, e), tol)),
                }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: f64 = std::f64::consts::FRAC_1_SQRT_2;

    fn close(a: Vec2, b: Vec2) -> bool {
        (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12
    }

    fn thin_wall() -> Scene {
        Scene::builtin("thin-wall").unwrap()
    }

    /// A box `[x0, x1] x [y0, y1]`, counter-clockwise.
    fn square(x0: f64, x1: f64, y0: f64, y1: f64) -> [Vec2; 4] {
        [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    #[test]
    fn an_outline_overlaps_by_a_corner_a_vertex_or_a_crossing() {
        let scene = thin_wall();
        // Above the floor and clear of the wall (0.20..0.22 m), or resting on the floor.
        assert_eq!(scene.overlap(&square(0.05, 0.10, 0.01, 0.04), 1e-9), None);
        assert_eq!(scene.overlap(&square(0.05, 0.10, 0.0, 0.04), 1e-9), None);
        // A corner 3 mm into the floor: the deepest corner, either orientation.
        for outline in [square(0.05, 0.10, -0.003, 0.04), {
            let mut cw = square(0.05, 0.10, -0.003, 0.04);
            cw.reverse();
            cw
        }] {
            let o = scene.overlap(&outline, 1e-9).unwrap();
            assert!((o.depth_m - 0.003).abs() < 1e-15 && o.point_m[1] == -0.003, "{o:?}");
        }
        // The wall's top corners poking 5 mm up into an outline wider than the wall.
        let o = scene.overlap(&square(0.19, 0.23, 0.245, 0.28), 1e-9).unwrap();
        assert!((o.depth_m - 0.005).abs() < 1e-12 && o.point_m[1] == 0.25, "{o:?}");
        // The wall passing right through a tall outline: no vertex of either
        // inside the other, its edges cross.
        let o = scene.overlap(&square(0.19, 0.23, 0.10, 0.12), 1e-9).unwrap();
        assert_eq!(o.depth_m, 0.0);
        assert!(close(o.point_m, [0.20, 0.10]) || close(o.point_m, [0.22, 0.10]), "{o:?}");
        // Within the slack: clear.
        assert_eq!(scene.overlap(&square(0.05, 0.10, -0.002, 0.04), 0.0025), None);
    }

    #[test]
    fn signed_distance_by_hand_at_a_thin_wall() {
        let scene = thin_wall();
        // In front of the near face: its edge (edge 3 runs down the near face).
        let (d, f, n, c) = scene.signed_distance([0.15, 0.10]);
        assert!((d - 0.05).abs() < 1e-12 && close(n, [-1.0, 0.0]) && close(c, [0.20, 0.10]), "{d} {n:?}");
        assert_eq!(f, Feature::Edge { solid: 1, edge: 3 });
        // Inside, nearer the far face.
        let (d, f, n, _) = scene.signed_distance([0.215, 0.10]);
        assert!((d + 0.005).abs() < 1e-12 && close(n, [1.0, 0.0]));
        assert_eq!(f, Feature::Edge { solid: 1, edge: 1 });
        // Diagonally above the far top corner: the vertex, normal towards p.
        let (d, f, n, c) = scene.signed_distance([0.23, 0.26]);
        assert!((d - 0.01 * 2f64.sqrt()).abs() < 1e-12 && close(n, [S, S]) && close(c, [0.22, 0.25]));
        assert_eq!(f, Feature::Vertex { solid: 1, vertex: 2 });
        // Above the floor away from the wall, and under it.
        let (d, f, n, _) = scene.signed_distance([0.5, -0.02]);
        assert!((d + 0.02).abs() < 1e-15 && n == [0.0, 1.0] && f == Feature::HalfPlane { solid: 0 });
    }

    #[test]
    fn vertex_normals_point_out_of_concave_polygons() {
        // An L whose reflex vertex 3 is at (1, 1); from inside it is the
        // closest point, and the normal points from p towards it.
        let l = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
        let scene = Scene::new("L", vec![Solid::Polygon { points_m: l }]).unwrap();
        let (d, f, n, _) = scene.signed_distance([0.9, 0.9]);
        assert_eq!(f, Feature::Vertex { solid: 0, vertex: 3 });
        assert!((d + 0.1 * 2f64.sqrt()).abs() < 1e-12 && close(n, [S, S]));
        // On the vertex itself: the bisector.
        let (d, _, n, _) = scene.signed_distance([1.0, 1.0]);
        assert!(d == 0.0 && close(n, [S, S]));
        // Both faces of the inside corner count from free space near it.
        let mut out = Vec::new();
        scene.features_near([1.05, 1.02], 0.1, &mut out);
        let features: Vec<_> = out.iter().map(|c| c.feature).collect();
        assert_eq!(features, vec![Feature::Edge { solid: 0, edge: 2 }, Feature::Edge { solid: 0, edge: 3 }]);
        // From inside, diagonally below it: the reflex vertex, negative.
        scene.features_near([0.95, 0.95], 0.1, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!(out[0].feature == Feature::Vertex { solid: 0, vertex: 3 } && out[0].distance < 0.0);
        // From inside under the lower face: that face alone, negative.
        scene.features_near([1.05, 0.95], 0.1, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!(out[0].feature == Feature::Edge { solid: 0, edge: 2 } && (out[0].distance + 0.05).abs() < 1e-12);
    }

    #[test]
    fn features_near_skip_back_faces_but_keep_them_inside() {
        let scene = thin_wall();
        let mut out = Vec::new();
        // Beside the far face, 5 mm out: the near face (25 mm behind) is not a contact.
        scene.features_near([0.225, 0.10], 0.05, &mut out);
        let features: Vec<_> = out.iter().map(|c| c.feature).collect();
        assert_eq!(features, vec![Feature::Edge { solid: 1, edge: 1 }]);
        // Inside the wall: both faces, negative.
        scene.features_near([0.205, 0.10], 0.05, &mut out);
        assert_eq!(out.len(), 2);
        assert!(out.iter().all(|c| c.distance < 0.0));
        // At the foot of the near face: the floor and the face (an inside corner).
        scene.features_near([0.19, 0.01], 0.02, &mut out);
        let features: Vec<_> = out.iter().map(|c| c.feature).collect();
        assert_eq!(features, vec![Feature::HalfPlane { solid: 0 }, Feature::Edge { solid: 1, edge: 3 }]);
        for c in &out {
            assert!(close(add_scaled(c.closest, c.distance, c.normal), [0.19, 0.01]));
        }
    }

    #[test]
    fn exposed_convex_corners_of_builtins() {
        let corners: Vec<_> = thin_wall().convex_corners().collect();
        // The two top corners; the bottom two are buried in the floor.
        assert_eq!(corners.iter().map(|c| c.vertex).collect::<Vec<_>>(), vec![2, 3]);
        assert!(close(corners[0].bisector, [S, S]) && close(corners[1].bisector, [-S, S]));
        assert!(corners.iter().all(|c| (c.interior_angle_rad - PI / 2.0).abs() < 1e-12));
        let step: Vec<_> = Scene::builtin("step").unwrap().convex_corners().map(|c| c.point).collect();
        assert_eq!(step, vec![[1.20, 0.10], [0.20, 0.10]]);
        // A box resting on the floor (not buried): its bottom corners lie on the floor.
        let rests = Scene::new(
            "box",
            vec![
                Solid::HalfPlane { point_m: [0.0, 0.0], normal: [0.0, 1.0] },
                Solid::Polygon { points_m: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]] },
            ],
        )
        .unwrap();
        let c: Vec<_> = rests.convex_corners().collect();
        assert_eq!(c.len(), 1);
        assert!(c[0].point == [0.0, 1.0] && (c[0].interior_angle_rad - PI / 4.0).abs() < 1e-12);
        assert_eq!(Scene::builtin("floor-to-wall").unwrap().convex_corners().count(), 0);
    }

    #[test]
    fn segment_corner_distance_by_hand() {
        let corner = thin_wall().convex_corners().next().unwrap(); // (0.22, 0.25)
        let (d, s, n) = Scene::segment_corner_distance([0.0, 0.30], [0.4, 0.30], &corner);
        assert!((d - 0.05).abs() < 1e-12 && (s - 0.55).abs() < 1e-12 && close(n, [0.0, 1.0]));
        let (d, s, n) = Scene::segment_corner_distance([0.3, 0.35], [0.3, 0.45], &corner);
        assert!((d - (0.08f64.powi(2) + 0.1f64.powi(2)).sqrt()).abs() < 1e-12 && s == 0.0 && n[0] > 0.0);
        // Touching: the bisector.
        let (d, _, n) = Scene::segment_corner_distance([0.22, 0.25], [0.3, 0.35], &corner);
        assert!(d == 0.0 && n == corner.bisector);
        // A point-like link.
        let (d, s, _) = Scene::segment_corner_distance([0.22, 0.26], [0.22, 0.26], &corner);
        assert!((d - 0.01).abs() < 1e-12 && s == 0.0);
    }

    #[test]
    #[should_panic(expected = "at least one solid")]
    fn signed_distance_needs_a_solid() {
        Scene { name: "none".into(), solids: Vec::new(), start: None }.signed_distance([0.0, 0.0]);
    }

    #[test]
    fn free_and_inside() {
        let scene = thin_wall();
        assert!(scene.is_free([0.1, 0.1], 0.05) && !scene.is_free([0.1, 0.1], 0.1 + 1e-9));
        assert!(!scene.is_free([0.17, 0.1], 0.05) && scene.is_free([0.17, 0.1], 0.03));
        assert!(scene.inside([0.21, 0.0]) && scene.inside([0.0, -1e-9]) && !scene.inside([0.0, 0.0]));
        assert!(!scene.inside([0.23, 0.1]) && !scene.inside([0.21, 0.2500001]));
        let empty = Scene { name: "none".into(), solids: Vec::new(), start: None };
        assert!(empty.is_free([0.0, 0.0], 1.0) && !empty.inside([0.0, 0.0]));
        assert!(empty.surface_frame([0.0, 0.0]).is_none());
    }

    #[test]
    fn surface_frames_follow_the_robot_convention() {
        let frame = |name: &str, p: Vec2| Scene::builtin(name).unwrap().surface_frame(p).unwrap();
        let (c, a) = frame("floor", [0.3, 0.2]);
        assert!(close(c, [0.3, 0.0]) && a == 0.0);
        let (c, a) = frame("wall", [-0.1, 0.2]);
        assert!(close(c, [0.0, 0.2]) && (a - PI / 2.0).abs() < 1e-15);
        let (c, a) = frame("ceiling", [-0.1, 0.2]);
        assert!(close(c, [-0.1, 0.25]) && (a - PI).abs() < 1e-15);
        // The far face of the thin wall runs down; its top runs along +x.
        let (_, a) = frame("thin-wall", [0.23, 0.1]);
        assert!((a + PI / 2.0).abs() < 1e-15);
        let (_, a) = frame("thin-wall", [0.21, 0.3]);
        assert!(a.abs() < 1e-15);
    }

    #[test]
    fn cups_lie_flat_on_one_edge_only() {
        let scene = thin_wall();
        let (w, dt, at) = (0.025, 1e-3, 0.02);
        assert!(scene.flat_on_one_edge([0.0, 0.0], 0.0, w, dt, at));
        assert!(scene.flat_on_one_edge([0.0, 0.0005], 0.01, w, dt, at));
        assert!(!scene.flat_on_one_edge([0.0, 0.002], 0.0, w, dt, at), "lifted");
        assert!(!scene.flat_on_one_edge([0.0, 0.0], 0.1, w, dt, at), "tilted");
        assert!(!scene.flat_on_one_edge([0.0, 0.0], PI, w, dt, at), "upside down");
        // Touching the foot of the wall is fine, straddling it is not.
        assert!(scene.flat_on_one_edge([0.175, 0.0], 0.0, w, dt, at));
        assert!(!scene.flat_on_one_edge([0.19, 0.0], 0.0, w, dt, at));
        assert!(!scene.flat_on_one_edge([0.21, 0.0], 0.0, w, dt, at));
        // Up the near face, clear of the floor; too low reaches into the floor.
        assert!(scene.flat_on_one_edge([0.20, 0.1], PI / 2.0, w, dt, at));
        assert!(!scene.flat_on_one_edge([0.20, 0.02], PI / 2.0, w, dt, at));
        // Down the far face; the top is narrower than the cup.
        assert!(scene.flat_on_one_edge([0.22, 0.1], -PI / 2.0, w, dt, at));
        assert!(!scene.flat_on_one_edge([0.22, 0.1], PI / 2.0, w, dt, at));
        assert!(!scene.flat_on_one_edge([0.21, 0.25], 0.0, w, dt, at));
        assert!(scene.flat_on_one_edge([0.21, 0.25], 0.0, 0.009, dt, at));
        // Past the top of the near face (within the slack, then beyond).
        assert!(scene.flat_on_one_edge([0.20, 0.2255], PI / 2.0, w, dt, at));
        assert!(!scene.flat_on_one_edge([0.20, 0.24], PI / 2.0, w, dt, at));
    }
}
