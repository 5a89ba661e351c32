//! Contact rows of the 3D body with a [`Scene3`]'s solids (docs/model3d.md
//! section 12): unilateral, at the link points (each link's tip, as the
//! planar stance uses its points), each against the plane of a solid within
//! reach (a tip in a corner gets a row for each solid; frozen while the row
//! is active) moved out by the tube's radius (the clearance the centre line
//! keeps), under any of the holds of [`crate::hold::front3`].
//! [`crate::stance3::solve_in`] is the entry point:
//!
//! ```
//! use leech::body3::Body3;
//! use leech::hold::{AsBuilt, Hold3, Pose3};
//! use leech::prelude::*;
//! use leech::scene::{Scene3, Solid3};
//! use leech::stance3;
//! let mut robot = Robot::builtin();
//! robot.world.base_angle_deg = 0.0; // the driving unit along a floor
//! let body = Body3::from_robot(&robot, [0.34, 0.36, 0.28]).unwrap();
//! // The floor under the rear cup's face.
//! let floor = Solid3::HalfSpace { point_m: body.rear_cup_centre(&robot), normal: [0.0, 1.0, 0.0] };
//! let scene = Scene3::new("floor", vec![floor]).unwrap();
//! let held = stance3::solve_in(&robot, &body, Hold3::Rear(AsBuilt), &scene, &Solver::default()).unwrap();
//! assert!(held.equilibrium.contacts.iter().all(|c| c.force_n >= 0.0));
//! ```
//!
//! # The row
//!
//! Link `j` of tube `i` ends at `p_ij = root_i + sum_{k <= j} l_ik R_ik e_x`.
//! Against the plane `(x0, n)` its gap, and the sign rules of a contact, are
//!
//! ```text
//! g = n . (p_ij - x0) >= 0           (m)     the point stays out of the solid
//! mu >= 0                            (N)     the contact force mu n pushes
//! mu g = 0                                   force only where the gap is closed
//! ```
//!
//! (with the clearance `r`, `x0` is the solid's plane point moved by `r n`).
//! The Lagrangian gets `-mu g`. In local rotation coordinates
//! (`R_ik <- R_ik Exp(delta_k)`) each link `k <= j` of the tube enters `g`
//! through a linear term `n . (R_ik Exp(delta_k) a_k)`, `a_k = l_ik e_x`
//! (docs/model3d.md section 4), so
//!
//! ```text
//! dg/ddelta_k        = a_k x (R_ik^T n)                                        (m/rad)
//! d2(-mu g)/ddelta_k^2 = -mu ( sym(w a_k^T) - (w . a_k) I ),   w = R_ik^T n     (J/rad^2)
//! ```
//!
//! and no second derivative couples two links: a contact row adds to the
//! diagonal 3 x 3 blocks only, and its Jacobian (dense along the tube up to
//! link `j`) is one more border row of the factorization, as the weld's
//! are. The multiplier `mu` is the normal force (N) on the point.
//!
//! # Under the front hold
//!
//! Held at the front, the solver keeps the driving unit fixed and turns the
//! world with the plate ([`crate::stance3::held3`]): a picture's point `x'` is at
//! `x = G (x' - x'_tip) + P_f`, `G = R_f R'_P^T`, with `R'_P` unknown. So
//! the solids move with the plate, and the gap of the same tip is
//!
//! ```text
//! g = n . (G (x'_ij - x'_tip) + P_f - x0) = (R'_P nu) . (K + sum_k c_k R'_k e_x) - nu . q0     (m)
//! nu = R_f^T n,   q0 = R_f^T (x0 - P_f)        the plane in the held plate's frame, origin tube 1's tip
//! K  = root_i - root_1                                                                           (m)
//! c_k = l_ik [k <= j on tube i] - l_1k [k on tube 1]                                             (m)
//! ```
//!
//! (the tip `x'_tip` is tube 1's: every link of tube 1 beyond the point
//! enters, and for a point on tube 2 or 3 all of them). It is the hanging
//! gravity's form (`V_g / g`, [`crate::stance3::held3`] module doc) with `u = nu`,
//! and `Body3::plate_bilinear` gives both. With `s = R'_P nu`,
//! `w_k = R'_k^T s` and `W = R'_P^T (K + sum_k c_k R'_k e_x)`:
//!
//! ```text
//! dg/ddelta_k            = c_k e_x x w_k                                     (m/rad)
//! d2g/ddelta_k^2         = c_k ( sym(w_k e_x^T) - (w_k . e_x) I )            (m/rad^2)
//! d2g/ddelta_P ddelta_k  = -c_k [nu] R'_P^T R'_k [e_x]                       (m/rad^2)
//! dg/ddelta_P            = nu x W,    d2g/ddelta_P^2 = sym(W nu^T) - (W . nu) I     (m/rad, m/rad^2)
//! ```
//!
//! (the plate's own link adds the constant `c_P nu_x`); the Lagrangian's
//! blocks are these times `-mu`. Two links couple only through the plate,
//! whose coordinates are already border rows reaching every block of the
//! hanging body's factorization: a row's cross blocks cost nothing new and
//! its Jacobian, dense along tube 1, is one border row as under the rear
//! hold. The tips of each tube's last two links get no row: the hold fixes
//! them (tube 1's last link is the plate, the side tubes' are welded to it
//! in position and rotation), so a row there would be zero or a combination
//! of the weld's, as the planar stance leaves them out too.
//!
//! # The active set
//!
//! Gravity is raised in stages; at each, the body is settled (Newton with
//! the inertia test) and the active set updated until it stands: the row
//! pulling hardest (`mu < -tol k / l`) is released, else each tube's
//! deepest link tip inside a solid (`g < -tol l`) gets a row with `mu = 0`
//! (docs/model3d.md section 12): one row per solid at a tip, and a plane
//! facing the way of one the tip already has a row on (normals within 1e-3
//! rad) replaces it, since two such rows at one point would be dependent.
//! On a free front joint each turn of the swing is settled so from the last
//! turn's shape and rows (a warm start at full gravity). The rear cup's
//! reaction takes the contact forces off the tubes' root forces; the front
//! cup's, off the whole body's weight and moment ([`crate::stance3::held3`]).

