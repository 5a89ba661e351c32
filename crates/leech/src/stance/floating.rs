//! The body with a floating driving unit: the chains' angles plus the
//! unit's pose `(p0, phi0)`, under the weld and the holds.

use super::unit::{placed, Unit};
use crate::body::{Body, WELD_ROWS};
use crate::cantilever::start_compliance;
use crate::chain::Chain;
use crate::contact::planar::{chain_terms, point_on, ContactRow, Face, Touching, FRONT_CUP, REAR_CUP, UNIT};
use crate::geom::{dot, right_normal, unit, Vec2};
use crate::hold::{Hold, Pose};
use crate::hose::{Stop, StopRow};
use crate::robot::Robot;
use crate::statics::{Constraints, Evaluation, Path, PathTerms, Potential, Row, RowKind, Stage, StaticSystem};

/// Free coordinates: `p0` (x, y; m) and `phi0` (rad), after the chains' angles.
pub const FREE: usize = 3;
/// Rows of one hold: x, y (m) and angle (rad).
pub const HOLD_ROWS: usize = 3;

/// What the continuation parameter `t` moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Approach {
    /// Gravity, from 0 (`t = 0`) to `g` (`t = 1`); the holds stay.
    Load,
    /// The front hold's target, from this pose (`t = 0`) to the hold's
    /// (`t = 1`), under full gravity, its rows compliant
    /// ([`FloatingBody::front_compliance`]).
    Front(Pose),
    /// The front hold's rows stiffened, their compliance from
    /// [`FloatingBody::front_compliance`] (`t = 0`) to zero (`t = 1`), the
    /// target the hold's, under full gravity.
    Stiffen,
    /// The rear cup releasing, under full gravity: its hold's rows
    /// compliant, this many times chain A's compliance as a cantilever
    /// ([`FloatingBody::cantilever_compliance`]); nothing moves with `t`.
    ReleaseRear(f64),
    /// The front cup releasing, its rows compliant as [`Approach::ReleaseRear`]'s.
    ReleaseFront(f64),
}

impl Approach {
    /// The approach that follows this one on its path: a front approach's
    /// compliant rows are then stiffened; none after the others.
    pub fn then(self) -> Option<Approach> {
        match self {
            Approach::Front(_) => Some(Approach::Stiffen),
            _ => None,
        }
    }
}

/// The floating body: a [`StaticSystem`] with coordinates
/// `q = (phi^A, phi^B, p0_x, p0_y, phi0)` (see the [module doc](super)).
#[derive(Clone, Debug)]
pub struct FloatingBody<'a> {
    body: &'a Body,
    base_spacing: f64,
    unit: Unit,
    hold: Hold,
    approach: Approach,
    contacts: Vec<ContactRow>,
    faces: Option<CupFaces>,
    /// The hose's minimum bend radius (m) and each chain's locked
    /// stiffness (N m/rad), where it stops the joints.
    hose: Option<(f64, [f64; 2])>,
    stops: Vec<StopRow>,
}

/// Where the cups' faces sit, for a body whose free cups rest on surfaces:
/// the rear face's centre `rear_m` from `p0` along `nu(phi0)` and
/// `rear_behind_m` behind it along `-e(phi0)`, the front face's `front_m`
/// from the endpoint along `nu` of the plate, each face `half_width_m` each
/// way along its direction (its rims).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CupFaces {
    /// The rear face's centre from `p0` along `nu(phi0)` (m): `b + rear_offset`.
    pub rear_m: f64,
    /// The rear face's centre behind `p0` along `-e(phi0)` (m).
    pub rear_behind_m: f64,
    /// The front face's centre from the endpoint along `nu` of the plate (m): `c + front_offset`.
    pub front_m: f64,
    /// Half the cup's diameter (m).
    pub half_width_m: f64,
}

impl CupFaces {
    /// The rims of `cup`'s face in its frame, `(along, across)` (m): the
    /// driving unit's for the rear cup, the plate's for the front.
    fn rims(&self, cup: usize) -> [Vec2; 2] {
        let (centre, across) = if cup == REAR_CUP { (-self.rear_behind_m, self.rear_m) } else { (0.0, self.front_m) };
        [-1.0, 1.0].map(|side| [centre + side * self.half_width_m, across])
    }
}

