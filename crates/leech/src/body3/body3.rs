//! The three-tube body: the tubes, the driving unit's pose, the endpoint
//! plate, and the Lagrangian's derivatives in local rotation coordinates
//! (docs/model3d.md sections 2 to 5).
//!
//! ```text
//! V = sum_tubes sum_j E_j(theta_j) + t g sum_tubes sum_j s_i W_j (R_j e_x)_y + g sum_i M_i y(root_i)   (J)
//! C_pos,i = root_i + sum_j s_i l_ij R_ij e_x - root_1 - sum_j s_1 l_1j R_1j e_x - R_P (v_i - v_1)     (m)
//! C_rot,i = Log(R_P^T R_i,n_i)                                                                   (rad)
//! ```
//!
//! for `i = 2, 3`, `R_P` tube 1's last link (the plate), `v_i` the plate's
//! triangle, `t` the load fraction and `s_i` the feeding scales of the
//! tubes' links (1 at the body's lengths). The coordinates are the links'
//! local rotation vectors (`R <- R Exp(delta)`), ordered for the block
//! factorization: tube 1's links but the last, tube 2's, tube 3's, then the
//! plate (three dense *free* coordinates, since the weld's rotation rows
//! couple the plate with the side tubes' last links).

use super::tube3::Tube3;
use crate::chain::{Chain, Discretization};
use crate::error::InputError;
use crate::geom3::{
    apply, axpy, cross, is_rotation, linear_terms, mul_tn, pair_terms, rot_z, scale, tangent_hessian, transpose, Mat3,
    Vec3,
};
use crate::robot::Robot;
use crate::statics::Evaluation;

/// Number of the plate's constraint rows: position and rotation of tubes 2 and 3.
pub const PLATE_ROWS: usize = 12;

/// The three-tube body under gravity, driving unit fixed.
#[derive(Clone, Debug, PartialEq)]
pub struct Body3 {
    tubes: [Tube3; 3],
    base: Mat3,
    base_point: Vec3,
    plate: [Vec3; 3],
    gravity: f64,
    moment_scale: f64,
    element_length: f64,
}

/// The links' frames (rotation matrices, columns the link's axes in world
/// coordinates; local x the tangent), in the body's coordinate order.
#[derive(Clone, Debug, PartialEq)]
pub struct Frames(pub(crate) Vec<Mat3>);

impl Frames {
    /// Every link's frame, in the body's coordinate order ([`Body3::index`]).
    pub fn as_slice(&self) -> &[Mat3] {
        &self.0
    }
}

impl std::ops::Deref for Frames {
    type Target = [Mat3];
    fn deref(&self) -> &[Mat3] {
        &self.0
    }
}

/// Where on the continuation paths a body is evaluated: the load fraction
/// `t` and the feeding scales `s_i` of the tubes' link lengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Param {
    pub load: f64,
    pub scale: [f64; 3],
    /// Hanging from the front cup: gravity as [`crate::stance3::held3`] writes it
    /// (turning with the plate), in place of the fixed unit's.
    pub hang: Option<crate::hold::front3::Hanging>,
    /// Both cups holding: the front hold's target (tube 1's tip and the
    /// plate's frame), whose six rows follow the weld's 12 ([`crate::stance3::held3`]).
    pub front: Option<crate::hold::front3::FrontTarget>,
}

impl Param {
    /// The body itself: full gravity, true lengths.
    pub const FULL: Param = Param { load: 1.0, scale: [1.0; 3], hang: None, front: None };
}

/// The triangle's vertices in the unit's (or plate's) local frame for radius
/// `r`: tube 1 at `(0, r, 0)`, tubes 2 and 3 at `(0, -r/2, +-r sqrt(3)/2)`.
pub fn triangle(r: f64) -> [Vec3; 3] {
    let side = r * 3f64.sqrt() / 2.0;
    [[0.0, r, 0.0], [0.0, -0.5 * r, side], [0.0, -0.5 * r, -side]]
}

