//! One clamped tube as a planar chain of rigid links.
//!
//! The generalized coordinates are the absolute link angles `phi_j` (rad,
//! counter-clockwise from +x), `j = 1..n`. The clamp fixes the point `p0` (m)
//! and the angle `phi_0` (rad). With `e(a) = (cos a, sin a)` and
//! `e'(a) = (-sin a, cos a)`, the tip of link `i` is
//!
//! ```text
//! r_i = s + sum_{j <= i} l_j e(phi_j)          (m)
//! ```
//!
//! where `s = p0 + a_0 e(phi_0)` is where the first flexible joint sits (`a_0 = 0`
//! for [`Discretization::Paper`], `l / 2` for [`Discretization::Midpoint`]).
//!
//! Each link carries a point mass `m_j` (kg) at distance `a_j` along it (the tip
//! for `Paper`, the centre for `Midpoint`), and the last link carries the tip mass
//! `P` (kg). All the chain's weight then acts on link `j` through the *lever*
//!
//! ```text
//! W_j = a_j m_j + l_j (sum_{i > j} m_i + P)      (kg m)
//! ```
//!
//! so that, with `g` (m/s^2) the gravity along -y,
//!
//! ```text
//! V_g       = g sum_i m_i y_i + g P y_n                         (J)
//! dV_g/dphi_j   =  g W_j cos(phi_j)                             (N m)
//! d2V_g/dphi_j2 = -g W_j sin(phi_j)       (diagonal)            (N m / rad)
//! V_s = sum_j k_j / 2 (phi_j - phi_{j-1})^2    (tridiagonal Hessian)
//! ```
//!
//! For dynamics the mass matrix is `M_jk = C_jk cos(phi_j - phi_k) + I_j delta_jk`
//! with `C_jk = l_j W_k` for `j < k`, `C_kk = a_k^2 m_k + l_k^2 (sum_{i>k} m_i + P)`
//! (kg m^2), `I_j` the links' own rotational inertia (zero for `Paper`, whose
//! masses are points; `m_j l_j^2 / 12` for `Midpoint`, whose mass is spread), and
//! the velocity-product terms are `h_j = sum_k C_jk sin(phi_j - phi_k) dphi_k^2`.
//! For `Paper` these are exactly the paper's `M_jk = l_j l_k mu_max(j,k) cos(...)`.
//!
//! A tube of length `L` gets `n` elements of length `l`, the last one shorter,
//! its spring stiffer in proportion, so that shapes are continuous in `L` (see
//! [`Discretization`]).

use serde::{Deserialize, Serialize};

use crate::error::InputError;
use crate::geom::unit;
use crate::linalg::quasiseparable::{self, Generators};
use crate::statics::Evaluation;

/// How a continuous tube is cut into rigid links.
///
/// A tube of length `L` is cut into `n = ceil(L / l)` elements of length `l`,
/// the last one of length `l_n = L - (n - 1) l` in `(0, l]`. Each element `j`
/// has one joint whose spring carries that element's bending compliance,
/// `k_j = EI / l_j = k l / l_j` (so `k` for whole elements), and a damper
/// `d l / l_j`; its mass is `m l_j / l`.
///
/// * `Paper` (the paper's scheme): the joint at the start of each element,
///   the element is the link, its mass at its tip. First-order accurate in
///   `l` against the continuous elastica.
/// * `Midpoint` (pseudo-rigid-body scheme): the joint at the middle of each
///   element; the piece from the clamp to the first joint is rigid, the links
///   run from joint to joint and the last from the last joint to the tip,
///   each carrying its own mass at its centre. With whole elements the end
///   pieces are `l/2` long. Second-order accurate in `l`.
///
/// Scaling the last joint's spring with `l / l_n` (a constant `k`, as the
/// paper has it, does not: docs/model.md section 4) makes shapes continuous in `L` even when the tip is loaded or welded
/// to the plate: a new element appears rigid and softens as it grows. With a
/// constant `k` the endpoint of the built-in body jumps by several
/// millimetres each time a tube crosses a whole number of elements.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Discretization {
    /// Springs at element starts, masses at element tips (the paper's model).
    #[default]
    Paper,
    /// Joints at element midpoints, half-length end pieces, masses spread.
    Midpoint,
}

