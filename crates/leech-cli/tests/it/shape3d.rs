//! `leech shape3d`: the three-tube body in 3D as a user meets it, against
//! the library, the planar `leech shape`, and its mirror image.

use leech::body3::Body3;
use leech::prelude::*;
use leech::stance3;
use leech::stance3::planar;
use serde_json::Value;

use super::{json_of, leech, not_converged, rejected};

fn vector(v: &Value) -> Vec<f64> {
    v.as_array().expect("an array").iter().map(|x| x.as_f64().expect("a number")).collect()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt()
}

/// A scratch directory of this test's own.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("leech-cli-shape3d-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn json_has_the_documented_keys_and_the_librarys_values() {
    let lengths = [0.30, 0.28, 0.28];
    let v = json_of(&["shape3d", "--lengths", "0.30,0.28,0.28"]);
    for key in [
        "status",
        "stable",
        "iterations",
        "residual",
        "events",
        "endpoint_m",
        "plate_frame",
        "tubes",
        "max_twist_rad",
        "planar_difference_m",
        "planar",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["status"], "converged");
    let robot = Robot::builtin();
    let body = Body3::from_robot(&robot, lengths).unwrap();
    let eq = body.solve(&Solver::default()).unwrap();
    assert_eq!(v["stable"], eq.stable);
    assert_eq!(v["iterations"].as_u64().unwrap() as usize, eq.iterations);
    assert!(distance(&vector(&v["endpoint_m"]), &body.endpoint(&eq.frames)) < 1e-12);
    let plate = body.plate_frame(&eq.frames);
    for (r, row) in plate.iter().enumerate() {
        assert!(distance(&vector(&v["plate_frame"][r]), row) < 1e-12, "plate_frame row {r}");
    }
    assert!((v["max_twist_rad"].as_f64().unwrap() - body.max_twist(&eq.frames)).abs() < 1e-12);
    let tubes = v["tubes"].as_array().unwrap();
    assert_eq!(tubes.len(), 3);
    for (i, tube) in tubes.iter().enumerate() {
        assert!((tube["length_m"].as_f64().unwrap() - lengths[i]).abs() < 1e-15);
        let points = tube["points_m"].as_array().unwrap();
        let expected = body.points(&eq.frames, i);
        assert_eq!(points.len(), expected.len(), "tube {}: root, then every link's tip", i + 1);
        assert_eq!(tube["links"].as_u64().unwrap() as usize + 1, points.len());
        for (p, e) in points.iter().zip(&expected) {
            assert!(distance(&vector(p), e) < 1e-12);
        }
    }
    assert_eq!(tubes[0]["points_m"].as_array().unwrap().last().unwrap(), &v["endpoint_m"]);
    // b != c: the planar model is an approximation, its difference reported.
    let flat = robot.body(lengths[0], lengths[1]).unwrap();
    let expected = planar::planar_difference(&body, &flat, &Solver::default()).unwrap();
    let reported = v["planar_difference_m"].as_f64().unwrap();
    assert!((reported - expected.endpoint_m).abs() < 1e-12, "{reported} against {}", expected.endpoint_m);
    assert!(reported > 1e-6, "b != c leaves a difference: {reported}");
    let planar_endpoint = vector(&v["planar"]["endpoint_m"]);
    assert!((distance(&planar_endpoint, &vector(&v["endpoint_m"])) - reported).abs() < 1e-12);
    assert_eq!(v["planar_note"], Value::Null);
}