/// One chain's attachment to the driving unit.
struct Attachment<'c> {
    chain: &'c Chain,
    /// The chain's clamp from `p0`, as a function of `phi0`: 0 for chain A,
    /// `b nu(phi0)` for chain B.
    spacing: f64,
    /// First coordinate of the chain in `q`.
    first: usize,
}

impl Attachment<'_> {
    /// The clamp's offset from `p0` and its first two derivatives in `phi0`
    /// (`b nu`, `b e`, `b e'`), plus the rigid root piece `r e(phi0)`.
    fn offset(&self, phi0: f64, root: f64) -> [Vec2; 3] {
        let (b, [c, s]) = (self.spacing, unit(phi0));
        // nu = (s, -c), nu' = e = (c, s), nu'' = e' = (-s, c); root: r e, r e', -r e.
        [
            [b * s + root * c, -b * c + root * s],
            [b * c - root * s, b * s + root * c],
            [-b * s - root * c, b * c - root * s],
        ]
    }
}

impl<'a> FloatingBody<'a> {
    /// The floating form of `body` (its chains' clamps are the reference
    /// pose: A's clamp point and direction), with base spacing `b` (m), the
    /// driving unit's mass (kg) at the midpoint of the clamps, and `hold`.
    pub fn new(body: &'a Body, base_spacing: f64, unit_mass: f64, hold: Hold, approach: Approach) -> FloatingBody<'a> {
        FloatingBody {
            body,
            base_spacing,
            unit: Unit::point_mass(unit_mass, base_spacing),
            hold,
            approach,
            contacts: Vec::new(),
            faces: None,
            hose: None,
            stops: Vec::new(),
        }
    }

    /// The floating form of `body` for `robot`: its base spacing and its
    /// driving unit with the tubes' tails ([`Unit::of`]).
    pub fn of(robot: &Robot, body: &'a Body, hold: Hold, approach: Approach) -> FloatingBody<'a> {
        FloatingBody::new(body, robot.body.base_spacing_m, 0.0, hold, approach).with_unit(Unit::of(robot, body))
    }

    /// The same body with the hose's stop at `min_bend_radius` (m), each
    /// chain `stiffness` (N m/rad) stiff there ([`crate::hose`]): its stop rows,
    /// found at each solved shape, keep every joint within
    /// `l / min_bend_radius` but for the give of the locked hose. No stop
    /// for a radius of 0.
    pub fn with_hose_stop(mut self, min_bend_radius: f64, stiffness: [f64; 2]) -> Self {
        self.hose = (min_bend_radius > 0.0).then_some((min_bend_radius, stiffness));
        self
    }

    /// The same body with this driving unit: its mass where it sits, and
    /// its outline, which rests on the solids where the unit is free and the
    /// faces are in the world ([`FloatingBody::with_cup_faces`]).
    pub fn with_unit(mut self, unit: Unit) -> Self {
        self.unit = unit;
        self
    }

    /// The same body with the cups' faces in the world: a cup that does not
    /// hold rests on what its face meets (its rims get contact rows), and so
    /// does the driving unit's outline where the rear cup does not hold.
    pub fn with_cup_faces(mut self, faces: CupFaces) -> Self {
        self.faces = Some(faces);
        self
    }

    /// The corners of face `chain` ([`REAR_CUP`], [`FRONT_CUP`], [`UNIT`])
    /// in its frame, `(along, across)` (m).
    fn face_corners(&self, chain: usize) -> Vec<Vec2> {
        match chain {
            UNIT => self.unit.outline_m.map_or_else(Vec::new, |o| o.to_vec()),
            cup => self.faces.expect("cup faces").rims(cup).to_vec(),
        }
    }

    /// The frame a face moves with: the driving unit's pose, or for the
    /// front cup the endpoint and chain A's last angle.
    fn face_frame(&self, q: &[f64], chain: usize) -> (Vec2, f64) {
        let n = self.chains();
        if chain == FRONT_CUP {
            (self.endpoint(q), q[self.body.chain_a().len() - 1])
        } else {
            ([q[n], q[n + 1]], q[n + 2])
        }
    }

    /// Where on its face a row on a face touches, with its derivatives in
    /// the face's frame's angle: a corner, or a point along an edge
    /// ([`ContactRow::fraction`]).
    fn face_terms(&self, q: &[f64], contact: &ContactRow) -> [Vec2; 3] {
        // The point in the face's frame, without building the face: this
        // runs for every face row at every evaluation.
        let (link, fraction) = (contact.link, contact.fraction);
        let local = match contact.chain {
            UNIT => point_on(&self.unit.outline_m.expect("a row on the unit's outline"), link, fraction),
            cup => point_on(&self.faces.expect("cup faces").rims(cup), link, fraction),
        };
        let (origin, angle) = self.face_frame(q, contact.chain);
        placed(origin, local, angle)
    }

    /// The same body with these contact rows (after the holds' rows).
    pub fn with_contacts(mut self, contacts: Vec<ContactRow>) -> Self {
        self.contacts = contacts;
        self
    }

    /// The contact rows.
    pub fn contacts(&self) -> &[ContactRow] {
        &self.contacts
    }

    /// The first contact row's index.
    pub fn contact_row(&self) -> usize {
        Touching::contact_row(self)
    }

    /// Chain `c`'s centre line where it is (m): the clamp, the first joint
    /// when there is a rigid root piece, then every link's tip (the last
    /// [`FloatingBody::chain_len`] points).
    pub fn chain_points(&self, q: &[f64], c: usize) -> Vec<Vec2> {
        let n = self.chains();
        let att = &self.attachments()[c];
        let d = self.shift(att, [q[n], q[n + 1]], q[n + 2]);
        let mut points = att.chain.points(&q[att.first..att.first + att.chain.len()]);
        points.iter_mut().for_each(|p| *p = [p[0] + d[0], p[1] + d[1]]);
        // The clamp itself does not turn with the root piece.
        let clamp = att.offset(q[n + 2], 0.0)[0];
        points[0] = [q[n] + clamp[0], q[n + 1] + clamp[1]];
        points
    }

    /// Number of links of chain `c` (0: A, 1: B).
    pub fn chain_len(&self, c: usize) -> usize {
        self.attachments()[c].chain.len()
    }

    /// The clamped body underneath.
    pub fn body(&self) -> &Body {
        self.body
    }

    /// What the continuation parameter moves.
    pub fn approach(&self) -> Approach {
        self.approach
    }

    /// The same body moved along another approach.
    pub fn with_approach(mut self, approach: Approach) -> Self {
        self.approach = approach;
        self
    }

    /// The holds.
    pub fn hold(&self) -> Hold {
        self.hold
    }

    fn chains(&self) -> usize {
        self.body.chain_a().len() + self.body.chain_b().len()
    }

    fn attachments(&self) -> [Attachment<'a>; 2] {
        let (a, b) = (self.body.chain_a(), self.body.chain_b());
        [
            Attachment { chain: a, spacing: 0.0, first: 0 },
            Attachment { chain: b, spacing: self.base_spacing, first: a.len() },
        ]
    }

    /// Every point of chain `c` moves by `p0 - p_ref + off_c(phi0) - off_c(phi_ref)`
    /// from where the reference clamp puts it (m).
    fn shift(&self, c: &Attachment<'_>, p0: Vec2, phi0: f64) -> Vec2 {
        let reference = self.body.chain_a().clamp_point();
        let phi_ref = self.body.chain_a().clamp_angle();
        let root = c.chain.root_length();
        let (now, before) = (c.offset(phi0, root)[0], c.offset(phi_ref, root)[0]);
        [p0[0] - reference[0] + now[0] - before[0], p0[1] - reference[1] + now[1] - before[1]]
    }

    /// The driving unit's pose `(p0, phi0)` in `q`.
    pub fn unit_pose(&self, q: &[f64]) -> Pose {
        let n = self.chains();
        Pose { point_m: [q[n], q[n + 1]], angle_rad: q[n + 2] }
    }

    /// The endpoint (chain A's tip, m) for `q`.
    pub fn endpoint(&self, q: &[f64]) -> Vec2 {
        let n = self.chains();
        let [a, _] = self.attachments();
        let tip = a.chain.tip(&q[..a.chain.len()]);
        let d = self.shift(&a, [q[n], q[n + 1]], q[n + 2]);
        [tip[0] + d[0], tip[1] + d[1]]
    }

    /// Total weight carried by the holds and contacts (N): chains, payload,
    /// root pieces and the driving unit.
    pub fn weight(&self) -> f64 {
        let g = self.body.gravity();
        let chains: f64 = self.attachments().iter().map(|c| c.chain.total_mass() + c.chain.root_mass()).sum();
        g * (chains + self.unit.mass_kg)
    }

    /// The centre of mass of everything the holds carry (m).
    pub fn centre_of_mass(&self, q: &[f64]) -> Vec2 {
        let n = self.chains();
        let (p0, phi0) = ([q[n], q[n + 1]], q[n + 2]);
        let mut moment = [0.0; 2];
        let mut mass = 0.0;
        for c in &self.attachments() {
            let m = c.chain.total_mass();
            let own = c.chain.mass_moment(&q[c.first..c.first + c.chain.len()]);
            let shift = self.shift(c, p0, phi0);
            let root = c.offset(phi0, 0.5 * c.chain.root_length())[0];
            for i in 0..2 {
                moment[i] += own[i] + m * shift[i] + c.chain.root_mass() * (p0[i] + root[i]);
            }
            mass += m + c.chain.root_mass();
        }
        let unit = placed(p0, self.unit.centre_m, phi0)[0];
        for i in 0..2 {
            moment[i] += self.unit.mass_kg * unit[i];
        }
        mass += self.unit.mass_kg;
        [moment[0] / mass, moment[1] / mass]
    }

    /// Where the hold rows start: rear first, then front.
    fn hold_rows(&self) -> (Option<usize>, Option<usize>) {
        let rear = self.hold.rear().map(|_| WELD_ROWS);
        let front = self.hold.front().map(|_| WELD_ROWS + if rear.is_some() { HOLD_ROWS } else { 0 });
        (rear, front)
    }

    /// The front hold's target at `t`.
    fn front_target(&self, t: f64) -> Option<Pose> {
        let front = self.hold.front()?;
        Some(match self.approach {
            Approach::Front(from) => from.lerp(&front, t),
            _ => front,
        })
    }

    /// The compliance of the front hold's rows while the front cup attaches:
    /// chain A as a cantilever ([`start_compliance`]), m/N for the
    /// endpoint's rows and rad/(N m) for the plate's angle. Along a straight
    /// chain A the endpoint's row has a zero Jacobian (an inextensible tube
    /// cannot move its tip along itself), so rigid rows there make the KKT
    /// matrix singular; compliant ones load the tube as a column, which
    /// buckles (a bifurcation the path reports) instead.
    pub fn front_compliance(&self) -> [f64; 2] {
        let chain = self.body.chain_a();
        start_compliance(chain.tube_length(), chain.nominal_stiffness() * chain.element_length())
    }

    /// Chain A as a cantilever, `L^3 / EI` (m/N) and `L / EI` (rad/(N m)):
    /// the scale of a releasing hold's compliance.
    pub fn cantilever_compliance(&self) -> [f64; 2] {
        let chain = self.body.chain_a();
        let (length, bending) = (chain.tube_length(), chain.nominal_stiffness() * chain.element_length());
        [length.powi(3) / bending, length / bending]
    }

    /// The compliance of the rows of a releasing hold (rear when `rear`), zero for the others.
    fn release_softness(&self, rear: bool) -> [f64; HOLD_ROWS] {
        let softness = match (self.approach, rear) {
            (Approach::ReleaseRear(s), true) | (Approach::ReleaseFront(s), false) => s,
            _ => return [0.0; HOLD_ROWS],
        };
        let [tip, angle] = self.cantilever_compliance();
        [softness * tip, softness * tip, softness * angle]
    }

    /// The front hold's three rows' compliance at `t` and its rate along `t`.
    fn front_softness(&self, t: f64) -> ([f64; HOLD_ROWS], [f64; HOLD_ROWS]) {
        let [tip, angle] = self.front_compliance();
        let soft = [tip, tip, angle];
        match self.approach {
            Approach::Load | Approach::ReleaseRear(_) => ([0.0; HOLD_ROWS], [0.0; HOLD_ROWS]),
            Approach::Front(_) => (soft, [0.0; HOLD_ROWS]),
            Approach::Stiffen => (soft.map(|c| (1.0 - t) * c), soft.map(|c| -c)),
            Approach::ReleaseFront(_) => (self.release_softness(false), [0.0; HOLD_ROWS]),
        }
    }

    fn load(&self, t: f64) -> f64 {
        match self.approach {
            Approach::Load => t,
            _ => 1.0,
        }
    }

    /// The first springs now turn against `phi0`, not the reference clamp
    /// angle: their correction to the reference chains' terms.
    fn attach_springs(&self, q: &[f64], ev: &mut Evaluation) {
        let n = self.chains();
        let phi0 = q[n + 2];
        for c in &self.attachments() {
            let (k, phi1, phi_ref) = (c.chain.stiffness()[0], q[c.first], c.chain.clamp_angle());
            ev.energy += 0.5 * k * ((phi1 - phi0).powi(2) - (phi1 - phi_ref).powi(2));
            ev.gradient[c.first] += k * (phi_ref - phi0);
            ev.gradient[n + 2] -= k * (phi1 - phi0);
            ev.hessian_border[c.first * FREE + 2] -= k;
            ev.hessian_corner[2 * FREE + 2] += k;
        }
    }

    /// Gravity's terms on the driving unit's pose, per unit of gravity
    /// (kg m, kg, kg m, kg m): the chains ride on the clamps' offsets, the
    /// root pieces' and the unit's weights on the pose itself. Returns the
    /// potential, `d/dp0_y`, `d/dphi0` and `d2/dphi0^2`, each over `g`.
    fn base_weight(&self, q: &[f64]) -> [f64; 4] {
        let n = self.chains();
        let (p0, phi0) = ([q[n], q[n + 1]], q[n + 2]);
        let mut out = [0.0; 4];
        for c in &self.attachments() {
            let (mass, root_mass, root) = (c.chain.total_mass(), c.chain.root_mass(), c.chain.root_length());
            let shift = self.shift(c, p0, phi0);
            let [_, d1, d2] = c.offset(phi0, root);
            // The root piece's weight sits at its middle; a clamped chain leaves it out.
            let [mid, mid1, mid2] = c.offset(phi0, 0.5 * root);
            out[0] += mass * shift[1] + root_mass * (p0[1] + mid[1]);
            out[1] += mass + root_mass;
            out[2] += mass * d1[1] + root_mass * mid1[1];
            out[3] += mass * d2[1] + root_mass * mid2[1];
        }
        // The driving unit's mass where it sits in the unit's frame.
        let [at, d1, d2] = placed(p0, self.unit.centre_m, phi0);
        let md = self.unit.mass_kg;
        [out[0] + md * at[1], out[1] + md, out[2] + md * d1[1], out[3] + md * d2[1]]
    }
}

impl Potential for FloatingBody<'_> {
    fn dim(&self) -> usize {
        self.chains() + FREE
    }

    fn blocks(&self) -> Vec<usize> {
        self.body.blocks()
    }

    fn free(&self) -> usize {
        FREE
    }

    fn moment_scale(&self) -> f64 {
        self.body.moment_scale()
    }

    fn potential(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        let n = self.chains();
        let load = self.load(t);
        self.body.potential_with(&q[..n], self.body.gravity(), load, [1.0; 2], ev);
        self.attach_springs(q, ev);
        let weight = load * self.body.gravity();
        let [v, dy, dphi, ddphi] = self.base_weight(q);
        ev.energy += weight * v;
        ev.gradient[n + 1] += weight * dy;
        ev.gradient[n + 2] += weight * dphi;
        ev.hessian_corner[2 * FREE + 2] += weight * ddphi;
    }
}

impl Constraints for FloatingBody<'_> {
    fn rows(&self) -> usize {
        let (rear, front) = (self.hold.rear().is_some(), self.hold.front().is_some());
        WELD_ROWS + HOLD_ROWS * (usize::from(rear) + usize::from(front)) + self.stops.len() + self.contacts.len()
    }

