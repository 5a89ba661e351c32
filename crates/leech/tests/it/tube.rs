//! The single clamped tube resting on a scene's solids: balance,
//! complementarity, and the propped cantilever of beam theory.

use leech::cantilever::CantileverSpec;
use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::{self, TubeHeld};

/// A level floor whose surface is at `y` (m): solid below.
fn floor_at(y: f64) -> Scene {
    let text = format!("name = \"floor\"\n[[half_plane]]\npoint_m = [0.0, {y}]\nnormal = [0.0, 1.0]\n");
    Scene::from_toml_str(&text, "floor").unwrap()
}

/// A horizontal tube of `n` elements of 10 mm, 1 g each, at shape parameter `pi`.
fn spec(n: usize, pi: f64, d: Discretization) -> CantileverSpec {
    let (l, m, g) = (0.01, 0.001, 9.81);
    CantileverSpec {
        elements: n,
        element_length_m: l,
        element_mass_kg: m,
        joint_stiffness_nm_per_rad: pi * m * g * l,
        tip_mass_kg: 0.0,
        base_angle_deg: 0.0,
        gravity_m_per_s2: g,
        discretization: d,
    }
}

/// Force and moment balance to 1e-9 relative, no penetration beyond 1e-9 m,
/// and complementarity: every reported force pushes, and where it pushes the
/// gap is closed (the point one radius above the floor at `floor_y`).
fn check(held: &TubeHeld, floor_y: f64, radius: f64) {
    assert!(held.equilibrium.stable);
    let w = held.weight_n;
    let mut force = held.clamp.force_n;
    for c in &held.contacts {
        assert!(c.force_n > 0.0, "{c:?}");
        assert!((c.point_m[1] - floor_y - radius).abs() <= 1e-9, "gap at a pushing contact: {c:?}");
        force = [force[0] + c.force_n * c.normal[0], force[1] + c.force_n * c.normal[1]];
    }
    assert!(force[0].abs() <= 1e-9 * w && (force[1] - w).abs() <= 1e-9 * w, "force {force:?} vs weight {w}");
    // Moments on the scale of the weight times the tube's length.
    let length = held.tube.chain().tube_length();
    let moment = held.moment_about_clamp();
    assert!(moment.abs() <= 1e-9 * w * length, "moments about the clamp sum to {moment:e} N m");
    assert!(held.penetration_m <= 1e-9, "{}", held.penetration_m);
    for p in &held.points_m[1..] {
        assert!(p[1] >= floor_y + radius - 1e-9, "{p:?} inside the clearance");
    }
}

#[test]
fn a_soft_tube_lies_on_a_floor_below_its_clamp() {
    let radius = 0.005;
    for d in [Discretization::Paper, Discretization::Midpoint] {
        let floor_y = -0.04;
        let held = stance::tube_in(&spec(30, 20.0, d), &floor_at(floor_y), radius, &Solver::default()).unwrap();
        // Soft: it bends down and lies along the floor over several nodes.
        assert!(held.contacts.len() >= 3, "{d:?}: {:?}", held.contacts);
        check(&held, floor_y, radius);
        assert_eq!(held.points_m, held.tube.chain().points(&held.equilibrium.q));
    }
}

#[test]
fn a_tube_clear_of_the_floor_is_the_cantilever() {
    let s = spec(20, 500.0, Discretization::Paper);
    let held = stance::tube_in(&s, &floor_at(-0.5), 0.005, &Solver::default()).unwrap();
    let free = s.build().unwrap().solve(&Solver::default()).unwrap();
    assert!(held.contacts.is_empty());
    for (a, b) in held.equilibrium.q.iter().zip(&free.q) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
    check(&held, -0.5, 0.005);
    // Without contacts the clamp carries everything: the moment from the
    // first spring is the weight's, W x_G.
    let x_g = held.tube.chain().mass_moment(&free.q)[0] / held.tube.chain().total_mass();
    assert!((held.clamp.moment_nm - held.weight_n * x_g).abs() < 1e-9 * held.weight_n * 0.2);
}

/// A stiff horizontal tube whose tip rests on a floor below the clamp: beam
/// theory's propped cantilever. With `EI = k l` and `w = m g / l`, the free
/// tip sags `delta = w L^4 / (8 EI)`; a prop `d` below the clamp pushes with
/// `R = 3 EI (delta - d) / L^3`: `3 w L / 16` for `d = delta / 2`.
///
/// Tolerance: the `midpoint` cut is second order in `l / L` (1/40 here: a few
/// 1e-4 of `R`), and the rotations (`delta / L = 0.008`) add their square
/// (about 1e-4); 2e-3 is well above both and far below the 1/16 by which a
/// wrong support condition (a pin at the clamp, a free tip) would miss.
#[test]
fn a_stiff_tube_propped_at_its_tip_matches_beam_theory() {
    let (n, pi, radius) = (40, 1e6, 0.005);
    let s = spec(n, pi, Discretization::Midpoint);
    let (length, w, ei) = (n as f64 * 0.01, 0.001 * 9.81 / 0.01, s.joint_stiffness_nm_per_rad * 0.01);
    let delta = w * length.powi(4) / (8.0 * ei);
    let floor_y = -(0.5 * delta + radius);
    let held = stance::tube_in(&s, &floor_at(floor_y), radius, &Solver::default()).unwrap();
    check(&held, floor_y, radius);
    let last = held.tube.chain().len();
    assert_eq!(held.contacts.len(), 1, "{:?}", held.contacts);
    let tip = held.contacts[0];
    assert_eq!((tip.node, tip.fraction), (last, 0.0));
    let expected = 3.0 * w * length / 16.0;
    assert!((tip.force_n - expected).abs() <= 2e-3 * expected, "prop {} N vs beam theory {expected} N", tip.force_n);
}
