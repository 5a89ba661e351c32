//! The three-tube body in 3D: three orthographic views side by side at one
//! scale (front: x-y seen from +z; side: z-y seen from -x; top: x against
//! -z, seen from +y), with a scene's solids and the cups.
//!
//! A solid is drawn as its projection along the view's depth, clipped to the
//! body's surroundings: a half-space whose normal lies in the page is a
//! half-plane, one tilted out of it covers the whole view (it lies behind
//! or in front of everything); a box is the convex hull of its projected
//! corners; a prism (a planar polygon extruded along z) is its polygon in
//! the front view and the band it spans in the others. Each cup is the rim
//! of its face (a circle of its diameter, seen as an ellipse), coloured by
//! its verdict as in [`crate::stance`].

use leech::body3::{Body3, Frames};
use leech::geom::Vec2;
use leech::geom3::{cross, dot, Vec3};
use leech::robot::Robot;
use leech::scene::{Scene3, Solid3, MAX_COORDINATE_M};
use leech::stance3::place3::front_cup_centre;
use leech::stance3::{CupState3, Held3};
use leech::stride::{SidewaysPlan, SidewaysScenario};

use crate::figure::{Axes, Figure, SeriesStyle, PALETTE};
use crate::stance::{bounds, clip, verdict, MARGIN, MIN_MARGIN_M, SOLID};

const GREY: (u8, u8, u8) = (90, 90, 90);

/// The three tubes' colours in the 3D pictures: tube 1 as chain A.
const TUBES: [(u8, u8, u8); 3] = [PALETTE[0], PALETTE[1], PALETTE[3]];

/// Each panel's size (pixels).
const PANEL: (u32, u32) = (520, 560);

/// Points on a cup's rim.
const RIM_POINTS: usize = 24;

/// One view: its caption, axis titles, and the page's axes in the world
/// (across and up; the depth is their cross product, towards the viewer).
struct View {
    title: &'static str,
    x_label: &'static str,
    y_label: &'static str,
    across: Vec3,
    up: Vec3,
}

const VIEWS: [View; 3] = [
    View {
        title: "front (seen from +z)",
        x_label: "x (mm)",
        y_label: "y (mm)",
        across: [1.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
    },
    View {
        title: "side (seen from -x)",
        x_label: "z (mm)",
        y_label: "y (mm)",
        across: [0.0, 0.0, 1.0],
        up: [0.0, 1.0, 0.0],
    },
    View {
        title: "top (seen from +y)",
        x_label: "x (mm)",
        y_label: "-z (mm)",
        across: [1.0, 0.0, 0.0],
        up: [0.0, 0.0, -1.0],
    },
];

impl View {
    fn project(&self, p: Vec3) -> Vec2 {
        [dot(p, self.across), dot(p, self.up)]
    }

    fn flat(&self, points: &[Vec3]) -> Vec<Vec2> {
        points.iter().map(|p| self.project(*p)).collect()
    }
}

/// A body drawn in the views: its tubes' points from root to tip (m).
pub struct Tubes(pub [Vec<Vec3>; 3]);

impl Tubes {
    /// The tubes of `body` at `frames`.
    pub fn of(body: &Body3, frames: &Frames) -> Tubes {
        Tubes([0, 1, 2].map(|i| body.points(frames, i)))
    }
}

/// A cup's face to mark: its centre (m), the surface's outward normal, the
/// cup's diameter (m) and its verdict when it holds.
struct CupMark<'a> {
    name: &'static str,
    centre: Vec3,
    normal: Vec3,
    diameter: f64,
    holding: Option<&'a CupState3>,
}