    fn row(&self, r: usize) -> Row {
        if r >= self.contact_row() {
            return Row { kind: RowKind::Inequality, scale: self.body.row(0).scale };
        }
        if r >= Touching::stop_row(self) {
            return Row { kind: RowKind::Inequality, scale: 1.0 };
        }
        // Positions in element lengths, angles in radians, as the weld.
        let position = (r - WELD_ROWS.min(r)) % HOLD_ROWS < 2;
        let scale = if r < WELD_ROWS {
            self.body.row(r).scale
        } else if position {
            self.body.row(0).scale
        } else {
            1.0
        };
        Row { kind: RowKind::Equality, scale }
    }

    fn constraints(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        let n = self.chains();
        let m = ev.rows();
        self.body.weld_with(&q[..n], [1.0; 2], ev);
        // The weld moves with the clamps' offsets: p0 cancels, phi0 does not.
        let [a, b] = self.attachments();
        let phi0 = q[n + 2];
        let (oa, ob) = (a.offset(phi0, a.chain.root_length()), b.offset(phi0, b.chain.root_length()));
        let shift = [self.shift(&b, [q[n], q[n + 1]], phi0), self.shift(&a, [q[n], q[n + 1]], phi0)];
        for r in 0..2 {
            ev.constraints[r] += shift[0][r] - shift[1][r];
            ev.jacobian[(n + 2) * m + r] = ob[1][r] - oa[1][r];
            ev.curvature[(n + 2) * m + r] = ob[2][r] - oa[2][r];
        }
        let (rear, front) = self.hold_rows();
        if let (Some(row), Some(pose)) = (rear, self.hold.rear()) {
            let target = [pose.point_m[0], pose.point_m[1], pose.angle_rad];
            for i in 0..HOLD_ROWS {
                ev.constraints[row + i] = q[n + i] - target[i];
                ev.jacobian[(n + i) * m + row + i] = 1.0;
            }
            ev.compliance[row..row + HOLD_ROWS].copy_from_slice(&self.release_softness(true));
        }
        if let (Some(row), Some(pose)) = (front, self.front_target(t)) {
            self.front_rows(q, row, pose, &oa, ev);
            ev.compliance[row..row + HOLD_ROWS].copy_from_slice(&self.front_softness(t).0);
        }
        let stop_row = Touching::stop_row(self);
        for (i, stop) in self.stops.iter().enumerate() {
            self.stop_terms(q, stop_row + i, stop, ev);
        }
        let first = self.contact_row();
        for (i, contact) in self.contacts.iter().enumerate() {
            match contact.chain {
                REAR_CUP | UNIT => self.unit_face_terms(q, first + i, contact, ev),
                FRONT_CUP => self.front_rim_terms(q, first + i, contact, ev),
                _ => self.contact_terms(q, first + i, contact, ev),
            }
        }
    }
}