impl Body3 {
    /// The body of `robot` at tube lengths `lengths = [L1, L2, L3]` (m), the
    /// driving unit at the origin turned by the clamp angle about z
    /// (docs/model3d.md section 2). The tubes are cut by the `paper` scheme.
    pub fn from_robot(robot: &Robot, lengths: [f64; 3]) -> Result<Body3, InputError> {
        robot.validate()?;
        if robot.model.discretization != Discretization::Paper {
            return Err(InputError::Invalid {
                field: "model.discretization".into(),
                value: robot.model.discretization.name().into(),
                allowed: "\"paper\" (the 3D body cuts its tubes by the paper's scheme)".into(),
            });
        }
        let names = ["lengths[0] (L1)", "lengths[1] (L2)", "lengths[2] (L3)"];
        let mut checked = [0.0; 3];
        for ((out, name), length) in checked.iter_mut().zip(names).zip(lengths) {
            *out = robot.check_tube_length(name, length)?;
        }
        let base = rot_z(robot.world.base_angle_deg.to_radians());
        let roots = triangle(robot.body.base_spacing_m / 1.5).map(|v| apply(&base, v));
        let ratio = robot.tube.torsion_stiffness() / robot.tube.joint_stiffness_nm_per_rad;
        // The payload sits at the midpoint of tubes 2 and 3's tips: half on each.
        let tip_mass = [0.0, 0.5 * robot.body.payload_kg, 0.5 * robot.body.payload_kg];
        let tube =
            |i: usize| Tube3::new(&Chain::new(&robot.spec(checked[i], 1.0, tip_mass[i], [0.0; 2])), roots[i], ratio);
        Ok(Body3 {
            tubes: [tube(0), tube(1), tube(2)],
            base,
            base_point: [0.0; 3],
            plate: triangle(robot.body.tip_spacing_m / 1.5),
            gravity: robot.world.gravity_m_per_s2,
            moment_scale: robot.tube.joint_stiffness_nm_per_rad,
            element_length: robot.tube.element_length_m,
        })
    }

    /// The same body with each tube's axial rotation at the driving unit
    /// free (no torsional spring at the first joints): the unactuated
    /// helical freedom of the tube in its gear.
    pub fn with_free_axial_rotation(mut self) -> Body3 {
        self.tubes.iter_mut().for_each(Tube3::free_axial_rotation);
        self
    }

    /// The same body moved rigidly: turned by `rotation` about the origin,
    /// then shifted by `translation` (m).
    pub(crate) fn placed(&self, rotation: &Mat3, translation: Vec3) -> Body3 {
        let mut out = self.clone();
        out.base = crate::geom3::mul(rotation, &self.base);
        for tube in out.tubes.iter_mut() {
            tube.set_root(axpy(1.0, translation, apply(rotation, tube.root())));
        }
        out
    }

    /// Tube `i` (0, 1, 2 for tubes 1, 2, 3).
    pub fn tube(&self, i: usize) -> &Tube3 {
        &self.tubes[i]
    }

    /// The three tubes' lengths ahead of their clamps `(L1, L2, L3)` (m).
    pub fn tube_lengths(&self) -> [f64; 3] {
        self.tubes.each_ref().map(Tube3::tube_length)
    }

    /// The driving unit's frame `R0` (columns its axes).
    pub fn base_frame(&self) -> Mat3 {
        self.base
    }

    /// Gravity (m/s^2).
    pub fn gravity(&self) -> f64 {
        self.gravity
    }

    /// Moment scale of residuals: the tube's joint stiffness `k` (N m/rad).
    pub fn moment_scale(&self) -> f64 {
        self.moment_scale
    }

    /// Number of links of all tubes.
    pub fn links(&self) -> usize {
        self.tubes.iter().map(Tube3::len).sum()
    }

    /// Where link `j` of tube `i` sits in the coordinate order (module doc).
    pub fn index(&self, i: usize, j: usize) -> usize {
        let n1 = self.tubes[0].len();
        match i {
            0 if j + 1 == n1 => self.links() - 1,
            0 => j,
            1 => n1 - 1 + j,
            _ => n1 - 1 + self.tubes[1].len() + j,
        }
    }

