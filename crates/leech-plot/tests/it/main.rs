//! Pictures render to well-formed SVG and PNG.

use leech::prelude::*;
use leech_plot::shape::{body_figure, cantilever_figure};

#[test]
fn body_svg_has_axes_legend_and_gravity() {
    let robot = Robot::builtin();
    let body = robot.body(0.3, 0.28).unwrap();
    let eq = body.solve(&Solver::default()).unwrap();
    let svg = body_figure(&robot.name, &body, &eq.q).to_svg_string().unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for text in ["x (mm)", "y (mm)", "chain A", "chain B", "endpoint plate", "driving unit", "LA = 300.0 mm"] {
        assert!(svg.contains(text), "missing {text}");
    }
    assert!(svg.contains("\ng\n</text>"), "gravity arrow label");
}

#[test]
fn png_is_written() {
    let spec = CantileverSpec {
        elements: 10,
        element_length_m: 0.01,
        element_mass_kg: 0.001,
        joint_stiffness_nm_per_rad: 0.05,
        tip_mass_kg: 0.0,
        base_angle_deg: 30.0,
        gravity_m_per_s2: 9.81,
        discretization: Discretization::Paper,
    };
    let tube = spec.build().unwrap();
    let eq = tube.solve(&Solver::default()).unwrap();
    let dir = std::env::temp_dir().join(format!("leech-plot-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("tube.png");
    cantilever_figure("tube", &tube, &eq.q).write_png(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    std::fs::remove_dir_all(&dir).ok();
}