/// Most links one chain may have: keeps memory and time bounded for any input
/// (a 100 m tube at 1 cm elements).
pub const MAX_LINKS: usize = 10_000;

/// Longest tube (m) a chain may describe: any longer and a product of
/// finite inputs (`elements x element length`) may overflow, or describe
/// nothing a soft robot could be.
pub const MAX_TUBE_LENGTH_M: f64 = 1e3;

/// Element lengths (m) a tube may be cut into: 0.1 mm to 1 m. Shorter, a
/// link's inertia and spring (`k / l`, `m l^2`) leave the range where the
/// solvers' tolerances mean anything (a subnormal length solves to
/// nonsense); longer, one element is no longer a short piece of a soft tube.
pub const ELEMENT_LENGTH_M: (f64, f64) = (1e-4, 1.0);

/// Element masses (kg): a microgram to a tonne. Below, gravity's terms
/// vanish beside the solver's tolerances (a subnormal mass is accepted as
/// weightless and means nothing); above, nothing a soft robot carries.
pub const ELEMENT_MASS_KG: (f64, f64) = (1e-9, 1e3);

/// Checks an element length against [`ELEMENT_LENGTH_M`].
pub fn check_element_length(field: &str, length: f64) -> Result<f64, InputError> {
    crate::error::within(field, length, ELEMENT_LENGTH_M.0, ELEMENT_LENGTH_M.1)
}

/// Checks an element mass against [`ELEMENT_MASS_KG`].
pub fn check_element_mass(field: &str, mass: f64) -> Result<f64, InputError> {
    crate::error::within(field, mass, ELEMENT_MASS_KG.0, ELEMENT_MASS_KG.1)
}

/// Largest factor by which a short last element's spring exceeds `k`.
pub const MAX_STIFFNESS_RATIO: f64 = 1e4;

/// Guards `ceil` against a length that is a whole number of elements up to
/// rounding (0.3 / 0.01 = 29.999999999999996).
const WHOLE_ELEMENT_SLACK: f64 = 1e-9;

impl Discretization {
    /// Number of elements (and links) for a tube of length `tube_length` (m)
    /// cut into elements of `element_length` (m); at least one.
    ///
    /// ```
    /// use leech::chain::Discretization;
    /// assert_eq!(Discretization::Paper.link_count(0.30, 0.01), 30);
    /// assert_eq!(Discretization::Paper.link_count(0.3004, 0.01), 31);
    /// assert_eq!(Discretization::Midpoint.link_count(0.296, 0.01), 30);
    /// ```
    pub fn link_count(self, tube_length: f64, element_length: f64) -> usize {
        ((tube_length / element_length - WHOLE_ELEMENT_SLACK).ceil().max(1.0)) as usize
    }

    /// The name used in robot files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Discretization::Paper => "paper",
            Discretization::Midpoint => "midpoint",
        }
    }
}

/// Mutable views of one chain's part of the solver's scratch.
pub(crate) struct Block<'a> {
    pub cos: &'a mut [f64],
    pub sin: &'a mut [f64],
    pub grad: &'a mut [f64],
    pub diag: &'a mut [f64],
    pub off: &'a mut [f64],
}

impl<'a> Block<'a> {
    /// The views of the coordinates `range` of an evaluation.
    pub fn of(ev: &'a mut Evaluation, range: std::ops::Range<usize>) -> Block<'a> {
        let off_end = range.end.min(ev.hessian_off.len());
        Block {
            cos: &mut ev.cos[range.clone()],
            sin: &mut ev.sin[range.clone()],
            grad: &mut ev.gradient[range.clone()],
            diag: &mut ev.hessian_diag[range.clone()],
            off: &mut ev.hessian_off[range.start..off_end],
        }
    }
}

/// Everything needed to cut one tube into a [`Chain`]. All SI.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainSpec {
    /// Free tube length `L` (m).
    pub tube_length: f64,
    /// Element length `l` (m).
    pub element_length: f64,
    /// Mass of one whole element `m` (kg).
    pub element_mass: f64,
    /// Torsional stiffness of one joint `k` (N m/rad).
    pub stiffness: f64,
    /// Torsional damping of one joint `d` (N m s/rad).
    pub damping: f64,
    /// Point mass at the tip (kg).
    pub tip_mass: f64,
    /// Clamp position `p0` (m).
    pub clamp_point: [f64; 2],
    /// Clamp angle `phi_0` (rad).
    pub clamp_angle: f64,
    /// How the tube is cut into links.
    pub discretization: Discretization,
}

