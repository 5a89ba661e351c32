//! The standard pictures of an equilibrium: both chains with their joints,
//! the endpoint plate, the driving unit and gravity's direction.

use leech::body::Body;
use leech::body3::{Body3, Frames};
use leech::cantilever::Cantilever;
use leech::constant_curvature::PlanarBody;

use crate::figure::{Axes, Figure, SeriesStyle, PALETTE};

const GREY: (u8, u8, u8) = (90, 90, 90);

/// The body at configuration `q`: chain A, chain B, the endpoint plate
/// (from chain A's tip to chain B's) and the driving unit (between the clamps).
pub fn body_figure(robot: &str, body: &Body, q: &[f64]) -> Figure {
    let (qa, qb) = body.split(q);
    let (a, b) = (body.chain_a(), body.chain_b());
    let (la, lb) = (a.tube_length(), b.tube_length());
    let mut fig = Figure::new(format!("{robot}: LA = {:.1} mm, LB = {:.1} mm", la * 1e3, lb * 1e3));
    let pa = a.points(qa);
    let pb = b.points(qb);
    fig.push("driving unit", vec![a.clamp_point(), b.clamp_point()], SeriesStyle::Thick, GREY);
    fig.push("chain A (centre tube)", pa.clone(), SeriesStyle::LineAndDots, PALETTE[0]);
    fig.push("chain B (side tubes)", pb.clone(), SeriesStyle::LineAndDots, PALETTE[1]);
    fig.push("endpoint plate", vec![*pa.last().unwrap(), *pb.last().unwrap()], SeriesStyle::Thick, PALETTE[2]);
    fig.gravity_arrow = body.gravity() > 0.0;
    fig
}

/// A single tube at configuration `q`, with its clamp.
pub fn cantilever_figure(title: &str, tube: &Cantilever, q: &[f64]) -> Figure {
    let chain = tube.chain();
    let mut fig = Figure::new(title);
    let clamp = chain.clamp_point();
    let back = leech::geom::unit(chain.clamp_angle() + std::f64::consts::PI);
    let stub = 0.05 * chain.tube_length();
    fig.push("clamp", vec![[clamp[0] + stub * back[0], clamp[1] + stub * back[1]], clamp], SeriesStyle::Thick, GREY);
    fig.push("tube", chain.points(q), SeriesStyle::LineAndDots, PALETTE[0]);
    fig.gravity_arrow = tube.gravity() > 0.0;
    fig
}

/// The two-chain body at `q` with the constant-curvature body of the same
/// tube lengths drawn dashed over it.
pub fn comparison_figure(robot: &str, body: &Body, q: &[f64], cc: &PlanarBody) -> Figure {
    let mut fig = body_figure(robot, body, q);
    let (la, lb) = (body.chain_a().tube_length(), body.chain_b().tube_length());
    let (a, b) = cc.chain_points(la, lb, 60);
    fig.push("constant curvature A", a, SeriesStyle::Dashed, PALETTE[4]);
    fig.push("constant curvature B", b, SeriesStyle::Dashed, PALETTE[5]);
    fig
}

/// The constant-curvature body alone.
pub fn constant_curvature_figure(robot: &str, cc: &PlanarBody, la: f64, lb: f64) -> Figure {
    let mut fig = Figure::new(format!("{robot}, constant curvature: LA = {:.1} mm, LB = {:.1} mm", la * 1e3, lb * 1e3));
    let (a, b) = cc.chain_points(la, lb, 60);
    fig.push("driving unit", vec![cc.clamp_point, cc.clamp_point_b()], SeriesStyle::Thick, GREY);
    fig.push("chain A (arc)", a.clone(), SeriesStyle::Line, PALETTE[0]);
    fig.push("chain B (arc)", b.clone(), SeriesStyle::Line, PALETTE[1]);
    fig.push("endpoint plate", vec![*a.last().unwrap(), *b.last().unwrap()], SeriesStyle::Thick, PALETTE[2]);
    fig
}

