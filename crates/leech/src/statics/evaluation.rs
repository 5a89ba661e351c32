//! Values and derivatives of a static system at one configuration.

/// What [`StaticSystem::evaluate`](super::StaticSystem::evaluate) fills: the
/// potential's terms and the constraints' terms at one `(q, t)`.
///
/// The `n` coordinates are the chains' `n_s` first, then `f` *free*
/// coordinates (a floating base's pose) whose Hessian couples densely: the
/// banded part (`hessian_diag`, `hessian_off`) covers the chains, the border
/// `hessian_border` (`n_s x f`, entry `(i, a)` at `i f + a`) couples chains
/// and free coordinates, and `hessian_corner` (`f x f`, row-major) the free
/// coordinates among themselves. With blocks of 3
/// ([`Potential::block_size`](super::Potential::block_size)) the chains'
/// diagonal and off-diagonal hold `3 x 3` blocks, 9 row-major entries per
/// block of 3 coordinates.
#[derive(Clone, Debug, Default)]
pub struct Evaluation {
    /// Potential `V` (J).
    pub energy: f64,
    /// `dV/dq` (N m).
    pub gradient: Vec<f64>,
    /// Diagonal of `d2V/dq2` over the chains' coordinates (N m/rad).
    pub hessian_diag: Vec<f64>,
    /// Off-diagonal of the tridiagonal `d2V/dq2`; entry `i` couples `i` and
    /// `i + 1` (zero between chains).
    pub hessian_off: Vec<f64>,
    /// `d2V/dq_i dq_a` between chain coordinate `i` and free coordinate `a`, at `i f + a`.
    pub hessian_border: Vec<f64>,
    /// `d2V/dq_a dq_b` among the free coordinates, row-major.
    pub hessian_corner: Vec<f64>,
    /// Constraint values `C` (m for positions, rad for angles), `m` of them.
    pub constraints: Vec<f64>,
    /// Each row's compliance `c_r` (m/N for positions, rad/(N m) for
    /// angles; zero for a rigid row): the row holds `C_r + c_r lambda_r = 0`,
    /// a stiff spring of stiffness `1/c_r` instead of a rigid constraint.
    pub compliance: Vec<f64>,
    /// Constraint Jacobian, interleaved by coordinate: `dC_r/dq_i` at `i m + r`.
    pub jacobian: Vec<f64>,
    /// Diagonals of the constraint Hessians `d2C_r/dq_i2`, laid out as `jacobian`.
    pub curvature: Vec<f64>,
    /// Cosines of the coordinates (for systems of link angles).
    pub cos: Vec<f64>,
    /// Sines of the coordinates.
    pub sin: Vec<f64>,
    /// Number of free coordinates (the last ones).
    free: usize,
    /// The chains' block size (1 or 3).
    block: usize,
}

impl Evaluation {
    /// Zeroed storage for `n` chain coordinates and `m` constraint rows.
    pub fn new(n: usize, m: usize) -> Evaluation {
        Evaluation::with_free(n, 0, m)
    }

    /// Zeroed storage for `n` coordinates of which the last `free` are free
    /// (dense) ones, and `m` constraint rows.
    pub fn with_free(n: usize, free: usize, m: usize) -> Evaluation {
        let mut ev = Evaluation::default();
        ev.resize(n, free, m);
        ev
    }

    /// Resizes to `n` coordinates of which `free` are free, and `m` rows
    /// (the values left are stale: an evaluation clears what it accumulates).
    pub fn resize(&mut self, n: usize, free: usize, m: usize) {
        self.resize_blocks(n, free, m, 1);
    }

    /// [`Evaluation::resize`] for chains of blocks of `block` (1 or 3)
    /// coordinates: `block x block` entries per block on the diagonal and
    /// off it (for blocks of 1, the `n_s - 1` couplings of neighbours).
    pub fn resize_blocks(&mut self, n: usize, free: usize, m: usize, block: usize) {
        let chains = n - free;
        (self.free, self.block) = (free, block);
        self.gradient.resize(n, 0.0);
        self.hessian_diag.resize(chains * block, 0.0);
        self.hessian_off.resize(if block == 1 { chains.saturating_sub(1) } else { chains * block }, 0.0);
        self.hessian_border.resize(chains * free, 0.0);
        self.hessian_corner.resize(free * free, 0.0);
        self.constraints.resize(m, 0.0);
        self.compliance.resize(m, 0.0);
        self.jacobian.resize(n * m, 0.0);
        self.curvature.resize(n * m, 0.0);
        self.cos.resize(n, 0.0);
        self.sin.resize(n, 0.0);
    }

    /// Number of free coordinates `f`.
    pub fn free(&self) -> usize {
        self.free
    }

    /// The chains' block size (1 or 3).
    pub fn block_size(&self) -> usize {
        self.block.max(1)
    }

    /// Number of constraint rows `m`.
    pub fn rows(&self) -> usize {
        self.constraints.len()
    }

    /// Sets every accumulated quantity to zero before an evaluation.
    pub fn clear(&mut self) {
        self.clear_multiplied();
        self.curvature.fill(0.0);
    }

    /// [`Evaluation::clear`] but for the curvature: for a system whose
    /// Hessian holds its rows' curvature times the multipliers
    /// ([`StaticSystem::multipliers_in_hessian`](super::StaticSystem::multipliers_in_hessian)),
    /// which leaves it unused.
    pub fn clear_multiplied(&mut self) {
        self.clear_first_order();
        for v in [&mut self.hessian_diag, &mut self.hessian_off, &mut self.hessian_border, &mut self.hessian_corner] {
            v.fill(0.0);
        }
    }

    /// [`Evaluation::clear_multiplied`] but for the Hessian too: for an
    /// evaluation of the first derivatives alone, which leaves it unused.
    pub fn clear_first_order(&mut self) {
        self.energy = 0.0;
        for v in [&mut self.gradient, &mut self.constraints, &mut self.compliance, &mut self.jacobian] {
            v.fill(0.0);
        }
    }

    /// Row `r`'s residual with multiplier `lambda`: `C_r + c_r lambda`.
    pub fn row_value(&self, r: usize, lambda: f64) -> f64 {
        self.constraints[r] + self.compliance[r] * lambda
    }
}

/// Derivatives along the continuation parameter `t` at fixed `q`
/// ([`Path::path`](super::Path::path)).
#[derive(Clone, Debug, Default)]
pub struct PathTerms {
    /// `d(dV/dq)/dt` (N m).
    pub gradient: Vec<f64>,
    /// `d(dC/dq)/dt`, laid out as [`Evaluation::jacobian`].
    pub jacobian: Vec<f64>,
    /// `dC/dt`.
    pub constraints: Vec<f64>,
    /// `dc/dt` of each row's compliance ([`Evaluation::compliance`]).
    pub compliance: Vec<f64>,
}

impl PathTerms {
    /// Zeroed storage for `n` coordinates and `m` constraint rows.
    pub fn new(n: usize, m: usize) -> PathTerms {
        let mut path = PathTerms::default();
        path.resize(n, m);
        path
    }

    /// Resizes to `n` coordinates and `m` rows (values left stale).
    pub fn resize(&mut self, n: usize, m: usize) {
        self.gradient.resize(n, 0.0);
        self.jacobian.resize(n * m, 0.0);
        self.constraints.resize(m, 0.0);
        self.compliance.resize(m, 0.0);
    }

    /// Sets everything to zero.
    pub fn clear(&mut self) {
        self.gradient.fill(0.0);
        self.jacobian.fill(0.0);
        self.constraints.fill(0.0);
        self.compliance.fill(0.0);
    }
}