/// A discretized tube: link lengths, masses, springs and dampers.
#[derive(Clone, Debug, PartialEq)]
pub struct Chain {
    clamp_point: [f64; 2],
    clamp_angle: f64,
    root_length: f64,
    /// `clamp_point + root_length e(clamp_angle)` (m), kept: every solver
    /// evaluation of a body starts four sums there (each chain's potential,
    /// the weld's two tips), and its sine and cosine were 4 % of the
    /// evaluations' on the Fig. 12 sweep.
    first_joint: [f64; 2],
    tube_length: f64,
    element_length: f64,
    lengths: Vec<f64>,
    masses: Vec<f64>,
    mass_offsets: Vec<f64>,
    /// The mass matrix's diagonal `C_jj + I_j` (kg m^2).
    mass_diagonal: Vec<f64>,
    stiffness: Vec<f64>,
    nominal_stiffness: f64,
    damping: Vec<f64>,
    tip_mass: f64,
    levers: Vec<f64>,
}

impl Chain {
    /// Cuts a tube into links. The spec is assumed valid (positive, finite,
    /// `tube_length >= element_length`); [`crate::robot`] checks user input.
    pub fn new(spec: &ChainSpec) -> Chain {
        let l = spec.element_length;
        let d = spec.discretization;
        let n = d.link_count(spec.tube_length, l);
        let mut elements = vec![l; n];
        elements[n - 1] = spec.tube_length - (n - 1) as f64 * l;
        let (root_length, lengths) = match d {
            Discretization::Paper => (0.0, elements.clone()),
            Discretization::Midpoint => (
                0.5 * elements[0],
                (0..n).map(|j| 0.5 * (elements[j] + elements.get(j + 1).copied().unwrap_or(0.0))).collect(),
            ),
        };
        let masses: Vec<f64> = lengths.iter().map(|li| spec.element_mass * li / l).collect();
        let (mass_offsets, inertias): (Vec<f64>, Vec<f64>) = match d {
            Discretization::Paper => (lengths.clone(), vec![0.0; n]),
            Discretization::Midpoint => (
                lengths.iter().map(|li| 0.5 * li).collect(),
                lengths.iter().zip(&masses).map(|(li, mi)| mi * li * li / 12.0).collect(),
            ),
        };
        // A vanishing element would make its spring arbitrarily stiff and the
        // Newton system arbitrarily ill-conditioned; capping the ratio leaves
        // a jump of 1/MAX_STIFFNESS_RATIO of the uncapped one (sub-micrometre).
        let compliance = |e: &f64| (l / e).min(MAX_STIFFNESS_RATIO);
        let mut chain = Chain {
            clamp_point: spec.clamp_point,
            clamp_angle: spec.clamp_angle,
            root_length,
            first_joint: {
                let u = unit(spec.clamp_angle);
                [spec.clamp_point[0] + root_length * u[0], spec.clamp_point[1] + root_length * u[1]]
            },
            tube_length: spec.tube_length,
            element_length: l,
            lengths,
            masses,
            mass_offsets,
            mass_diagonal: inertias,
            stiffness: elements.iter().map(|e| spec.stiffness * compliance(e)).collect(),
            nominal_stiffness: spec.stiffness,
            damping: elements.iter().map(|e| spec.damping * compliance(e)).collect(),
            tip_mass: spec.tip_mass,
            levers: Vec::new(),
        };
        chain.update_levers();
        chain
    }

    /// Levers `W_j` and the mass matrix's diagonal, which holds the links'
    /// own inertias `I_j` on entry.
    fn update_levers(&mut self) {
        let n = self.len();
        self.levers.resize(n, 0.0);
        let mut beyond = self.tip_mass;
        for j in (0..n).rev() {
            let (a, l, m) = (self.mass_offsets[j], self.lengths[j], self.masses[j]);
            self.levers[j] = a * m + l * beyond;
            self.mass_diagonal[j] += a * a * m + l * l * beyond;
            beyond += m;
        }
    }

    /// Number of flexible links `n`.
    pub fn len(&self) -> usize {
        self.lengths.len()
    }

