//! `leech shape` with holds and scenes, and `leech scene`.

use super::{json_of, leech, rejected, succeeds};
use serde_json::Value;

fn pair(v: &Value) -> [f64; 2] {
    [v[0].as_f64().unwrap(), v[1].as_f64().unwrap()]
}

/// The holds' forces and the contacts' together carry the weight.
fn assert_balanced(v: &Value) {
    let weight = v["weight_n"].as_f64().unwrap();
    let mut sum = [0.0, 0.0];
    for hold in v["holds"].as_object().unwrap().values() {
        let f = pair(&hold["force_n"]);
        sum = [sum[0] + f[0], sum[1] + f[1]];
    }
    for c in v["contacts"].as_array().unwrap() {
        let (n, f) = (pair(&c["normal"]), c["force_n"].as_f64().unwrap());
        sum = [sum[0] + f * n[0], sum[1] + f * n[1]];
    }
    let error = sum[0].hypot(sum[1] - weight);
    assert!(error <= 1e-9 * weight, "forces {sum:?} against the weight {weight} N: off by {error:e} N");
}

/// The top-level keys of pretty JSON, in the order printed.
fn key_order(text: &str) -> Vec<String> {
    text.lines().filter_map(|l| l.strip_prefix("  \"")).map(|l| l[..l.find('"').unwrap()].to_string()).collect()
}

