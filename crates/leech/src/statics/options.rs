//! The solver's bounds, tolerances and tuning knobs.

use crate::budget::Deadline;

/// Which way the solver leaves a symmetric bifurcation (an unstable
/// equilibrium on a path, such as a vertical tube past its buckling load).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BranchRule {
    /// To the side where [`StaticSystem::side_measure`](super::StaticSystem::side_measure)
    /// is positive (for the robot: the endpoint to the right of the clamp
    /// direction, towards chain B).
    #[default]
    Right,
    /// To the other side.
    Left,
    /// Not at all: an unstable equilibrium is an error.
    Refuse,
}

/// Bounds and tolerances of the static solver.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverOptions {
    /// Converged when the scaled residual's sup norm is below this.
    pub tolerance: f64,
    /// Looser tolerance for the intermediate points of a continuation path,
    /// which only seed the next step.
    pub path_tolerance: f64,
    /// Newton iterations allowed for one whole solve, all stages together.
    pub max_iterations: usize,
    /// Newton iterations allowed for one continuation corrector.
    pub max_corrector_iterations: usize,
    /// Newton iterations allowed for one free minimization (snap, escape,
    /// warm start), within [`SolverOptions::max_iterations`]. No bound of its
    /// own by default (`usize::MAX`), so that the whole solve's bound, the
    /// one a user sets, governs; set it lower to cap one minimization (the
    /// adaptive feeding of [`crate::stance`] does).
    pub max_minimization_iterations: usize,
    /// Continuation steps allowed for one path.
    pub max_steps: usize,
    /// Smallest continuation step before a persisting jump counts as a fold.
    pub min_step: f64,
    /// Largest distance (rad, sup norm) between predictor and corrector
    /// that still counts as following the same branch.
    pub jump_tolerance: f64,
    /// Longest step (rad, sup norm) taken where the curvature is corrected.
    pub trust_radius: f64,
    /// A residual that no step can reduce counts as converged up to this
    /// multiple of the tolerance (the rounding floor near folds).
    pub rounding_slack: f64,
    /// A settle after a failed step moving some angle by more than this
    /// (rad) is reported as a snap.
    pub snap_threshold: f64,
    /// Which way to leave a symmetric bifurcation.
    pub branch: BranchRule,
    /// When to stop (checked at every Newton iteration and continuation
    /// step); one deadline may bound many solves. Never, by default.
    pub deadline: Deadline,
    /// The algorithm's internal constants.
    pub tuning: Tuning,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            tolerance: 1e-11,
            path_tolerance: 1e-6,
            max_iterations: 20000,
            max_corrector_iterations: 8,
            max_minimization_iterations: usize::MAX,
            max_steps: 500,
            min_step: 1e-4,
            jump_tolerance: 0.5,
            trust_radius: 0.1,
            rounding_slack: 1e3,
            snap_threshold: 0.05,
            branch: BranchRule::Right,
            deadline: Deadline::none(),
            tuning: Tuning::default(),
        }
    }
}

