//! The standard pictures of an equilibrium: both chains with their joints,
//! the endpoint plate, the driving unit and gravity's direction.

use leech::body::Body;
use leech::cantilever::Cantilever;
use leech::constant_curvature::PlanarBody;

use crate::figure::{Figure, SeriesStyle, PALETTE};

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
