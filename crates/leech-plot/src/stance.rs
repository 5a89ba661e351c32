//! The body where its holds put it: the scene's solids around it, the cups
//! coloured by their verdicts, the holds' reactions and the contact forces as
//! arrows on one scale.

use leech::cup::CupVerdict;
use leech::geom::{add_scaled, dot, sub, unit, Vec2};
use leech::report::Cups;
use leech::robot::Robot;
use leech::scene::{Scene, Solid};
use leech::stance::{ContactForce, Held, TubeHeld};

use crate::figure::{Figure, SeriesStyle, PALETTE};

const GREY: (u8, u8, u8) = (90, 90, 90);
pub(crate) const SOLID: (u8, u8, u8) = (120, 120, 120);
const FREE_CUP: (u8, u8, u8) = (170, 170, 170);
const HOLDS: (u8, u8, u8) = PALETTE[2];
const BELOW_MINIMUM: (u8, u8, u8) = PALETTE[5];
const FAILS: (u8, u8, u8) = (200, 30, 30);
const REACTION: (u8, u8, u8) = (0, 0, 0);
const CONTACT: (u8, u8, u8) = PALETTE[3];

/// Margin around the body, its cups and arrows that the scene is drawn
/// into, as a fraction of their larger extent (m at least [`MIN_MARGIN_M`]).
pub(crate) const MARGIN: f64 = 0.15;
pub(crate) const MIN_MARGIN_M: f64 = 0.02;

/// The longest force arrow as a fraction of the body's larger extent.
const ARROW_SHARE: f64 = 0.3;

/// A straight piece of the picture: from, to.
pub(crate) type Segment = [Vec2; 2];

/// `held` (a body of `robot`) in `scene`, with the cups as [`Held::cups`]
/// judged them: the solids clipped to the body's surroundings, each cup a
/// thick segment of its diameter on its face, coloured by its verdict.
pub fn held_figure(robot: &Robot, held: &Held, scene: Option<&Scene>, cups: &Cups) -> Figure {
    let [a, b] = held.chain_points(robot);
    let (la, lb) = (held.body.chain_a().tube_length(), held.body.chain_b().tube_length());
    // The scene's name is in the legend.
    let holds = match held.hold.name() {
        "both" => "both holds".to_string(),
        one => format!("{one} hold"),
    };
    let title = format!("{}: LA = {:.1} mm, LB = {:.1} mm, {holds}", robot.name, la * 1e3, lb * 1e3);
    let mut fig = Figure::new(title);
    let faces = cup_faces(robot, held);
    let mut extent: Vec<Vec2> = a.iter().chain(&b).chain(faces.iter().flatten()).copied().collect();
    let (lo, hi) = bounds(&extent);
    // The holds' reactions at their cups' centres.
    let reactions = [&cups.0, &cups.1].into_iter().flatten().map(|c| (c.centre_m, c.force_n)).collect();
    let forces = Forces::new(reactions, &held.contacts, ARROW_SHARE * (hi[0] - lo[0]).max(hi[1] - lo[1]));
    extent.extend(forces.reactions.iter().chain(&forces.contacts).flatten());
    if let Some(scene) = scene {
        solids(&mut fig, scene, bounds(&extent));
    }
    body(&mut fig, robot, held);
    for ((name, cup), segment) in [("rear cup", &cups.0), ("front cup", &cups.1)].into_iter().zip(faces) {
        let (label, color) = verdict(name, cup.as_ref().map(|c| &c.verdict), robot.cup.min_safety_factor);
        fig.push(label, segment.to_vec(), SeriesStyle::Thick, color);
    }
    forces.push(&mut fig, "hold reactions");
    fig.gravity_arrow = held.body.gravity() > 0.0;
    fig
}

/// The body of `held` as series: the driving unit (its outline, or the
/// line between the clamps for a unit without one), the arms to the cups,
/// the chains and the endpoint plate (the cups themselves are not drawn).
pub(crate) fn body(fig: &mut Figure, robot: &Robot, held: &Held) {
    let [a, b] = held.chain_points(robot);
    let (a_tip, b_tip) = (*a.last().expect("a chain"), *b.last().expect("a chain"));
    let unit = match held.unit_outline_m(robot) {
        Some(corners) => corners.iter().chain(&corners[..1]).copied().collect(),
        None => vec![a[0], b[0]],
    };
    fig.push("driving unit", unit, SeriesStyle::Thick, GREY);
    fig.push("", vec![b[0], held.rear_cup_m(robot)], SeriesStyle::Line, GREY);
    fig.push("", vec![b_tip, held.front_cup_m(robot)], SeriesStyle::Line, GREY);
    fig.push("chain A (centre tube)", a, SeriesStyle::LineAndDots, PALETTE[0]);
    fig.push("chain B (side tubes)", b, SeriesStyle::LineAndDots, PALETTE[1]);
    // The rigid parts in grey: the cups' verdict colours stay distinct.
    fig.push("endpoint plate", vec![a_tip, b_tip], SeriesStyle::Thick, GREY);
}

