//! Scenes: built-in files, one-line validation errors, and the geometric
//! queries against brute force on random convex and concave polygons.

use std::f64::consts::PI;

use leech::geom::{add_scaled, cross, dot, norm, sub, unit, Vec2};
use leech::prelude::*;
use leech::scene::{Candidate, Corner, Feature, Scene, Solid, BUILTIN_SCENES, MAX_SCENE_BYTES};
use proptest::prelude::*;

// ---------------------------------------------------------------- files

#[test]
fn builtins_parse_validate_and_round_trip() {
    let names: Vec<_> = Scene::builtin_names().map(|(name, _)| name).collect();
    assert_eq!(names, ["floor", "wall", "floor-to-wall", "step", "thin-wall", "ceiling"]);
    for builtin in BUILTIN_SCENES {
        let scene = Scene::builtin(builtin.name).unwrap();
        scene.validate().unwrap();
        assert!(builtin.toml.starts_with('#'), "{}: commented with its sources", builtin.name);
        assert!(!builtin.description.is_empty() && !builtin.description.contains('\n'));
        let text = scene.to_toml_string();
        assert_eq!(Scene::from_toml_str(&text, "again").unwrap(), scene, "{text}");
    }
    let thin = Scene::builtin("thin-wall").unwrap();
    let Solid::Polygon { points_m } = &thin.solids[1] else { panic!("the wall is a polygon") };
    let (width, height) = (points_m[1][0] - points_m[0][0], points_m[2][1]);
    assert!((width - 0.020).abs() < 1e-12 && (height - 0.25).abs() < 1e-12);
}

/// The thin-wall example from the module docs, edited by `replace`.
const TEXT: &str = "name = \"thin wall\"
[[half_plane]]
point_m = [0.0, 0.0]
normal = [0.0, 1.0]
[[polygon]]
points_m = [[0.30, -0.05], [0.32, -0.05], [0.32, 0.25], [0.30, 0.25]]
";

fn rejected(replace: &str, by: &str) -> String {
    assert!(TEXT.contains(replace), "test edits text that exists: {replace}");
    let e = Scene::from_toml_str(&TEXT.replace(replace, by), "wall.toml").expect_err(by).to_string();
    assert!(!e.contains('\n') && e.starts_with("wall.toml: "), "one line naming the file: {e}");
    e
}

fn has(e: &str, parts: &[&str]) {
    for part in parts {
        assert!(e.contains(part), "`{part}` missing from: {e}");
    }
}

#[test]
fn bad_numbers_name_field_and_value() {
    has(&rejected("[0.32, 0.25]", "[0.32, nan]"), &["polygon[0].points_m[2]", "[0.32, NaN]", "finite"]);
    has(&rejected("point_m = [0.0, 0.0]", "point_m = [-inf, 0.0]"), &["half_plane[0].point_m", "[-inf, 0]"]);
    has(&rejected("[0.30, 0.25]", "[0.30, 2000]"), &["polygon[0].points_m[3]", "[0.3, 2000]", "1000 m"]);
    has(&rejected("normal = [0.0, 1.0]", "normal = [0.0, 2.0]"), &["half_plane[0].normal", "length 2", "unit"]);
    has(&rejected("normal = [0.0, 1.0]", "normal = [0.6, 0.8000001]"), &["half_plane[0].normal", "length 1.00000"]);
    has(&rejected("normal = [0.0, 1.0]", "normal = [nan, 1.0]"), &["half_plane[0].normal", "NaN"]);
    assert!(Scene::from_toml_str(&TEXT.replace("[0.0, 1.0]", "[0.6, 0.8]"), "ok").is_ok());
}