    /// The chains of the block factorization: tube 1 without its last link, tubes 2 and 3.
    pub(crate) fn chain_blocks(&self) -> [usize; 3] {
        [self.tubes[0].len() - 1, self.tubes[1].len(), self.tubes[2].len()]
    }

    /// The structure of the KKT matrix: the chains, and the border of the
    /// plate's 3 coordinates, the 12 rows and `contacts` contact rows (3
    /// primal) with where
    /// each border row reaches each chain. Tube 1 carries both position
    /// blocks, tube 2 and tube 3 their own, on every link; the plate's
    /// coordinates reach each chain's last block only (tube 1's last joint,
    /// the weld's rotation rows) and so do a side tube's rotation rows. A
    /// body `hanging` from the front cup couples the plate with every link
    /// (gravity turns with the plate: [`crate::stance3::held3`]), so there the
    /// plate's coordinates reach every block.
    /// A contact row reaches one link only, but is declared on every block
    /// (the pattern is made once per active set, not per link). The
    /// `contacts` run-time rows include the front hold's six when both cups
    /// hold; [`Body3::front_rows_reach`] narrows those.
    pub(crate) fn pattern(&self, hanging: bool, contacts: usize) -> crate::linalg::Pattern {
        let chains = self.chain_blocks();
        let mut pattern = crate::linalg::Pattern::new(3, &chains, 3 + PLATE_ROWS + contacts, 3);
        for (c, len) in chains.into_iter().enumerate() {
            let last = len.saturating_sub(1);
            for a in 0..3 {
                pattern.set_border_start(c, a, if hanging { 0 } else { last });
            }
            // Border row 3 + r is the plate's row r: 6 per side (3 position, 3 rotation).
            for row in 0..PLATE_ROWS {
                let (side, rotation) = (row / 6, row % 6 >= 3);
                let first = match (c, rotation) {
                    (0, false) => 0,
                    (_, false) if c == side + 1 => 0,
                    (_, true) if c == side + 1 => last,
                    _ => len,
                };
                pattern.set_border_start(c, 3 + row, first);
            }
        }
        pattern
    }

    /// Every link along the driving unit's direction.
    pub fn straight(&self) -> Frames {
        Frames(vec![self.base; self.links()])
    }

    /// Frames given link by link in the body's order ([`Body3::index`]):
    /// one per link, each a rotation (orthonormal to 1e-9, determinant +1).
    pub fn frames_from(&self, frames: Vec<Mat3>) -> Result<Frames, InputError> {
        if frames.len() != self.links() {
            return Err(InputError::Invalid {
                field: "frames".into(),
                value: format!("{} frames", frames.len()),
                allowed: format!("one per link: {}", self.links()),
            });
        }
        for (u, r) in frames.iter().enumerate() {
            if !is_rotation(r) {
                return Err(InputError::Invalid {
                    field: format!("frames[{u}]"),
                    value: format!("{r:?}"),
                    allowed: "a rotation matrix".into(),
                });
            }
        }
        Ok(Frames(frames))
    }

    /// Frame of link `j` of tube `i`.
    pub fn frame(&self, frames: &[Mat3], i: usize, j: usize) -> Mat3 {
        frames[self.index(i, j)]
    }

    /// The plate's frame: tube 1's last link (columns the plate's axes).
    pub fn plate_frame(&self, frames: &[Mat3]) -> Mat3 {
        frames[self.links() - 1]
    }

    /// Tube `i`'s centre line: its root, then every link's tip (m).
    pub fn points(&self, frames: &[Mat3], i: usize) -> Vec<Vec3> {
        let tube = &self.tubes[i];
        let mut p = tube.root();
        let mut out = vec![p];
        for (j, l) in tube.lengths().iter().enumerate() {
            let r = self.frame(frames, i, j);
            p = axpy(*l, [r[0][0], r[1][0], r[2][0]], p);
            out.push(p);
        }
        out
    }

    /// The endpoint: tube 1's tip (m).
    pub fn endpoint(&self, frames: &[Mat3]) -> Vec3 {
        self.points(frames, 0).pop().unwrap_or(self.tubes[0].root())
    }