    /// Always false: a chain has at least one link.
    pub fn is_empty(&self) -> bool {
        self.lengths.is_empty()
    }

    /// Link lengths `l_j` (m).
    pub fn lengths(&self) -> &[f64] {
        &self.lengths
    }

    /// Link masses `m_j` (kg), not counting the tip mass.
    pub fn masses(&self) -> &[f64] {
        &self.masses
    }

    /// Joint stiffnesses `k_j` (N m/rad); joint `j` sits at the start of link `j`.
    pub fn stiffness(&self) -> &[f64] {
        &self.stiffness
    }

    /// The stiffness `k` of a whole element's joint (N m/rad).
    pub fn nominal_stiffness(&self) -> f64 {
        self.nominal_stiffness
    }

    /// The element length `l` (m): the tube's bending stiffness is
    /// `EI = k l` ([`Chain::nominal_stiffness`]).
    pub fn element_length(&self) -> f64 {
        self.element_length
    }

    /// The discrete shape parameter `k / (m g l)` of a whole element under
    /// `gravity` (dimensionless; 0 without gravity or mass).
    pub fn discrete_stiffness(&self, gravity: f64) -> f64 {
        let weight = self.masses.first().copied().unwrap_or(0.0) * gravity.abs() * self.element_length;
        if weight > 0.0 {
            self.nominal_stiffness / weight
        } else {
            0.0
        }
    }

    /// Joint dampers `d_j` (N m s/rad).
    pub fn damping(&self) -> &[f64] {
        &self.damping
    }

    /// Gravity levers `W_j` (kg m): `dV_g/dphi_j = g W_j cos(phi_j)`.
    pub fn levers(&self) -> &[f64] {
        &self.levers
    }

    /// Point mass at the tip (kg).
    pub fn tip_mass(&self) -> f64 {
        self.tip_mass
    }

    /// Total mass of the flexible links plus the tip mass (kg).
    pub fn total_mass(&self) -> f64 {
        self.masses.iter().sum::<f64>() + self.tip_mass
    }

    /// Clamp angle `phi_0` (rad).
    pub fn clamp_angle(&self) -> f64 {
        self.clamp_angle
    }

    /// Clamp point `p0` (m).
    pub fn clamp_point(&self) -> [f64; 2] {
        self.clamp_point
    }

    /// Tube length from the clamp to the tip (m), as given.
    pub fn tube_length(&self) -> f64 {
        self.tube_length
    }

    /// Smallest bending radius of the centre line (m): a joint turning by
    /// `dphi` stands for an element length `l` of tube bent to radius
    /// `l / |dphi|` (the clamp counts as a joint). Infinite when straight.
    pub fn min_bend_radius(&self, q: &[f64]) -> f64 {
        self.min_bend_radius_from(self.clamp_angle, q)
    }

    /// [`Self::min_bend_radius`] for the chain clamped along `clamp_angle`
    /// (rad) instead of its own: a driving unit that floats (held by the
    /// front cup) turns the clamp with it.
    pub fn min_bend_radius_from(&self, clamp_angle: f64, q: &[f64]) -> f64 {
        let mut prev = clamp_angle;
        let mut sharpest: f64 = 0.0;
        for phi in q {
            sharpest = sharpest.max((phi - prev).abs());
            prev = *phi;
        }
        self.element_length / sharpest
    }

    /// Angles for this chain from a state `q` of a chain of the same tube
    /// with another length: shared links keep their angles, new links continue
    /// the last one straight, missing ones are dropped. Feeding a tube by a
    /// small step is then a small change of state.
    pub fn carry_over(&self, q: &[f64]) -> Vec<f64> {
        let last = q.last().copied().unwrap_or(self.clamp_angle);
        (0..self.len()).map(|j| q.get(j).copied().unwrap_or(last)).collect()
    }

    /// Length of the rigid piece from the clamp to the first joint (m; 0
    /// for [`Discretization::Paper`]).
    pub fn root_length(&self) -> f64 {
        self.root_length
    }

    /// Mass of the rigid root piece (kg), `m root / l`: a clamped chain
    /// leaves it out (its weight is a constant), a floating base carries it.
    pub fn root_mass(&self) -> f64 {
        self.masses.first().map_or(0.0, |m0| m0 * self.root_length / self.lengths[0])
    }

