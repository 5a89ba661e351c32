//! `leech climb` and `leech scenario`; a climb's step replayed through `leech shape`.

use super::{json_of, leech, rejected, succeeds};
use serde_json::Value;

/// `[x, y, deg]` as `--rear`/`--front` take it, every digit kept.
fn pose_flag(v: &Value) -> String {
    let n: Vec<String> = v.as_array().unwrap().iter().map(|x| format!("{:?}", x.as_f64().unwrap())).collect();
    n.join(",")
}

#[test]
fn a_floor_crawl_is_reached_and_its_steps_replay_through_shape() {
    let dir = std::env::temp_dir().join(format!("leech-cli-climb-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, svg) = (dir.join("crawl.csv"), dir.join("crawl.svg"));
    let v = succeeds(
        leech().args(["climb", "--scenario", "crawl-floor", "--json", "--csv"]).arg(&csv).arg("--svg").arg(&svg),
    );
    assert_eq!(v["status"], "reached");
    assert_eq!(v["reason"], Value::Null);
    assert_eq!(v["scenario"], "crawl on the floor");
    for key in
        ["robot", "strides", "tube_travel_m", "duration_s", "min_safety_factor", "solves", "goal_m", "tolerance_m"]
    {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    let steps = v["steps"].as_array().unwrap();
    let strides = v["strides"].as_u64().unwrap() as usize;
    assert!(strides >= 1);
    assert_eq!(steps.len(), 1 + 6 * strides, "the start, then six phases a stride");
    assert_eq!(steps[0]["phase"], "start");
    for s in steps {
        for key in [
            "phase",
            "stride",
            "lengths_m",
            "hold",
            "rear",
            "front",
            "rear_cup_m",
            "front_cup_m",
            "endpoint_m",
            "driving_unit_m",
            "safety_factor",
            "snapped",
        ] {
            assert!(s.get(key).is_some(), "missing {key} in {s}");
        }
        let hold = s["hold"].as_str().unwrap();
        assert_eq!(s["rear"].is_null(), hold == "front", "{s}");
        assert_eq!(s["front"].is_null(), hold == "rear", "{s}");
        assert_eq!(s["safety_factor"]["rear"].is_null(), hold == "front", "{s}");
        assert_eq!(s["snapped"], false);
    }
    // The rear cup lands within the goal's tolerance.
    let last = steps.last().unwrap();
    let (x, y) = (last["rear_cup_m"][0].as_f64().unwrap(), last["rear_cup_m"][1].as_f64().unwrap());
    assert!((x - 0.5).hypot(y) <= v["tolerance_m"].as_f64().unwrap());
    // The CSV has a header and one row per step.
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("phase,stride,la_m,lb_m,hold,"), "{text}");
    assert_eq!(text.lines().count(), 1 + steps.len());
    // The animation: one frame per step, each shown in its turn.
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert_one_frame_per_step(&picture, steps.len());
    assert!(picture.contains("stride 7/7, release_front") || picture.contains(&format!("stride {strides}/{strides}")));
    assert!(picture.contains(">goal</text>"));
    std::fs::remove_dir_all(&dir).ok();

    // A step with both holds and one with the front hold alone, replayed.
    for phase in ["attach_front", "release_rear"] {
        let s = steps.iter().find(|s| s["phase"] == phase).unwrap();
        let lengths = format!("{:?},{:?}", s["lengths_m"][0].as_f64().unwrap(), s["lengths_m"][1].as_f64().unwrap());
        let mut args = vec!["shape", "--scene", "floor", "--hold", s["hold"].as_str().unwrap()];
        let (rear, front);
        if !s["rear"].is_null() {
            rear = pose_flag(&s["rear"]);
            args.extend(["--rear", &rear]);
        }
        if !s["front"].is_null() {
            front = pose_flag(&s["front"]);
            args.extend(["--front", &front]);
        }
        args.extend(["--lengths", &lengths, "--free-cups", "rest"]);
        let r = json_of(&args);
        for key in ["driving_unit_m", "endpoint_m"] {
            for i in 0..2 {
                let (a, b) = (r[key][i].as_f64().unwrap(), s[key][i].as_f64().unwrap());
                assert!((a - b).abs() <= 1e-9, "{phase} {key}[{i}]: replayed {a}, planned {b}");
            }
        }
    }
}

/// `svg` is a whole SVG document with `steps` frames, each animated.
fn assert_one_frame_per_step(svg: &str, steps: usize) {
    assert!(svg.starts_with("<svg") || svg.starts_with("<?xml"), "{}", &svg[..svg.len().min(200)]);
    assert!(svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("<g visibility=").count(), steps, "one frame per step");
    let animations = svg.matches(r#"<animate attributeName="visibility""#).count();
    assert_eq!(animations, if steps > 1 { steps } else { 0 });
    assert_eq!(svg.matches("<g visibility=\"visible\"").count(), 1, "the first frame shows without SMIL");
}

#[test]
fn a_climb_cut_short_still_draws_its_steps_and_an_unwritable_svg_is_one_line() {
    let dir = std::env::temp_dir().join(format!("leech-cli-climb-svg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let svg = dir.join("short.svg");
    // The deadline runs from the command's start, so how far a short limit
    // gets depends on the machine: longer limits until a plan is cut short
    // after its first steps (with none, nothing is drawn and no file made).
    let mut drawn = false;
    for limit in ["0.001", "0.01", "0.05", "0.2", "1"] {
        let args = ["climb", "--scenario", "crawl-floor", "--time-limit", limit, "--json", "--svg"];
        let out = leech().args(args).arg(&svg).output().unwrap();
        let v: Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
        if v["status"] == "reached" {
            break;
        }
        assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
        assert_eq!(v["status"], "stopped");
        let steps = v["steps"].as_array().unwrap().len();
        if steps == 0 {
            assert!(!svg.exists(), "an SVG without steps");
            continue;
        }
        assert_one_frame_per_step(&std::fs::read_to_string(&svg).unwrap(), steps);
        drawn = true;
        break;
    }
    assert!(drawn, "no time limit cut the climb short after some steps");
    let args = ["climb", "--scenario", "crawl-floor", "--time-limit", "0.001", "--json", "--svg"];

    // An unwritable path is bad input, found before the planning.
    let out = leech().args(args).arg(dir.join("no/such/dir/climb.svg")).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains("climb.svg"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_impossible_climb_exits_3_with_its_reason_in_the_json() {
    // A goal behind the robot: every stride lands ahead, none gets closer.
    let out = leech()
        .args(["climb", "--scene", "floor", "--start", "0,0,0", "--goal", "-0.5,0", "--json", "--time-limit", "20"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let blocking = v["reason"]["blocking"].as_str().unwrap();
    assert!(["reach", "cup_force", "collision", "snap", "time_limit"].contains(&blocking), "{blocking}");
    // Out of time is no verdict: the plan is then stopped.
    let status = if blocking == "time_limit" { "stopped" } else { "impossible" };
    assert_eq!(v["status"], status);
    assert!(v["reason"]["phase"].is_string() && v["reason"]["detail"].is_string());
    assert!(!v["steps"].as_array().unwrap().is_empty(), "the start at least");
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.starts_with(&format!("leech: climb {status}: ")), "{err}");
}

#[test]
fn bad_climbs_exit_2_with_one_line() {
    let e = rejected(&["climb", "--scenario", "moon"]);
    assert!(e.contains("--scenario: got 'moon'") && e.contains("crawl-floor"), "{e}");
    let e = rejected(&["climb", "--scene", "floor", "--start", "0,0", "--goal", "0.5,0"]);
    assert!(e.contains("--start") && e.contains("'0,0'"), "{e}");
    let e = rejected(&["climb", "--scene", "floor", "--start", "0,x,0", "--goal", "0.5,0"]);
    assert!(e.contains("--start"), "{e}");
    let e = rejected(&["climb", "--scene", "floor", "--start", "0,0.2,0", "--goal", "0.5,0"]);
    assert!(e.starts_with("leech: --start: got [0, 0.2, 0.0000]") && e.contains("flush"), "{e}");
    let e = rejected(&["climb", "--scene", "floor", "--start", "0,0,0", "--goal", "0.5,0", "--tolerance", "0"]);
    assert!(e.contains("--tolerance"), "{e}");
    let e = rejected(&["climb", "--scene", "floor", "--start", "0,0,0", "--goal", "0.3,-0.1"]);
    assert!(e.starts_with("leech: --goal: got [0.3, -0.1] (inside a solid") && e.contains("tolerance"), "{e}");
    let e = rejected(&["climb", "--scenario", "crawl-floor", "--scene", "floor"]);
    assert!(e.contains("--scene") || e.contains("--scenario"), "{e}");
    let e = rejected(&["climb"]);
    assert!(e.contains("--scenario"), "{e}");

    let dir = std::env::temp_dir().join(format!("leech-cli-bad-scenario-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = leech::stride::BUILTIN_SCENARIOS[0].toml.replace("tolerance_m = 0.03", "tolerance_m = 0.03\ncolour = 1");
    let file = dir.join("bad.toml");
    std::fs::write(&file, text).unwrap();
    let e = rejected(&["climb", "--scenario", file.to_str().unwrap()]);
    assert!(e.contains("bad.toml: line") && e.contains("unknown field `colour`"), "{e}");
    let e = rejected(&["scenario", "show", file.to_str().unwrap()]);
    assert!(e.contains("unknown field `colour`"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scenarios_are_listed_and_shown() {
    let out = leech().args(["scenario", "list"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let names = [
        "crawl-floor",
        "climb-wall-up",
        "climb-wall-down",
        "floor-to-wall",
        "wall-to-floor",
        "over-thin-wall",
        "wall-to-ceiling",
        "sideways-wall",
    ];
    assert_eq!(text.lines().count(), names.len(), "{text}");
    for (line, name) in text.lines().zip(names) {
        assert!(line.starts_with(name), "{line}");
    }
    let list = json_of(&["scenario", "list"]);
    assert_eq!(list["scenarios"].as_array().unwrap().len(), 8);
    let shown = leech().args(["scenario", "show", "climb-wall-down"]).output().unwrap();
    let text = String::from_utf8(shown.stdout).unwrap();
    assert!(text.starts_with('#') && text.contains("ESTIMATE"), "the file with its comments:\n{text}");
    let v = json_of(&["scenario", "show", "climb-wall-up"]);
    assert_eq!(v["start"]["heading_deg"].as_f64().unwrap(), 90.0);
    assert_eq!(v["goal"]["point_m"][1].as_f64().unwrap(), 0.5);
    assert_eq!(v["scene"]["name"], "wall");
    let e = rejected(&["scenario", "show", "moon"]);
    assert!(e.contains("scenario show: got 'moon'"), "{e}");
}

#[test]
fn free_cups_need_a_scene() {
    let e = rejected(&["shape", "--lengths", "0.2,0.2", "--free-cups", "rest"]);
    assert!(e.contains("--scene") || e.contains("--free-cups"), "{e}");
}

#[test]
fn a_sideways_climb_is_planned_with_the_3d_body() {
    let e = rejected(&["climb", "--scenario", "sideways"]);
    assert!(e.contains("sideways maneuver") && e.contains("3D") && e.contains("sideways-wall"), "{e}");
    let v = json_of(&["climb", "--scenario", "sideways-wall"]);
    assert_eq!(v["status"], "reached");
    let goal = v["goal_lateral_m"].as_f64().unwrap();
    assert!((v["lateral_m"].as_f64().unwrap() - goal).abs() <= v["tolerance_m"].as_f64().unwrap());
    let steps = v["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 1 + 6 * v["strides"].as_u64().unwrap() as usize);
    assert!(steps.iter().any(|s| s["hold"] == "front_pivot" && s["front_cup"]["verdict"]["holds"] == true));
    let e = rejected(&["climb", "--scenario", "sideways-wall", "--csv", "x.csv"]);
    assert!(e.contains("--csv") && e.contains("no table"), "{e}");
}

#[test]
fn a_sideways_plan_is_drawn_and_a_stopped_one_says_so() {
    let dir = std::env::temp_dir().join(format!("leech-cli-sideways-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let svg = dir.join("sideways.svg");
    let out = leech().args(["climb", "--scenario", "sideways-wall", "--svg", svg.to_str().unwrap()]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&svg).unwrap();
    for part in ["front (seen from +z)", "side (seen from -x)", "top (seen from +y)", "scene: wall", "front cup: holds"]
    {
        assert!(text.contains(part), "{part}");
    }
    let out =
        leech().args(["climb", "--scenario", "sideways-wall", "--time-limit", "0.001", "--json"]).output().unwrap();
    assert_eq!(out.status.code(), Some(3));
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(v["status"], "stopped");
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.starts_with("leech: sideways climb stopped: ") && err.contains("--time-limit"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
