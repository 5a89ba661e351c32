//! The tri-tube constant-curvature model of the robot (docs/model3d.md
//! section 9): analytic limits, hand-derived cases, the planar model, the
//! general tri-tube form, its inverse, and the 3D body without gravity.

use leech::body3::constant_curvature3::ConstantCurvature3;
use leech::body3::Body3;
use leech::constant_curvature::{Arc, TriTube};
use leech::geom3::{apply, log, mul, mul_tn, rot_z, transpose, Mat3, Vec3};
use leech::prelude::*;
use proptest::prelude::*;

/// The built-in robot with spacings `b`, `c` (m), gravity `g` and clamp angle (deg), its driving
/// unit without an outline (the 3D body has none; the built-in outline holds spacings up to 19 mm).
fn robot(b: f64, c: f64, g: f64, angle: f64) -> Robot {
    let mut robot = Robot::builtin().with_base_angle(angle).unwrap().with_gravity(g).unwrap();
    robot.body.base_spacing_m = b;
    robot.body.tip_spacing_m = c;
    (robot.driving_unit.length_m, robot.driving_unit.height_m) = (0.0, 0.0);
    robot.validate().unwrap();
    robot
}

fn distance(a: Vec3, b: Vec3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn frame_gap(a: &Mat3, b: &Mat3) -> f64 {
    let v = log(&mul_tn(a, b));
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn column(r: &Mat3, c: usize) -> Vec3 {
    [r[0][c], r[1][c], r[2][c]]
}

#[test]
fn equal_lengths_give_a_straight_body() {
    for (angle, b, c) in [(0.0, 0.017, 0.012), (90.0, 0.015, 0.015), (-135.0, 0.02, 0.01)] {
        let cc = ConstantCurvature3::new(&robot(b, c, 9.81, angle), [0.23; 3]).unwrap();
        let arc = cc.arc();
        assert_eq!((arc.bend, arc.plane, cc.curvature()), (0.0, 0.0, 0.0));
        assert!((arc.length - 0.23).abs() < 1e-16);
        let r0 = rot_z(f64::to_radians(angle));
        assert_eq!(cc.plate_frame(), r0);
        for tube in 0..3 {
            let root = cc.root(tube).unwrap();
            for (k, p) in cc.points(tube, 7).unwrap().into_iter().enumerate() {
                let s = 0.23 * k as f64 / 7.0;
                let straight = [root[0] + s * r0[0][0], root[1] + s * r0[1][0], root[2]];
                assert!(distance(p, straight) < 1e-16, "{angle} tube {tube}: {p:?} vs {straight:?}");
            }
        }
    }
}

/// Hand-derived: one tube shorter by `delta` (the others at `L`) bends the
/// body towards it by `2 delta / (3 r)`; one longer, away from it; `L2 = L3`
/// longer than `L1` by `delta`, towards tube 1 by `delta / (1.5 r)`.
#[test]
fn bend_and_plane_by_hand() {
    let (b, c) = (0.018, 0.012);
    let r = (b + c) / 3.0;
    let rb = robot(b, c, 9.81, 90.0);
    let (l, delta) = (0.2, 0.004);
    let deg = f64::to_radians;
    let cases = [
        ([l - delta, l, l], 2.0 * delta / (3.0 * r), 0.0),
        ([l, l - delta, l], 2.0 * delta / (3.0 * r), deg(120.0)),
        ([l, l, l - delta], 2.0 * delta / (3.0 * r), deg(-120.0)),
        ([l, l + delta, l], 2.0 * delta / (3.0 * r), deg(-60.0)),
        ([l, l + delta, l + delta], delta / (1.5 * r), 0.0),
        ([l + delta, l, l], 2.0 * delta / (3.0 * r), deg(180.0)),
    ];
    for (lengths, bend, plane) in cases {
        let arc = ConstantCurvature3::new(&rb, lengths).unwrap().arc();
        assert!((arc.bend - bend).abs() < 1e-13, "{lengths:?}: {arc:?} vs bend {bend}");
        assert!((arc.plane - plane).abs() < 1e-13, "{lengths:?}: {arc:?} vs plane {plane}");
        assert!((arc.length - lengths.iter().sum::<f64>() / 3.0).abs() < 1e-16);
    }
}

proptest! {
    /// Webster and Jones' closed form of the curvature, and the general
    /// tri-tube form ([`TriTube`]: base frame with z along the clamp, tube 1
    /// on its x axis) mapped to the unit's frame `(x, y, z)_base ->
    /// (y, z, x)_unit`: the same arc and, with `b = c`, the same tube tips.
    #[test]
    fn agrees_with_webster_jones_and_the_general_tri_tube_form(
        l1 in 0.05f64..0.3, l2 in 0.05f64..0.3, l3 in 0.05f64..0.3, b in 0.01f64..0.03, angle in -180.0f64..180.0,
    ) {
        let cc = ConstantCurvature3::new(&robot(b, b, 9.81, angle), [l1, l2, l3]).unwrap();
        let r = b / 1.5;
        // Webster and Jones' `sqrt(l1^2 + l2^2 + l3^2 - l1 l2 - l2 l3 - l3 l1)`,
        // written as half the sum of the squared differences: expanded, it
        // loses about 1e-11 relative to cancellation on nearly equal tubes.
        let spread = ((l1 - l2).powi(2) + (l2 - l3).powi(2) + (l3 - l1).powi(2)) / 2.0;
        let kappa = 2.0 * spread.sqrt() / (r * (l1 + l2 + l3));
        prop_assert!((cc.curvature() - kappa).abs() < 1e-12 * (1.0 + kappa), "{} vs {kappa}", cc.curvature());
        let tri = TriTube { radius: r, first_angle: 0.0 };
        let general = tri.arc([l1, l2, l3]);
        let arc = cc.arc();
        prop_assert!((general.bend - arc.bend).abs() < 1e-12 && (general.length - arc.length).abs() < 1e-15);
        prop_assume!(arc.bend > 1e-6);
        let turn = (general.plane - arc.plane).rem_euclid(std::f64::consts::TAU);
        prop_assert!(turn.min(std::f64::consts::TAU - turn) < 1e-9, "{general:?} vs {arc:?}");
        let r0 = rot_z(angle.to_radians());
        for (tube, tip) in tri.tube_tips(general).into_iter().enumerate() {
            let unit = apply(&r0, [tip[2], tip[0], tip[1]]);
            let ours = cc.points(tube, 1).unwrap()[1];
            prop_assert!(distance(unit, ours) < 1e-13, "tube {tube}: {unit:?} vs {ours:?}");
        }
    }

    /// With `L2 = L3` tube 1 is the planar model's chain A and the midpoint
    /// of tubes 2 and 3 its chain B (with `w = (b + c)/2`), to round-off,
    /// for any `b` and `c`; the plate turns about z by the planar bend.
    #[test]
    fn equal_side_tubes_are_the_planar_model(
        l1 in 0.05f64..0.3, l23 in 0.05f64..0.3, b in 0.01f64..0.03, c in 0.01f64..0.03, angle in -180.0f64..180.0,
    ) {
        let robot = robot(b, c, 9.81, angle);
        let cc = ConstantCurvature3::new(&robot, [l1, l23, l23]).unwrap();
        let planar = PlanarBody::of(&robot);
        let pose = planar.pose(l1, l23);
        let (a, chain_b) = planar.chain_points(l1, l23, 12);
        let (t1, t2, t3) = (cc.points(0, 12).unwrap(), cc.points(1, 12).unwrap(), cc.points(2, 12).unwrap());
        let origin = cc.root(0).unwrap();
        for k in 0..=12 {
            let mid = [0.5 * (t2[k][0] + t3[k][0]), 0.5 * (t2[k][1] + t3[k][1]), 0.5 * (t2[k][2] + t3[k][2])];
            let (pa, pb) = ([a[k][0] + origin[0], a[k][1] + origin[1], 0.0], [chain_b[k][0] + origin[0], chain_b[k][1] + origin[1], 0.0]);
            prop_assert!(distance(t1[k], pa) < 1e-15 && distance(mid, pb) < 1e-15, "{k}: {:?} {:?}", t1[k], pa);
        }
        prop_assert!(frame_gap(&cc.plate_frame(), &rot_z(pose.endpoint_angle)) < 1e-14);
        prop_assert!((cc.arc().bend - pose.bend.abs()).abs() < 1e-12);
    }

    /// Swapping `L2` and `L3` mirrors the body in z, tubes 2 and 3 exchanged.
    #[test]
    fn swapping_the_side_tubes_mirrors_in_z(
        l1 in 0.05f64..0.3, l2 in 0.05f64..0.3, l3 in 0.05f64..0.3, angle in -180.0f64..180.0,
    ) {
        let robot = robot(0.017, 0.012, 9.81, angle);
        let cc = ConstantCurvature3::new(&robot, [l1, l2, l3]).unwrap();
        let swapped = ConstantCurvature3::new(&robot, [l1, l3, l2]).unwrap();
        for (tube, mirror) in [(0, 0), (1, 2), (2, 1)] {
            for (p, q) in cc.points(tube, 9).unwrap().into_iter().zip(swapped.points(mirror, 9).unwrap()) {
                prop_assert!(distance(p, [q[0], q[1], -q[2]]) < 1e-15, "{tube}: {p:?} {q:?}");
            }
        }
        let m = |r: Mat3| {
            let mut out = r;
            for (row, sign) in out.iter_mut().zip([1.0, 1.0, -1.0]) {
                for (col, s) in row.iter_mut().zip([1.0, 1.0, -1.0]) {
                    *col *= sign * s;
                }
            }
            out
        };
        prop_assert!(frame_gap(&cc.plate_frame(), &m(swapped.plate_frame())) < 1e-15);
    }

    /// Arc to lengths to arc, and lengths to arc to lengths.
    #[test]
    fn the_inverse_round_trips(
        ell in 0.12f64..0.25, bend in 1e-6f64..3.0, plane in -3.1f64..3.1, b in 0.01f64..0.03, c in 0.01f64..0.03,
        l in proptest::array::uniform3(0.05f64..0.3),
    ) {
        let robot = robot(b, c, 0.0, 30.0);
        let target = Arc { length: ell, bend, plane };
        if let Ok(lengths) = ConstantCurvature3::lengths_for(&robot, target) {
            let arc = ConstantCurvature3::new(&robot, lengths).unwrap().arc();
            prop_assert!((arc.length - ell).abs() < 1e-15 && (arc.bend - bend).abs() < 1e-12, "{arc:?} vs {target:?}");
            prop_assert!((arc.plane - plane).abs() < 1e-12 / bend, "{arc:?} vs {target:?}");
        }
        let arc = ConstantCurvature3::new(&robot, l).unwrap().arc();
        let back = ConstantCurvature3::lengths_for(&robot, arc).unwrap();
        for i in 0..3 {
            prop_assert!((back[i] - l[i]).abs() < 1e-15, "{back:?} vs {l:?}");
        }
    }

    /// The geometry: each tube is a circle of its own length (the polygon
    /// through many of its points), leaving its root along the clamp and
    /// tangent to its frame; the tube's tip frame is the plate's; with
    /// `b = c` the side tubes end exactly on the plate's triangle (the
    /// length relation is the arcs' geometry), and with `b != c` they miss
    /// it by the documented gap.
    #[test]
    fn tubes_are_arcs_that_end_on_the_plate(
        l in proptest::array::uniform3(0.05f64..0.3), b in 0.01f64..0.03, c in 0.01f64..0.03, angle in -180.0f64..180.0,
    ) {
        let robot = robot(b, c, 9.81, angle);
        let cc = ConstantCurvature3::new(&robot, l).unwrap();
        let plate = cc.plate_frame();
        let (rb, rt, r) = (b / 1.5, c / 1.5, (b + c) / 3.0);
        let units: [Vec3; 3] = [[0.0, 1.0, 0.0], [0.0, -0.5, 0.75f64.sqrt()], [0.0, -0.5, -(0.75f64.sqrt())]];
        let arc = cc.arc();
        let d = [0.0, arc.plane.cos(), arc.plane.sin()];
        let r0 = rot_z(angle.to_radians());
        for tube in 0..3 {
            let n = 4000;
            let points = cc.points(tube, n).unwrap();
            let length: f64 = points.windows(2).map(|w| distance(w[0], w[1])).sum();
            // A chord polygon of n sides is shorter by L theta^2 / (24 n^2).
            prop_assert!((length - l[tube]).abs() < 1e-12 + l[tube] * arc.bend.powi(2) / (20.0 * (n * n) as f64));
            let h = 1e-6 * l[tube];
            for s in [0.0, 0.3 * l[tube], l[tube]] {
                let (lo, hi) = ((s - h).max(0.0), (s + h).min(l[tube]));
                let (p, q) = (cc.point(tube, lo).unwrap(), cc.point(tube, hi).unwrap());
                let tangent = [(q[0] - p[0]) / (hi - lo), (q[1] - p[1]) / (hi - lo), (q[2] - p[2]) / (hi - lo)];
                prop_assert!(distance(tangent, column(&cc.frame(tube, s).unwrap(), 0)) < 1e-8 + 1e-6 * arc.bend, "{tube} {s}");
            }
            prop_assert!(frame_gap(&cc.frame(tube, l[tube]).unwrap(), &plate) < 1e-14);
            let du = [units[tube][0] - units[0][0], units[tube][1] - units[0][1], units[tube][2] - units[0][2]];
            let ddu = d[1] * du[1] + d[2] * du[2];
            let (ct, st) = (arc.bend.cos(), arc.bend.sin());
            let local: Vec3 = std::array::from_fn(|k| {
                let swing = [st, (1.0 - ct) * d[1], (1.0 - ct) * d[2]][k];
                (rb - rt) * (du[k] - 0.5 * ddu * swing)
            });
            let gap = apply(&r0, local);
            let tip = cc.points(tube, 1).unwrap()[1];
            let vertex = apply(&plate, [0.0, rt * du[1], rt * du[2]]);
            let end = cc.endpoint();
            let expected: Vec3 = std::array::from_fn(|k| end[k] + vertex[k] + gap[k]);
            prop_assert!(distance(tip, expected) < 1e-14, "tube {tube}: {tip:?} vs {expected:?} (r {r})");
        }
        prop_assert!(distance(cc.endpoint(), cc.point(0, l[0]).unwrap()) == 0.0);
        prop_assert!(frame_gap(&mul(&transpose(&r0), &cc.base_frame()), &rot_z(0.0)) == 0.0);
    }
}

#[test]
fn bad_input_names_the_field() {
    let robot = Robot::builtin();
    let message = |e: InputError| {
        let text = e.to_string();
        assert!(!text.contains('\n'), "{text}");
        text
    };
    for (lengths, field) in [
        ([0.2, f64::NAN, 0.2], "lengths[1] (L2)"),
        ([0.2, 0.2, -0.1], "lengths[2] (L3)"),
        ([1e3, 0.2, 0.2], "lengths[0] (L1)"),
    ] {
        let text = message(ConstantCurvature3::new(&robot, lengths).unwrap_err());
        assert!(text.starts_with(field), "{text}");
    }
    let cc = ConstantCurvature3::new(&robot, [0.2, 0.21, 0.19]).unwrap();
    assert!(message(cc.points(3, 10).unwrap_err()).starts_with("tube: got 3"));
    assert!(message(cc.points(0, 0).unwrap_err()).starts_with("samples: got 0"));
    assert!(message(cc.point(1, 0.3).unwrap_err()).starts_with("arc length along the tube: got 0.3"));
    assert!(cc.frame(2, -1e-3).is_err() && cc.root(7).is_err() && cc.point(1, f64::NAN).is_err());
    for (arc, field) in [
        (Arc { length: f64::INFINITY, bend: 0.1, plane: 0.0 }, "arc.length"),
        (Arc { length: 0.2, bend: -0.1, plane: 0.0 }, "arc.bend"),
        (Arc { length: 0.2, bend: 0.1, plane: f64::NAN }, "arc.plane"),
        (Arc { length: 0.2, bend: 500.0, plane: 0.0 }, "lengths[0] (L1) of the arc"),
    ] {
        let text = message(ConstantCurvature3::lengths_for(&robot, arc).unwrap_err());
        assert!(text.starts_with(field), "{text}");
    }
    let other = Body3::from_robot(&robot, [0.2, 0.21, 0.2]).unwrap();
    let text = message(cc.difference(&other, &other.straight()).unwrap_err());
    assert!(text.starts_with("body3 tube 3 length"), "{text}");
}

/// The 3D body of `robot` solved (no events, stable).
fn solved(robot: &Robot, lengths: [f64; 3]) -> (Body3, leech::body3::Frames) {
    let body = Body3::from_robot(robot, lengths).unwrap();
    let eq = body.solve(&Solver::default()).unwrap();
    assert!(eq.stable && eq.events.is_empty() && eq.residual < 1e-10, "{lengths:?}: {:?}", eq.events);
    (body, eq.frames.clone())
}

/// Without gravity, with `b = c`, equal tubes: the body is the straight
/// constant-curvature body.
#[test]
fn the_unloaded_body_with_equal_tubes_is_straight() {
    let robot = robot(0.015, 0.015, 0.0, 90.0);
    let (body, frames) = solved(&robot, [0.2437; 3]);
    let d = ConstantCurvature3::new(&robot, [0.2437; 3]).unwrap().difference(&body, &frames).unwrap();
    assert!(d.max_point_m < 1e-12 && d.plate_angle_rad < 1e-12, "{d:?}");
}

/// Slopes at lengths `l` along `direction` (central differences, step
/// `h` m): the plate's rotation vector (rad/m) of the solved body and of the
/// arcs, the endpoint's (m/m) of both, and the `paper` scheme's factor
/// `1 + sum_j e_j^2 / L1^2` of tube 1.
struct Slopes {
    body_turn: Vec3,
    arc_turn: Vec3,
    body_end: Vec3,
    arc_end: Vec3,
    factor: f64,
}

fn slopes(robot: &Robot, l: f64, direction: [f64; 3]) -> Slopes {
    let h = 1e-6;
    let at = |sign: f64| std::array::from_fn::<f64, 3, _>(|i| l + sign * h * direction[i]);
    let (plus, minus) = (at(1.0), at(-1.0));
    let ((bp, fp), (bm, fm)) = (solved(robot, plus), solved(robot, minus));
    let (cp, cm) = (ConstantCurvature3::new(robot, plus).unwrap(), ConstantCurvature3::new(robot, minus).unwrap());
    let r0 = cp.base_frame();
    let slope = |a: Vec3, b: Vec3| -> Vec3 { std::array::from_fn(|k| (a[k] - b[k]) / (2.0 * h)) };
    let turn = |r: &Mat3| log(&mul(r, &transpose(&r0)));
    Slopes {
        body_turn: slope(turn(&bp.plate_frame(&fp)), turn(&bm.plate_frame(&fm))),
        arc_turn: slope(cp.rotation_vector(), cm.rotation_vector()),
        body_end: slope(bp.endpoint(&fp), bm.endpoint(&fm)),
        arc_end: slope(cp.endpoint(), cm.endpoint()),
        factor: 1.0 + bp.tube(0).lengths().iter().map(|e| e * e).sum::<f64>() / (plus[0] * plus[0]),
    }
}

fn largest(v: Vec3) -> f64 {
    v.iter().map(|x| x.abs()).fold(0.0, f64::max)
}

/// Without gravity and with `b = c` the body and the arcs agree to first
/// order in the bend (docs/model3d.md section 9): near equal tubes the
/// plate's rotation vector changes with the lengths exactly as the arcs'
/// `theta a` (any discretization), and the endpoint as the arcs' with the
/// lateral part scaled by the `paper` scheme's `1 + sum_j e_j^2 / L1^2`
/// (its polygon turns at the start of each link). Central differences
/// with bends of about 1e-4 rad: their error is third order in the bend,
/// and the solver's (about 1e-12 rad over a step of 1e-6 m) about 1e-6
/// rad/m; measured 2e-8 to 1.2e-7 of the slopes, allowed 1e-6.
#[test]
fn the_unloaded_body_agrees_with_the_arcs_to_first_order() {
    for (element, angle) in [(0.01, 90.0), (0.004, 30.0)] {
        let mut robot = robot(0.015, 0.015, 0.0, angle);
        robot.tube.element_length_m = element;
        robot.limits.tube_length_min_m = 2.0 * element;
        robot.limits.tube_length_max_m = 0.3;
        robot.validate().unwrap();
        let l = 0.2437;
        for direction in [[0.0, 1.0, -1.0], [-1.0, 0.5, 0.5], [0.3, -1.0, 0.4]] {
            let Slopes { body_turn, arc_turn, body_end, arc_end, factor } = slopes(&robot, l, direction);
            let scale = largest(arc_turn);
            assert!(distance(body_turn, arc_turn) < 1e-6 * scale, "{direction:?}: {body_turn:?} vs {arc_turn:?}");
            let axis = column(&rot_z(f64::to_radians(angle)), 0);
            let axial = arc_end[0] * axis[0] + arc_end[1] * axis[1] + arc_end[2] * axis[2];
            let expected: Vec3 = std::array::from_fn(|k| axial * axis[k] + factor * (arc_end[k] - axial * axis[k]));
            assert!(
                distance(body_end, expected) < 1e-6 * l * scale,
                "{element} {direction:?}: {body_end:?} vs {expected:?}"
            );
            // Not the arcs' endpoint: the discretization's offset is there.
            assert!(distance(body_end, arc_end) > 0.1 * (factor - 1.0) * l * scale);
        }
    }
}

/// With `b != c` (the built-in robot, no gravity) the body's first-order
/// turn is that of arcs of some radius between `r_t` and `r_b`; the mean
/// radius the model takes is nearer to it than either end's (each end's
/// arcs turn `r / r_t` or `r / r_b` times as much as the mean's, since
/// `theta a` is proportional to `1/r`).
#[test]
fn with_unequal_spacings_the_mean_radius_is_the_nearest() {
    let robot = robot(0.017, 0.012, 0.0, 90.0);
    let (rb, rt) = (0.017 / 1.5, 0.012 / 1.5);
    let r = 0.5 * (rb + rt);
    for direction in [[0.0, 1.0, -1.0], [-1.0, 0.5, 0.5]] {
        let Slopes { body_turn, arc_turn, .. } = slopes(&robot, 0.2437, direction);
        let off = |radius: f64| distance(body_turn, arc_turn.map(|x| x * r / radius));
        println!("{direction:?}: body {body_turn:?}, arcs (mean radius) {arc_turn:?}");
        assert!(off(r) < off(rt) && off(r) < off(rb), "{direction:?}: {} {} {}", off(r), off(rt), off(rb));
        assert!(off(r) < 0.05 * largest(arc_turn), "{direction:?}: {}", off(r));
    }
}