use crate::body3::body3::{Body3, Param, Terms3, PLATE_ROWS};
use crate::geom3::{apply, apply_t, axpy, dot, linear_terms, scale, scale_mat, Mat3, Vec3};
use crate::hold::front3::{FrontHold, FRONT_ROWS};
use crate::scene::{Plane3, Scene3};
use crate::statics::Evaluation;

/// A contact row: the tip of link `link` of tube `tube` (0, 1, 2) against
/// `plane`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactRow3 {
    /// The tube (0, 1, 2 for tubes 1, 2, 3).
    pub tube: usize,
    /// The link whose tip touches.
    pub link: usize,
    /// The solid's index in its scene.
    pub solid: usize,
    /// The plane the gap is measured to.
    pub plane: Plane3,
}

/// A contact of an equilibrium: its row, the point (m) and the normal
/// force `mu` (N, along the plane's normal: the multiplier of the row).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact3 {
    /// The row.
    pub row: ContactRow3,
    /// The touching point (m).
    pub point_m: Vec3,
    /// The normal force on the body (N): `force_n * row.plane.normal`.
    pub force_n: f64,
}

/// Which cups hold the body whose contact rows are sought.
#[derive(Clone, Copy, Debug)]
pub(crate) enum HeldAt<'a> {
    /// The rear cup alone: the body as built.
    Rear,
    /// Both cups: the body as built, its plate fixed too.
    Both,
    /// The front cup alone: the solver's picture of that hold.
    Front(&'a FrontHold),
}

/// Where a run-time row's terms go, row `r` of `ev`'s: its Jacobian
/// (at `i m + r`), with `HESSIAN` its diagonal Hessian blocks and, where the
/// row couples a link with the plate (link `plate`; the solids turning with
/// it under a front hold), the cross block.
pub(crate) fn row_sink<const HESSIAN: bool>(
    ev: &mut Evaluation,
    r: usize,
    plate: usize,
) -> impl FnMut(usize, Vec3, Mat3, Option<Mat3>) + '_ {
    let m = ev.rows();
    move |u, grad, hess, cross| {
        for (c, g) in grad.iter().enumerate() {
            ev.jacobian[(3 * u + c) * m + r] = *g;
        }
        if HESSIAN {
            ev.add_hessian(u, u, &hess);
            if let Some(cross) = cross {
                ev.add_hessian(plate, u, &cross);
            }
        }
    }
}

