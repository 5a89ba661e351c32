//! A fraction of the contact census (`leech::stance::census`; the whole is
//! `cargo run --release -p leech --example contact_census`): the body fed
//! against a wall and steps ahead, its free front cup resting on the solids.
//! Every solved case is checked as an equilibrium among the solids (stable,
//! no penetration, the weight carried by the rear cup and the contacts,
//! every contact pushing); a failure must name its reason.

use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::census;
use leech::stance::FreeCups;

/// Checks one solved case; returns a line saying what is wrong, if anything.
fn check(robot: &Robot, scene: &Scene, lengths: [f64; 2], held: &leech::stance::Held) -> Result<(), String> {
    let name = format!("{} at {lengths:?}", scene.name);
    if !held.equilibrium.stable {
        return Err(format!("{name}: unstable"));
    }
    let deep = held.penetration_m(robot, scene);
    if !(deep <= 1e-9) {
        return Err(format!("{name}: penetrates {deep:e} m"));
    }
    let rear = held.rear.ok_or(format!("{name}: the rear cup does not hold"))?;
    let mut force = rear.force_n;
    for c in &held.contacts {
        if !(c.force_n > 0.0) {
            return Err(format!("{name}: a contact pulls ({} N)", c.force_n));
        }
        force = [force[0] + c.force_n * c.normal[0], force[1] + c.force_n * c.normal[1]];
    }
    let off = (force[0].powi(2) + (force[1] - held.weight_n).powi(2)).sqrt();
    if !(off <= 1e-9 * held.weight_n) {
        return Err(format!("{name}: forces miss the weight by {off:e} N"));
    }
    Ok(())
}

/// A wall ahead: every third case of the grid solves (the grid's 89 of 136
/// failed before the blocking rows, the inside corners' two rows per rim and
/// the dual regularization), and each is an equilibrium among the solids.
#[test]
fn bodies_fed_into_a_wall_ahead_settle() {
    let (robot, solver, scene) = (Robot::builtin(), Solver::default(), census::wall_ahead());
    let mut wrong = Vec::new();
    for lengths in census::lengths().into_iter().step_by(3) {
        match census::solve(&robot, &scene, lengths, FreeCups::Rest, &solver) {
            Ok(held) => wrong.extend(check(&robot, &scene, lengths, &held).err()),
            Err(e) => wrong.push(format!("wall at {lengths:?}: {e}")),
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Steps ahead (60 and 30 mm): what solves is an equilibrium among the
/// solids, what fails says why (a solver's reason, never a wrong shape).
#[test]
fn bodies_fed_against_a_step_settle_or_say_why() {
    let (robot, solver) = (Robot::builtin(), Solver::default());
    let mut wrong = Vec::new();
    let mut solved = 0;
    for scene in [census::step_ahead(0.06), census::step_ahead(0.03)] {
        for lengths in census::lengths().into_iter().step_by(9) {
            match census::solve(&robot, &scene, lengths, FreeCups::Rest, &solver) {
                Ok(held) => {
                    solved += 1;
                    wrong.extend(check(&robot, &scene, lengths, &held).err());
                }
                Err(leech::stance::StanceError::Solve(e)) => assert!(!e.to_string().is_empty()),
                Err(e) => wrong.push(format!("{} at {lengths:?}: not a solve's failure: {e}", scene.name)),
            }
        }
    }
    assert!(solved > 0, "no step case solved");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