/// With `b = c` and `L2 = L3` the 3D body is the planar one: `shape3d`'s
/// endpoint is `shape`'s (the planar clamp on tube 1's root) to 1e-9 m.
#[test]
fn equals_shape_when_b_equals_c() {
    let dir = scratch("b-equals-c");
    let builtin = String::from_utf8(leech().arg("robot").output().unwrap().stdout).unwrap();
    let equal = builtin.replace("tip_spacing_m = 0.012 ", "tip_spacing_m = 0.017 ");
    assert_ne!(equal, builtin);
    let path = dir.join("b-equals-c.toml");
    std::fs::write(&path, equal).unwrap();
    let robot = path.to_str().unwrap();
    for (three, two) in [("0.30,0.28,0.28", "0.30,0.28"), ("0.20,0.25,0.25", "0.20,0.25")] {
        let v = json_of(&["shape3d", "--lengths", three, "--robot", robot]);
        let flat = json_of(&["shape", "--lengths", two, "--robot", robot]);
        let root = vector(&v["tubes"][0]["points_m"][0]);
        let endpoint = vector(&v["endpoint_m"]);
        let planar = vector(&flat["endpoint_m"]);
        let shifted = [planar[0] + root[0], planar[1] + root[1], root[2]];
        let d = distance(&endpoint, &shifted);
        assert!(d < 1e-9, "{three}: {d} m from shape's endpoint");
        assert!(v["planar_difference_m"].as_f64().unwrap() < 1e-9);
        assert!(endpoint[2].abs() < 1e-9, "in the plane z = 0: {}", endpoint[2]);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Swapping L2 and L3 mirrors the body in z: points `(x, y, -z)`, tube 2
/// for tube 3, and the plate's frame `M R M` with `M = diag(1, 1, -1)`.
#[test]
fn swapping_the_side_tubes_mirrors_z() {
    let a = json_of(&["shape3d", "--lengths", "0.30,0.25,0.29"]);
    let b = json_of(&["shape3d", "--lengths", "0.30,0.29,0.25"]);
    let mirror = |p: Vec<f64>| vec![p[0], p[1], -p[2]];
    let ea = vector(&a["endpoint_m"]);
    assert!(ea[2].abs() > 1e-3, "the body turns: z {}", ea[2]);
    assert!(distance(&mirror(ea), &vector(&b["endpoint_m"])) < 1e-10);
    for (i, j) in [(0, 0), (1, 2), (2, 1)] {
        let pa = a["tubes"][i]["points_m"].as_array().unwrap();
        let pb = b["tubes"][j]["points_m"].as_array().unwrap();
        assert_eq!(pa.len(), pb.len());
        for (p, q) in pa.iter().zip(pb) {
            assert!(distance(&mirror(vector(p)), &vector(q)) < 1e-10, "tube {} against tube {}", i + 1, j + 1);
        }
    }
    let sign = [1.0, 1.0, -1.0];
    for r in 0..3 {
        for c in 0..3 {
            let x = a["plate_frame"][r][c].as_f64().unwrap() * sign[r] * sign[c];
            assert!((x - b["plate_frame"][r][c].as_f64().unwrap()).abs() < 1e-10, "plate_frame[{r}][{c}]");
        }
    }
    assert!((a["max_twist_rad"].as_f64().unwrap() - b["max_twist_rad"].as_f64().unwrap()).abs() < 1e-10);
    // No planar counterpart for unequal side tubes, and the note says why.
    assert_eq!(a["planar_difference_m"], Value::Null);
    assert_eq!(a["planar"], Value::Null);
    assert!(a["planar_note"].as_str().unwrap().contains("L2 != L3"));
}

#[test]
fn text_mirrors_shape() {
    let out = leech().args(["shape3d", "--lengths", "0.25,0.25,0.25", "--free-axial-rotation"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("converged in") && text.contains("stable"), "{text}");
    assert!(text.contains("endpoint at") && text.contains("axial rotation free"), "{text}");
    assert!(text.contains("planar model: endpoint at"), "{text}");
    let v = json_of(&["shape3d", "--lengths", "0.25,0.25,0.25", "--free-axial-rotation"]);
    assert_eq!(v["free_axial_rotation"], true);
}

#[test]
fn three_views_are_drawn() {
    let dir = scratch("views");
    let (svg, png) = (dir.join("body.svg"), dir.join("body.png"));
    leech()
        .args(["shape3d", "--lengths", "0.3,0.25,0.28", "--svg"])
        .arg(&svg)
        .arg("--png")
        .arg(&png)
        .assert()
        .success();
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"));
    for label in ["front", "side", "top", "x (mm)", "y (mm)", "z (mm)", "-z (mm)", "tube 3", "endpoint plate"] {
        assert!(text.contains(label), "no {label:?} in the picture");
    }
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_exits_2_naming_the_field() {
    let dir = scratch("midpoint");
    let builtin = String::from_utf8(leech().arg("robot").output().unwrap().stdout).unwrap();
    let midpoint = dir.join("midpoint.toml");
    std::fs::write(&midpoint, builtin.replace("discretization = \"paper\"", "discretization = \"midpoint\"")).unwrap();
    let cases: [(&[&str], &[&str]); 7] = [
        (&["--lengths", "0.3,0.28"], &["--lengths", "three numbers"]),
        (&["--lengths", "0.3,-0.2,0.28"], &["L2", "-0.2"]),
        (&["--lengths", "0.3,0.28,nan"], &["L3", "NaN"]),
        (&["--lengths", "0.3,0.28,0.28", "--base-angle", "1e9"], &["--base-angle", "1e9"]),
        (&["--lengths", "0.3,0.28,0.28", "--time-limit", "0"], &["--time-limit"]),
        (&["--lengths", "0.3,0.28,0.28", "--png", "body.svg"], &["--png", ".png"]),
        (&["--lengths", "0.3,0.28,0.28", "--robot", midpoint.to_str().unwrap()], &["discretization", "midpoint"]),
    ];
    for (args, words) in cases {
        let e = rejected(&[&["shape3d"], args].concat());
        assert!(words.iter().all(|w| e.contains(w)), "{args:?}: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn failed_solve_exits_3_with_status() {
    not_converged(&["shape3d", "--lengths", "0.3,0.25,0.28"]);
}

/// This crate's test data.
fn data(name: &str) -> String {
    format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn cup_factor(v: &Value, cup: &str) -> f64 {
    v[cup]["safety_factor"].as_f64().unwrap_or_else(|| panic!("{cup}: {}", v[cup]))
}

#[test]
fn holds_report_their_cups_as_the_library_solves_them() {
    use leech::hold::{AsBuilt, Hold3, Pose3};
    use leech::stance3::place3::plate_frame_from_angles;
    let robot = Robot::builtin();
    let body = Body3::from_robot(&robot, [0.25, 0.25, 0.25]).unwrap();
    let solver = Solver::default();
    // The default: the rear cup holds, the front cup is free.
    let v = json_of(&["shape3d", "--lengths", "0.25,0.25,0.25"]);
    assert_eq!((v["hold"].as_str(), v["front_cup"].is_null()), (Some("rear"), true));
    let rear = stance3::solve(&robot, &body, Hold3::Rear(AsBuilt), &solver).unwrap().rear.unwrap();
    assert!((cup_factor(&v, "rear_cup") - rear.verdict.safety_factor).abs() < 1e-9);
    assert!(distance(&vector(&v["rear_cup"]["force_n"]), &rear.reaction.force_n) < 1e-9);
    // The front hold up a wall, turned 15 deg about the face's normal: out of the plane, no planar model.
    let args = ["shape3d", "--lengths", "0.25,0.25,0.25", "--hold", "front", "--front", "0,0.3,0,90,15"];
    let v = json_of(&args);
    let plate = plate_frame_from_angles(90f64.to_radians(), 15f64.to_radians(), 0.0);
    let held =
        stance3::solve(&robot, &body, Hold3::Front(Pose3 { point_m: [0.0, 0.3, 0.0], frame: plate }), &solver).unwrap();
    let front = held.front.unwrap();
    assert!(v["rear_cup"].is_null() && (cup_factor(&v, "front_cup") - front.verdict.safety_factor).abs() < 1e-9);
    assert!(distance(&vector(&v["front_cup"]["moment_nm"]), &front.reaction.moment_nm) < 1e-9);
    assert!(v["planar"].is_null() && v["planar_note"].as_str().unwrap().contains("out of the x-y plane"));
    // In the plane, the planar front hold beside it: the same endpoint and cup (b != c: to 1e-3).
    let v = json_of(&["shape3d", "--lengths", "0.25,0.25,0.25", "--hold", "front", "--front", "0,0.3,0,90"]);
    assert!(v["planar_difference_m"].as_f64().unwrap() < 1e-6, "{}", v["planar_difference_m"]);
    let flat = leech::stance::solve(
        &robot,
        [0.25, 0.25],
        leech::stance::Hold::Front(leech::stance::Pose::from_deg([0.0, 0.3], 90.0)),
        &solver,
    )
    .unwrap();
    let (rear_flat, front_flat) = flat.cups(&robot).unwrap();
    assert!(rear_flat.is_none());
    let sf = front_flat.unwrap().verdict.safety_factor;
    assert!((cup_factor(&v, "front_cup") - sf).abs() < 1e-3 * sf, "{} against {sf}", cup_factor(&v, "front_cup"));
    // The free joint swings the turned body back: the turn undoes the yaw.
    let v = json_of(&["shape3d", "--lengths", "0.25,0.25,0.25", "--hold", "front-pivot", "--front", "0,0.3,0,90,15"]);
    assert!((v["pivot_turn_rad"].as_f64().unwrap() + 15f64.to_radians()).abs() < 1e-6, "{}", v["pivot_turn_rad"]);
}

#[test]
fn scenes_give_contacts_and_bad_holds_exit_2_naming_the_flag() {
    // The built-in floor as prisms, against the planar body on it.
    let v = json_of(&["shape3d", "--lengths", "0.25,0.25,0.25", "--scene", "floor"]);
    assert_eq!(v["scene"], "floor");
    let contacts = v["contacts"].as_array().unwrap();
    assert!(!contacts.is_empty() && contacts.iter().all(|c| c["force_n"].as_f64().unwrap() > 0.0));
    assert!(contacts.iter().all(|c| (1..=3).contains(&c["tube"].as_u64().unwrap())));
    assert!(v["planar_difference_m"].as_f64().unwrap() < 2e-4, "{}", v["planar_difference_m"]);
    // The weight is carried by the cup and the contacts.
    let up = v["rear_cup"]["force_n"][1].as_f64().unwrap()
        + contacts.iter().map(|c| c["force_n"].as_f64().unwrap() * c["normal"][1].as_f64().unwrap()).sum::<f64>();
    let robot = Robot::builtin();
    // All of it: the unit, the payload and the three tubes whole (their
    // tails behind the clamps ride on the unit), the paper's 240 g.
    let full = robot.tube.full_length_m.unwrap();
    let mass = robot.driving_unit.mass_kg
        + robot.body.payload_kg
        + 3.0 * full * robot.tube.element_mass_kg / robot.tube.element_length_m;
    assert!((mass - 0.240).abs() < 1e-12, "the built-in robot weighs {mass} kg on board");
    assert!((up / robot.world.gravity_m_per_s2 - mass).abs() < 1e-6 * mass, "{up} N for {mass} kg");
    // A 3D scene file: a 3D scene has no planar counterpart.
    let v = json_of(&["shape3d", "--lengths", "0.25,0.25,0.25", "--scene", &data("scene3-step.toml")]);
    assert_eq!(v["scene"], "floor and block");
    assert!(v["planar_note"].as_str().unwrap().contains("3D"), "{}", v["planar_note"]);
    // Holds inside a solid, bad flags.
    let e = rejected(&["shape3d", "--lengths", "0.25,0.25,0.25", "--scene", "floor", "--base-angle", "0"]);
    assert!(e.starts_with("leech: --scene: got the rear hold at the origin") && e.contains("inside a solid"), "{e}");
    let e = rejected(&[
        "shape3d",
        "--lengths",
        "0.25,0.25,0.25",
        "--scene",
        "floor",
        "--hold",
        "front",
        "--front",
        "0.2,-0.1,0,0",
    ]);
    assert!(e.starts_with("leech: --front: got 0.2,-0.1,0,0,0,0, which puts the endpoint plate"), "{e}");
    let e = rejected(&["shape3d", "--lengths", "0.25,0.25,0.25", "--hold", "front"]);
    assert!(e.contains("--hold front: needs --front"), "{e}");
    let e = rejected(&["shape3d", "--lengths", "0.25,0.25,0.25", "--front", "0,0.3,0,90"]);
    assert!(e.starts_with("leech: --front: got 0,0.3,0,90,0,0 with the rear hold"), "{e}");
    // Both cups 0.30 m apart on a 0.25 m tube 1: the solve fails and says why.
    let out = leech()
        .args(["shape3d", "--lengths", "0.25,0.25,0.25", "--hold", "both", "--front", "0,0.3,0,90"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    let e = String::from_utf8(out.stderr).unwrap();
    assert!(e.contains("out of reach") && e.contains("0.2500 m"), "{e}");
    // Both cups on the built-in floor: the loop rests on it.
    let v = json_of(&[
        "shape3d",
        "--lengths",
        "0.3,0.28,0.28",
        "--scene",
        "floor",
        "--hold",
        "both",
        "--front",
        "0.15,0.032,0,0",
    ]);
    assert_eq!((v["status"].as_str(), v["hold"].as_str()), (Some("converged"), Some("both")), "{v}");
    let contacts = v["contacts"].as_array().unwrap();
    assert!(!contacts.is_empty() && contacts.iter().all(|c| c["force_n"].as_f64().unwrap() >= 0.0), "{v}");
    assert!(v["rear_cup"]["force_n"].is_array() && v["front_cup"]["force_n"].is_array(), "{v}");
    let e = rejected(&["shape3d", "--lengths", "0.25,0.25,0.25", "--hold", "front", "--front", "0,0.3,0,90,400"]);
    assert!(e.starts_with("leech: --front yaw (deg)") && e.contains("400"), "{e}");
    let e = rejected(&["shape3d", "--lengths", "0.25,0.25,0.25", "--front", "0,0.3,90"]);
    assert!(e.contains("--front") && e.contains("'0,0.3,90'"), "{e}");
    let e = rejected(&["shape3d", "--lengths", "0.25,0.25,0.25", "--scene", "floor", "--model", "constant-curvature"]);
    assert!(e.starts_with("leech: --scene, --hold, --front: only with --model chain"), "{e}");
}

#[test]
fn the_constant_curvature_model_is_the_librarys_and_has_three_views() {
    use leech::body3::ConstantCurvature3;
    let dir = scratch("cc");
    let svg = dir.join("cc.svg");
    let v = json_of(&[
        "shape3d",
        "--lengths",
        "0.25,0.26,0.24",
        "--model",
        "constant-curvature",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    let cc = ConstantCurvature3::new(&Robot::builtin(), [0.25, 0.26, 0.24]).unwrap();
    assert_eq!(v["model"], "constant-curvature");
    assert!(distance(&vector(&v["endpoint_m"]), &cc.endpoint()) < 1e-15);
    // The last point of each tube is its tip; tube 1's is the endpoint.
    assert!(distance(&vector(v["tubes"][0]["points_m"].as_array().unwrap().last().unwrap()), &cc.endpoint()) < 1e-12);
    assert!((v["bend_rad"].as_f64().unwrap() - cc.arc().bend).abs() < 1e-15);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(["front (seen from +z)", "side (seen from -x)", "top (seen from +y)"].iter().all(|t| text.contains(t)));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_held_picture_shows_the_three_views_the_scene_and_the_cups() {
    let dir = scratch("held");
    let svg = dir.join("held.svg");
    let out = leech()
        .args(["shape3d", "--lengths", "0.25,0.25,0.25", "--scene", "floor", "--svg", svg.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&svg).unwrap();
    for part in ["front (seen from +z)", "side (seen from -x)", "top (seen from +y)", "scene: floor", "rear cup: holds"]
    {
        assert!(text.contains(part), "{part}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
