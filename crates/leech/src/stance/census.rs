//! The contact census: the body held by its rear cup on a floor, fed
//! against a surface ahead, over a grid of tube lengths; each solve counted
//! as solved or failed by its reason. It measures what issue-sized claims
//! about contact ("most bodies pushed against a wall fail") rest on, and
//! the tests run a fraction of it.
//!
//! # Grids
//!
//! The rear cup on the floor `y = 0` with the driving unit at
//! `(0.25, 0.032) m`, clamp direction 0 deg (the built-in robot's rear cup
//! face then lies on the floor), and ahead of it one of:
//!
//! * a wall: the half-plane `x >= 0.35 m`;
//! * a step of height `h`: the polygon from `x = 0.35 m`, top at `y = h`
//!   (60 mm and 30 mm).
//!
//! Lengths: `LA` from 0.16 to 0.30 m by 10 mm and `LB - LA` in
//! {0, 2, 4, 6, 8, 10, 12, 15, 20, 30} mm, `LB <= 0.30 m` (136 pairs). The
//! free front cup's face rests on the solids ([`FreeCups::Rest`], as the
//! climb planner solves every phase), or passes through them (the tubes
//! alone touching: [`FreeCups::PassThrough`]).

use std::collections::BTreeMap;

use super::{solve_among, FreeCups, Hold, Pose, StanceError};
use crate::robot::Robot;
use crate::scene::{Scene, Solid};
use crate::statics::Solver;

/// The driving unit's point (m) and clamp direction (deg) of every census case.
pub const REAR: ([f64; 2], f64) = ([0.25, 0.032], 0.0);

/// Where the surface ahead starts (m).
pub const AHEAD_M: f64 = 0.35;

/// The floor with a wall at [`AHEAD_M`].
pub fn wall_ahead() -> Scene {
    let floor = Solid::HalfPlane { point_m: [0.0, 0.0], normal: [0.0, 1.0] };
    let wall = Solid::HalfPlane { point_m: [AHEAD_M, 0.0], normal: [-1.0, 0.0] };
    Scene::new("wall ahead", vec![floor, wall]).expect("a valid scene")
}

/// The floor with a step `height_m` high from [`AHEAD_M`] (its block buried
/// 0.1 m in the floor, so that no face lies on it).
pub fn step_ahead(height_m: f64) -> Scene {
    let floor = Solid::HalfPlane { point_m: [0.0, 0.0], normal: [0.0, 1.0] };
    let (x0, x1) = (AHEAD_M, AHEAD_M + 1.0);
    let block = Solid::Polygon { points_m: vec![[x0, -0.1], [x1, -0.1], [x1, height_m], [x0, height_m]] };
    Scene::new(format!("step {:.0} mm", height_m * 1e3), vec![floor, block]).expect("a valid scene")
}

/// The census's length pairs `[LA, LB]` (m), in grid order.
pub fn lengths() -> Vec<[f64; 2]> {
    const DIFFERENCES_MM: [f64; 10] = [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 30.0];
    let mut out = Vec::new();
    for i in 0..15 {
        let la_mm = 160.0 + 10.0 * i as f64;
        for d in DIFFERENCES_MM {
            if la_mm + d <= 300.0 {
                out.push([la_mm * 1e-3, (la_mm + d) * 1e-3]);
            }
        }
    }
    out
}

/// One case of the census, solved as the planner solves a phase (the free
/// cups resting, [`FreeCups::Rest`]) or with `cups` as given.
pub fn solve(
    robot: &Robot,
    scene: &Scene,
    lengths: [f64; 2],
    cups: FreeCups,
    solver: &Solver,
) -> Result<super::Held, StanceError> {
    let hold = Hold::Rear(Pose::from_deg(REAR.0, REAR.1));
    solve_among(robot, lengths, hold, scene, solver, cups)
}

/// How a grid fared: solves, and failures counted by their message.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tally {
    /// Cases solved.
    pub solved: usize,
    /// Failed cases by the error's reason (its message's last clause).
    pub failed: BTreeMap<String, usize>,
    /// The failed cases' lengths (m).
    pub failures: Vec<[f64; 2]>,
}

impl Tally {
    /// Counts one outcome.
    pub fn count(&mut self, lengths: [f64; 2], outcome: &Result<super::Held, StanceError>) {
        match outcome {
            Ok(_) => self.solved += 1,
            Err(e) => {
                let text = e.to_string();
                let reason = text.rsplit(": ").next().unwrap_or(&text).to_string();
                *self.failed.entry(reason).or_default() += 1;
                self.failures.push(lengths);
            }
        }
    }

    /// Cases counted.
    pub fn total(&self) -> usize {
        self.solved + self.failures.len()
    }
}