    /// The plate's 12 constraint values (m for positions, rad for rotations):
    /// tube 2's position and rotation rows, then tube 3's.
    pub fn constraints(&self, frames: &[Mat3]) -> [f64; PLATE_ROWS] {
        let tip = |i: usize| self.points(frames, i).pop().unwrap_or(self.tubes[i].root());
        let plate = self.plate_frame(frames);
        let mut out = [0.0; PLATE_ROWS];
        for side in 0..2 {
            let offset = apply(&plate, axpy(-1.0, self.plate[0], self.plate[side + 1]));
            let gap = axpy(-1.0, axpy(1.0, tip(0), offset), tip(side + 1));
            out[6 * side..6 * side + 3].copy_from_slice(&gap);
            let last = self.tubes[side + 1].len() - 1;
            out[6 * side + 3..6 * side + 6]
                .copy_from_slice(&crate::geom3::log(&mul_tn(&plate, &self.frame(frames, side + 1, last))));
        }
        out
    }

    /// The element length `l` (m).
    pub fn element_length(&self) -> f64 {
        self.element_length
    }

    /// Scale of row `r` (m for positions, 1 for rotations): residuals are divided by it.
    pub fn row_scale(&self, r: usize) -> f64 {
        if r % 6 < 3 {
            self.element_length
        } else {
            1.0
        }
    }

    /// Potential energy, springs and gravity (J).
    pub fn energy(&self, frames: &[Mat3]) -> f64 {
        let mut ev = self.evaluation(PLATE_ROWS);
        self.evaluate::<false>(frames, &[0.0; PLATE_ROWS], Param::FULL, &mut ev);
        ev.energy
    }

    /// The largest twist `|theta_x|` of any joint (rad): the torsion the
    /// tubes carry.
    pub fn max_twist(&self, frames: &[Mat3]) -> f64 {
        let mut most = 0.0f64;
        for (i, tube) in self.tubes.iter().enumerate() {
            let mut prev = self.base;
            for j in 0..tube.len() {
                let r = self.frame(frames, i, j);
                most = most.max(crate::geom3::log(&mul_tn(&prev, &r))[0].abs());
                prev = r;
            }
        }
        most
    }

    /// The Lagrangian `V - lambda . C` and its local derivatives at one point,
    /// dense (for checks and small studies; the solver keeps them banded).
    pub fn derivatives(&self, frames: &[Mat3], lambda: &[f64; PLATE_ROWS]) -> Derivatives {
        self.derivatives_at(frames, lambda, Param::FULL)
    }

    /// [`Body3::derivatives`] at `param`.
    pub(crate) fn derivatives_at(&self, frames: &[Mat3], lambda: &[f64; PLATE_ROWS], param: Param) -> Derivatives {
        let mut ev = self.evaluation(PLATE_ROWS);
        self.evaluate::<true>(frames, lambda, param, &mut ev);
        let n = 3 * self.links();
        let mut gradient = vec![0.0; n];
        ev.stationarity(lambda, &mut gradient);
        let mut hessian = vec![0.0; n * n];
        let chain = n - 3;
        let mut put = |i: usize, j: usize, v: f64| {
            hessian[i * n + j] += v;
            if i != j {
                hessian[j * n + i] += v;
            }
        };
        for u in 0..self.links() - 1 {
            for r in 0..3 {
                for c in 0..3 {
                    if c >= r {
                        put(3 * u + r, 3 * u + c, ev.hessian_diag[9 * u + 3 * r + c]);
                    }
                    put(3 * u + r, 3 * u + 3 + c, ev.hessian_off[9 * u + 3 * r + c]);
                    put(3 * u + r, chain + c, ev.hessian_border[9 * u + 3 * r + c]);
                }
            }
        }
        for r in 0..3 {
            for c in r..3 {
                put(chain + r, chain + c, ev.hessian_corner[3 * r + c]);
            }
        }
        let multiplied: f64 = lambda.iter().zip(&ev.constraints).map(|(l, c)| l * c).sum();
        Derivatives {
            lagrangian: ev.energy - multiplied,
            gradient,
            hessian,
            constraints: ev.constraints[..].try_into().expect("the weld's 12 rows"),
            jacobian: ev.jacobian,
        }
    }