/// The faces of the rear and front cups of `held`: each its diameter on its face.
pub(crate) fn cup_faces(robot: &Robot, held: &Held) -> [Segment; 2] {
    let plate = held.body.endpoint_angle(&held.equilibrium.q);
    [
        face(held.rear_cup_m(robot), held.unit.angle_rad, robot.cup.diameter_m),
        face(held.front_cup_m(robot), plate, robot.cup.diameter_m),
    ]
}

/// The single tube `held` in `scene` ([`crate::shape::cantilever_figure`]
/// with the solids around it), the clamp's force and the contact forces as
/// arrows on one scale.
pub fn tube_figure(title: &str, held: &TubeHeld, scene: &Scene) -> Figure {
    let mut fig = crate::shape::cantilever_figure(title, &held.tube, &held.equilibrium.q);
    let mut extent = held.points_m.clone();
    let (lo, hi) = bounds(&extent);
    let clamp = vec![(held.tube.chain().clamp_point(), held.clamp.force_n)];
    let forces = Forces::new(clamp, &held.contacts, ARROW_SHARE * (hi[0] - lo[0]).max(hi[1] - lo[1]));
    extent.extend(forces.reactions.iter().chain(&forces.contacts).flatten());
    // The solids first: the tube is drawn over them.
    let tube = std::mem::take(&mut fig.series);
    solids(&mut fig, scene, bounds(&extent));
    fig.series.extend(tube);
    forces.push(&mut fig, "clamp force");
    fig
}

/// A cup's face: its diameter along `angle`, centred on `centre`.
fn face(centre: Vec2, angle: f64, diameter: f64) -> Segment {
    let along = unit(angle);
    [add_scaled(centre, -0.5 * diameter, along), add_scaled(centre, 0.5 * diameter, along)]
}

/// A cup's legend entry and colour from its verdict: holds, holds below the
/// minimum safety factor, fails; grey when it does not hold the body.
pub(crate) fn verdict(name: &str, cup: Option<&CupVerdict>, minimum: f64) -> (String, (u8, u8, u8)) {
    let Some(v) = cup else { return (format!("{name} (free)"), FREE_CUP) };
    match (v.holds, v.meets_minimum) {
        _ if v.safety_factor.is_infinite() => (format!("{name}: holds, unloaded"), HOLDS),
        (true, true) => (format!("{name}: holds (SF {:.2})", v.safety_factor), HOLDS),
        (true, false) => (format!("{name}: holds, SF {:.2} < {minimum}", v.safety_factor), BELOW_MINIMUM),
        (false, _) => (format!("{name}: fails (SF {:.2})", v.safety_factor), FAILS),
    }
}

/// The force arrows, on one scale (m per N).
struct Forces {
    reactions: Vec<Segment>,
    contacts: Vec<Segment>,
    /// Millimetres of arrow per newton, a round number.
    mm_per_n: f64,
}

impl Forces {
    /// Arrows of the forces on the robot from where they act: the
    /// reactions (each a point and a force, N) and the contacts at the
    /// touching points; the largest about `longest` (m) long.
    fn new(reactions: Vec<(Vec2, Vec2)>, contacts: &[ContactForce], longest: f64) -> Forces {
        let contacts: Vec<(Vec2, Vec2)> =
            contacts.iter().map(|c| (c.point_m, [c.force_n * c.normal[0], c.force_n * c.normal[1]])).collect();
        let largest = reactions.iter().chain(&contacts).map(|(_, f)| f[0].hypot(f[1])).fold(0.0, f64::max);
        let mm_per_n = round_down(1e3 * longest / largest);
        if !mm_per_n.is_finite() {
            // No force at all (no gravity): nothing to draw.
            return Forces { reactions: Vec::new(), contacts: Vec::new(), mm_per_n: 0.0 };
        }
        let arrow = |(at, f): &(Vec2, Vec2)| [*at, add_scaled(*at, mm_per_n * 1e-3, *f)];
        let keep = |s: &Segment| s[0] != s[1];
        Forces {
            reactions: reactions.iter().map(arrow).filter(keep).collect(),
            contacts: contacts.iter().map(arrow).filter(keep).collect(),
            mm_per_n,
        }
    }