/// The views of `bodies` under `title`, `scene`'s solids (if any) behind
/// them and `cups` over them (a holding cup below `min_safety_factor` in
/// its own colour); gravity's arrow in the two views where it lies in the
/// page when `gravity`. The legend (tubes, triangles, cups, scene) is in the
/// front view.
fn views(
    title: String,
    bodies: &[Tubes],
    scene: Option<&Scene3>,
    cups: &[CupMark],
    gravity: bool,
    min_safety_factor: f64,
) -> Figure {
    let panels = VIEWS
        .iter()
        .enumerate()
        .map(|(v, view)| {
            let mut fig = Figure::new(view.title);
            fig.axes = Axes { scale: 1e3, x_label: view.x_label.into(), y_label: view.y_label.into() };
            let label = |text: String| if v == 0 { text } else { String::new() };
            let rims: Vec<Vec<Vec3>> = cups.iter().map(rim).collect();
            if let Some(scene) = scene {
                let mut seen: Vec<Vec2> =
                    bodies.iter().flat_map(|b| b.0.iter().flatten()).map(|p| view.project(*p)).collect();
                seen.extend(rims.iter().flatten().map(|p| view.project(*p)));
                solids(&mut fig, view, scene, bounds(&seen), v == 0);
            }
            for (k, body) in bodies.iter().enumerate() {
                body_series(&mut fig, view, body, v == 0 && k == 0);
            }
            // Overlaid steps: each cup's name once in the legend, with its first verdict.
            let mut named = Vec::new();
            for (cup, points) in cups.iter().zip(&rims) {
                let (text, color) = verdict(cup.name, cup.holding.map(|c| &c.verdict), min_safety_factor);
                let text = if named.contains(&cup.name) { String::new() } else { label(text) };
                named.push(cup.name);
                fig.push(text, view.flat(points), SeriesStyle::Thick, color);
            }
            fig.gravity_arrow = gravity && v < 2;
            fig
        })
        .collect();
    Figure::row(title, panels, PANEL)
}

/// One body's series: the driving unit's triangle (the roots), the tubes,
/// the plate's triangle (the tips), labelled when `legend`.
fn body_series(fig: &mut Figure, view: &View, tubes: &Tubes, legend: bool) {
    let label = |text: &str| if legend { text.to_string() } else { String::new() };
    // Each triangle's edges one by one: a thick line folding back on itself
    // (a triangle seen edge-on) would draw a spike at its mitred corner.
    let triangle = |fig: &mut Figure, name: &str, corners: [Vec3; 3], color| {
        for k in 0..3 {
            let edge = view.flat(&[corners[k], corners[(k + 1) % 3]]);
            fig.push(if k == 0 { label(name) } else { String::new() }, edge, SeriesStyle::Thick, color);
        }
    };
    let end =
        |first: bool| tubes.0.each_ref().map(|t| if first { t[0] } else { *t.last().expect("a tube has its root") });
    triangle(fig, "driving unit", end(true), GREY);
    for (i, (tube, color)) in tubes.0.iter().zip(TUBES).enumerate() {
        fig.push(label(&format!("tube {}", i + 1)), view.flat(tube), SeriesStyle::LineAndDots, color);
    }
    triangle(fig, "endpoint plate", end(false), PALETTE[2]);
}

/// The rim of a cup's face: a circle of its diameter about its normal.
fn rim(cup: &CupMark) -> Vec<Vec3> {
    let n = cup.normal;
    // Any direction not along n, then two across it.
    let other = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let a = unit(cross(n, other));
    let b = cross(n, a);
    let r = 0.5 * cup.diameter;
    (0..=RIM_POINTS)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / RIM_POINTS as f64;
            [0, 1, 2].map(|c| cup.centre[c] + r * (t.cos() * a[c] + t.sin() * b[c]))
        })
        .collect()
}