    /// Where the first flexible joint sits (m).
    pub fn first_joint(&self) -> [f64; 2] {
        self.first_joint
    }

    /// The straight, unloaded configuration: every link along the clamp.
    pub fn straight(&self) -> Vec<f64> {
        vec![self.clamp_angle; self.len()]
    }

    /// Tip of the last link (m).
    pub fn tip(&self, q: &[f64]) -> [f64; 2] {
        let mut p = self.first_joint();
        for (l, phi) in self.lengths.iter().zip(q) {
            let u = unit(*phi);
            p[0] += l * u[0];
            p[1] += l * u[1];
        }
        p
    }

    /// The centre line as a polyline (m): the clamp, the first joint when the
    /// discretization has a rigid root piece, then every link tip.
    pub fn points(&self, q: &[f64]) -> Vec<[f64; 2]> {
        let mut out = Vec::with_capacity(self.len() + 2);
        out.push(self.clamp_point);
        let mut p = self.first_joint();
        if self.root_length > 0.0 {
            out.push(p);
        }
        for (l, phi) in self.lengths.iter().zip(q) {
            let u = unit(*phi);
            p[0] += l * u[0];
            p[1] += l * u[1];
            out.push(p);
        }
        out
    }

    /// Fused statics evaluation for the solver: fills `cos`/`sin` of every
    /// link, writes the potential's gradient and Hessian (springs and gravity
    /// `load * gravity`) over the block (every entry: it need not be cleared)
    /// and returns the potential (J). Link
    /// lengths are multiplied by `scale` (the feeding homotopy; 1 otherwise).
    pub(crate) fn evaluate_block(&self, q: &[f64], gravity: f64, load: f64, scale: f64, b: Block<'_>) -> f64 {
        // The solver's hot loop, called once per Newton trial: the
        // trigonometry in a pass of its own, then one fused pass.
        let n = self.len();
        let (q, k) = (&q[..n], &self.stiffness[..n]);
        let (levers, masses, offsets) = (&self.levers[..n], &self.masses[..n], &self.mass_offsets[..n]);
        let (cos, sin, grad, diag) = (&mut b.cos[..n], &mut b.sin[..n], &mut b.grad[..n], &mut b.diag[..n]);
        let off = &mut b.off[..n - 1];
        let weight_scale = gravity * scale;
        let mut prev = self.clamp_angle;
        let mut spring = 0.0;
        let mut y = self.first_joint()[1];
        let mut weight = 0.0;
        let mut previous_torque = 0.0;
        // Link j's own terms wait here until joint j + 1 completes them.
        let (mut own_grad, mut own_diag) = (0.0, 0.0);
        // The trigonometry first, on its own: every register is the callee's
        // across a call, so the sums below would otherwise go through memory.
        for ((c, s), phi) in cos.iter_mut().zip(sin.iter_mut()).zip(q) {
            (*s, *c) = phi.sin_cos();
        }
        for j in 0..n {
            let (s, c) = (sin[j], cos[j]);
            let bend = q[j] - prev;
            prev = q[j];
            let torque = k[j] * bend;
            spring += 0.5 * torque * bend;
            if j > 0 {
                grad[j - 1] = own_grad + (previous_torque - torque);
                diag[j - 1] = own_diag + k[j];
                off[j - 1] = -k[j];
            }
            previous_torque = torque;
            weight += masses[j] * (y + offsets[j] * scale * s);
            y += self.lengths[j] * scale * s;
            let moment = weight_scale * levers[j] * c;
            own_diag = k[j] - load * weight_scale * levers[j] * s;
            own_grad = load * moment;
        }
        grad[n - 1] = own_grad + previous_torque;
        diag[n - 1] = own_diag;
        spring + load * gravity * (weight + self.tip_mass * y)
    }

    /// The gravity moments `g W_j cos(phi_j)` (N m) from the links' cosines
    /// into `out`: the derivative of the gradient with respect to the
    /// fraction of gravity applied (the load path).
    pub(crate) fn load_gradient(&self, cos: &[f64], gravity: f64, out: &mut [f64]) {
        for ((o, w), c) in out.iter_mut().zip(&self.levers).zip(cos) {
            *o = gravity * w * c;
        }
    }

