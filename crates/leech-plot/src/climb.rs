//! Animated SVG (SMIL) of a planned climb: one frame per step of the plan.
//!
//! The scene's solids and the goal stay still; each frame shows the body at
//! a phase's end (as [`crate::stance::held_figure`] draws it), its cups
//! (a holding cup filled, in its verdict's colour, with its safety factor in
//! the caption; a released cup an outline) and a caption naming the stride
//! and the phase. The axes are fixed for all frames (the union of the
//! bodies' boxes and the goal, with a margin), with equal scales on x and y.
//! The animation loops; a viewer without SMIL shows the first frame.

use std::fmt::Write as _;

use leech::geom::{add_scaled, sub};
use leech::robot::Robot;
use leech::scene::Scene;
use leech::stride::{Goal, Phase, Step};

use crate::animation::{points, xml_escape, View};
use crate::figure::{Figure, Series, SeriesStyle};
use crate::stance::{body, cup_faces, solids_within, Segment};

/// How long each frame is shown (s).
pub const SECONDS_PER_STEP: f64 = 0.8;

/// The drawing is at most this many times as tall as it is wide.
const MAX_ASPECT: f64 = 1.5;

const HOLDING: &str = "#009e73";
const BELOW_MINIMUM: &str = "#e69f00";
const RELEASED: &str = "#777777";
const GOAL: &str = "#cc0000";

/// The climb of `robot` through `steps` (a plan's steps, from the start; for
/// an impossible climb, those to its farthest stance) in `scene`, to `goal`,
/// as an SVG document; `strides` is the plan's number of strides and
/// `title` (lines separated by `'\n'`) is shown above the drawing. `steps`
/// must not be empty.
pub fn climb_svg(title: &str, robot: &Robot, scene: &Scene, steps: &[Step], strides: usize, goal: &Goal) -> String {
    let bodies: Vec<Figure> = steps
        .iter()
        .map(|s| {
            let mut fig = Figure::new(String::new());
            body(&mut fig, robot, &s.held);
            fig
        })
        .collect();
    let faces: Vec<[Segment; 2]> = steps.iter().map(|s| cup_faces(robot, &s.held)).collect();
    // The fixed axes: every body, cup and the goal's circle (mm, y up).
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let goal_box = [
        add_scaled(goal.point_m, -goal.tolerance_m, [1.0, 1.0]),
        add_scaled(goal.point_m, goal.tolerance_m, [1.0, 1.0]),
    ];
    let everything = bodies
        .iter()
        .flat_map(|f| f.series.iter().flat_map(|s| s.points.iter()))
        .chain(faces.iter().flatten().flatten())
        .chain(&goal_box);
    for p in everything {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k] * 1e3);
            hi[k] = hi[k].max(p[k] * 1e3);
        }
    }
    // A tall climb (up a wall) is widened, so that the captions fit.
    let widen = 0.5 * ((hi[1] - lo[1]) / MAX_ASPECT - (hi[0] - lo[0])).max(0.0);
    let mut view = View::around([lo[0] - widen, lo[1]], [hi[0] + widen, hi[1]]);
    // The picture is 760 px wide: sizes in pixels, the text at most 16 px.
    let px = view.w / 760.0;
    view.font = view.font.min(16.0 * px);
    let mut svg = view.open(title);
    // The still parts: the solids within the view, the goal.
    let mut still = Figure::new(String::new());
    solids_within(&mut still, scene, view.bounds_m());
    for s in &still.series {
        svg.push_str(&series_svg(s, px));
    }
    let [gx, gy] = [goal.point_m[0] * 1e3, -goal.point_m[1] * 1e3];
    let _ = writeln!(
        svg,
        r#"<g stroke="{GOAL}" fill="none" stroke-width="{:.3}"><circle cx="{gx:.3}" cy="{gy:.3}" r="{:.3}" stroke-dasharray="{:.3}"/><path d="M{:.3},{gy:.3}H{:.3}M{gx:.3},{:.3}V{:.3}"/></g><text x="{gx:.3}" y="{:.3}" font-family="sans-serif" font-size="{:.3}" fill="{GOAL}" text-anchor="middle">goal</text>"#,
        1.5 * px,
        goal.tolerance_m * 1e3,
        4.0 * px,
        gx - 6.0 * px,
        gx + 6.0 * px,
        gy - 6.0 * px,
        gy + 6.0 * px,
        gy - goal.tolerance_m * 1e3 - 0.3 * view.font,
        0.8 * view.font
    );
    let n = steps.len();
    let duration = SECONDS_PER_STEP * n as f64;
    for (i, ((step, fig), faces)) in steps.iter().zip(&bodies).zip(&faces).enumerate() {
        let initial = if i == 0 { "visible" } else { "hidden" };
        let _ = writeln!(svg, r#"<g visibility="{initial}">{}"#, shown_in_turn(i, n, duration));
        for s in &fig.series {
            svg.push_str(&series_svg(s, px));
        }
        let held = [step.held.hold.rear().is_some(), step.held.hold.front().is_some()];
        let factors = [step.rear_safety_factor, step.front_safety_factor];
        for ((face, holds), factor) in faces.iter().zip(held).zip(factors) {
            svg.push_str(&cup_svg(*face, holds, factor, robot.cup.min_safety_factor, px));
        }
        let _ = writeln!(
            svg,
            r#"<text x="{:.3}" y="{:.3}" font-family="sans-serif" font-size="{:.3}">{}</text>"#,
            view.x0 + 0.02 * view.w,
            view.y0 + 1.2 * view.font,
            view.font,
            xml_escape(&caption(step, strides, i, n))
        );
        svg.push_str("</g>\n");
    }
    svg.push_str("</svg>\n");
    svg
}