fn unit(v: Vec3) -> Vec3 {
    let l = dot(v, v).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

/// The scene's solids projected on `view` and clipped to the box `(lo, hi)`
/// (the body's surroundings) plus a margin, as filled polygons.
fn solids(fig: &mut Figure, view: &View, scene: &Scene3, (lo, hi): (Vec2, Vec2), legend: bool) {
    let margin = (MARGIN * (hi[0] - lo[0]).max(hi[1] - lo[1])).max(MIN_MARGIN_M);
    let (x0, y0, x1, y1) = (lo[0] - margin, lo[1] - margin, hi[0] + margin, hi[1] + margin);
    let rect = vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
    let sides = [([x0, y0], [0.0, -1.0]), ([x1, y0], [1.0, 0.0]), ([x1, y1], [0.0, 1.0]), ([x0, y1], [-1.0, 0.0])];
    let within = |poly: Vec<Vec2>| sides.iter().fold(poly, |poly, (point, outward)| clip(&poly, *point, *outward));
    let mut label = if legend { format!("scene: {}", scene.name) } else { String::new() };
    let depth = cross(view.across, view.up);
    for solid in &scene.solids {
        let outline = match solid {
            Solid3::HalfSpace { point_m, normal } => {
                // Tilted out of the page: the half-space covers the whole view.
                if dot(*normal, depth).abs() > 1e-9 {
                    rect.clone()
                } else {
                    let n = view.project(*normal);
                    let l = n[0].hypot(n[1]);
                    clip(&rect, view.project(*point_m), [n[0] / l, n[1] / l])
                }
            }
            Solid3::Box { centre_m, half_extents_m, frame } => {
                let corners: Vec<Vec2> = (0..8)
                    .map(|k| {
                        let s = [0, 1, 2].map(|a| if k >> a & 1 == 1 { half_extents_m[a] } else { -half_extents_m[a] });
                        let p = [0, 1, 2].map(|r| centre_m[r] + dot(frame[r], s));
                        view.project(p)
                    })
                    .collect();
                within(hull(corners))
            }
            Solid3::Prism { section } => {
                let polygon: Vec<Vec2> = section
                    .solids
                    .iter()
                    .flat_map(|s| match s {
                        leech::scene::Solid::Polygon { points_m } => points_m.clone(),
                        leech::scene::Solid::HalfPlane { .. } => Vec::new(),
                    })
                    .collect();
                if dot(depth, [0.0, 0.0, 1.0]).abs() > 1.0 - 1e-9 {
                    within(polygon.iter().map(|p| view.project([p[0], p[1], 0.0])).collect())
                } else {
                    // Extruded along z, which lies in the page: the band it spans.
                    let far = MAX_COORDINATE_M;
                    let ends = polygon.iter().flat_map(|p| [[p[0], p[1], -far], [p[0], p[1], far]]);
                    within(hull(ends.map(|p| view.project(p)).collect()))
                }
            }
        };
        if outline.len() >= 3 {
            fig.push(std::mem::take(&mut label), outline, SeriesStyle::Area, SOLID);
        }
    }
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain).
fn hull(mut points: Vec<Vec2>) -> Vec<Vec2> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let turn = |o: Vec2, a: Vec2, b: Vec2| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut out: Vec<Vec2> = Vec::with_capacity(2 * points.len());
    for pass in [points.clone(), points.into_iter().rev().collect()] {
        let start = out.len();
        for p in pass {
            while out.len() >= start + 2 && turn(out[out.len() - 2], out[out.len() - 1], p) <= 0.0 {
                out.pop();
            }
            out.push(p);
        }
        // Each chain's last point is the next one's first.
        out.pop();
    }
    out
}

/// The cups of `held` (a body of `robot`): each face where it is, coloured
/// by its verdict when it holds, grey when free.
fn cups<'a>(robot: &Robot, held: &'a Held3) -> [CupMark<'a>; 2] {
    let (body, frames) = (&held.body, &held.equilibrium.frames);
    let base = body.base_frame();
    let plate = body.plate_frame(frames);
    let diameter = robot.cup.diameter_m;
    [
        CupMark {
            name: "rear cup",
            centre: body.rear_cup_centre(robot),
            normal: [base[0][1], base[1][1], base[2][1]],
            diameter,
            holding: held.rear.as_ref(),
        },
        CupMark {
            name: "front cup",
            centre: front_cup_centre(robot, body.endpoint(frames), &plate),
            normal: [plate[0][1], plate[1][1], plate[2][1]],
            diameter,
            holding: held.front.as_ref(),
        },
    ]
}

