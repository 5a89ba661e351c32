//! Benchmarks of the body in a situation (divan): held by a cup on a floor
//! with its contacts (a soft body lying on many, against the same body with
//! no scene), both cups holding, and the growth with links.
//! `cargo bench -p leech --bench stance`.

use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::{self, Hold, Pose};

fn main() {
    divan::main();
}

/// The rear cup on the floor at the origin, the robot facing +x: the driving
/// unit's point `b + rear_offset` above it (the cups lie on chain B's side).
fn on_floor(robot: &Robot) -> Hold {
    Hold::Rear(Pose::from_deg([0.0, robot.body.base_spacing_m + robot.cup.rear_offset_m], 0.0))
}

/// The built-in robot at 0.30/0.28 m on the floor, solved cold: fed from the
/// shortest length with its contacts refreshed (`stance::solve_in`).
#[divan::bench]
fn floor_cold_30_28(bencher: divan::Bencher) {
    let robot = Robot::builtin();
    let floor = Scene::builtin("floor").unwrap();
    let (hold, solver) = (on_floor(&robot), Solver::default());
    bencher.bench_local(|| stance::solve_in(&robot, [0.30, 0.28], hold, &floor, &solver).unwrap());
}

/// A softer body (shape parameter 100 instead of about 5100) lying on the
/// floor on 24 contacts, solved cold: the many-contact case.
#[divan::bench]
fn floor_lying_cold_30_28(bencher: divan::Bencher) {
    let robot = Robot::builtin().with_shape_parameter(100.0).unwrap();
    let floor = Scene::builtin("floor").unwrap();
    let (hold, solver) = (on_floor(&robot), Solver::default());
    let held = stance::solve_in(&robot, [0.30, 0.28], hold, &floor, &solver).unwrap();
    assert!(held.contacts.len() >= 20, "{} contacts", held.contacts.len());
    bencher.bench_local(|| stance::solve_in(&robot, [0.30, 0.28], hold, &floor, &solver).unwrap());
}

/// The body of [`floor_lying_cold_30_28`] with the same hold and no scene
/// (it hangs through where the floor would be), solved cold: what the
/// lying body's solve is measured against.
#[divan::bench]
fn lying_no_scene_30_28(bencher: divan::Bencher) {
    let robot = Robot::builtin().with_shape_parameter(100.0).unwrap();
    let (hold, solver) = (on_floor(&robot), Solver::default());
    bencher.bench_local(|| stance::solve(&robot, [0.30, 0.28], hold, &solver).unwrap());
}

/// The same on a floor with tubes cut into `links` elements each (0.30 m).
#[divan::bench(args = [30, 100, 300], sample_count = 20)]
fn floor_cold_links(bencher: divan::Bencher, links: usize) {
    let robot = Robot::builtin().with_element_length(0.30 / links as f64).unwrap();
    let floor = Scene::builtin("floor").unwrap();
    let (hold, solver) = (on_floor(&robot), Solver::default());
    bencher.bench_local(|| stance::solve_in(&robot, [0.30, 0.28], hold, &floor, &solver).unwrap());
}

/// Both cups: the front cup attached 2 mm beyond where the free endpoint of
/// the rear-held 0.30/0.28 m body hangs, warm from that free shape
/// (`stance::attach_front`).
#[divan::bench]
fn both_warm_30_28(bencher: divan::Bencher) {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let rear = Pose::from_deg([0.0, 0.0], robot.world.base_angle_deg);
    let free = stance::solve(&robot, [0.30, 0.28], Hold::Rear(rear), &solver).unwrap();
    let front = Pose { point_m: [free.endpoint_m[0], free.endpoint_m[1] + 0.002], angle_rad: free.plate_angle() };
    bencher.bench_local(|| stance::attach_front(&robot, &free, front, &solver).unwrap());
}