    /// Jacobian of the tip, `d tip / d phi_j = l_j e'(phi_j)`, as `n` columns (m/rad).
    pub fn tip_jacobian(&self, q: &[f64]) -> Vec<[f64; 2]> {
        self.lengths
            .iter()
            .zip(q)
            .map(|(l, phi)| {
                let (s, c) = phi.sin_cos();
                [-l * s, l * c]
            })
            .collect()
    }

    /// First moment of the links' masses and the tip mass, `sum m_i r_i + P r_tip`
    /// (kg m): divided by [`Chain::total_mass`] it is their centre of mass.
    pub fn mass_moment(&self, q: &[f64]) -> [f64; 2] {
        let mut p = self.first_joint();
        let mut moment = [0.0; 2];
        for ((l, a), (m, phi)) in self.lengths.iter().zip(&self.mass_offsets).zip(self.masses.iter().zip(q)) {
            let u = unit(*phi);
            moment[0] += m * (p[0] + a * u[0]);
            moment[1] += m * (p[1] + a * u[1]);
            p = [p[0] + l * u[0], p[1] + l * u[1]];
        }
        [moment[0] + self.tip_mass * p[0], moment[1] + self.tip_mass * p[1]]
    }

    /// Spring potential `sum_j k_j/2 (phi_j - phi_{j-1})^2` (J).
    pub fn spring_energy(&self, q: &[f64]) -> f64 {
        let mut prev = self.clamp_angle;
        let mut v = 0.0;
        for (k, phi) in self.stiffness.iter().zip(q) {
            let d = phi - prev;
            v += 0.5 * k * d * d;
            prev = *phi;
        }
        v
    }

    /// Gravity potential `g (sum_i m_i y_i + P y_tip)` (J), with heights measured
    /// from `y = 0`. The rigid root piece's weight is a constant and left out.
    pub fn gravity_energy(&self, q: &[f64], gravity: f64) -> f64 {
        let mut y = self.first_joint()[1];
        let mut v = 0.0;
        for ((l, a), (m, phi)) in self.lengths.iter().zip(&self.mass_offsets).zip(self.masses.iter().zip(q)) {
            let s = phi.sin();
            v += m * (y + a * s);
            y += l * s;
        }
        gravity * (v + self.tip_mass * y)
    }

    /// Total potential `V_s + V_g` (J).
    pub fn energy(&self, q: &[f64], gravity: f64) -> f64 {
        self.spring_energy(q) + self.gravity_energy(q, gravity)
    }

    /// Adds the gradient of the spring potential to `grad` (N m).
    pub fn add_spring_gradient(&self, q: &[f64], grad: &mut [f64]) {
        let n = self.len();
        let mut prev = self.clamp_angle;
        for j in 0..n {
            let t = self.stiffness[j] * (q[j] - prev);
            grad[j] += t;
            if j > 0 {
                grad[j - 1] -= t;
            }
            prev = q[j];
        }
    }

    /// Adds the spring Hessian (tridiagonal) to `diag` and `off` (`off[j]`
    /// couples links `j` and `j + 1`; `off` has `n - 1` entries or more).
    pub fn add_spring_hessian(&self, diag: &mut [f64], off: &mut [f64]) {
        let n = self.len();
        for j in 0..n {
            diag[j] += self.stiffness[j];
            if j + 1 < n {
                diag[j] += self.stiffness[j + 1];
                off[j] -= self.stiffness[j + 1];
            }
        }
    }

    /// Generalized spring and damper force `-(K phi - k_1 phi_0 e_1) - D dphi`
    /// (N m), written to `out`.
    pub fn elastic_forces(&self, q: &[f64], dq: &[f64], out: &mut [f64]) {
        self.damping_forces(dq, out);
        let mut spring = vec![0.0; self.len()];
        self.add_spring_gradient(q, &mut spring);
        out.iter_mut().zip(&spring).for_each(|(o, s)| *o -= s);
    }

    /// Generalized damper force `-D dphi` (N m), `D` tridiagonal like `K`
    /// (dampers act on the relative rates, the clamp's being zero), into `out`.
    pub fn damping_forces(&self, dq: &[f64], out: &mut [f64]) {
        let n = self.len();
        out[..n].iter_mut().for_each(|o| *o = 0.0);
        let mut prev = 0.0;
        for j in 0..n {
            let t = self.damping[j] * (dq[j] - prev);
            out[j] -= t;
            if j > 0 {
                out[j - 1] += t;
            }
            prev = dq[j];
        }
    }