/// `held` (a body of `robot`) in `scene` if any: the three views with the
/// solids and both cups (coloured by their verdicts when they hold).
pub fn held3_figure(robot: &Robot, held: &Held3, scene: Option<&Scene3>) -> Figure {
    let body = &held.body;
    let [l1, l2, l3] = [0, 1, 2].map(|i| body.tube(i).tube_length() * 1e3);
    let hold = held.hold.name().replace('_', " ");
    let title = format!("{}: L1 = {l1:.1} mm, L2 = {l2:.1} mm, L3 = {l3:.1} mm, {hold} hold", robot.name);
    let tubes = Tubes::of(body, &held.equilibrium.frames);
    views(title, &[tubes], scene, &cups(robot, held), body.gravity() > 0.0, robot.cup.min_safety_factor)
}

/// The constant-curvature model's tubes (points from root to tip, m) in
/// the three views; no gravity (the model has none).
pub fn arcs3_figure(robot: &str, tubes: Tubes) -> Figure {
    let lengths: Vec<String> = tubes.0.iter().map(|t| format!("{:.1}", arc_length(t) * 1e3)).collect();
    let title = format!("{robot}, constant curvature: L1, L2, L3 = {} mm", lengths.join(", "));
    views(title, &[tubes], None, &[], false, 1.0)
}

/// The length of a polyline (m).
fn arc_length(points: &[Vec3]) -> f64 {
    points.windows(2).map(|w| dot(sub(w[1], w[0]), sub(w[1], w[0])).sqrt()).sum()
}

fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// How thick the wall of a sideways scenario is drawn (m): it is solid
/// beyond its face without end.
const WALL_DRAWN_M: f64 = 0.05;

/// A sideways plan on its scenario's wall: every step where the body moved
/// (the start, then each stride's turn, swing, settle and release of the
/// front cup) overlaid in one set of views, each holding cup's face where
/// it held, coloured by its verdict. One set of views rather than one per
/// step: the strides march along the wall (z), so the side view shows them
/// side by side, and a picture of 1 + 4 n rows would be too tall to read.
pub fn sideways_figure(robot: &Robot, scenario: &SidewaysScenario, plan: &SidewaysPlan) -> Figure {
    let w = &scenario.wall;
    let half = |r: [f64; 2]| 0.5 * (r[1] - r[0]);
    let slab = Solid3::Box {
        centre_m: [
            w.x_m + 0.5 * WALL_DRAWN_M,
            0.5 * (w.y_range_m[0] + w.y_range_m[1]),
            0.5 * (w.z_range_m[0] + w.z_range_m[1]),
        ],
        half_extents_m: [0.5 * WALL_DRAWN_M, half(w.y_range_m), half(w.z_range_m)],
        frame: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };
    let wall = Scene3 { name: "wall".into(), solids: vec![slab] };
    let moved = plan.steps.iter().filter(|s| !s.phase.name().starts_with("attach"));
    let bodies: Vec<Tubes> = moved.clone().map(|s| Tubes::of(&s.held.body, &s.held.equilibrium.frames)).collect();
    let marks: Vec<CupMark> =
        moved.flat_map(|step| cups(robot, &step.held)).filter(|mark| mark.holding.is_some()).collect();
    let title = format!(
        "{} ({}): {} strides, {:.1} mm sideways ({:?})",
        scenario.name,
        robot.name,
        plan.strides,
        plan.lateral_m * 1e3,
        plan.status
    );
    views(title, &bodies, Some(&wall), &marks, true, robot.cup.min_safety_factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hull_of_a_box_corners_and_a_rim_are_what_they_should_be() {
        let square = hull(vec![[0.0, 0.0], [1.0, 0.0], [0.5, 0.5], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0]]);
        assert_eq!(square, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let cup =
            CupMark { name: "c", centre: [0.1, 0.2, 0.3], normal: [0.0, 0.0, 1.0], diameter: 0.04, holding: None };
        for p in rim(&cup) {
            let d = sub(p, cup.centre);
            assert!((dot(d, d).sqrt() - 0.02).abs() < 1e-15 && d[2].abs() < 1e-15);
        }
    }
}