#[test]
fn default_shape_keeps_its_keys_first_and_adds_the_rear_hold() {
    let out = leech().args(["shape", "--lengths", "0.25,0.20", "--json"]).output().unwrap();
    assert!(out.status.success() && out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let before = "model status stable iterations residual steps events robot lengths_m links shape_parameter \
                  endpoint_m endpoint_angle_rad energy_j chains";
    let added = "driving_unit_m driving_unit_angle_rad holds contacts hose_stops rear_cup_m front_cup_m penetration_m \
                 weight_n hold scene centre_of_mass_m";
    assert_eq!(key_order(&text).join(" "), format!("{before} {added}"));
    let v: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(pair(&v["driving_unit_m"]), [0.0, 0.0]);
    assert!((v["driving_unit_angle_rad"].as_f64().unwrap() - 90f64.to_radians()).abs() < 1e-15);
    let holds = v["holds"].as_object().unwrap();
    assert_eq!(holds.keys().collect::<Vec<_>>(), ["rear"]);
    let rear = &holds["rear"];
    for key in ["force_n", "moment_nm", "safety_factor", "holds", "cup_m", "verdict"] {
        assert!(rear.get(key).is_some(), "missing holds.rear.{key}");
    }
    assert_eq!(rear["cup_m"], v["rear_cup_m"]);
    assert_eq!(v["contacts"].as_array().unwrap().len(), 0);
    assert_eq!(v["penetration_m"], 0.0);
    assert_balanced(&v);
    // --rear at the origin and the base angle is the default, to the byte.
    let same = leech().args(["shape", "--lengths", "0.25,0.20", "--json", "--rear", "0,0,90"]).output().unwrap();
    assert_eq!(String::from_utf8(same.stdout).unwrap(), text);
}

#[test]
fn front_and_both_holds_balance_the_weight() {
    let v = json_of(&["shape", "--lengths", "0.25,0.2", "--hold", "front", "--front", "0.1,0.2,0"]);
    assert_eq!(v["hold"], "front");
    let end = pair(&v["endpoint_m"]);
    assert!((end[0] - 0.1).abs() < 1e-9 && (end[1] - 0.2).abs() < 1e-9, "{end:?}");
    assert_eq!(v["holds"].as_object().unwrap().keys().collect::<Vec<_>>(), ["front"]);
    assert_eq!(v["endpoint_m"], v["chains"]["a"]["points_m"].as_array().unwrap().last().unwrap().clone());
    assert_balanced(&v);
    let v = json_of(&["shape", "--lengths", "0.25,0.2", "--hold", "both", "--front", "0.139,0.16,20"]);
    assert_eq!(v["holds"].as_object().unwrap().keys().collect::<Vec<_>>(), ["front", "rear"]);
    assert!((v["endpoint_angle_rad"].as_f64().unwrap() - 20f64.to_radians()).abs() < 1e-9);
    assert_balanced(&v);
}

#[test]
fn a_scene_places_the_robot_at_its_start() {
    // The wall's [start]: the rear cup on the wall at the origin, climbing up.
    let v = json_of(&["shape", "--lengths", "0.25,0.2", "--scene", "wall"]);
    let cup = pair(&v["rear_cup_m"]);
    assert!(cup[0].abs() < 1e-12 && cup[1].abs() < 1e-12, "the rear cup's face at the origin: {cup:?}");
    assert!((v["driving_unit_angle_rad"].as_f64().unwrap() - 90f64.to_radians()).abs() < 1e-12);
    assert!(pair(&v["driving_unit_m"])[0] < 0.0, "the driving unit in free space, off the wall");
    assert_balanced(&v);
}

#[test]
fn a_floor_carries_the_tubes_it_touches() {
    let v = json_of(&["shape", "--lengths", "0.25,0.2", "--scene", "floor"]);
    assert_eq!(v["scene"], "floor");
    let cup = pair(&v["rear_cup_m"]);
    assert!(cup[0].abs() < 1e-12 && cup[1].abs() < 1e-12, "the rear cup's face on the floor: {cup:?}");
    let contacts = v["contacts"].as_array().unwrap();
    assert!(!contacts.is_empty());
    for c in contacts {
        assert!(c["force_n"].as_f64().unwrap() >= 0.0, "{c}");
        assert!(c["chain"] == "a" || c["chain"] == "b");
    }
    assert!(v["penetration_m"].as_f64().unwrap() <= 1e-9);
    assert_balanced(&v);
}

#[test]
fn scenes_are_listed_and_shown() {
    let out = leech().args(["scene", "list"]).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    for name in ["floor", "wall", "floor-to-wall", "step", "thin-wall", "ceiling"] {
        assert!(text.lines().any(|l| l.starts_with(name)), "{name} in\n{text}");
    }
    let list = json_of(&["scene", "list"]);
    assert_eq!(list["scenes"].as_array().unwrap().len(), 6);
    let shown = leech().args(["scene", "show", "step"]).output().unwrap();
    let toml = String::from_utf8(shown.stdout).unwrap();
    assert!(toml.contains("ESTIMATE") && toml.contains("[[polygon]]"), "{toml}");
    let v = json_of(&["scene", "show", "floor"]);
    assert_eq!(v["half_plane"][0]["normal"], serde_json::json!([0.0, 1.0]));
    assert_eq!(v["polygon"].as_array().unwrap().len(), 0);
    // A file is checked and written back as a scene file.
    let dir = std::env::temp_dir().join(format!("leech-cli-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("box.toml");
    std::fs::write(&path, "name = \"box\"\n[[polygon]]\npoints_m = [[0.1, 0], [0.2, 0], [0.2, 0.1]]\n").unwrap();
    let v = succeeds(leech().args(["scene", "show", "--json"]).arg(&path));
    assert_eq!(v["polygon"][0]["points_m"][2], serde_json::json!([0.2, 0.1]));
    let out = leech().args(["scene", "show"]).arg(&path).output().unwrap();
    assert!(String::from_utf8(out.stdout).unwrap().contains("points_m = [[0.1, 0.0]"));
    let e = rejected(&["scene", "show", "cliff"]);
    assert!(e.contains("cliff") && e.contains("thin-wall"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_holds_and_scenes_exit_2_naming_the_flag() {
    let shape = |extra: &[&str]| {
        let mut args = vec!["shape", "--lengths", "0.25,0.2"];
        args.extend(extra);
        rejected(&args)
    };
    for (extra, flag) in [
        (&["--hold", "front"][..], "--hold front"),
        (&["--hold", "both"], "--hold both"),
        (&["--front", "0.1,0.2,0"], "--front"),
        (&["--hold", "front", "--front", "0.1,0.2,0", "--rear", "0,0,90"], "--rear"),
        (&["--rear", "nan,0,0"], "--rear x"),
        (&["--rear", "0,0"], "--rear"),
        (&["--hold", "front", "--front", "0,inf,0"], "--front y"),
        (&["--hold", "front", "--front", "0,0.1,1e9"], "--front angle"),
        (&["--rear", "0,0,0", "--base-angle", "90"], "--rear"),
        (&["--scene", "cliff"], "--scene"),
        (&["--scene", "wall", "--rear", "0,0,90"], "--rear"),
        (&["--scene", "wall", "--rear", "-0.047,0,90", "--hold", "both", "--front", "0.2,0.1,90"], "--front"),
        (&["--scene", "floor", "--model", "both"], "--scene"),
        (&["--scene", "floor", "--rear", "0,0.047,0", "--repeat", "3"], "--repeat"),
    ] {
        let e = shape(extra);
        assert!(e.contains(flag), "{extra:?}: {e}");
    }
    let dir = std::env::temp_dir().join(format!("leech-cli-bad-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (broken, big) = (dir.join("broken.toml"), dir.join("big.toml"));
    std::fs::write(&broken, "name = \"x\"\n[[half_plane]]\npoint_m = [0, 0]\nnormal = [0, 2]\n").unwrap();
    std::fs::write(&big, " ".repeat(leech::scene::MAX_SCENE_BYTES + 1)).unwrap();
    let e = shape(&["--scene", broken.to_str().unwrap()]);
    assert!(e.contains("broken.toml") && e.contains("normal"), "{e}");
    let e = shape(&["--scene", big.to_str().unwrap()]);
    assert!(e.contains("--scene") && e.contains("larger than 1 MiB"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_front_hold_out_of_reach_exits_3_with_the_residual() {
    let out = leech()
        .args(["shape", "--lengths", "0.25,0.2", "--hold", "both", "--front", "1,1,0", "--json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["status"], "not_converged");
    assert!(v["residual"].as_f64().unwrap() > 0.0);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("residual") && err.contains("out of reach"), "{err}");
}

#[test]
fn a_picture_with_a_scene_draws_its_solids() {
    let dir = std::env::temp_dir().join(format!("leech-cli-scene-svg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let svg = dir.join("floor.svg");
    leech()
        .args(["shape", "--lengths", "0.25,0.2", "--scene", "floor", "--rear", "0,0.047,0", "--svg"])
        .arg(&svg)
        .assert()
        .success();
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("<polygon") && text.contains("scene: floor"), "solids drawn");
    for label in ["rear cup: holds", "front cup (free)", "hold reactions", "contact forces"] {
        assert!(text.contains(label), "missing {label}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_front_hold_out_of_reach_on_a_floor_says_so() {
    let args = ["shape", "--lengths", "0.3,0.28", "--scene", "floor", "--hold", "both", "--front", "0.6,0.032,0"];
    let out = leech().args(args).output().unwrap();
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("out of reach") && err.contains("residual"), "{err}");
}
