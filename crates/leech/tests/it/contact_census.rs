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

/// Steps ahead (60 and 30 mm): every ninth case of each grid solves (7 of
/// the 60 mm grid's 136 and 52 of the 30 mm grid's failed before the
/// descent through a fold), and each is an equilibrium among the solids.
#[test]
fn bodies_fed_against_a_step_settle() {
    let (robot, solver) = (Robot::builtin(), Solver::default());
    let mut wrong = Vec::new();
    for scene in [census::step_ahead(0.06), census::step_ahead(0.03)] {
        for lengths in census::lengths().into_iter().step_by(9) {
            match census::solve(&robot, &scene, lengths, FreeCups::Rest, &solver) {
                Ok(held) => wrong.extend(check(&robot, &scene, lengths, &held).err()),
                Err(e) => wrong.push(format!("{} at {lengths:?}: {e}", scene.name)),
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Before a 30 mm step at 0.160/0.162 m the tubes' tips push on the nosing
/// and the free front cup hangs in front of the riser; fed 0.1 mm further,
/// no equilibrium is left near (a fold): the tips slip onto the top. A
/// settle from there leapt to the cup lying on the top, its lower rim's
/// straight path through the block. The descent follows the body down
/// instead: the cup swings into the riser and rests against it, and the
/// feed reports the snap.
#[test]
fn a_body_that_snaps_over_a_nosing_is_followed_down_to_the_riser() {
    let (robot, solver, scene) = (Robot::builtin(), Solver::default(), census::step_ahead(0.03));
    let lengths = [0.160, 0.162];
    let held = census::solve(&robot, &scene, lengths, FreeCups::Rest, &solver).unwrap();
    check(&robot, &scene, lengths, &held).unwrap();
    let snapped = held.equilibrium.events.iter().any(|e| matches!(e, leech::statics::Event::Snap { .. }));
    assert!(snapped, "no snap reported: {:?}", held.equilibrium.events);
    let riser = held.contacts.iter().find(|c| c.chain == "front_cup" && c.normal == [-1.0, 0.0]);
    let riser = riser.unwrap_or_else(|| panic!("the front cup does not rest on the riser: {:?}", held.contacts));
    assert!((riser.point_m[0] - census::AHEAD_M).abs() < 1e-9 && riser.point_m[1] < 0.03, "{riser:?}");
    let on_top =
        held.contacts.iter().any(|c| c.chain == "b" && c.normal == [0.0, 1.0] && c.point_m[0] > census::AHEAD_M);
    assert!(on_top, "tube B's tip is not on the step's top: {:?}", held.contacts);
}