impl Body3 {
    /// The body's evaluation with the run-time rows after the weld's 12:
    /// the front hold's six when `param` holds the front too, then the
    /// contact rows `rows`, each contact's value its gap (m). The weld's
    /// multipliers are `lambda[..12]`, the run-time rows' (the front
    /// hold's, then the contacts' forces) `lambda[12..]`; `ev` holds
    /// `12 + 6 + rows.len()` rows (without the front hold's six when it
    /// does not hold). With `HESSIAN`, the rows' Hessian blocks are added to
    /// the Lagrangian's; without it, no Hessian at all.
    pub(crate) fn evaluate_rows<const HESSIAN: bool>(
        &self,
        frames: &[Mat3],
        lambda: &[f64],
        param: Param,
        rows: &[ContactRow3],
        ev: &mut Evaluation,
    ) {
        let (weld, extra) = lambda.split_at(PLATE_ROWS);
        let weld: &[f64; PLATE_ROWS] = weld.try_into().expect("the weld's 12 multipliers come first");
        self.evaluate::<HESSIAN>(frames, weld, param, ev);
        let held = if param.front.is_some() { FRONT_ROWS } else { 0 };
        assert_eq!(ev.rows(), PLATE_ROWS + held + rows.len(), "evaluate_rows: storage for every row");
        if let Some(target) = &param.front {
            self.add_front_rows::<HESSIAN>(frames, target, &extra[..FRONT_ROWS], ev);
        }
        let plate = self.links() - 1;
        for (r, (row, mu)) in rows.iter().zip(&extra[held..]).enumerate() {
            let r = PLATE_ROWS + held + r;
            let sink = row_sink::<HESSIAN>(ev, r, plate);
            let gap = if param.hang.is_some() {
                // Under the front hold the solids turn with the plate: the
                // gap couples the plate with every link it reaches.
                self.front_contact_terms(frames, row, *mu, sink)
            } else {
                let mut sink = sink;
                self.contact_terms(frames, row, *mu, |u, grad, hess| sink(u, grad, hess, None));
                self.contact_gap(frames, row)
            };
            ev.constraints[r] = gap;
        }
    }

    /// The tip of link `link` of tube `tube` (m).
    pub fn link_tip(&self, frames: &[Mat3], tube: usize, link: usize) -> Vec3 {
        let t = self.tube(tube);
        t.lengths()[..=link].iter().enumerate().fold(t.root(), |p, (k, l)| {
            let r = self.frame(frames, tube, k);
            axpy(*l, [r[0][0], r[1][0], r[2][0]], p)
        })
    }

    /// The row's gap `g` (m, module doc).
    pub fn contact_gap(&self, frames: &[Mat3], row: &ContactRow3) -> f64 {
        row.plane.gap(self.link_tip(frames, row.tube, row.link))
    }

    /// The row's Jacobian `dg/ddelta` (m/rad, 3 per link in the body's
    /// order, [`Body3::index`]) into `out`, zero for links past the point.
    ///
    /// # Panics
    /// If `out` does not hold 3 entries per link.
    pub fn contact_jacobian(&self, frames: &[Mat3], row: &ContactRow3, out: &mut [f64]) {
        assert_eq!(out.len(), 3 * self.links(), "contact_jacobian: one 3-vector per link");
        out.fill(0.0);
        self.contact_terms(frames, row, 0.0, |u, grad, _| out[3 * u..3 * u + 3].copy_from_slice(&grad));
    }

    /// Calls `each(u, dg/ddelta_u, d2(-force g)/ddelta_u^2)` for every link
    /// `u` the row's point depends on (module doc): the Jacobian's 3-vectors
    /// and the Lagrangian's diagonal Hessian blocks for the multiplier
    /// `force` (N). No allocation: the solver's evaluation calls it per row.
    pub fn contact_terms(&self, frames: &[Mat3], row: &ContactRow3, force: f64, each: impl FnMut(usize, Vec3, Mat3)) {
        self.point_terms(frames, row.tube, row.link, row.plane.normal, force, each);
    }

    /// [`Body3::contact_terms`] of any row `n . p` (m) on the tip `p` of
    /// link `link` of tube `tube`, `n` a fixed unit vector, its multiplier
    /// `force` (N): a contact's row, or one of the front hold's tip rows
    /// ([`crate::stance3::held3`]).
    pub(crate) fn point_terms(
        &self,
        frames: &[Mat3],
        tube: usize,
        link: usize,
        n: Vec3,
        force: f64,
        mut each: impl FnMut(usize, Vec3, Mat3),
    ) {
        let lengths = self.tube(tube).lengths();
        for (k, l) in lengths[..=link].iter().enumerate() {
            let u = self.index(tube, k);
            let r = &frames[u];
            let a = [*l, 0.0, 0.0];
            let (grad, _) = linear_terms(r, n, a);
            let (_, hess) = linear_terms(r, scale(-force, n), a);
            each(u, grad, hess);
        }
    }