    /// Storage for the body's evaluation with `rows` rows (the weld's 12
    /// first): blocks of 3, the plate's 3 coordinates free.
    pub(crate) fn evaluation(&self, rows: usize) -> Evaluation {
        let mut ev = Evaluation::default();
        ev.resize_blocks(3 * self.links(), 3, rows, 3);
        ev
    }

    /// Evaluates at `frames` with the weld's multipliers `lambda` on the
    /// path point `param` (module doc): energy, gradient, the weld's rows
    /// (the first 12 of `ev`'s) and their Jacobian and, with `HESSIAN`, the
    /// Lagrangian Hessian `hess V - sum_r lambda_r hess C_r` into `ev`
    /// (cleared here but for its unused curvature); without it the
    /// Hessian is left as it was (unused), at about half the cost.
    pub(crate) fn evaluate<const HESSIAN: bool>(
        &self,
        frames: &[Mat3],
        lambda: &[f64; PLATE_ROWS],
        param: Param,
        ev: &mut Evaluation,
    ) {
        if HESSIAN {
            ev.clear_multiplied();
        } else {
            ev.clear_first_order();
        }
        let f = frames;
        // Hanging, gravity turns with the plate: added after the loop.
        let g = if param.hang.is_some() { 0.0 } else { param.load * self.gravity };
        let positions = [[lambda[0], lambda[1], lambda[2]], [lambda[6], lambda[7], lambda[8]]];
        let mut tips = [[0.0; 3]; 3];
        for (i, tube) in self.tubes.iter().enumerate() {
            let s = param.scale[i];
            ev.energy += g * tube.total_mass() * (self.base_point[1] + tube.root()[1]);
            let (mut prev, mut prev_index) = (self.base, None);
            for j in 0..tube.len() {
                let u = self.index(i, j);
                let r = &f[u];
                self.add_joint::<HESSIAN>(tube.stiffness(j), &prev, prev_index, r, u, ev);
                let lever = g * s * tube.levers()[j];
                let d = s * tube.lengths()[j];
                tips[i] = axpy(d, [r[0][0], r[1][0], r[2][0]], tips[i]);
                // The link's linear terms all lie along its tangent e_x, so
                // they share one Hessian: its height under gravity, and its
                // share `sign d R e_x` of the position rows (tube 1 enters
                // both blocks with -1, tube i + 1 its own with +1), whose
                // `-lambda . C` is the linear term of `w = -sign d lambda`.
                let mut w = [0.0, lever, 0.0];
                for side in 0..2 {
                    let sign = match i {
                        0 => -1.0,
                        _ if i == side + 1 => 1.0,
                        _ => continue,
                    };
                    ev.add_position_jacobian(r, u, scale(sign * d, [1.0, 0.0, 0.0]), side);
                    w = axpy(-sign * d, positions[side], w);
                }
                ev.energy += lever * r[1][0];
                // d(lever (R e_x)_y) = e_x x R^T (lever e_y).
                ev.add_gradient(u, [0.0, -lever * r[1][2], lever * r[1][1]], 1.0);
                if HESSIAN {
                    ev.add_hessian(u, u, &tangent_hessian(r, w));
                }
                (prev, prev_index) = (*r, Some(u));
            }
        }
        let p = self.links() - 1;
        let plate = f[p];
        for side in 0..2 {
            let offset = axpy(-1.0, self.plate[0], self.plate[side + 1]);
            let a = scale(-1.0, offset);
            ev.add_position_jacobian(&plate, p, a, side);
            if HESSIAN {
                ev.add_hessian(p, p, &linear_terms(&plate, scale(-1.0, positions[side]), a).1);
            }
            let gap = axpy(-1.0, axpy(1.0, tips[0], apply(&plate, offset)), tips[side + 1]);
            let roots = axpy(-1.0, self.tubes[0].root(), self.tubes[side + 1].root());
            ev.constraints[6 * side..6 * side + 3].copy_from_slice(&axpy(1.0, roots, gap));
            // The rotation rows: -lambda . theta in the Lagrangian.
            let rows = 6 * side + 3;
            let b = self.index(side + 1, self.tubes[side + 1].len() - 1);
            let mult = [-lambda[rows], -lambda[rows + 1], -lambda[rows + 2]];
            let m = mul_tn(&plate, &f[b]);
            let terms = pair_terms(&m, |_| mult, [0.0; 3], HESSIAN);
            ev.constraints[rows..rows + 3].copy_from_slice(&terms.theta);
            let jacobian_a = terms.jacobian_a(&m);
            for c in 0..3 {
                ev.set_jacobian(p, rows + c, jacobian_a[c]);
                ev.set_jacobian(b, rows + c, terms.jacobian_b[c]);
            }
            if HESSIAN {
                ev.add_hessian(p, p, &terms.h_aa);
                ev.add_hessian(b, b, &terms.h_bb);
                ev.add_hessian(p, b, &terms.h_ab);
            }
        }
        if let Some(hang) = &param.hang {
            self.add_hanging(frames, hang, param, ev);
        }
    }