impl FloatingBody<'_> {
    /// The front hold's rows at `row..row + 3`: the endpoint on the target
    /// point and chain A's last link (the plate) at the target angle.
    fn front_rows(&self, q: &[f64], row: usize, pose: Pose, oa: &[Vec2; 3], ev: &mut Evaluation) {
        let (n, m) = (self.chains(), ev.rows());
        let chain = self.body.chain_a();
        let na = chain.len();
        let tip = self.endpoint(q);
        for (j, l) in chain.lengths().iter().enumerate() {
            let (c, s) = (ev.cos[j], ev.sin[j]);
            ev.jacobian[j * m + row] = -l * s;
            ev.jacobian[j * m + row + 1] = l * c;
            ev.curvature[j * m + row] = -l * c;
            ev.curvature[j * m + row + 1] = -l * s;
        }
        for i in 0..2 {
            ev.constraints[row + i] = tip[i] - pose.point_m[i];
            ev.jacobian[(n + i) * m + row + i] = 1.0;
            // The root piece turns with phi0 (chain A has no spacing).
            ev.jacobian[(n + 2) * m + row + i] = oa[1][i];
            ev.curvature[(n + 2) * m + row + i] = oa[2][i];
        }
        ev.constraints[row + 2] = q[na - 1] - pose.angle_rad;
        ev.jacobian[(na - 1) * m + row + 2] = 1.0;
    }
}