    /// Under the front hold, the row's gap `g` (m) for a row whose plane is
    /// in the held plate's frame (module doc), and its terms: calls
    /// `each(u, dg/ddelta_u, d2(-force g)/ddelta_u^2, cross)` for every
    /// link `u` the gap depends on (tube 1's and the row's tube's up to the
    /// point), `cross` the block `d2(-force g)/ddelta_P ddelta_u` (rows the
    /// plate's coordinates), none for the plate itself. No allocation.
    pub(crate) fn front_contact_terms(
        &self,
        frames: &[Mat3],
        row: &ContactRow3,
        force: f64,
        mut each: impl FnMut(usize, Vec3, Mat3, Option<Mat3>),
    ) -> f64 {
        let (first, own) = (self.tube(0), self.tube(row.tube));
        let constant = axpy(-1.0, first.root(), own.root());
        // The point's links with +l, tube 1's (to the tip) with -l.
        let coefficient = |i: usize, j: usize| {
            let on = if i == row.tube && j <= row.link { own.lengths()[j] } else { 0.0 };
            on - if i == 0 { first.lengths()[j] } else { 0.0 }
        };
        let normal = row.plane.normal;
        let plate = self.plate_bilinear(frames, normal, constant, coefficient, |u, grad, hess, cross| {
            each(u, grad, scale_mat(-force, &hess), Some(scale_mat(-force, &cross)));
        });
        each(self.links() - 1, plate.gradient, scale_mat(-force, &plate.hessian), None);
        plate.value - dot(normal, row.plane.point_m)
    }

    /// The row's gap (m): in the world ([`Body3::contact_gap`]), or under
    /// the front hold (`front`) with the plane in the held plate's frame.
    pub(crate) fn row_gap(&self, frames: &[Mat3], row: &ContactRow3, front: bool) -> f64 {
        if front {
            row.plane.gap(self.plate_local(frames, self.link_tip(frames, row.tube, row.link)))
        } else {
            self.contact_gap(frames, row)
        }
    }

    /// A point `p` (m) of the solver's picture in the plate's frame, origin
    /// tube 1's tip: `R_P^T (p - x_tip)`.
    fn plate_local(&self, frames: &[Mat3], p: Vec3) -> Vec3 {
        let tip = self.link_tip(frames, 0, self.tube(0).len() - 1);
        apply_t(&self.plate_frame(frames), axpy(-1.0, tip, p))
    }

    /// The candidate rows at `frames`: every link tip closer than
    /// `clearance + margin` (m) to a solid of `scene` (inside it included),
    /// one per such solid, against its plane at the tip moved out by
    /// `clearance` (the tube's radius: the centre line keeps it).
    pub fn contact_rows(
        &self,
        frames: &[Mat3],
        scene: &Scene3,
        clearance: f64,
        margin: f64,
        out: &mut Vec<ContactRow3>,
    ) {
        self.contact_rows_in(frames, scene, clearance, margin, HeldAt::Rear, out);
    }