    /// A joint between `prev` (the driving unit, or frame `prev_index`) and
    /// frame `r` at index `u`: energy, gradient, Hessian.
    fn add_joint<const HESSIAN: bool>(
        &self,
        k: Vec3,
        prev: &Mat3,
        prev_index: Option<usize>,
        r: &Mat3,
        u: usize,
        ev: &mut Evaluation,
    ) {
        let terms = pair_terms(&mul_tn(prev, r), |th| [k[0] * th[0], k[1] * th[1], k[2] * th[2]], k, HESSIAN);
        let th = terms.theta;
        ev.energy += 0.5 * (k[0] * th[0] * th[0] + k[1] * th[1] * th[1] + k[2] * th[2] * th[2]);
        ev.add_gradient(u, terms.grad_b, 1.0);
        if HESSIAN {
            ev.add_hessian(u, u, &terms.h_bb);
        }
        if let Some(a) = prev_index {
            ev.add_gradient(a, terms.grad_a, 1.0);
            if HESSIAN {
                ev.add_hessian(a, a, &terms.h_aa);
                ev.add_hessian(a, u, &terms.h_ab);
            }
        }
    }
}

/// The Lagrangian's derivatives in local rotation coordinates
/// ([`Body3::derivatives`]); `n = 3 N` coordinates, 3 per link in the
/// body's order.
#[derive(Clone, Debug, PartialEq)]
pub struct Derivatives {
    /// `V - lambda . C` (J).
    pub lagrangian: f64,
    /// `grad V - J^T lambda` (N m).
    pub gradient: Vec<f64>,
    /// The Lagrangian Hessian, dense `n x n`, row-major (N m/rad).
    pub hessian: Vec<f64>,
    /// `C` (m, rad).
    pub constraints: [f64; PLATE_ROWS],
    /// `dC_r/ddelta_i` at `i * 12 + r`.
    pub jacobian: Vec<f64>,
}

/// Writing the body's terms into an [`Evaluation`] of blocks of 3 (the
/// layout of [`crate::linalg::BorderedLdl`]): link `u`'s coordinates are
/// `3 u .. 3 u + 3`, the plate (the last link) the 3 free ones; row `r`'s
/// Jacobian entry for coordinate `i` at `i m + r` (`m` rows).
pub(crate) trait Terms3 {
    /// Adds `s g` to link `u`'s gradient.
    fn add_gradient(&mut self, u: usize, g: Vec3, s: f64);
    /// The Jacobian of a position row block's term `R Exp(delta) a` of
    /// frame `r` at index `u` (`side` 0: tube 2's rows, 1: tube 3's): row
    /// `c` is `a x (R^T e_c)`.
    fn add_position_jacobian(&mut self, r: &Mat3, u: usize, a: Vec3, side: usize);
    /// Adds `v` to row `row`'s Jacobian at link `u`.
    fn add_jacobian(&mut self, u: usize, row: usize, v: Vec3);
    /// Sets row `row`'s Jacobian at link `u` to `v`.
    fn set_jacobian(&mut self, u: usize, row: usize, v: Vec3);
    /// Adds `h` (rows: link `a`, columns: link `b`) and, for `a != b`, its
    /// transpose: the only pairs are a link with itself, consecutive links
    /// of one tube, and a link with the plate.
    fn add_hessian(&mut self, a: usize, b: usize, h: &Mat3);
    /// `grad V - J^T lambda` over the first `lambda.len()` rows into `out` (3 per link).
    fn stationarity(&self, lambda: &[f64], out: &mut [f64]);
}