#[test]
fn bad_polygons_name_field_and_value() {
    let square = "[[0.30, -0.05], [0.32, -0.05], [0.32, 0.25], [0.30, 0.25]]";
    has(&rejected(square, "[[0.30, -0.05], [0.32, -0.05]]"), &["polygon[0].points_m", "2 points", "3 to 1024"]);
    has(
        &rejected(square, "[[0.30, -0.05], [0.32, -0.05], [0.32, -0.05], [0.30, 0.25]]"),
        &["polygon[0].points_m[2]", "[0.32, -0.05]", "same as points_m[1]"],
    );
    has(
        &rejected(square, "[[0.30, -0.05], [0.32, -0.05], [0.32, 0.25], [0.30, -0.05]]"),
        &["polygon[0].points_m[3]", "same as points_m[0]"],
    );
    has(
        &rejected(square, "[[0.30, -0.05], [0.30, 0.25], [0.32, 0.25], [0.32, -0.05]]"),
        &["polygon[0].points_m", "clockwise", "counter-clockwise"],
    );
    // A bow tie: edge 0 (bottom-left to top-right) crosses edge 2.
    has(
        &rejected(square, "[[0.30, -0.05], [0.32, 0.25], [0.32, -0.05], [0.30, 0.25]]"),
        &["polygon[0].points_m", "edges 0 (points_m[0] to points_m[1]) and 2 (points_m[2] to points_m[3])", "simple"],
    );
    let many: Vec<String> = (0..1025).map(|i| format!("[{}, 0]", i as f64 * 1e-3)).collect();
    has(&rejected(square, &format!("[{}]", many.join(", "))), &["polygon[0].points_m", "1025 points"]);
}

#[test]
fn bad_files_are_one_line_errors() {
    has(&rejected("normal = [0.0, 1.0]", "normal = [0.0, 1.0]\ncolour = 1"), &["line 5", "unknown field `colour`"]);
    has(&rejected("name = \"thin wall\"", "name = \"thin wall\"\nsize = 2"), &["line 2", "unknown field `size`"]);
    has(&rejected("[[polygon]]", "[[polygons]]"), &["unknown field `polygons`"]);
    has(&rejected("name = \"thin wall\"\n", ""), &["missing field `name`"]);
    has(&rejected("normal = [0.0, 1.0]", "normal = \"up\""), &["line 4"]);
    has(&rejected("normal = [0.0, 1.0]", "normal = [0.0, 1.0, 0.0]"), &["half_plane[0].normal", "3 numbers", "[x, y]"]);
    has(&rejected("[0.32, 0.25]", "[0.32]"), &["polygon[0].points_m[2]", "1 number,"]);
    has(&rejected("[[polygon]]", "[[polygon]"), &["line 5"]);
    let zero = rejected(TEXT, "name = \"nothing\"");
    has(&zero, &["half_plane, polygon", "0 solids", "1 to 256"]);
    let table = "[[half_plane]]\npoint_m = [0.0, 0.0]\nnormal = [0.0, 1.0]\n";
    has(&rejected(TEXT, &format!("name = \"many\"\n{}", table.repeat(257))), &["257 solids"]);
    let huge = format!("{TEXT}#{}", " ".repeat(MAX_SCENE_BYTES));
    let e = Scene::from_toml_str(&huge, "huge.toml").unwrap_err().to_string();
    has(&e, &["huge.toml", &format!("{} bytes", huge.len()), "at most 1048576 bytes"]);
}

#[test]
fn scenes_built_in_code_are_checked_too() {
    let e = Scene::new("x", vec![Solid::HalfPlane { point_m: [0.0, 0.0], normal: [1.0, 1.0] }]).unwrap_err();
    has(&e.to_string(), &["half_plane[0].normal", "length 1.414"]);
    let floor = Solid::HalfPlane { point_m: [0.0, 0.0], normal: [0.0, 1.0] };
    let triangle = Solid::Polygon { points_m: vec![[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]] };
    // Fields count each kind: the clockwise triangle is polygon[0] though it is solid 1.
    let e = Scene::new("x", vec![floor.clone(), triangle]).unwrap_err().to_string();
    has(&e, &["polygon[0].points_m", "clockwise"]);
    assert!(Scene::new("x", vec![floor; 256]).is_ok());
    let e = Scene::builtin("moon").unwrap_err().to_string();
    has(&e, &["scene", "\"moon\"", "floor, wall, floor-to-wall, step, thin-wall, ceiling"]);
}

// ---------------------------------------------------------------- brute force

/// Distance from `p` to segment `a-b`, by the textbook formula.
fn segment_distance(a: Vec2, b: Vec2, p: Vec2) -> f64 {
    let d = sub(b, a);
    let t = (dot(sub(p, a), d) / dot(d, d)).clamp(0.0, 1.0);
    norm(sub(p, add_scaled(a, t, d)))
}

