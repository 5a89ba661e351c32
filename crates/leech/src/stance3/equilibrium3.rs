//! A converged equilibrium of the three-tube body ([`Equilibrium3`]): the
//! links' frames, the solve's summary, the contacts that push and the front
//! hold's multipliers. The type every solve of the body returns, below the
//! solver and the holds that make it.

use crate::body3::body3::Frames;
use crate::contact::space::Contact3;
use crate::hold::front3::FRONT_ROWS;
use crate::statics::Equilibrium;

/// A converged equilibrium of the 3D body: its frames, and the solve's
/// summary as the planar solver gives it, whose `q` holds every link's
/// rotation vector `Log(R_j)` (3 per link, in the body's order) and whose
/// `multipliers` the weld's 12 (N on the position rows, N m on the rotation
/// rows; tube 2's, then tube 3's). Its fields are reached through `Deref`.
#[derive(Clone, Debug, PartialEq)]
pub struct Equilibrium3 {
    /// The links' frames.
    pub frames: Frames,
    /// Energy, residual, stability, counters and events.
    pub summary: Equilibrium,
    /// The contacts with a scene's solids that push (empty without a
    /// scene; their forces follow the weld's 12 and the front hold's 6 in
    /// `multipliers`).
    pub contacts: Vec<Contact3>,
    /// With both cups holding, the front hold's 6 multipliers (they follow
    /// the weld's 12 in `multipliers`): the force on tube 1's tip (N, world
    /// axes), then the plate's rotation rows' (N m, in the plate's chart;
    /// [`super::held3`]).
    pub front_hold: Option<[f64; FRONT_ROWS]>,
}

impl std::ops::Deref for Equilibrium3 {
    type Target = Equilibrium;

    fn deref(&self) -> &Equilibrium {
        &self.summary
    }
}