    /// [`Body3::contact_rows`] for the body `held`: in the solver's picture
    /// of a front hold, the points placed in the world to meet the scene
    /// and the planes kept in the held plate's frame; held at the front
    /// (that picture, or both cups), no row at the tips of a tube's last two
    /// links, which the hold fixes (a row there would be zero, or a
    /// combination of the weld's and the hold's).
    pub(crate) fn contact_rows_in(
        &self,
        frames: &[Mat3],
        scene: &Scene3,
        clearance: f64,
        margin: f64,
        held: HeldAt,
        out: &mut Vec<ContactRow3>,
    ) {
        let front = match held {
            HeldAt::Front(hold) => Some(hold),
            HeldAt::Rear | HeldAt::Both => None,
        };
        let front_held = !matches!(held, HeldAt::Rear);
        out.clear();
        for tube in 0..3 {
            let links = self.tube(tube).len();
            let free = if front_held { links.saturating_sub(2) } else { links };
            for link in 0..free {
                let mut p = self.link_tip(frames, tube, link);
                if let Some(held) = front {
                    p = axpy(1.0, held.tip, apply(&held.plate, self.plate_local(frames, p)));
                }
                // Every solid within reach: a tip in a corner rests on two.
                for (solid, shape) in scene.solids.iter().enumerate() {
                    if shape.signed_distance(p) - clearance <= margin {
                        let plane = shape.plane(p);
                        let moved = Plane3 { point_m: axpy(clearance, plane.normal, plane.point_m), ..plane };
                        let plane = front.map_or(moved, |held| held.plane_local(&moved));
                        out.push(ContactRow3 { tube, link, solid, plane });
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body3::body3::{retract, Frames};
    use crate::geom3::{column, exp};
    use crate::robot::Robot;
    use crate::scene::Solid3;

    /// A bent, twisted state of an uneven body, and a tilted plane.
    fn case() -> (Body3, Frames, ContactRow3) {
        let body = Body3::from_robot(&Robot::builtin(), [0.25, 0.28, 0.22]).unwrap();
        let frames = body
            .frames_from(
                (0..body.links())
                    .map(|u| {
                        let t = u as f64;
                        exp([0.3 * (0.7 * t).sin(), 0.2 + 0.05 * t, -0.4 * (0.3 * t).cos()])
                    })
                    .collect(),
            )
            .unwrap();
        let n: Vec3 = [0.3, 0.9, -0.2];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let plane = Plane3 { point_m: [0.1, -0.05, 0.02], normal: scale(1.0 / len, n) };
        let link = body.tube(1).len() - 2;
        (body, frames, ContactRow3 { tube: 1, link, solid: 0, plane })
    }

    /// The state moved by `(coordinate, h)` each: one retraction per link
    /// of the summed local step (the pullback `R Exp(delta)`).
    fn moved(frames: &Frames, moves: &[(usize, f64)]) -> Frames {
        let mut steps = vec![[0.0; 3]; frames.0.len()];
        for (c, h) in moves {
            steps[c / 3][c % 3] += h;
        }
        let mut out = frames.clone();
        for (f, v) in out.0.iter_mut().zip(steps) {
            *f = retract(f, v);
        }
        out
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let (body, frames, row) = case();
        let mut jac = vec![0.0; 3 * body.links()];
        body.contact_jacobian(&frames, &row, &mut jac);
        let h = 1e-6;
        let mut nonzero = 0;
        for (c, j) in jac.iter().enumerate() {
            let fd = (body.contact_gap(&moved(&frames, &[(c, h)]), &row)
                - body.contact_gap(&moved(&frames, &[(c, -h)]), &row))
                / (2.0 * h);
            assert!((fd - j).abs() < 1e-8, "coordinate {c}: {j} against {fd}");
            nonzero += usize::from(fd.abs() > 1e-6);
        }
        // Every link up to the point moves it (two coordinates each at least).
        assert!(nonzero >= 2 * (row.link + 1), "{nonzero}");
    }

    #[test]
    fn hessian_blocks_match_second_differences() {
        let (body, frames, row) = case();
        let force = 2.5;
        let lagrangian = |f: &Frames| -force * body.contact_gap(f, &row);
        let mut blocks = Vec::new();
        body.contact_terms(&frames, &row, force, |u, _, hess| blocks.push((u, hess)));
        assert_eq!(blocks.len(), row.link + 1);
        let h = 1e-4;
        for (u, hess) in &blocks {
            for a in 0..3 {
                for b in 0..3 {
                    let (ca, cb) = (3 * u + a, 3 * u + b);
                    let second = (lagrangian(&moved(&frames, &[(ca, h), (cb, h)]))
                        - lagrangian(&moved(&frames, &[(ca, h), (cb, -h)]))
                        - lagrangian(&moved(&frames, &[(ca, -h), (cb, h)]))
                        + lagrangian(&moved(&frames, &[(ca, -h), (cb, -h)])))
                        / (4.0 * h * h);
                    let exact = hess[a][b];
                    assert!((second - exact).abs() < 1e-6, "link {u} ({a}, {b}): {exact} against {second}");
                }
            }
        }
        // Two different links: no coupling.
        let (u, v) = (blocks[0].0, blocks[1].0);
        let cross = (lagrangian(&moved(&frames, &[(3 * u + 1, h), (3 * v + 2, h)]))
            - lagrangian(&moved(&frames, &[(3 * u + 1, h), (3 * v + 2, -h)]))
            - lagrangian(&moved(&frames, &[(3 * u + 1, -h), (3 * v + 2, h)]))
            + lagrangian(&moved(&frames, &[(3 * u + 1, -h), (3 * v + 2, -h)])))
            / (4.0 * h * h);
        assert!(cross.abs() < 1e-6, "{cross}");
    }

    /// Under the front hold: the gap of a row (its plane in the held
    /// plate's frame) against first and second differences in every
    /// coordinate, the plate's included: the Jacobian (dense along tube 1),
    /// the diagonal blocks, the plate-link cross blocks and the plate's own
    /// block, and no coupling between two links other than through the
    /// plate (a sample of the pairs).
    #[test]
    fn front_gap_derivatives_match_finite_differences() {
        let (body, frames, row) = case();
        let n = 3 * body.links();
        let p = body.links() - 1;
        let force = 2.5;
        // A row on a side tube and one on tube 1, short of its tip.
        for row in [row, ContactRow3 { tube: 0, link: body.tube(0).len() - 4, ..row }] {
            let gap = |f: &Frames| body.row_gap(f, &row, true);
            let mut jac = vec![0.0; n];
            let mut hessian = vec![0.0; n * n];
            let value = body.front_contact_terms(&frames, &row, force, |u, grad, hess, cross| {
                jac[3 * u..3 * u + 3].copy_from_slice(&grad);
                for a in 0..3 {
                    for b in 0..3 {
                        hessian[(3 * u + a) * n + 3 * u + b] += hess[a][b];
                        if let Some(cross) = cross {
                            hessian[(3 * p + a) * n + 3 * u + b] += cross[a][b];
                            hessian[(3 * u + b) * n + 3 * p + a] += cross[a][b];
                        }
                    }
                }
            });
            assert!((value - gap(&frames)).abs() < 1e-15, "{value} against {}", gap(&frames));
            let h = 1e-6;
            for (c, j) in jac.iter().enumerate() {
                let fd = (gap(&moved(&frames, &[(c, h)])) - gap(&moved(&frames, &[(c, -h)]))) / (2.0 * h);
                assert!((fd - j).abs() < 1e-8, "{row:?} coordinate {c}: {j} against {fd}");
            }
            // Every link of tube 1 moves the point relative to the tip.
            let reached = (0..body.tube(0).len()).filter(|j| {
                let u = body.index(0, *j);
                jac[3 * u..3 * u + 3].iter().any(|x| x.abs() > 1e-6)
            });
            let expected = if row.tube == 0 { body.tube(0).len() - row.link - 1 } else { body.tube(0).len() };
            assert_eq!(reached.count(), expected, "{row:?}");
            let lagrangian = |f: &Frames| -force * gap(f);
            let h = 1e-4;
            let mut cross_blocks = 0;
            for a in 0..n {
                // Every block of a link with itself or with the plate, and
                // a seventh of the pairs of two links.
                for b in (a..n).filter(|b| a / 3 == b / 3 || b / 3 == p || (a + b) % 7 == 0) {
                    let second = (lagrangian(&moved(&frames, &[(a, h), (b, h)]))
                        - lagrangian(&moved(&frames, &[(a, h), (b, -h)]))
                        - lagrangian(&moved(&frames, &[(a, -h), (b, h)]))
                        + lagrangian(&moved(&frames, &[(a, -h), (b, -h)])))
                        / (4.0 * h * h);
                    let exact = hessian[a * n + b];
                    assert!((second - exact).abs() < 1e-6, "{row:?} ({a}, {b}): {exact} against {second}");
                    cross_blocks += usize::from(b / 3 == p && a / 3 != p && exact.abs() > 1e-6);
                }
            }
            // At least two entries of each reached link's block but the plate's own.
            assert!(cross_blocks >= 2 * (expected - 1), "{row:?}: {cross_blocks}");
        }
    }

    #[test]
    fn rows_are_found_at_the_points_near_a_floor() {
        let body = Body3::from_robot(&Robot::builtin(), [0.25, 0.28, 0.22]).unwrap();
        let frames = body.straight();
        // A ceiling just above tube 1 (the unit's y axis up): only tube 1's points are near.
        let base = body.base_frame();
        let up = column(&base, 1);
        let point_m = axpy(0.001, up, body.tube(0).root());
        let scene = Scene3::new("ceiling", vec![Solid3::HalfSpace { point_m, normal: scale(-1.0, up) }]).unwrap();
        let mut rows = Vec::new();
        body.contact_rows(&frames, &scene, 0.0, 0.002, &mut rows);
        assert_eq!(rows.len(), body.tube(0).len());
        assert!(rows.iter().all(|r| r.tube == 0 && (body.contact_gap(&frames, r) - 0.001).abs() < 1e-12));
    }
}