/// Inside by winding number: the angles the edges subtend at `p` add up to a
/// full turn inside and to zero outside (independent of the library's ray test).
fn winds(points: &[Vec2], p: Vec2) -> bool {
    let n = points.len();
    let turn: f64 = (0..n)
        .map(|i| {
            let (u, v) = (sub(points[i], p), sub(points[(i + 1) % n], p));
            cross(u, v).atan2(dot(u, v))
        })
        .sum();
    turn > PI
}

fn boundary_distance(points: &[Vec2], p: Vec2) -> f64 {
    let n = points.len();
    (0..n).map(|i| segment_distance(points[i], points[(i + 1) % n], p)).fold(f64::INFINITY, f64::min)
}

/// A star-shaped polygon around `center`: `n` vertices at increasing angles
/// (each turn slot jittered by less than half a slot, so neighbours are less
/// than half a turn apart and the polygon is simple and counter-clockwise),
/// at radii `scale * r`. Equal radii give a convex polygon.
fn star(center: Vec2, scale: f64, jitters: &[(f64, f64)], convex: bool) -> Vec<Vec2> {
    let n = jitters.len() as f64;
    jitters
        .iter()
        .enumerate()
        .map(|(i, &(jitter, r))| {
            let angle = 2.0 * PI * (i as f64 + 0.5 * jitter) / n;
            add_scaled(center, scale * if convex { 1.0 } else { r }, unit(angle))
        })
        .collect()
}

fn polygon_strategy() -> impl Strategy<Value = Vec<Vec2>> {
    (
        (-1.0..1.0f64, -1.0..1.0f64),
        0.02..0.5f64,
        prop::collection::vec((0.0..1.0f64, 0.15..1.0f64), 4..14),
        any::<bool>(),
    )
        .prop_map(|((cx, cy), scale, jitters, convex)| star([cx, cy], scale, &jitters, convex))
}

/// A scene of one polygon, sometimes with a floor cutting through it.
fn scene_strategy() -> impl Strategy<Value = (Scene, Vec<Vec2>)> {
    (polygon_strategy(), any::<bool>()).prop_map(|(points, floor)| {
        let mut solids = vec![Solid::Polygon { points_m: points.clone() }];
        if floor {
            let y = points.iter().map(|p| p[1]).sum::<f64>() / points.len() as f64;
            solids.push(Solid::HalfPlane { point_m: [0.0, y], normal: [0.6, 0.8] });
        }
        (Scene::new("random", solids).expect("star polygons are simple and counter-clockwise"), points)
    })
}

fn point_near(points: &[Vec2], f: (f64, f64)) -> Vec2 {
    let (lo, hi) = points.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), p| {
        ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
    });
    let pad = 0.5 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
    [lo[0] - pad + f.0 * (hi[0] - lo[0] + 2.0 * pad), lo[1] - pad + f.1 * (hi[1] - lo[1] + 2.0 * pad)]
}

/// Where a feature's closest point must lie: on the edge, at the vertex, or
/// on the half-plane's line.
fn on_feature(scene: &Scene, feature: Feature, c: Vec2) -> bool {
    match (feature, &scene.solids[feature_solid(feature)]) {
        (Feature::HalfPlane { .. }, Solid::HalfPlane { point_m, normal }) => {
            dot(sub(c, *point_m), *normal).abs() < 1e-12
        }
        (Feature::Edge { edge, .. }, Solid::Polygon { points_m }) => {
            segment_distance(points_m[edge], points_m[(edge + 1) % points_m.len()], c) < 1e-12
        }
        (Feature::Vertex { vertex, .. }, Solid::Polygon { points_m }) => norm(sub(c, points_m[vertex])) < 1e-12,
        _ => false,
    }
}

fn feature_solid(feature: Feature) -> usize {
    match feature {
        Feature::HalfPlane { solid } | Feature::Edge { solid, .. } | Feature::Vertex { solid, .. } => solid,
    }
}

/// The signed distance by brute force: min over all edges, sign by winding;
/// half-planes by their line; the union's value is the minimum.
fn brute_signed_distance(scene: &Scene, p: Vec2) -> f64 {
    scene
        .solids
        .iter()
        .map(|s| match s {
            Solid::HalfPlane { point_m, normal } => dot(sub(p, *point_m), *normal),
            Solid::Polygon { points_m } => {
                let d = boundary_distance(points_m, p);
                if winds(points_m, p) {
                    -d
                } else {
                    d
                }
            }
        })
        .fold(f64::INFINITY, f64::min)
}