    /// Generalized force of a constant planar force `f` (N) acting on link
    /// `link` at `offset` (m) along it: `Q_j = lever_j e'(phi_j) . f` for `j <= link`.
    /// Added to `out` (N m).
    pub fn add_point_force(&self, q: &[f64], link: usize, offset: f64, f: [f64; 2], out: &mut [f64]) {
        for j in 0..=link {
            let lever = if j == link { offset } else { self.lengths[j] };
            let (s, c) = q[j].sin_cos();
            out[j] += lever * (-s * f[0] + c * f[1]);
        }
    }

    /// The generators of the mass matrix (kg m^2) from the links' cosines
    /// and sines: a symmetric quasiseparable matrix of order 2
    /// ([`crate::linalg::quasiseparable`]). Below the diagonal
    /// `M_jk = l_k W_j cos(phi_j - phi_k) = u_j . v_k` (`j > k`) with
    /// `u_j = W_j e(phi_j)`, `v_k = l_k e(phi_k)` and transitions 1: the
    /// factorization, solves and products with `M` are then O(n).
    pub fn mass_generators<'a>(
        &'a self,
        cos: &'a [f64],
        sin: &'a [f64],
    ) -> impl DoubleEndedIterator<Item = Generators<2>> + ExactSizeIterator + Clone + 'a {
        let n = self.len();
        let (cos, sin) = (&cos[..n], &sin[..n]);
        (0..n).map(move |j| {
            let (c, s, w, l) = (cos[j], sin[j], self.levers[j], self.lengths[j]);
            Generators { diagonal: self.mass_diagonal[j], p: [w * c, w * s], q: [l * c, l * s], a: [1.0, 1.0] }
        })
    }

    /// Velocity-product terms `h_j = sum_k C_jk sin(phi_j - phi_k) dphi_k^2` (N m),
    /// into `out`. With `C_jk = l_j W_k` (j < k) and `l_k W_j` (j > k) and
    /// `sin(phi_j - phi_k) = s_j c_k - c_j s_k`, prefix and suffix sums make it O(n).
    pub fn velocity_terms(&self, q: &[f64], dq: &[f64], out: &mut [f64]) {
        let (sin, cos): (Vec<f64>, Vec<f64>) = q[..self.len()].iter().map(|phi| phi.sin_cos()).unzip();
        self.velocity_terms_from_trig(&cos, &sin, dq, out);
    }

    /// [`Chain::velocity_terms`] from the links' cosines and sines.
    pub fn velocity_terms_from_trig(&self, cos: &[f64], sin: &[f64], dq: &[f64], out: &mut [f64]) {
        let n = self.len();
        // Suffix sums over k > j of W_k (c_k, s_k) dphi_k^2.
        let (mut sc, mut ss) = (0.0, 0.0);
        for j in (0..n).rev() {
            let (sj, cj) = (sin[j], cos[j]);
            out[j] = self.lengths[j] * (sj * sc - cj * ss);
            let w = self.levers[j] * dq[j] * dq[j];
            sc += w * cj;
            ss += w * sj;
        }
        // Prefix sums over k < j of l_k (c_k, s_k) dphi_k^2.
        let (mut pc, mut ps) = (0.0, 0.0);
        for j in 0..n {
            let (sj, cj) = (sin[j], cos[j]);
            out[j] += self.levers[j] * (sj * pc - cj * ps);
            let w = self.lengths[j] * dq[j] * dq[j];
            pc += w * cj;
            ps += w * sj;
        }
    }

    /// Kinetic energy `dq^T M dq / 2` (J).
    pub fn kinetic_energy(&self, q: &[f64], dq: &[f64]) -> f64 {
        let (sin, cos): (Vec<f64>, Vec<f64>) = q[..self.len()].iter().map(|phi| phi.sin_cos()).unzip();
        self.kinetic_energy_from_trig(&cos, &sin, dq)
    }

    /// [`Chain::kinetic_energy`] from the links' cosines and sines, O(n).
    pub fn kinetic_energy_from_trig(&self, cos: &[f64], sin: &[f64], dq: &[f64]) -> f64 {
        0.5 * quasiseparable::quadratic_form(self.mass_generators(cos, sin), &dq[..self.len()])
    }
}