/// What frame `i` of `n` shows: "stride 3/7, release_rear, safety factor front 7.35".
pub fn caption(step: &Step, strides: usize, i: usize, n: usize) -> String {
    let mut text = match step.phase {
        Phase::Start => "start".to_string(),
        phase => format!("stride {}/{strides}, {}", step.stride, phase.name()),
    };
    let factors: Vec<String> = [("rear", step.rear_safety_factor), ("front", step.front_safety_factor)]
        .into_iter()
        .filter_map(|(cup, sf)| {
            sf.map(|sf| if sf.is_finite() { format!("{cup} {sf:.2}") } else { format!("{cup} unloaded") })
        })
        .collect();
    if !factors.is_empty() {
        let _ = write!(text, ", safety factor {}", factors.join(", "));
    }
    let _ = write!(text, " (step {}/{n})", i + 1);
    text
}

/// The frame `i` of `n` shown in its turn, the whole lasting `duration` (s), looping.
fn shown_in_turn(i: usize, n: usize, duration: f64) -> String {
    if n < 2 {
        return String::new();
    }
    let (from, to) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
    let (values, key_times) = match i {
        0 => ("visible;hidden".to_string(), format!("0;{to:.6}")),
        _ if i + 1 == n => ("hidden;visible".to_string(), format!("0;{from:.6}")),
        _ => ("hidden;visible;hidden".to_string(), format!("0;{from:.6};{to:.6}")),
    };
    format!(
        r#"<animate attributeName="visibility" calcMode="discrete" values="{values}" keyTimes="{key_times}" dur="{duration:.3}s" repeatCount="indefinite"/>"#
    )
}

/// A cup on `face`: a box of the face's width and a quarter of it deep on the
/// body's side (the face's left, chain B's cups face right of the surface),
/// filled in its verdict's colour when it holds, an outline when released.
fn cup_svg(face: Segment, holds: bool, factor: Option<f64>, minimum: f64, px: f64) -> String {
    let along = sub(face[1], face[0]);
    let depth = 0.25;
    let up = [-along[1] * depth, along[0] * depth];
    let corners = [face[0], face[1], add_scaled(face[1], 1.0, up), add_scaled(face[0], 1.0, up)];
    let (fill, stroke) = match (holds, factor) {
        (false, _) => ("none", RELEASED),
        (true, Some(sf)) if sf < minimum => (BELOW_MINIMUM, BELOW_MINIMUM),
        (true, _) => (HOLDING, HOLDING),
    };
    format!(
        r#"<polygon points="{}" fill="{fill}" stroke="{stroke}" stroke-width="{:.3}"/>"#,
        points(&corners),
        1.5 * px
    ) + "\n"
}

/// One series as an SVG element (mm, y down); `px` is a pixel's length (mm).
fn series_svg(s: &Series, px: f64) -> String {
    let (r, g, b) = s.color;
    let color = format!("#{r:02x}{g:02x}{b:02x}");
    let width = match s.style {
        SeriesStyle::Thick => 5.0,
        SeriesStyle::LineAndDots => 2.5,
        _ => 1.5,
    } * px;
    let pts = points(&s.points);
    match s.style {
        SeriesStyle::Area => {
            format!(
                r#"<polygon points="{pts}" fill="{color}" fill-opacity="0.35" stroke="{color}" stroke-width="{width:.3}"/>"#
            ) + "\n"
        }
        SeriesStyle::Dots => String::new(),
        SeriesStyle::Dashed => {
            format!(
                r#"<polyline points="{pts}" fill="none" stroke="{color}" stroke-width="{width:.3}" stroke-dasharray="{:.3}"/>"#,
                4.0 * px
            ) + "\n"
        }
        _ => {
            format!(
                r#"<polyline points="{pts}" fill="none" stroke="{color}" stroke-width="{width:.3}" stroke-linecap="round" stroke-linejoin="round"/>"#
            ) + "\n"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_take_turns_and_loop() {
        assert!(shown_in_turn(0, 1, 1.0).is_empty());
        let first = shown_in_turn(0, 4, 4.0);
        assert!(first.contains(r#"values="visible;hidden" keyTimes="0;0.250000""#), "{first}");
        let middle = shown_in_turn(1, 4, 4.0);
        assert!(middle.contains(r#"keyTimes="0;0.250000;0.500000""#), "{middle}");
        assert!(shown_in_turn(3, 4, 4.0).contains(r#"values="hidden;visible" keyTimes="0;0.750000""#));
        assert!(first.contains(r#"repeatCount="indefinite""#));
    }
}