/// Measured points (dots) over the shapes of a fitted robot (lines): sag
/// tubes and bodies, each in its own colour.
pub fn calibration_figure(
    title: &str,
    robot: &leech::robot::Robot,
    sag: &[leech::calibration::SagTube],
    shapes: &[leech::calibration::BodyShape],
) -> Figure {
    use leech::statics::Solver;
    let mut fig = Figure::new(title);
    let mut colour = 0;
    for tube in sag {
        let r = robot.with_base_angle(tube.base_angle_deg);
        let color = PALETTE[colour % PALETTE.len()];
        colour += 1;
        if let Ok(c) = r.and_then(|r| r.cantilever(tube.length, tube.tip_mass)) {
            if let Ok(eq) = c.solve(&Solver::default()) {
                fig.push(
                    format!("tube {:.0} mm (fit)", tube.length * 1e3),
                    c.chain().points(&eq.q),
                    SeriesStyle::Line,
                    color,
                );
            }
        }
        fig.push("", tube.points.clone(), SeriesStyle::Dots, color);
    }
    for shape in shapes {
        let r = robot.with_base_angle(shape.base_angle_deg);
        let color = PALETTE[colour % PALETTE.len()];
        colour += 1;
        if let Ok(body) = r.and_then(|r| r.body(shape.lengths[0], shape.lengths[1])) {
            if let Ok(eq) = body.solve(&Solver::default()) {
                let (qa, qb) = body.split(&eq.q);
                fig.push(format!("{} (fit)", shape.name), body.chain_a().points(qa), SeriesStyle::Line, color);
                fig.push("", body.chain_b().points(qb), SeriesStyle::Line, color);
            }
        }
        let mut measured = shape.points_a.clone();
        measured.extend(&shape.points_b);
        measured.extend(shape.endpoint);
        fig.push("", measured, SeriesStyle::Dots, color);
    }
    fig.gravity_arrow = true;
    fig
}

/// The three tubes' colours in the 3D pictures: tube 1 as chain A.
const TUBES: [(u8, u8, u8); 3] = [PALETTE[0], PALETTE[1], PALETTE[3]];

/// The three-tube body in 3D at `frames`: three orthographic views side by
/// side at one scale, front (x-y, seen from +z), side (z-y, seen from -x)
/// and top (x against -z, seen from +y), each with the tubes in their own
/// colours, the driving unit's triangle (the tubes' roots) and the endpoint
/// plate's (their tips); the legend in the front view, gravity's arrow in
/// the two views where it lies in the page.
pub fn body3_figure(robot: &str, body: &Body3, frames: &Frames) -> Figure {
    let tubes: Vec<Vec<[f64; 3]>> = (0..3).map(|i| body.points(frames, i)).collect();
    // Each triangle's edges one by one: a thick line folding back on itself
    // (a triangle seen edge-on) would draw a spike at its mitred corner.
    let edges = |pick: fn(&Vec<[f64; 3]>) -> [f64; 3]| {
        let corners: Vec<[f64; 3]> = tubes.iter().map(pick).collect();
        (0..3).map(|k| vec![corners[k], corners[(k + 1) % 3]]).collect::<Vec<_>>()
    };
    let unit = edges(|t| t[0]);
    let plate = edges(|t| *t.last().expect("a tube has its root"));
    let views: [(&str, &str, &str, fn([f64; 3]) -> [f64; 2]); 3] = [
        ("front (seen from +z)", "x (mm)", "y (mm)", |p| [p[0], p[1]]),
        ("side (seen from -x)", "z (mm)", "y (mm)", |p| [p[2], p[1]]),
        ("top (seen from +y)", "x (mm)", "-z (mm)", |p| [p[0], -p[2]]),
    ];
    let panels = views
        .iter()
        .enumerate()
        .map(|(v, (title, x, y, project))| {
            let mut fig = Figure::new(*title);
            fig.axes = Axes { scale: 1e3, x_label: (*x).into(), y_label: (*y).into() };
            let flat = |points: &[[f64; 3]]| points.iter().map(|p| project(*p)).collect::<Vec<_>>();
            let label = |text: &str| if v == 0 { text.to_string() } else { String::new() };
            let triangle = |fig: &mut Figure, name: &str, edges: &[Vec<[f64; 3]>], color| {
                for (k, edge) in edges.iter().enumerate() {
                    fig.push(if k == 0 { label(name) } else { String::new() }, flat(edge), SeriesStyle::Thick, color);
                }
            };
            triangle(&mut fig, "driving unit", &unit, GREY);
            for (i, (tube, color)) in tubes.iter().zip(TUBES).enumerate() {
                fig.push(label(&format!("tube {}", i + 1)), flat(tube), SeriesStyle::LineAndDots, color);
            }
            triangle(&mut fig, "endpoint plate", &plate, PALETTE[2]);
            fig.gravity_arrow = body.gravity() > 0.0 && v < 2;
            fig
        })
        .collect();
    let [l1, l2, l3] = [0, 1, 2].map(|i| body.tube(i).tube_length() * 1e3);
    Figure::row(format!("{robot}: L1 = {l1:.1} mm, L2 = {l2:.1} mm, L3 = {l3:.1} mm"), panels, (520, 560))
}
