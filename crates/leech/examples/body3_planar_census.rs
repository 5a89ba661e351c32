//! The 3D body against the planar one at random lengths and clamp angles
//! (`b = c`, `L2 = L3`): how often the default 3D path ends on the planar
//! equilibrium, and how it leaves it where it does not (docs/model3d.md
//! section 7).
//!
//! `cargo run --release -p leech --example body3_planar_census -- [CASES] [SEED]`
//! (default 1500 cases, seed 12345). Each case is put in one class:
//!
//! * `equal`: the 3D answer is the planar one to 1e-9 m and rad, with the
//!   same events;
//! * `equal, left first`: the same answer, the 3D path having left the
//!   plane at a bifurcation before a planar event (or during feeding);
//! * `saddle`: the planar equilibrium is a 3D saddle (a warm start from it
//!   leaves it) and the 3D path reported a bifurcation;
//! * anything else is printed as `unexpected`, with the case.

use leech::body3::Body3;
use leech::geom3::rot_z;
use leech::prelude::*;
use leech::stance3::planar::compare;

fn main() {
    let args: Vec<u64> = std::env::args().skip(1).filter_map(|s| s.parse().ok()).collect();
    let cases = args.first().copied().unwrap_or(1500);
    let mut seed = args.get(1).copied().unwrap_or(12345);
    // A linear congruential generator: the same cases on every machine.
    let mut uniform = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let solver = Solver::default();
    let mut counts = [0usize; 4];
    for _ in 0..cases {
        let (l1, l23, angle) = (0.05 + 0.25 * uniform(), 0.05 + 0.25 * uniform(), -180.0 + 360.0 * uniform());
        let mut robot = Robot::builtin().with_base_angle(angle).expect("an angle in range");
        robot.body.tip_spacing_m = robot.body.base_spacing_m;
        let body3 = Body3::from_robot(&robot, [l1, l23, l23]).expect("lengths in range");
        let body = robot.body(l1, l23).expect("lengths in range");
        let (eq3, eq) = match (body3.solve(&solver), body.solve(&solver)) {
            (Ok(a), Ok(b)) => (a, b),
            (a, b) => {
                println!("unexpected: {l1} {l23} {angle}: {:?} {:?}", a.err(), b.err());
                counts[3] += 1;
                continue;
            }
        };
        let (qa, qb) = body.split(&eq.q);
        let mut frames = vec![rot_z(0.0); body3.links()];
        for (t, q) in [(0, qa), (1, qb), (2, qb)] {
            for (j, phi) in q.iter().enumerate() {
                frames[body3.index(t, j)] = rot_z(*phi);
            }
        }
        let planar = body3.frames_from(frames).expect("rotations about z");
        let saddle = body3.solve_from(&solver, &planar).map(|e| !e.events.is_empty()).unwrap_or(false);
        let d = compare(&body3, &eq3, &body, &eq);
        let equal = d.max_point_m < 1e-9 && d.max_angle_rad < 1e-9;
        let left = eq3.events.iter().any(|e| matches!(e, Event::Bifurcation { .. }));
        let class = match (equal, saddle) {
            (true, false) if eq3.events.len() == eq.events.len() && !left => 0,
            (true, false) => 1,
            (false, true) if left => 2,
            _ => 3,
        };
        if class == 3 {
            println!("unexpected: {l1} {l23} {angle}: {d:?} 3D {:?} planar {:?}", eq3.events, eq.events);
        }
        counts[class] += 1;
    }
    println!(
        "{cases} cases: equal {}, equal after leaving first {}, planar saddle left {}, unexpected {}",
        counts[0], counts[1], counts[2], counts[3]
    );
}