impl FloatingBody<'_> {
    /// A stop row `beta_max - s (phi_j - phi_(j-1))` at `row`, the joint at
    /// the clamp turning from the driving unit's angle `phi0`.
    fn stop_terms(&self, q: &[f64], row: usize, stop: &StopRow, ev: &mut Evaluation) {
        let m = ev.rows();
        let (at, before) = self.joint_coordinates(stop.chain, stop.joint);
        ev.constraints[row] = stop.value(q[at] - q[before]);
        ev.jacobian[at * m + row] = -stop.sign;
        ev.jacobian[before * m + row] = stop.sign;
        ev.compliance[row] = stop.stop.compliance;
    }

    /// The coordinates of the two angles joint `joint` of chain `c` turns
    /// between: its link's, and the link's before it or, at the clamp, the
    /// driving unit's `phi0`.
    fn joint_coordinates(&self, c: usize, joint: usize) -> (usize, usize) {
        let at = self.attachments()[c].first + joint;
        (at, if joint == 0 { self.chains() + 2 } else { at - 1 })
    }

    /// A contact row `n . x - h` at `row`: `x` moves with the links before
    /// it, its own link by the fraction, and the driving unit's pose.
    fn contact_terms(&self, q: &[f64], row: usize, contact: &ContactRow, ev: &mut Evaluation) {
        let (n, m) = (self.chains(), ev.rows());
        let att = &self.attachments()[contact.chain];
        let normal = contact.normal;
        let shift = self.shift(att, [q[n], q[n + 1]], q[n + 2]);
        let first = att.chain.first_joint();
        let start = [shift[0] + first[0], shift[1] + first[1]];
        let x = chain_terms(att.chain, att.first, start, row, contact, ev);
        ev.constraints[row] = dot(normal, x) - contact.offset;
        let [_, d1, d2] = att.offset(q[n + 2], att.chain.root_length());
        ev.jacobian[n * m + row] = normal[0];
        ev.jacobian[(n + 1) * m + row] = normal[1];
        ev.jacobian[(n + 2) * m + row] = dot(normal, d1);
        ev.curvature[(n + 2) * m + row] = dot(normal, d2);
    }

    /// A row on a face the driving unit carries (the free rear cup's, its
    /// outline): `x = p0 + a e(phi0) + c nu(phi0)` ([`super::unit`]).
    fn unit_face_terms(&self, q: &[f64], row: usize, contact: &ContactRow, ev: &mut Evaluation) {
        let (n, m, normal) = (self.chains(), ev.rows(), contact.normal);
        let [x, dx, ddx] = self.face_terms(q, contact);
        ev.constraints[row] = dot(normal, x) - contact.offset;
        ev.jacobian[n * m + row] = normal[0];
        ev.jacobian[(n + 1) * m + row] = normal[1];
        ev.jacobian[(n + 2) * m + row] = dot(normal, dx);
        ev.curvature[(n + 2) * m + row] = dot(normal, ddx);
    }

    /// A row on the free front cup's rim: chain A's tip (as a contact there)
    /// plus `d nu(theta) + s w e(theta)`, `theta` chain A's last angle.
    fn front_rim_terms(&self, q: &[f64], row: usize, contact: &ContactRow, ev: &mut Evaluation) {
        let m = ev.rows();
        let last = self.body.chain_a().len() - 1;
        let tip = ContactRow { chain: 0, link: last, fraction: 1.0, ..*contact };
        self.contact_terms(q, row, &tip, ev);
        let [x, dx, ddx] = self.face_terms(q, contact);
        ev.constraints[row] = dot(contact.normal, x) - contact.offset;
        ev.jacobian[last * m + row] += dot(contact.normal, dx);
        ev.curvature[last * m + row] += dot(contact.normal, ddx);
    }

    /// Where contact row `contact` touches (m).
    pub fn contact_point(&self, q: &[f64], contact: &ContactRow) -> Vec2 {
        Touching::contact_point(self, q, contact)
    }
}