impl Terms3 for Evaluation {
    fn add_gradient(&mut self, u: usize, g: Vec3, s: f64) {
        for (x, y) in self.gradient[3 * u..3 * u + 3].iter_mut().zip(g) {
            *x += s * y;
        }
    }

    fn add_position_jacobian(&mut self, r: &Mat3, u: usize, a: Vec3, side: usize) {
        for c in 0..3 {
            self.add_jacobian(u, 6 * side + c, cross(a, r[c]));
        }
    }

    fn add_jacobian(&mut self, u: usize, row: usize, v: Vec3) {
        let m = self.rows();
        for (c, x) in v.iter().enumerate() {
            self.jacobian[(3 * u + c) * m + row] += x;
        }
    }

    fn set_jacobian(&mut self, u: usize, row: usize, v: Vec3) {
        let m = self.rows();
        for (c, x) in v.iter().enumerate() {
            self.jacobian[(3 * u + c) * m + row] = *x;
        }
    }

    fn add_hessian(&mut self, a: usize, b: usize, h: &Mat3) {
        let plate = self.gradient.len() / 3 - 1;
        let add = |buf: &mut [f64], offset: usize, m: &Mat3| {
            for r in 0..3 {
                for c in 0..3 {
                    buf[offset + 3 * r + c] += m[r][c];
                }
            }
        };
        match (a == plate, b == plate) {
            (true, true) => add(&mut self.hessian_corner, 0, h),
            (false, false) if a == b => add(&mut self.hessian_diag, 9 * a, h),
            (false, false) => add(&mut self.hessian_off, 9 * a, h),
            (false, true) => add(&mut self.hessian_border, 9 * a, h),
            (true, false) => add(&mut self.hessian_border, 9 * b, &transpose(h)),
        }
    }

    fn stationarity(&self, lambda: &[f64], out: &mut [f64]) {
        let m = self.rows();
        for ((o, g), row) in out.iter_mut().zip(&self.gradient).zip(self.jacobian.chunks_exact(m)) {
            *o = row.iter().zip(lambda).fold(*g, |acc, (j, l)| acc - j * l);
        }
    }
}

/// `R Exp(v)`, the retraction of a local step `v` (rad).
pub(crate) fn retract(r: &Mat3, v: Vec3) -> Mat3 {
    crate::geom3::mul(r, &crate::geom3::exp(v))
}

/// The angle between two frames (rad): `|Log(A^T B)|`.
pub fn angle_between(a: &Mat3, b: &Mat3) -> f64 {
    let v = crate::geom3::log(&mul_tn(a, b));
    crate::geom3::dot(v, v).sqrt()
}

/// The largest [`angle_between`] over the links of two states (rad).
pub fn distance(a: &[Mat3], b: &[Mat3]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| f64::max(m, angle_between(x, y)))
}

