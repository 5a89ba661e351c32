//! `leech chain --scene`: the single tube resting on a scene's solids.

use super::{json_of, leech, rejected};

const TUBE: [&str; 8] =
    ["chain", "--elements", "30", "--element-length", "0.01", "--element-mass", "0.001", "--shape-parameter"];

fn args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    TUBE.iter().copied().chain(["20"]).chain(extra.iter().copied()).collect()
}

#[test]
fn chain_on_a_floor_reports_contacts_and_the_clamp() {
    let v = json_of(&args(&["--base-angle", "90", "--scene", "floor", "--outer-diameter", "0.012"]));
    assert_eq!(v["status"], "converged");
    assert_eq!(v["scene"], "floor");
    let contacts = v["contacts"].as_array().unwrap();
    assert!(!contacts.is_empty());
    let weight = 30.0 * 0.001 * 9.81;
    let mut force = [v["clamp_force_n"][0].as_f64().unwrap(), v["clamp_force_n"][1].as_f64().unwrap()];
    for c in contacts {
        let keys: Vec<&String> = c.as_object().unwrap().keys().collect();
        // serde_json sorts the keys; no "chain" for the single tube.
        assert_eq!(keys, ["force_n", "fraction", "node", "normal", "point_m"]);
        // Resting one radius above the floor.
        assert!((c["point_m"][1].as_f64().unwrap() - 0.006).abs() < 1e-9, "{c}");
        let f = c["force_n"].as_f64().unwrap();
        force = [force[0] + f * c["normal"][0].as_f64().unwrap(), force[1] + f * c["normal"][1].as_f64().unwrap()];
    }
    assert!(force[0].abs() < 1e-9 * weight && (force[1] - weight).abs() < 1e-9 * weight, "{force:?}");
    assert!(v["clamp_moment_nm"].as_f64().is_some());
    assert!(v["penetration_m"].as_f64().unwrap() <= 1e-9);
    // The tube's own keys stay.
    for key in ["angles_rad", "points_m", "tip_m", "shape_parameter"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
}

#[test]
fn chain_without_a_scene_is_unchanged() {
    let v = json_of(&args(&[]));
    for key in ["contacts", "clamp_force_n", "clamp_moment_nm", "penetration_m", "scene"] {
        assert!(v.get(key).is_none(), "{key} without --scene");
    }
}

#[test]
fn chain_in_a_scene_draws_it() {
    let dir = std::env::temp_dir().join(format!("leech-cli-tube-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let svg = dir.join("tube.svg");
    leech().args(args(&["--base-angle", "90", "--scene", "floor", "--svg"])).arg(&svg).assert().success();
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("scene: floor") && text.contains("contact forces") && text.contains("clamp force"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_outer_diameters_and_scenes_exit_2() {
    for bad in ["0", "-0.01", "nan", "inf", "0.5"] {
        let e = rejected(&args(&["--scene", "floor", "--outer-diameter", bad]));
        assert!(e.contains("--outer-diameter") && e.contains("above 0") && e.contains("0.3 m"), "{e}");
    }
    // Only with a scene.
    let e = rejected(&args(&["--outer-diameter", "0.01"]));
    assert!(e.contains("--scene"), "{e}");
    let e = rejected(&args(&["--scene", "no-such-scene"]));
    assert!(e.contains("--scene") && e.contains("floor"), "{e}");
    // Straight into the wall.
    let e = rejected(&args(&["--scene", "wall"]));
    assert!(e.contains("--base-angle") && e.contains("solid"), "{e}");
}