/// The inherent methods of the same names, for the contact machinery.
impl Touching for FloatingBody<'_> {
    fn chain_count(&self) -> usize {
        2
    }

    fn chain_points(&self, q: &[f64], c: usize) -> Vec<Vec2> {
        FloatingBody::chain_points(self, q, c)
    }

    fn chain_len(&self, c: usize) -> usize {
        FloatingBody::chain_len(self, c)
    }

    fn contacts(&self) -> &[ContactRow] {
        &self.contacts
    }

    fn with_contacts(self, contacts: Vec<ContactRow>) -> Self {
        FloatingBody::with_contacts(self, contacts)
    }

    fn stop(&self, c: usize) -> Option<Stop> {
        let (radius, stiffness) = self.hose?;
        Stop::new(self.attachments()[c].chain.element_length(), radius, stiffness[c])
    }

    fn joint_turns(&self, q: &[f64], c: usize, out: &mut Vec<f64>) {
        out.clear();
        out.extend((0..self.attachments()[c].chain.len()).map(|j| {
            let (at, before) = self.joint_coordinates(c, j);
            q[at] - q[before]
        }));
    }

    fn stops(&self) -> &[StopRow] {
        &self.stops
    }

    /// Each row carries its stop: rows found with another body's hose (a
    /// phase continued from a held body) keep their own limits.
    fn with_stops(mut self, stops: Vec<StopRow>) -> Self {
        self.stops = stops;
        self
    }

    /// The free cups' faces and, where the rear cup does not hold, the
    /// driving unit's outline, when the faces are in the world.
    fn free_faces(&self, q: &[f64]) -> Vec<Face> {
        let rear_free = self.hold.rear().is_none();
        let free = [(REAR_CUP, rear_free), (FRONT_CUP, self.hold.front().is_none()), (UNIT, rear_free)];
        free.iter().filter(|(_, free)| *free).filter_map(|&(chain, _)| self.face(q, chain)).collect()
    }

    /// A face of the robot, held or not, when the faces are in the world
    /// (the outline where the unit has one).
    fn face(&self, q: &[f64], chain: usize) -> Option<Face> {
        if self.faces.is_none() || (chain == UNIT && self.unit.outline_m.is_none()) {
            return None;
        }
        let (origin, angle) = self.face_frame(q, chain);
        let corners = self.face_corners(chain).iter().map(|c| placed(origin, *c, angle)[0]).collect();
        Some(Face { chain, corners, closed: chain == UNIT })
    }

    /// With the front cup holding, the plate's pose fixes each chain's last
    /// link, chain A's by the hold and chain B's by the weld: a contact row
    /// there would be a combination of their rows (a singular Jacobian), and
    /// a surface's push there is part of the front reaction.
    fn held_by_front(&self, c: usize, link: usize, fraction: f64) -> bool {
        let n = self.chain_len(c);
        self.hold.front().is_some() && (link + 1 == n || (link + 2 == n && fraction >= 1.0))
    }

    /// A load raises gravity; a front approach moves a target (or stiffens
    /// its rows) under full gravity, a warm start's continuation.
    fn stage(&self) -> Stage {
        match self.approach {
            // A release is stepped as a feed is, at full load.
            Approach::Load | Approach::ReleaseRear(_) | Approach::ReleaseFront(_) => Stage::Load,
            Approach::Front(_) | Approach::Stiffen => Stage::WarmStart,
        }
    }
}