fn check_candidate(scene: &Scene, p: Vec2, radius: f64, c: &Candidate) {
    assert!(c.distance.abs() <= radius, "{c:?}");
    assert!((norm(c.normal) - 1.0).abs() < 1e-12, "{c:?}");
    assert!(norm(sub(add_scaled(c.closest, c.distance, c.normal), p)) < 1e-12, "p = closest + distance normal: {c:?}");
    assert!(on_feature(scene, c.feature, c.closest), "{c:?}");
}

/// The features `features_near` must report, by their definition: local
/// minima of the distance along each polygon's boundary (edge insides and
/// vertices that are the closest point of both their edges) within the
/// radius, less back faces seen from outside; and half-planes in range.
fn expected_near(scene: &Scene, p: Vec2, radius: f64) -> Vec<Feature> {
    let mut expected = Vec::new();
    for (solid, s) in scene.solids.iter().enumerate() {
        match s {
            Solid::HalfPlane { point_m, normal } => {
                if dot(sub(p, *point_m), *normal).abs() <= radius {
                    expected.push(Feature::HalfPlane { solid });
                }
            }
            Solid::Polygon { points_m: pts } => {
                let n = pts.len();
                let inside = winds(pts, p);
                let param = |i: usize| {
                    let (a, b) = (pts[i % n], pts[(i + 1) % n]);
                    dot(sub(p, a), sub(b, a)) / dot(sub(b, a), sub(b, a))
                };
                for i in 0..n {
                    let (a, b) = (pts[i], pts[(i + 1) % n]);
                    let side = cross(sub(b, a), sub(p, a)) <= 0.0; // right of the edge: outward
                    if param(i) > 0.0 && param(i) < 1.0 && segment_distance(a, b, p) <= radius && (side || inside) {
                        expected.push(Feature::Edge { solid, edge: i });
                    }
                    let convex = cross(sub(pts[i], pts[(i + n - 1) % n]), sub(b, a)) >= 0.0;
                    let at_vertex = param(i) <= 0.0 && param(i + n - 1) >= 1.0;
                    if at_vertex && norm(sub(p, a)) <= radius && (convex || inside) {
                        expected.push(Feature::Vertex { solid, vertex: i });
                    }
                }
            }
        }
    }
    expected
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn signed_distance_matches_brute_force((scene, points) in scene_strategy(), f in (0.0..1.0f64, 0.0..1.0f64)) {
        let p = point_near(&points, f);
        let (d, feature, normal, closest) = scene.signed_distance(p);
        let brute = brute_signed_distance(&scene, p);
        prop_assert!((d - brute).abs() < 1e-12, "{d} vs {brute}");
        prop_assert!((norm(normal) - 1.0).abs() < 1e-12);
        prop_assert!(norm(sub(add_scaled(closest, d, normal), p)) < 1e-12);
        prop_assert!(on_feature(&scene, feature, closest));
        prop_assert_eq!(scene.inside(p), brute < 0.0);
        prop_assert_eq!(scene.is_free(p, 0.01), brute >= 0.01);
        // The surface direction is the normal turned a quarter turn clockwise.
        let (c, angle) = scene.surface_frame(p).unwrap();
        prop_assert!(c == closest && norm(sub(unit(angle + PI / 2.0), normal)) < 1e-12);
    }

    #[test]
    fn features_near_are_complete(
        (scene, points) in scene_strategy(),
        f in (0.0..1.0f64, 0.0..1.0f64),
        radius in 0.0..0.3f64,
    ) {
        let p = point_near(&points, f);
        let mut out = vec![Candidate { feature: Feature::HalfPlane { solid: 9 }, distance: 0.0, closest: p, normal: p }];
        scene.features_near(p, radius, &mut out);
        for c in &out {
            check_candidate(&scene, p, radius, c);
        }
        let found: Vec<Feature> = out.iter().map(|c| c.feature).collect();
        prop_assert_eq!(&found, &expected_near(&scene, p, radius));
        // The closest surface point is always among them when in range.
        let (d, ..) = scene.signed_distance(p);
        if d.abs() <= radius {
            prop_assert!(out.iter().any(|c| (c.distance - d).abs() < 1e-12), "{d} not in {out:?}");
        }
    }

    #[test]
    fn corners_are_convex_and_point_out(points in polygon_strategy()) {
        let scene = Scene::new("random", vec![Solid::Polygon { points_m: points.clone() }]).unwrap();
        let corners: Vec<Corner> = scene.convex_corners().collect();
        prop_assert!(!corners.is_empty());
        let n = points.len();
        let convex_count = (0..n)
            .filter(|&i| cross(sub(points[i], points[(i + n - 1) % n]), sub(points[(i + 1) % n], points[i])) > 0.0)
            .count();
        prop_assert_eq!(corners.len(), convex_count);
        for c in &corners {
            prop_assert!(c.interior_angle_rad > 0.0 && c.interior_angle_rad < PI);
            let eps = 1e-6;
            prop_assert!(!scene.inside(add_scaled(c.point, eps, c.bisector)));
            prop_assert!(scene.inside(add_scaled(c.point, -eps, c.bisector)));
        }
    }

    #[test]
    fn segment_corner_distance_matches_sampling(
        a in (-1.0..1.0f64, -1.0..1.0f64),
        b in (-1.0..1.0f64, -1.0..1.0f64),
        q in (-1.0..1.0f64, -1.0..1.0f64),
    ) {
        let (a, b) = ([a.0, a.1], [b.0, b.1]);
        let corner = Corner { solid: 0, vertex: 0, point: [q.0, q.1], bisector: [0.0, 1.0], interior_angle_rad: 1.0 };
        let (d, s, normal) = Scene::segment_corner_distance(a, b, &corner);
        let samples = 4000;
        let (best_s, best_d) = (0..=samples)
            .map(|k| {
                let t = k as f64 / samples as f64;
                (t, norm(sub(add_scaled(a, t, sub(b, a)), corner.point)))
            })
            .fold((0.0, f64::INFINITY), |x, y| if y.1 < x.1 { y } else { x });
        let step = norm(sub(b, a)) / samples as f64;
        prop_assert!(d <= best_d + 1e-12 && d >= best_d - step, "{d} vs sampled {best_d}");
        prop_assert!((0.0..=1.0).contains(&s));
        // The sampled minimizer is within a step of s unless the distance is flat there.
        prop_assert!((s - best_s).abs() * norm(sub(b, a)) <= 2.0 * step + (2.0 * step * d).sqrt() + 1e-12);
        prop_assert!((norm(normal) - 1.0).abs() < 1e-12);
        prop_assert!(norm(sub(add_scaled(corner.point, d, normal), add_scaled(a, s, sub(b, a)))) < 1e-12);
    }
}