    /// The arrows as series, the scale in the first of each kind's legend
    /// entry; the reactions called `reactions`.
    fn push(self, fig: &mut Figure, reactions: &str) {
        let scale = format!("{} mm = 1 N", self.mm_per_n);
        for (i, s) in self.reactions.into_iter().enumerate() {
            let label = if i == 0 { format!("{reactions} ({scale})") } else { String::new() };
            fig.push(label, s.to_vec(), SeriesStyle::Arrow, REACTION);
        }
        for (i, s) in self.contacts.into_iter().enumerate() {
            let label = if i == 0 { format!("contact forces ({scale})") } else { String::new() };
            fig.push(label, s.to_vec(), SeriesStyle::Arrow, CONTACT);
        }
    }
}

/// The largest of 1, 2 and 5 times a power of ten not above `x` (NaN or
/// infinite stays so: no force to scale).
fn round_down(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return f64::INFINITY;
    }
    let power = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0].into_iter().map(|m| m * power).find(|v| *v <= x * (1.0 + 1e-12)).unwrap_or(power)
}

/// The smallest box around `points`: (low corner, high corner).
pub(crate) fn bounds(points: &[Vec2]) -> (Vec2, Vec2) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The scene's solids within `(lo, hi)` plus a margin, as filled polygons.
fn solids(fig: &mut Figure, scene: &Scene, (lo, hi): (Vec2, Vec2)) {
    let margin = (MARGIN * (hi[0] - lo[0]).max(hi[1] - lo[1])).max(MIN_MARGIN_M);
    solids_within(fig, scene, ([lo[0] - margin, lo[1] - margin], [hi[0] + margin, hi[1] + margin]));
}

/// The scene's solids clipped to the box `(lo, hi)`, as filled polygons.
pub(crate) fn solids_within(fig: &mut Figure, scene: &Scene, (lo, hi): (Vec2, Vec2)) {
    let (x0, y0, x1, y1) = (lo[0], lo[1], hi[0], hi[1]);
    let view = vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
    let mut label = format!("scene: {}", scene.name);
    for solid in &scene.solids {
        let clipped = match solid {
            Solid::HalfPlane { point_m, normal } => clip(&view, *point_m, *normal),
            Solid::Polygon { points_m } => {
                let sides =
                    [([x0, y0], [0.0, -1.0]), ([x1, y0], [1.0, 0.0]), ([x1, y1], [0.0, 1.0]), ([x0, y1], [-1.0, 0.0])];
                sides.iter().fold(points_m.clone(), |poly, (point, outward)| clip(&poly, *point, *outward))
            }
        };
        if clipped.len() >= 3 {
            fig.push(std::mem::take(&mut label), clipped, SeriesStyle::Area, SOLID);
        }
    }
}

/// The part of `polygon` behind the line through `point` with outward
/// normal `normal` (`(x - point) . normal <= 0`): one Sutherland-Hodgman pass.
pub(crate) fn clip(polygon: &[Vec2], point: Vec2, normal: Vec2) -> Vec<Vec2> {
    let side = |p: Vec2| dot(sub(p, point), normal);
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, &p) in polygon.iter().enumerate() {
        let next = polygon[(i + 1) % polygon.len()];
        let (sp, sn) = (side(p), side(next));
        if sp <= 0.0 {
            out.push(p);
        }
        if (sp < 0.0 && sn > 0.0) || (sp > 0.0 && sn < 0.0) {
            out.push(add_scaled(p, sp / (sp - sn), sub(next, p)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_the_solid_side_and_scales_are_round() {
        let square = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        let below = clip(&square, [0.0, 1.0], [0.0, 1.0]);
        assert_eq!(below, vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]);
        assert!(clip(&square, [0.0, -1.0], [0.0, 1.0]).is_empty());
        assert_eq!(clip(&square, [0.0, 3.0], [0.0, 1.0]), square);
        assert_eq!(round_down(37.0), 20.0);
        assert_eq!(round_down(5.0), 5.0);
        assert_eq!(round_down(0.013), 0.01);
        assert!(round_down(f64::INFINITY).is_infinite());
    }
}