impl StaticSystem for FloatingBody<'_> {
    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64 {
        let n = self.chains();
        let nu = right_normal(q[n + 2]);
        // The endpoint's displacement relative to the driving unit, along
        // the right normal of the clamp direction, as for the clamped body.
        let chain = self.body.chain_a();
        let tip_jacobian = chain.tip_jacobian(&q[..chain.len()]);
        tip_jacobian.iter().zip(dq).map(|(col, d)| (col[0] * nu[0] + col[1] * nu[1]) * d).sum()
    }
}

impl Path for FloatingBody<'_> {
    fn path(&self, q: &[f64], t: f64, ev: &Evaluation, out: &mut PathTerms) {
        let n = self.chains();
        match self.approach {
            Approach::Load => {
                // Everything gravity does is linear in the load: its gradient at full g.
                let g = self.body.gravity();
                let (a, b) = (self.body.chain_a(), self.body.chain_b());
                a.load_gradient(&ev.cos[..a.len()], g, &mut out.gradient[..a.len()]);
                b.load_gradient(&ev.cos[a.len()..n], g, &mut out.gradient[a.len()..n]);
                let [_, dy, dphi, _] = self.base_weight(q);
                out.gradient[n + 1] = g * dy;
                out.gradient[n + 2] = g * dphi;
            }
            Approach::Front(from) => {
                let (_, Some(row)) = self.hold_rows() else { return };
                let to = self.hold.front().expect("a front approach has a front hold");
                out.constraints[row] = from.point_m[0] - to.point_m[0];
                out.constraints[row + 1] = from.point_m[1] - to.point_m[1];
                out.constraints[row + 2] = from.angle_rad - to.angle_rad;
            }
            Approach::Stiffen => {
                let (_, Some(row)) = self.hold_rows() else { return };
                out.compliance[row..row + HOLD_ROWS].copy_from_slice(&self.front_softness(t).1);
            }
            // A release is stepped by its rows' compliance, not along `t`.
            Approach::ReleaseRear(_) | Approach::ReleaseFront(_) => {}
        }
    }
}