/// Whether [`distance`]`(a, b) <= limit` (rad), without a logarithm per
/// link: the angle `theta` between two frames has
/// `tr(A^T B) = 1 + 2 cos theta`, and `cos` falls on `[0, pi]`, so
/// `theta <= limit < pi` exactly when `tr(A^T B) >= 1 + 2 cos(limit)`.
pub(crate) fn within(a: &[Mat3], b: &[Mat3], limit: f64) -> bool {
    if limit >= std::f64::consts::PI {
        return true;
    }
    let least = 1.0 + 2.0 * limit.cos();
    let trace = |x: &Mat3, y: &Mat3| (0..3).map(|r| crate::geom3::dot(x[r], y[r])).sum::<f64>();
    a.iter().zip(b).all(|(x, y)| trace(x, y) >= least)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geom3::exp;

    /// A bent, twisted state of `body` (link `u` turned by
    /// `Exp(0.1, -0.2 + 0.03 u, 0.05)`) and a front hold to hang it from:
    /// a generic point for checks of the evaluation.
    pub(crate) fn bent_and_hanging(body: &Body3) -> (Frames, crate::hold::front3::Hanging) {
        let frames = Frames((0..body.links()).map(|u| exp([0.1, -0.2 + 0.03 * u as f64, 0.05])).collect());
        (frames, crate::hold::front3::Hanging { up: [0.6, 0.0, 0.8], unit_mass_kg: 0.1 })
    }

    /// The border reach declared to the factorization must hold: every
    /// border entry of the evaluation before a row's declared start on a
    /// chain is exactly zero (else the factorization would drop it).
    #[test]
    fn border_rows_reach_no_further_than_declared() {
        let body = Body3::from_robot(&Robot::builtin(), [0.08, 0.07, 0.06]).unwrap();
        let (frames, hang) = bent_and_hanging(&body);
        let lambda: [f64; PLATE_ROWS] = std::array::from_fn(|r| 0.3 + r as f64);
        for param in [Param::FULL, Param { hang: Some(hang), ..Param::FULL }] {
            let mut ev = body.evaluation(PLATE_ROWS);
            body.evaluate::<true>(&frames, &lambda, param, &mut ev);
            border_reaches_as_declared(&body.pattern(param.hang.is_some(), 0), &ev);
        }
    }

    /// [`within`] says what [`distance`] does, on pairs of states turned
    /// apart by angles from 0.01 to 3 rad, at limits on both sides.
    #[test]
    fn within_agrees_with_distance() {
        let turn = |angle: f64, u: usize| {
            exp([angle * 0.6, -angle * 0.8 * (u % 2) as f64, angle * 0.8 * u.is_multiple_of(3) as u8 as f64])
        };
        let base = Frames((0..7).map(|u| exp([0.3 * u as f64, 0.1, -0.2])).collect());
        for angle in [0.01, 0.3, 0.5, 1.2, 3.0] {
            let moved = Frames(base.0.iter().enumerate().map(|(u, r)| crate::geom3::mul(r, &turn(angle, u))).collect());
            let d = distance(&base, &moved);
            for limit in [0.5 * d, 0.999 * d, 1.001 * d, 2.0 * d, 4.0, f64::INFINITY] {
                assert_eq!(within(&base, &moved, limit), d <= limit, "angle {angle}, limit {limit}");
            }
        }
    }

    /// Every border entry `pattern` declares zero is zero in `ev`, and most are.
    fn border_reaches_as_declared(pattern: &crate::linalg::Pattern, ev: &Evaluation) {
        let (mut zeros, mut nonzeros) = (0, 0);
        for c in 0..pattern.chains() {
            let blocks = pattern.chain_blocks(c);
            for (t, u) in blocks.enumerate() {
                for a in 0..3 {
                    let row: Vec<f64> = (0..3)
                        .map(|p| ev.hessian_border[9 * u + 3 * a + p])
                        .chain((0..PLATE_ROWS).map(|r| ev.jacobian[(3 * u + a) * PLATE_ROWS + r]))
                        .collect();
                    for (r, v) in row.iter().enumerate() {
                        if t < pattern.border_start(c, r) {
                            assert_eq!(*v, 0.0, "chain {c}, block {t}, row {r}");
                            zeros += 1;
                        } else if *v != 0.0 {
                            nonzeros += 1;
                        }
                    }
                }
            }
        }
        // Most of the border is declared zero; what is declared present is.
        assert!(zeros > nonzeros && nonzeros > 0, "{zeros} {nonzeros}");
    }
}
