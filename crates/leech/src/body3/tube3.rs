//! One tube in 3D: its links' lengths, levers and joint stiffnesses.
//!
//! The tube is cut as the planar `paper` scheme cuts it (docs/model.md
//! section 4; this module reuses [`Chain`] for it): `n` links of length
//! `l_j` (`l`, the last one `e_n` in `(0, l]`), a point mass `m_j = m l_j / l`
//! at each link's tip, joint `j` at the start of link `j`. Joint `j` stores
//! the relative rotation `theta_j = Log(R_{j-1}^T R_j)` (rad; `R_0` the
//! driving unit's frame) with the energy
//!
//! ```text
//! E_j = (kt_j theta_x^2 + k_j (theta_y^2 + theta_z^2)) / 2                  (J)
//! k_j  = k  min(l / e_j, 1e4),    kt_j = kt min(l / e_j, 1e4)             (N m/rad)
//! ```
//!
//! (the last joint stiffer as in the planar model, for shapes continuous in
//! the tube's length). With the axial rotation at the driving unit left free,
//! `kt_1 = 0`. Gravity acts on link `j` through its lever
//! `W_j = l_j (sum_{i >= j} m_i + P)` (kg m), `P` the tip mass.

use crate::chain::Chain;
use crate::geom3::Vec3;

/// One tube of the 3D body (all SI).
#[derive(Clone, Debug, PartialEq)]
pub struct Tube3 {
    root: Vec3,
    tube_length: f64,
    lengths: Vec<f64>,
    levers: Vec<f64>,
    bending: Vec<f64>,
    torsion: Vec<f64>,
    total_mass: f64,
}

impl Tube3 {
    /// The tube cut as `chain` (its lengths, masses, tip mass and bending
    /// springs), leaving the driving unit at `root` (m), with torsional
    /// springs `torsion_ratio` times the bending ones (`kt / k`).
    pub(crate) fn new(chain: &Chain, root: Vec3, torsion_ratio: f64) -> Tube3 {
        Tube3 {
            root,
            tube_length: chain.tube_length(),
            lengths: chain.lengths().to_vec(),
            levers: chain.levers().to_vec(),
            bending: chain.stiffness().to_vec(),
            torsion: chain.stiffness().iter().map(|k| k * torsion_ratio).collect(),
            total_mass: chain.total_mass(),
        }
    }

    /// Moves the root (m): the body placed elsewhere.
    pub(crate) fn set_root(&mut self, root: Vec3) {
        self.root = root;
    }

    /// Frees the axial rotation at the driving unit (`kt_1 = 0`).
    pub(crate) fn free_axial_rotation(&mut self) {
        self.torsion[0] = 0.0;
    }

    /// Number of links `n`.
    pub fn len(&self) -> usize {
        self.lengths.len()
    }

    /// Always false: a tube has at least one link.
    pub fn is_empty(&self) -> bool {
        self.lengths.is_empty()
    }

    /// Where the tube leaves the driving unit (m).
    pub fn root(&self) -> Vec3 {
        self.root
    }

    /// The free length `L` (m).
    pub fn tube_length(&self) -> f64 {
        self.tube_length
    }

    /// Link lengths `l_j` (m).
    pub fn lengths(&self) -> &[f64] {
        &self.lengths
    }

    /// Gravity levers `W_j` (kg m), tip mass included.
    pub fn levers(&self) -> &[f64] {
        &self.levers
    }

    /// Links' and tip mass (kg).
    pub fn total_mass(&self) -> f64 {
        self.total_mass
    }

    /// The joint's stiffnesses `(kt_j, k_j, k_j)` about the link's local
    /// x, y, z axes (N m/rad).
    pub fn stiffness(&self, j: usize) -> Vec3 {
        [self.torsion[j], self.bending[j], self.bending[j]]
    }
}