#[test]
fn a_robot_base_stands_on_each_builtin() {
    // Every scene has its rear cup spot at the origin, flat on one surface,
    // facing the way the module docs promise.
    let robot = Robot::builtin();
    for (name, angle) in
        [("floor", 0.0), ("wall", 90.0), ("floor-to-wall", 0.0), ("step", 0.0), ("thin-wall", 0.0), ("ceiling", 90.0)]
    {
        let scene = Scene::builtin(name).unwrap();
        let (c, a) = scene.surface_frame([0.0, 0.0]).unwrap();
        assert!(norm(c) < 1e-15 && (a - f64::to_radians(angle)).abs() < 1e-15, "{name}: {a}");
        assert!(scene.flat_on_one_edge(c, a, 0.025, 1e-6, 1e-6), "{name}");
        assert!(scene.is_free(add_scaled(c, robot.body.base_spacing_m, unit(a + PI / 2.0)), 0.0));
    }
}

/// Names go into titles, SVG text and one-line messages: control characters are refused.
#[test]
fn a_name_with_control_characters_is_refused() {
    let toml = "name = \"a\\u0001b\"\n[[half_plane]]\npoint_m = [0.0, 0.0]\nnormal = [0.0, 1.0]\n";
    let e = leech::scene::Scene::from_toml_str(toml, "s.toml").unwrap_err().to_string();
    assert!(e.starts_with("s.toml: name: got 'a\\u{1}b'"), "{e}");
    assert!(leech::error::printable("name", "LEeCH (estimated parameters)").is_ok());
    assert!(leech::error::printable("name", &"x".repeat(201)).is_err());
}
