//! Contacts between the tubes and a scene's solids: frictionless, one-sided
//! rows found from the geometry and refreshed until they settle.
//!
//! # Rows
//!
//! A contact holds a material point `x` of a tube (a node, or a point a
//! fraction `s` along a link where a corner pokes between nodes) on the free
//! side of a surface, with the tube's radius `r` of clearance:
//!
//! ```text
//! C(q) = n . x(q) - h >= 0,      h = n . c + r                        (m)
//! ```
//!
//! with `n` the surface's outward unit normal and `c` the surface point
//! closest to `x` (the corner itself for a corner). `x` is a sum of terms
//! each in one coordinate (`l_j e(phi_j)`, the unit's pose), so the row's
//! Hessian is diagonal, as the solver wants. `n`, `c` and `s` are frozen
//! while Newton runs and refreshed from the new geometry after it
//! converges; at the fixed point `n` is the true contact normal (the
//! surface's normal at an edge, the direction from a vertex or corner to the
//! point), so the frozen rows are the exact frictionless contact conditions.
//! Their multipliers are the normal forces (N), `>= 0`.
//!
//! # Candidates
//!
//! Every node within [`ContactOptions::margin`] of a surface (its
//! clearance included) gets a row per nearby feature (edge, half-plane,
//! vertex), and every link within it of a convex corner gets a row at the
//! link's closest point: a thin wall's corner can touch a link between its
//! nodes, where node checks alone would miss it. The clamps (node 0) belong
//! to the driving unit (or the fixed clamp) and are not checked; with the
//! front cup holding, neither are the last links, which the plate's pose
//! fixes ([`Touching::held_by_front`]).
//!
//! # Swept motion
//!
//! Rows are refreshed only at solved shapes, so a stage may move the tubes
//! only as far as they cannot pass through a solid unseen. Between two
//! solved shapes every point is taken to move on a straight line (a node to
//! its new place, a link's points with its ends). The motion is clear when,
//! for every polygon, every moving point's path `d` satisfies
//!
//! ```text
//! |d| <= g_before + g_after,     g = distance from the centre line to the polygon   (m)
//! ```
//!
//! (distance is 1-Lipschitz: were the point inside somewhere along the path,
//! it would be farther than `g_before` from where it started or than
//! `g_after` from where it ends), and likewise for every link against every
//! convex corner, each of its points moving at most as far as its farther
//! end. The centre line's distance, not the clearance's: a tube resting on a
//! face (`g = r` at both ends) may slide `2 r` in a step, and to pass through
//! a solid unseen it would have to cross the solid's thickness. Half-planes
//! need no test: both shapes are on their free side and so is everything
//! between (it is convex).
//!
//! # Systems
//!
//! Everything here works on any [`Touching`] system: the two-tube body
//! ([`crate::stance::FloatingBody`]) and the single clamped tube ([`crate::stance::Tube`]).

use crate::chain::Chain;
use crate::geom::{dot, norm, sub, Vec2};
use crate::hose::{Stop, StopRow};
use crate::scene::{Scene, Solid};
use crate::statics::{Evaluation, Stage, StaticSystem};

/// The pseudo-chain of contact rows on the rear cup's face (its `link` is
/// the rim: 0 behind, 1 ahead). A cup that does not hold rests on what its
/// face meets, with no clearance: its face is what touches.
pub const REAR_CUP: usize = 2;

/// The pseudo-chain of contact rows on the front cup's face.
pub const FRONT_CUP: usize = 3;

/// The pseudo-chain of contact rows on the driving unit's outline (its
/// `link` a corner, [`crate::stance::Unit`]), where the unit is free.
pub const UNIT: usize = 4;

/// Whether a contact row's `chain` is a face of the robot (a cup's face, the
/// driving unit's outline) rather than a tube: it touches with no clearance.
pub fn on_face(chain: usize) -> bool {
    chain >= REAR_CUP
}

/// A face of the robot that rests on the solids with no clearance: a free
/// cup's face (its two rims, open) or the free driving unit's outline (its
/// corners, closed). Its rows are at its corners (`fraction` 1, `link` the
/// corner) and where a convex corner of a solid touches it between two
/// (`link` the edge from corner `link` to the next, `fraction` the way along).
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// Its pseudo-chain: [`REAR_CUP`], [`FRONT_CUP`] or [`UNIT`].
    pub chain: usize,
    /// Its corners (m).
    pub corners: Vec<Vec2>,
    /// Whether the last corner joins the first (an outline).
    pub closed: bool,
}

