//! The three-tube body as a static system of [`crate::statics`]: the
//! contract's block size 3, SO(3) retraction and Lagrangian Hessian, so that
//! the one solver ([`crate::statics::Solver`]) solves it as it solves the
//! planar body.
//!
//! A point `q` holds the links' frames, 9 entries per frame (row-major
//! rotation matrices, in the body's coordinate order, the plate last); a
//! tangent step holds 3 per link, the local rotation vector `delta_u`, and
//! the retraction is
//!
//! ```text
//! R_u (+) alpha delta_u = R_u Exp(alpha delta_u)
//! ```
//!
//! so the gradient and Hessian are those of the pullback at `delta = 0`
//! ([`crate::body3::body3`]). The distance of two points is the largest angle
//! between their frames, `|Log(A_u^T B_u)|` (rad). A plain Newton step turns
//! no frame by more than [`RETRACTION_LIMIT`], within the exponential map's
//! good range.
//!
//! The rows are the weld's 12, then the front hold's six when both cups
//! hold ([`super::held3`]), then the contact rows ([`crate::contact::space`]), all
//! equalities: the contacts' active set is kept by the solves among solids
//! ([`super::solve`]). The rows' Hessians couple frames, so the
//! evaluation writes the Lagrangian's Hessian itself.
//!
//! The path parameter `t` runs along a path of [`Param`]s (feeding, loading,
//! the front hold's target). The tangent's right-hand side, `dF/dt` at fixed
//! `q` and `lambda`, is `F(t + 1) - F(t)` exactly where the path is affine in
//! `t` (the feeding scales enter the link lengths, the load gravity, the
//! rows' compliance its value: all linearly), one evaluation without a
//! Hessian; the front hold's target turns along a geodesic, so there a
//! central difference.

use std::cell::RefCell;

use crate::body3::body3::{angle_between, retract, within, Body3, Param, PLATE_ROWS};
use crate::contact::space::ContactRow3;
use crate::geom3::{apply, axpy, column, cross, dot, Mat3};
use crate::hold::front3::FRONT_ROWS;
use crate::linalg::Pattern;
use crate::statics::{Border, Constraints, Evaluation, Path, PathTerms, Potential, Row, RowKind, StaticSystem, Tuning};

/// Most a plain Newton step turns a frame (rad, sup norm over the links).
pub const RETRACTION_LIMIT: f64 = 0.5;

/// The central difference's step along a path that is not affine (the
/// front hold's target, [`crate::hold::front3::FrontTarget::toward`]).
const PATH_DIFFERENCE: f64 = 1e-6;

/// The body along a path of [`Param`]s with its run-time rows.
pub(crate) struct System3<'a> {
    body: &'a Body3,
    path: &'a dyn Fn(f64) -> Param,
    contacts: &'a [ContactRow3],
    /// The front hold's rows ([`FRONT_ROWS`] when both cups hold, else 0).
    front_rows: usize,
    /// Where each border entry reaches each chain (the plate's 3
    /// coordinates, then the rows).
    pattern: Pattern,
    /// Another point's evaluation, for the path's derivative (made at the
    /// first tangent: a settle takes none).
    other: RefCell<Option<Evaluation>>,
    /// Zero multipliers, one per row (the rows' values do not depend on them).
    zero: Vec<f64>,
}

impl<'a> System3<'a> {
    /// `body` along `path`, with the contact rows `contacts` after the
    /// weld's and (when `path` holds the front) the front hold's.
    pub fn new(body: &'a Body3, path: &'a dyn Fn(f64) -> Param, contacts: &'a [ContactRow3]) -> System3<'a> {
        let start = path(0.0);
        let front_rows = if start.front.is_some() { FRONT_ROWS } else { 0 };
        let mut pattern = body.pattern(start.hang.is_some(), front_rows + contacts.len());
        if front_rows > 0 {
            body.front_rows_reach(&mut pattern);
        }
        let rows = PLATE_ROWS + front_rows + contacts.len();
        let (other, zero) = (RefCell::new(None), vec![0.0; rows]);
        System3 { body, path, contacts, front_rows, pattern, other, zero }
    }

    /// The frames of a point `q` (9 entries per frame, row-major).
    pub fn frames(q: &[f64]) -> &[Mat3] {
        let (rows, rest) = q.as_chunks::<3>();
        let (frames, left) = rows.as_chunks::<3>();
        debug_assert!(rest.is_empty() && left.is_empty(), "9 entries per frame");
        frames
    }

    /// The point of `frames` (9 entries per frame).
    pub fn point(frames: &[Mat3]) -> Vec<f64> {
        frames.iter().flatten().flatten().copied().collect()
    }

    /// The body's evaluation at `q`, `lambda` and path parameter `t` into
    /// `ev`, with the Hessian or without.
    fn evaluate_into<const HESSIAN: bool>(&self, q: &[f64], lambda: &[f64], t: f64, ev: &mut Evaluation) {
        self.body.evaluate_rows::<HESSIAN>(Self::frames(q), lambda, (self.path)(t), self.contacts, ev);
    }
}

impl Potential for System3<'_> {
    fn dim(&self) -> usize {
        3 * self.body.links()
    }
    fn blocks(&self) -> Vec<usize> {
        self.body.chain_blocks().map(|b| 3 * b).to_vec()
    }
    fn free(&self) -> usize {
        3
    }
    fn block_size(&self) -> usize {
        3
    }
    fn moment_scale(&self) -> f64 {
        self.body.moment_scale()
    }
    /// The whole evaluation at zero multipliers, where the Lagrangian's
    /// Hessian is the potential's: the body's terms come in one pass, the
    /// rows' with them ([`Constraints::constraints`] adds nothing).
    fn potential(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.evaluate_into::<true>(q, &self.zero, t, ev);
    }
}

