//! `leech shape3d`: the three-tube body in 3D as a user meets it, against
//! the library, the planar `leech shape`, and its mirror image.

use leech::body3::{planar, Body3};
use leech::prelude::*;
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