impl Face {
    /// Its edges: `(k, [corner k, corner k + 1])`, the last back to the
    /// first where it is closed.
    pub fn edges(&self) -> impl Iterator<Item = (usize, [Vec2; 2])> + '_ {
        let n = self.corners.len();
        let edges = if self.closed { n } else { n.saturating_sub(1) };
        (0..edges).map(move |k| (k, [self.corners[k], self.corners[(k + 1) % n]]))
    }

    /// The point of a row on it: corner `link` (`fraction >= 1`), or
    /// `fraction` of the way along edge `link`.
    pub fn point(&self, link: usize, fraction: f64) -> Vec2 {
        point_on(&self.corners, link, fraction)
    }

    /// How deep a point `p` lies inside a closed, convex face (m; <= 0 outside).
    fn depth_of(&self, p: Vec2) -> f64 {
        if !self.closed {
            return 0.0;
        }
        let area: f64 = self.edges().map(|(_, [a, b])| crate::geom::cross(a, b)).sum();
        let inward = area.signum();
        self.edges()
            .map(|(_, [a, b])| {
                let length = norm(sub(b, a));
                if length > 0.0 {
                    inward * crate::geom::cross(sub(b, a), sub(p, a)) / length
                } else {
                    f64::INFINITY
                }
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The point of a row on a face with these `corners` (in any frame):
/// corner `link` (`fraction >= 1`), or `fraction` of the way along the edge
/// from corner `link` to the next ([`Face::point`]).
pub fn point_on(corners: &[Vec2], link: usize, fraction: f64) -> Vec2 {
    let a = corners[link];
    if fraction >= 1.0 {
        return a;
    }
    let b = corners[(link + 1) % corners.len()];
    [a[0] + fraction * (b[0] - a[0]), a[1] + fraction * (b[1] - a[1])]
}

/// The rigid body a face is part of: the driving unit carries the rear
/// cup's face and the outline, the plate the front cup's face.
pub fn rigid_body_of(chain: usize) -> usize {
    usize::from(chain == FRONT_CUP)
}

/// Rows on one rigid body, kept only where independent of those kept before.
/// A row `n . x >= h` on a rigid body (in the plane) has the direction
/// `[n, (x - o) x n]` in the body's three coordinates about any point `o`;
/// at most three are independent, and rows whose directions are dependent
/// (three rims and corners on one floor, or two on one line of action) make
/// the working set's Jacobian singular where they act together.
#[derive(Clone, Debug, Default)]
pub(crate) struct RigidRows {
    origin: Option<Vec2>,
    /// Orthonormal directions of the rows kept.
    basis: Vec<[f64; 3]>,
}

impl RigidRows {
    /// Whether a row at `x` (m) with normal `n` is independent of the rows
    /// kept; if so it is kept.
    pub(crate) fn admits(&mut self, x: Vec2, n: Vec2) -> bool {
        let o = *self.origin.get_or_insert(x);
        let mut v = [n[0], n[1], crate::geom::cross(sub(x, o), n)];
        for b in &self.basis {
            let d = v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
            v = [v[0] - d * b[0], v[1] - d * b[1], v[2] - d * b[2]];
        }
        let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        // A unit normal is 1 long: what is left of it is rounding where the
        // row is a combination of the others.
        if length < 1e-9 {
            return false;
        }
        self.basis.push(v.map(|x| x / length));
        true
    }
}

/// A static system whose chains may touch a scene's solids: what contact
/// detection and the staged solves among solids need of it. Its contact
/// rows are its last rows.
pub trait Touching: StaticSystem + Sized + Clone {
    /// Number of chains.
    fn chain_count(&self) -> usize;
    /// Chain `c`'s centre line where it is (m): the clamp, the first joint
    /// when there is a rigid root piece, then every link's tip (the last
    /// [`Touching::chain_len`] points).
    fn chain_points(&self, q: &[f64], c: usize) -> Vec<Vec2>;
    /// Number of links of chain `c`.
    fn chain_len(&self, c: usize) -> usize;
    /// The contact rows.
    fn contacts(&self) -> &[ContactRow];
    /// The same system with these contact rows (replacing any it had).
    fn with_contacts(self, contacts: Vec<ContactRow>) -> Self;
    /// The stage the system's solves run at (for the solver's reports).
    fn stage(&self) -> Stage;

    /// Whether a hold fixes the point a fraction `fraction` along link
    /// `link` of chain `c` (1: the link's tip): such points get no contact
    /// rows (a row there would be a combination of the hold's) and count for
    /// no penetration. None by default.
    fn held_by_front(&self, _c: usize, _link: usize, _fraction: f64) -> bool {
        false
    }

    /// The robot's faces that rest on the solids: the faces of the cups
    /// that do not hold and the free driving unit's outline. None by default.
    fn free_faces(&self, _q: &[f64]) -> Vec<Face> {
        Vec::new()
    }

    /// The robot's face `chain` where it is at `q`, whether free or not: a
    /// row carried onto a face whose cup has since attached (a hand-over)
    /// still has its point. By default the free face of that chain.
    fn face(&self, q: &[f64], chain: usize) -> Option<Face> {
        self.free_faces(q).into_iter().find(|f| f.chain == chain)
    }

    /// The first contact row's index.
    fn contact_row(&self) -> usize {
        self.rows() - self.contacts().len()
    }

    /// The hose's stop of chain `c`'s joints ([`crate::hose`]); `None`, the
    /// default, where the chain has no stop.
    fn stop(&self, _c: usize) -> Option<Stop> {
        None
    }

    /// Chain `c`'s joint turns at `q` into `out` (rad, cleared first; 0 at
    /// the clamp), where [`Touching::stop`] gives a stop.
    fn joint_turns(&self, _q: &[f64], _c: usize, out: &mut Vec<f64>) {
        out.clear();
    }

    /// The hose's stop rows, just before the contact rows. None by default.
    fn stops(&self) -> &[StopRow] {
        &[]
    }

    /// The same system with these stop rows (replacing any it had). A
    /// system without a stop ([`Touching::stop`]) is given none.
    fn with_stops(self, stops: Vec<StopRow>) -> Self {
        assert!(stops.is_empty(), "stop rows for a system without a hose stop");
        self
    }

    /// The first stop row's index: the rows before it (the weld's, the
    /// holds') are the system's own.
    fn stop_row(&self) -> usize {
        self.contact_row() - self.stops().len()
    }

    /// Where contact row `contact` touches (m).
    fn contact_point(&self, q: &[f64], contact: &ContactRow) -> Vec2 {
        if on_face(contact.chain) {
            let face = self.face(q, contact.chain).expect("a row on one of the robot's faces");
            return face.point(contact.link, contact.fraction);
        }
        let points = self.chain_points(q, contact.chain);
        // The link's start is the point before its tip.
        let tip = points.len() - self.chain_len(contact.chain) + contact.link;
        let (a, b) = (points[tip - 1], points[tip]);
        [a[0] + contact.fraction * (b[0] - a[0]), a[1] + contact.fraction * (b[1] - a[1])]
    }
}

/// One contact row: a point of a chain held off a surface.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ContactRow {
    /// The chain: 0 for A, 1 for B; [`REAR_CUP`], [`FRONT_CUP`] or [`UNIT`] for a face.
    pub chain: usize,
    /// The link (0-based) the point is on; on a face, a corner or edge
    /// ([`Face`]; a cup's rims: 0 behind, 1 ahead).
    pub link: usize,
    /// How far along the link (1 at its tip: node `link + 1`). On a face: 1
    /// at corner `link`; below 1, a convex corner of a solid touching edge
    /// `link`, this fraction of the way along it.
    pub fraction: f64,
    /// Outward unit normal of the surface, frozen (into free space).
    pub normal: Vec2,
    /// `h = n . c + r` (m): the row is `n . x - h >= 0`.
    pub offset: f64,
}

/// Contact row `row`'s terms in the angles of `chain` (its coordinates
/// from `first` in `q`), after the potential filled `ev`'s trigonometry:
/// the point is `x = start + sum_{j < link} l_j e(phi_j) + s l_link e(phi_link)`,
/// so `dC/dphi_j = lever_j n . e'(phi_j)` and `d2C/dphi_j^2 = -lever_j n . e(phi_j)`
/// (diagonal). Returns `x` (m); the caller writes the row's value and any
/// other coordinates' terms.
pub(crate) fn chain_terms(
    chain: &Chain,
    first: usize,
    start: Vec2,
    row: usize,
    contact: &ContactRow,
    ev: &mut Evaluation,
) -> Vec2 {
    let (m, normal) = (ev.rows(), contact.normal);
    let mut x = start;
    for (j, l) in chain.lengths()[..=contact.link].iter().enumerate() {
        let i = first + j;
        let lever = if j == contact.link { contact.fraction * l } else { *l };
        let (c, s) = (ev.cos[i], ev.sin[i]);
        x = [x[0] + lever * c, x[1] + lever * s];
        ev.jacobian[i * m + row] = lever * (normal[1] * c - normal[0] * s);
        ev.curvature[i * m + row] = -lever * (normal[0] * c + normal[1] * s);
    }
    x
}

/// Tuning knobs of contact detection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactOptions {
    /// Points closer than this to a surface (beyond the tube's radius) get a
    /// candidate row (m). Rows that do not touch stay inactive and cost little.
    pub margin: f64,
    /// Rounds of refreshing the rows at one stage before giving up.
    pub max_rounds: usize,
    /// Largest penetration accepted (m).
    pub penetration_tolerance: f64,
    /// Whether a free cup's face gets every row a node would: a row per
    /// nearby face at each rim (both faces of an inside corner) and one
    /// where a convex corner touches the face between its rims. Off, each
    /// rim takes the closest surface alone (the plain pass of the staged
    /// solve, which keeps every earlier answer; see `scene_solve`).
    pub whole_faces: bool,
    /// Whether a staged settle that the plain active set cannot finish is
    /// tried again with blocking rows (see `scene_solve`). A feeding step
    /// that is not its last chance leaves it off: halving it keeps the
    /// branch a continuous feed follows, the fallback only where nothing
    /// else settles.
    pub fallback: bool,
}

impl Default for ContactOptions {
    fn default() -> Self {
        ContactOptions { margin: 0.005, max_rounds: 30, penetration_tolerance: 1e-9, whole_faces: true, fallback: true }
    }
}

/// Finds the contact candidates of the body at `q` in `scene`, tube radius
/// `radius` (m), into `out` (cleared first).
pub fn detect<S: Touching>(
    body: &S,
    q: &[f64],
    scene: &Scene,
    radius: f64,
    options: &ContactOptions,
    out: &mut Vec<ContactRow>,
) {
    out.clear();
    let reach = radius + options.margin;
    let mut near = Vec::new();
    let corners: Vec<_> = scene.convex_corners().collect();
    for chain in 0..body.chain_count() {
        let points = body.chain_points(q, chain);
        // The clamp (and a rigid root piece) belong to the driving unit; the
        // links' tips are the last points.
        let first_tip = points.len() - body.chain_len(chain);
        for (link, p) in points[first_tip..].iter().enumerate() {
            if body.held_by_front(chain, link, 1.0) {
                continue;
            }
            scene.features_near(*p, reach, &mut near);
            for candidate in &near {
                let n = candidate.normal;
                let offset = dot(n, candidate.closest) + radius;
                out.push(ContactRow { chain, link, fraction: 1.0, normal: n, offset });
            }
        }
        for (link, pair) in points[first_tip - 1..].windows(2).enumerate() {
            for corner in &corners {
                let (distance, s, n) = Scene::segment_corner_distance(pair[0], pair[1], corner);
                // At a link's end the node's own vertex row covers it.
                if distance <= reach && s > 1e-9 && s < 1.0 - 1e-9 && !body.held_by_front(chain, link, s) {
                    out.push(ContactRow { chain, link, fraction: s, normal: n, offset: dot(n, corner.point) + radius });
                }
            }
        }
    }
    // A face's corner (a cup's rim) gets a row per nearby feature, as a
    // node does: in an inside corner it touches both faces, and one row for
    // the closest alone switches between them from one refresh to the next.
    // A face may also start inside a solid (a released unit that hung
    // through a floor in free space): then its corners take the closest
    // surface at any depth as well.
    for face in body.free_faces(q) {
        for (link, p) in face.corners.iter().enumerate() {
            near.clear();
            if options.whole_faces {
                scene.features_near(*p, options.margin, &mut near);
            }
            for candidate in &near {
                let n = candidate.normal;
                out.push(ContactRow {
                    chain: face.chain,
                    link,
                    fraction: 1.0,
                    normal: n,
                    offset: dot(n, candidate.closest),
                });
            }
            let (distance, _, n, closest) = scene.signed_distance(*p);
            let listed = near
                .iter()
                .any(|c| dot(c.normal, n) > 1.0 - 1e-12 && (dot(n, closest) - dot(n, c.closest)).abs() < 1e-12);
            if distance <= options.margin && !listed {
                out.push(ContactRow { chain: face.chain, link, fraction: 1.0, normal: n, offset: dot(n, closest) });
            }
        }
        // A face resting on a nosing touches it between its corners.
        for (link, edge) in face.edges() {
            for corner in corners.iter().filter(|_| options.whole_faces) {
                let (distance, s, n) = Scene::segment_corner_distance(edge[0], edge[1], corner);
                let n = face_corner_normal(edge, corner).unwrap_or(n);
                if distance <= options.margin && s > 1e-9 && s < 1.0 - 1e-9 {
                    out.push(ContactRow {
                        chain: face.chain,
                        link,
                        fraction: s,
                        normal: n,
                        offset: dot(n, corner.point),
                    });
                }
            }
        }
    }
}

/// The normal of a row where `corner` touches a face's `edge`: the
/// face's own normal, pointing out of the solid, where the solid's wedge at
/// the corner lies on one side of the face's line (the face rests on the
/// corner, or is a hair past it). The face touches with no clearance, so the
/// direction from the corner to the face's closest point is rounding at
/// the fixed point: it turned by 1e-4 from one refresh to the next (each
/// refresh a new row, the settle never done), and a hair past the corner it
/// pointed into the solid (a row holding the face on the wrong side).
/// `None` where the face's line cuts the wedge: the face is through the
/// corner, and only the geometry says which way is out.
fn face_corner_normal(edge: [Vec2; 2], corner: &crate::scene::Corner) -> Option<Vec2> {
    let along = sub(edge[1], edge[0]);
    let length = norm(along);
    if length == 0.0 {
        return None;
    }
    let normal = [-along[1] / length, along[0] / length];
    // The wedge's directions are within half its angle of the inward
    // bisector: all on one side of the line when the face's normal is
    // within 90 degrees less that half angle of the bisector, either way.
    let cosine = dot(normal, corner.bisector);
    let one_side = cosine.abs() >= (0.5 * corner.interior_angle_rad).sin();
    one_side.then(|| if cosine > 0.0 { normal } else { [-normal[0], -normal[1]] })
}

/// The deepest penetration (m, positive inside the clearance) of any node
/// or link of the body at `q`, by the scene's exact geometry. The points a
/// hold fixes ([`Touching::held_by_front`]) are left out: where they are is
/// the hold's pose, which no solve can change.
pub fn penetration<S: Touching>(body: &S, q: &[f64], scene: &Scene, radius: f64) -> f64 {
    let mut deepest: f64 = 0.0;
    let corners: Vec<_> = scene.convex_corners().collect();
    for chain in 0..body.chain_count() {
        let points = body.chain_points(q, chain);
        let first_tip = points.len() - body.chain_len(chain);
        for (link, p) in points[first_tip..].iter().enumerate() {
            if !body.held_by_front(chain, link, 1.0) {
                deepest = deepest.max(radius - scene.signed_distance(*p).0);
            }
        }
        for (link, pair) in points[first_tip - 1..].windows(2).enumerate() {
            for corner in &corners {
                let (distance, s, _) = Scene::segment_corner_distance(pair[0], pair[1], corner);
                if !body.held_by_front(chain, link, s) {
                    deepest = deepest.max(radius - distance);
                }
            }
        }
    }
    for face in body.free_faces(q) {
        for p in &face.corners {
            deepest = deepest.max(-scene.signed_distance(*p).0);
        }
        // A solid's corner poking into an outline between its corners.
        for corner in &corners {
            deepest = deepest.max(face.depth_of(corner.point));
        }
    }
    deepest
}

/// The farthest any node or free face's corner of `body` moved between `a`
/// and `b` (m).
pub(crate) fn displacement<S: Touching>(body: &S, a: &[f64], b: &[f64]) -> f64 {
    let far = |x: &[Vec2], y: &[Vec2]| x.iter().zip(y).fold(0.0f64, |m, (p, r)| m.max(norm(sub(*p, *r))));
    let chains = (0..body.chain_count()).map(|c| far(&body.chain_points(a, c), &body.chain_points(b, c)));
    let faces = body.free_faces(a).into_iter().zip(body.free_faces(b)).map(|(x, y)| far(&x.corners, &y.corners));
    chains.chain(faces).fold(0.0, f64::max)
}

/// The length of a polyline (m).
fn polyline_length(points: &[Vec2]) -> f64 {
    points.windows(2).map(|w| norm(sub(w[1], w[0]))).sum()
}

/// The point at arc length `s` (m) along a polyline from its first point
/// (the first point for `s <= 0`, the last beyond its end).
fn point_along(points: &[Vec2], s: f64) -> Vec2 {
    let mut left = s;
    for w in points.windows(2) {
        let l = norm(sub(w[1], w[0]));
        if left <= l {
            let t = if l > 0.0 { left.max(0.0) / l } else { 0.0 };
            return [w[0][0] + t * (w[1][0] - w[0][0]), w[0][1] + t * (w[1][1] - w[0][1])];
        }
        left -= l;
    }
    points[points.len() - 1]
}

/// Whether the tubes could have moved from `before` to `after` (each a
/// system and its `q`; the systems may differ in links: points are matched
/// by their arc length from the tip) on straight paths without their centre lines entering a polygon
/// or crossing a convex corner (see the module's "Swept motion").
pub fn swept_clear<A: Touching, B: Touching>(before: (&A, &[f64]), after: (&B, &[f64]), scene: &Scene) -> bool {
    let polygons: Vec<usize> =
        (0..scene.solids.len()).filter(|i| matches!(scene.solids[*i], Solid::Polygon { .. })).collect();
    if polygons.is_empty() {
        return true;
    }
    let corners: Vec<_> = scene.convex_corners().collect();
    let gap = |p: Vec2, solid: usize| scene.solid_distance(solid, p);
    (0..after.0.chain_count()).all(|chain| {
        let old = before.0.chain_points(before.1, chain);
        let new = after.0.chain_points(after.1, chain);
        let (old_tips, new_tips) = (before.0.chain_len(chain), after.0.chain_len(chain));
        let (old_first, new_first) = (old.len() - old_tips, new.len() - new_tips);
        // Node `i` of the new shape (from its first tip) and where it was:
        // the material the same arc length from the tip (feeding adds tube at
        // the clamp; the links are a mesh over it, remeshed as it grows), or
        // the clamp for tube fed out since.
        let old_line = &old[old_first - 1..];
        let new_line = &new[new_first - 1..];
        let (old_length, new_length) = (polyline_length(old_line), polyline_length(new_line));
        let mut along = 0.0;
        let new_arc: Vec<f64> = std::iter::once(0.0)
            .chain(new_line.windows(2).map(|w| {
                along += norm(sub(w[1], w[0]));
                along
            }))
            .collect();
        let was = |i: usize| point_along(old_line, old_length - (new_length - new_arc[i + 1]));
        let nodes_clear = (0..new_tips).all(|i| {
            let (a, b) = (was(i), new[new_first + i]);
            let moved = norm(sub(b, a));
            polygons.iter().all(|s| moved <= gap(a, *s) + gap(b, *s))
        });
        let links_clear = (0..new_tips).all(|i| {
            let (a0, b0) = (if i == 0 { old_line[0] } else { was(i - 1) }, was(i));
            let (a1, b1) = (new[new_first + i - 1], new[new_first + i]);
            let moved = norm(sub(a1, a0)).max(norm(sub(b1, b0)));
            corners.iter().all(|c| {
                let before = Scene::segment_corner_distance(a0, b0, c).0;
                let after = Scene::segment_corner_distance(a1, b1, c).0;
                moved <= before + after
            })
        });
        nodes_clear && links_clear
    }) && rims_clear(before, after, scene, &corners)
}

/// Whether the free faces (cups' faces, the unit's outline) could have
/// moved from `before` to `after` without passing through a polygon
/// ([`Scene::face_sweep_clear`], edge by edge): the test of [`swept_clear`]
/// for the faces, which rest on the solids with no clearance, so that a
/// feeding step cannot tunnel a cup or the unit through a nosing.
fn rims_clear<A: Touching, B: Touching>(
    before: (&A, &[f64]),
    after: (&B, &[f64]),
    scene: &Scene,
    corners: &[crate::scene::Corner],
) -> bool {
    let old = before.0.free_faces(before.1);
    after.0.free_faces(after.1).iter().all(|now| match old.iter().find(|was| was.chain == now.chain) {
        Some(was) => was.edges().zip(now.edges()).all(|((_, a), (_, b))| scene.face_sweep_clear(a, b, corners)),
        None => true,
    })
}