impl Constraints for System3<'_> {
    fn rows(&self) -> usize {
        PLATE_ROWS + self.front_rows + self.contacts.len()
    }
    /// Every row is an equality: the weld's and the front hold's by
    /// construction, a contact's while it is in the solves' active set.
    fn row(&self, r: usize) -> Row {
        let scale = match r {
            r if r < PLATE_ROWS => self.body.row_scale(r),
            // The front hold's tip rows (m), then its rotation rows (rad).
            r if r < PLATE_ROWS + self.front_rows && r >= PLATE_ROWS + 3 => 1.0,
            _ => self.body.row_scale(0),
        };
        Row { kind: RowKind::Equality, scale }
    }
    /// Written with the potential ([`Potential::potential`]).
    fn constraints(&self, _q: &[f64], _t: f64, _ev: &mut Evaluation) {}
}

impl StaticSystem for System3<'_> {
    /// The endpoint's displacement along `dq`, `sum_j l_j R_j (dq_j x e_x)`
    /// over tube 1: its component to the right of the clamp direction
    /// (towards tubes 2 and 3) for a mode mostly in the plane of the clamp,
    /// else along `+z` (towards tube 2).
    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64 {
        let frames = Self::frames(q);
        let mut d = [0.0; 3];
        for (j, l) in self.body.tube(0).lengths().iter().enumerate() {
            let u = self.body.index(0, j);
            let local = cross([dq[3 * u], dq[3 * u + 1], dq[3 * u + 2]], [1.0, 0.0, 0.0]);
            d = axpy(*l, apply(&frames[u], local), d);
        }
        let right = -dot(column(&self.body.base_frame(), 1), d);
        if right.abs() >= d[2].abs() {
            right
        } else {
            d[2]
        }
    }

    fn evaluate(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.potential(q, t, ev);
    }

    fn evaluate_at(&self, q: &[f64], lambda: &[f64], t: f64, ev: &mut Evaluation) {
        self.evaluate_into::<true>(q, lambda, t, ev);
    }

    fn multipliers_in_hessian(&self) -> bool {
        true
    }

    fn point_dim(&self) -> usize {
        9 * self.body.links()
    }

    fn retract(&self, q: &[f64], dq: &[f64], alpha: f64, out: &mut [f64]) {
        let (rows, _) = out.as_chunks_mut::<3>();
        let (out, _) = rows.as_chunks_mut::<3>();
        for ((o, r), d) in out.iter_mut().zip(Self::frames(q)).zip(dq.chunks_exact(3)) {
            *o = retract(r, [alpha * d[0], alpha * d[1], alpha * d[2]]);
        }
    }

    fn distance(&self, a: &[f64], b: &[f64]) -> f64 {
        let pairs = Self::frames(a).iter().zip(Self::frames(b));
        pairs.fold(0.0, |m, (x, y)| f64::max(m, angle_between(x, y)))
    }

    fn within(&self, a: &[f64], b: &[f64], limit: f64) -> bool {
        within(Self::frames(a), Self::frames(b), limit)
    }

    fn step_limit(&self) -> f64 {
        RETRACTION_LIMIT
    }

    fn sparse_border(&self) -> bool {
        true
    }

    fn border_start(&self, chain: usize, border: Border) -> usize {
        let row = match border {
            Border::Free(a) => a,
            Border::Row(r) => 3 + r,
        };
        self.pattern.border_start(chain, row)
    }
}

impl Path for System3<'_> {
    fn path(&self, q: &[f64], t: f64, ev: &Evaluation, out: &mut PathTerms) {
        // Gradient, Jacobian and values do not depend on the multipliers.
        let mut other = self.other.borrow_mut();
        let other = other.get_or_insert_with(|| self.body.evaluation(self.rows()));
        if (self.path)(t).front.is_none() {
            self.evaluate_into::<false>(q, &self.zero, t + 1.0, other);
            each_term(out, other, |d, a| *d = a);
            each_term(out, ev, |d, b| *d -= b);
        } else {
            let over = 2.0 * PATH_DIFFERENCE;
            self.evaluate_into::<false>(q, &self.zero, t + PATH_DIFFERENCE, other);
            each_term(out, other, |d, a| *d = a / over);
            self.evaluate_into::<false>(q, &self.zero, t - PATH_DIFFERENCE, other);
            each_term(out, other, |d, b| *d -= b / over);
        }
    }

    /// The 3D paths turn the links by up to a right angle: the first step
    /// is always sized from the tangent
    /// ([`crate::statics::Tuning::first_frame_turn`]); the whole path first
    /// took 2.2 ms instead of 0.6 ms on the 25/30/22-link body.
    fn discrete_stiffness(&self) -> f64 {
        f64::INFINITY
    }

    fn first_turn(&self, tuning: &Tuning) -> f64 {
        tuning.first_frame_turn
    }
}

/// `f(d, e)` for each path term `d` of `out` and the matching entry `e` of
/// `ev` (gradient, Jacobian, values, compliance).
fn each_term(out: &mut PathTerms, ev: &Evaluation, f: impl Fn(&mut f64, f64)) {
    let pairs = [
        (&mut out.gradient, &ev.gradient),
        (&mut out.jacobian, &ev.jacobian),
        (&mut out.constraints, &ev.constraints),
        (&mut out.compliance, &ev.compliance),
    ];
    for (dst, src) in pairs {
        dst.iter_mut().zip(src).for_each(|(d, s)| f(d, *s));
    }
}
