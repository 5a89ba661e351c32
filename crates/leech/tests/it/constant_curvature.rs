//! The constant-curvature model against closed forms, its inverses, and the
//! planar form against the tri-tube form.

use leech::constant_curvature::{Arc, PlanarBody, TriTube};
use proptest::prelude::*;

fn planar(b: f64, c: f64, angle: f64) -> PlanarBody {
    PlanarBody { clamp_point: [0.01, -0.02], clamp_angle: angle, base_spacing: b, tip_spacing: c }
}

#[test]
fn equal_lengths_give_a_straight_body() {
    for angle in [0.0, 0.7, std::f64::consts::FRAC_PI_2, 3.0] {
        let cc = planar(0.017, 0.012, angle);
        let pose = cc.pose(0.23, 0.23);
        assert_eq!(pose.bend, 0.0);
        let expected = [0.01 + 0.23 * angle.cos(), -0.02 + 0.23 * angle.sin()];
        assert!((pose.endpoint[0] - expected[0]).abs() < 1e-15 && (pose.endpoint[1] - expected[1]).abs() < 1e-15);
    }
}

#[test]
fn planar_bend_is_length_difference_over_width() {
    let cc = planar(0.017, 0.012, 0.3);
    let pose = cc.pose(0.2, 0.25);
    let w = 0.5 * (0.017 + 0.012);
    assert!((pose.bend - 0.05 / w).abs() < 1e-13);
    assert!((pose.endpoint_angle - (0.3 + 0.05 / w)).abs() < 1e-13);
    // Chain A is an arc of radius LA/theta about a centre on its left.
    let r = 0.2 / pose.bend;
    let centre = [0.01 - r * 0.3f64.sin(), -0.02 + r * 0.3f64.cos()];
    let d = ((pose.endpoint[0] - centre[0]).powi(2) + (pose.endpoint[1] - centre[1]).powi(2)).sqrt();
    assert!((d - r).abs() < 1e-14);
}

#[test]
fn tiny_bends_are_exact() {
    let cc = planar(0.015, 0.015, 0.0);
    let straight = cc.pose(0.2, 0.2).endpoint;
    for d in [1e-14, 1e-10, 1e-7, 1e-5] {
        let p = cc.pose(0.2, 0.2 + d).endpoint;
        // First order: the tip moves left by LA^2 theta / 2.
        let theta = d / 0.015;
        assert!((p[1] - straight[1] - 0.2 * 0.2 * theta / 0.2 / 2.0).abs() < 1e-12 + 1e-6 * theta);
        assert!(p.iter().all(|x| x.is_finite()));
    }
}

proptest! {
    #[test]
    fn planar_inverse_inverts_forward(la in 0.02f64..0.4, bend in -6.0f64..6.0, angle in -3.0f64..3.0) {
        let cc = planar(0.017, 0.012, angle);
        let lb = la + cc.width() * bend;
        prop_assume!(lb > 0.005);
        let pose = cc.pose(la, lb);
        let [a, b] = cc.lengths_for(pose.endpoint).unwrap();
        prop_assert!((a - la).abs() < 1e-12 && (b - lb).abs() < 1e-12, "{a} {b} vs {la} {lb}");
    }

    #[test]
    fn tri_tube_forward_and_inverse_are_inverses(
        ell in 0.05f64..0.3,
        bend in 0.0f64..6.0,
        plane in -3.1f64..3.1,
        first_angle in -3.0f64..3.0,
    ) {
        let body = TriTube { radius: 0.012, first_angle };
        let l = body.lengths(Arc { length: ell, bend, plane });
        let arc = body.arc(l);
        let back = body.lengths(arc);
        for i in 0..3 {
            prop_assert!((back[i] - l[i]).abs() < 1e-12);
        }
        // A tip position fixes the arc below a full turn.
        let again = body.arc_for(body.pose(arc).position).unwrap();
        let lengths = body.lengths(again);
        for i in 0..3 {
            prop_assert!((lengths[i] - l[i]).abs() < 1e-12, "{lengths:?} vs {l:?}");
        }
        // The rotation is orthonormal.
        let r = body.pose(arc).rotation;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                let identity = if i == j { 1.0 } else { 0.0 };
                prop_assert!((dot - identity).abs() < 1e-12, "R^T R at {i},{j}");
            }
        }
    }

    /// With L2 = L3 the tri-tube body bends in the plane of tube 1 and tube 1
    /// follows the planar model's chain A with w = 3r/2.
    #[test]
    fn planar_form_is_the_tri_tube_form_in_its_plane(l1 in 0.05f64..0.3, l23 in 0.05f64..0.3) {
        let r = 0.01;
        let body = TriTube { radius: r, first_angle: 0.0 };
        let arc = body.arc([l1, l23, l23]);
        let tip = body.tube_tips(arc)[0];
        let (dx, dy, dz) = (tip[0] - r, tip[1], tip[2]);
        prop_assert!(dy.abs() < 1e-14);
        // Planar, clamped pointing up (+y) at the origin: left of the clamp is -x.
        let cc = PlanarBody { clamp_point: [0.0, 0.0], clamp_angle: std::f64::consts::FRAC_PI_2,
            base_spacing: 1.5 * r, tip_spacing: 1.5 * r };
        let pose = cc.pose(l1, l23);
        prop_assert!((pose.endpoint[0] + dx).abs() < 1e-13, "{} vs {}", pose.endpoint[0], -dx);
        prop_assert!((pose.endpoint[1] - dz).abs() < 1e-13);
        let signed = if arc.plane.abs() < 1.0 { arc.bend } else { -arc.bend };
        prop_assert!((pose.bend - signed).abs() < 1e-12);
    }
}

#[test]
fn tri_tube_straight_and_bad_targets() {
    let body = TriTube { radius: 0.01, first_angle: 0.0 };
    let arc = body.arc([0.2; 3]);
    assert!((arc.length - 0.2).abs() < 1e-15 && arc.bend < 1e-12);
    let straight = Arc { length: 0.2, bend: 0.0, plane: 0.0 };
    assert_eq!(body.pose(straight).position, [0.0, 0.0, 0.2]);
    assert!(body.arc_for([0.0, 0.0, 0.0]).is_err());
    assert!(planar(0.01, 0.01, 0.0).lengths_for([0.01, -0.02]).is_err());
}
