//! Where a held body's chains are.

use super::floating::{Approach, FloatingBody};
use super::Held;
use crate::geom::Vec2;
use crate::robot::Robot;

impl Held {
    /// Both chains' centre lines where the holds put them (m), as
    /// [`crate::chain::Chain::points`] lists them (the clamp, the first joint
    /// when there is a rigid root piece, then every link's tip), moved from
    /// the body's reference clamp to the driving unit's pose.
    pub fn chain_points(&self, robot: &Robot) -> [Vec<Vec2>; 2] {
        let floating = FloatingBody::new(&self.body, robot.body.base_spacing_m, 0.0, self.hold, Approach::Load);
        [0, 1].map(|c| floating.chain_points(&self.equilibrium.q, c))
    }
}