/// The constants inside the algorithm, named and documented in one place.
/// The defaults were tuned on the LEeCH body (30 to 3000 links per chain);
/// shifts are relative to the moment scale `k` (N m/rad).
#[derive(Clone, Debug, PartialEq)]
pub struct Tuning {
    /// Pivots below this times `k` count as zero (singular).
    pub tiny_pivot: f64,
    /// First inertia-correcting shift tried, times `k`.
    pub first_shift: f64,
    /// Growth of the inertia-correcting shift between tries.
    pub shift_growth: f64,
    /// Inertia-correcting shifts tried before the Jacobian counts as singular.
    pub max_shift_tries: usize,
    /// Smallest Levenberg shift after a rejected step, times `k`.
    pub min_damping: f64,
    /// Growth of the Levenberg shift after a rejected step.
    pub damping_growth: f64,
    /// Share of the last shift kept as damping after an accepted step.
    pub damping_memory: f64,
    /// Trial steps per Newton iteration before giving up.
    pub max_trials: usize,
    /// Armijo's sufficient-decrease fraction.
    pub armijo: f64,
    /// Relative decrease of the merit below which it counts as rounding.
    pub measurable_decrease: f64,
    /// Relative decrease of the residual that accepts a step where the
    /// curvature needed no correction.
    pub residual_decrease: f64,
    /// Margin of the penalty weight over the largest scaled multiplier.
    pub penalty_margin: f64,
    /// Steps (rad, sup norm; the multipliers' change scaled as the residual)
    /// under which the last factors still serve for the stability verdict and
    /// the next tangent.
    pub reuse_factors_step: f64,
    /// Iterations without halving the residual after which a residual within
    /// `rounding_slack` counts as stalled at rounding.
    pub stall_iterations: usize,
    /// Step size (rad, sup norm) that counts as a null step when stalled.
    pub stall_step: f64,
    /// Inverse iterations for the most negative curvature direction.
    pub escape_iterations: usize,
    /// Gap below the Gershgorin bound of the inverse-iteration shift, times `k`.
    pub escape_gap: f64,
    /// Size of the first kick (rad, sup norm) off an unstable equilibrium
    /// or a fold's ghost.
    pub escape_kick: f64,
    /// Growth of the kick between kicks of one settle (0.01, 0.03, 0.09, ...
    /// rad by default): a landing back where it was left is kicked harder.
    pub escape_kick_growth: f64,
    /// Kicks one settle may take before it gives up
    /// ([`StopReason::StillUnstable`](super::StopReason::StillUnstable)).
    pub escapes: usize,
    /// Most the predictor of a first continuation step may turn a coordinate
    /// (rad) on a stiff path: the first step is then
    /// `min(first_step, first_step_angle / |dq/dt|)`. Measured on the body at
    /// 300 and 3000 links per chain, a whole-path first step costs its
    /// corrector rejected trials 2.5 to 3.5 times over; 0.1 to 0.15 rad is
    /// the fastest, and from 0.2 rad the corrector fails again at 300 links.
    pub first_step_angle: f64,
    /// [`Tuning::first_step_angle`] for systems of frames, whose predictor
    /// turns rotation vectors ([`Path::first_turn`](super::Path::first_turn)
    /// of the three-tube body): measured on 400 random three-tube
    /// bodies (0.05 to 0.30 m, any clamp angle), 0.3 to 0.7 rad need the
    /// same iterations to 1 %, and 0.15 rad three more continuation steps
    /// on the 25/30/22-link body.
    pub first_frame_turn: f64,
    /// [`Path::discrete_stiffness`](super::Path::discrete_stiffness) above
    /// which the first step is sized from the tangent. Coarser chains (the
    /// paper's 30 links: about 5e3) converge from the whole path at once,
    /// which is faster there.
    pub stiff_path: f64,
    /// Continuation step after a snap or a bifurcation.
    pub step_after_event: f64,
    /// Active-set changes allowed in one Newton run per inequality row.
    pub active_set_changes_per_row: usize,
    /// Dual regularization of a degenerate working set's inequality rows,
    /// dimensionless: `-eps s_r^2 / k` on the KKT corner (m/N for a row in
    /// m), in the step's matrix only. Rows of one rigid piece touching one
    /// line at three points are dependent; with it the step is unique, the
    /// force shared among them in least squares, and Newton still converges
    /// on the exact residual.
    pub dual_regularization: f64,
    /// A blocking inequality row met within this fraction of the step joins
    /// the working set without a step (the point is on it already).
    pub blocked_fraction: f64,
    /// Whether a step stops at the first inactive inequality row it would
    /// cross (by the row's linearization), which then joins the working set:
    /// a primal active-set method, whose iterates stay on the feasible side
    /// of every row they meet. Off, rows join only after Newton converges on
    /// the working set (a primal-dual active set, which can pass a body
    /// through a surface and back, and cycle). The staged solves among
    /// solids ([`crate::stance`]) take the plain method first and this one
    /// where that does not settle.
    pub block_at_rows: bool,
}

impl Default for Tuning {
    fn default() -> Self {
        Tuning {
            tiny_pivot: 1e-13,
            first_shift: 1e-6,
            shift_growth: 8.0,
            max_shift_tries: 40,
            min_damping: 1e-8,
            damping_growth: 4.0,
            damping_memory: 0.25,
            max_trials: 80,
            armijo: 1e-4,
            measurable_decrease: 1e-14,
            residual_decrease: 1e-4,
            penalty_margin: 1e-3,
            reuse_factors_step: 1e-5,
            stall_iterations: 20,
            stall_step: 1e-10,
            escape_iterations: 200,
            escape_gap: 1e-3,
            escape_kick: 0.01,
            escape_kick_growth: 3.0,
            escapes: 4,
            first_step_angle: 0.15,
            first_frame_turn: 0.5,
            stiff_path: 2e4,
            step_after_event: 1e-3,
            active_set_changes_per_row: 4,
            dual_regularization: 1e-8,
            blocked_fraction: 1e-9,
            block_at_rows: false,
        }
    }
}
