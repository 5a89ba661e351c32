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

mod figures {
    use leech::prelude::*;
    use leech_plot::figures::{build, pi_sweep_data, workspace_data, NAMES, SWEEP_PIS, WORKSPACE_PIS};

    fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
        (a[0] - b[0]).hypot(a[1] - b[1])
    }

    /// Paper Fig. 10: as Pi grows the two-chain endpoints approach the
    /// constant-curvature ones.
    #[test]
    fn two_chain_approaches_constant_curvature_as_pi_grows() {
        let data = pi_sweep_data(&Robot::builtin()).unwrap();
        let mean: Vec<f64> = SWEEP_PIS
            .iter()
            .map(|pi| {
                let d: Vec<f64> =
                    data.iter().filter(|p| p.pi == *pi).map(|p| distance(p.two_chain, p.constant_curvature)).collect();
                d.iter().sum::<f64>() / d.len() as f64
            })
            .collect();
        // Falls by decades while gravity matters (Pi = 1e2, 1e3, 1e4) ...
        assert!(mean[0] > 2.0 * mean[1] && mean[1] > 2.0 * mean[2], "{mean:?}");
        // ... then levels off at the purely elastic two-chain shape, which is
        // not a pair of arcs: the model approaches constant curvature but
        // does not reach it (the paper's observation).
        assert!((mean[3] - mean[4]).abs() < 0.2 * mean[4], "{mean:?}");
        assert!(mean[4] < mean[1] / 3.0 && mean[4] > 1e-3, "{mean:?}");
    }

    /// Paper Fig. 12: soft bodies reach below the base, stiff ones higher.
    #[test]
    fn soft_bodies_reach_down_stiff_ones_up() {
        let data = workspace_data(&Robot::builtin(), 0.025).unwrap();
        let extent = |pi: f64| {
            data.iter()
                .filter(|p| p.pi == pi)
                .fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p.endpoint[1]), hi.max(p.endpoint[1])))
        };
        let (soft, stiff) = (extent(WORKSPACE_PIS[0]), extent(*WORKSPACE_PIS.last().unwrap()));
        assert!(soft.0 < -0.05, "the soft body reaches well below the base: {soft:?}");
        assert!(stiff.0 > soft.0);
        assert!(stiff.1 > soft.1, "the stiff body reaches higher: {stiff:?} vs {soft:?}");
        assert!(data.iter().all(|p| p.stable));
    }

    #[test]
    fn every_figure_renders_with_its_data() {
        let robot = Robot::builtin();
        for name in NAMES {
            let out = build(name, &robot).unwrap();
            let svg = out.figure.to_svg_string().unwrap();
            assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{name}");
            assert!(!out.figure.title.is_empty());
            let csv = out.table.to_csv_string();
            let mut lines = csv.lines();
            let header = lines.next().unwrap();
            assert!(header.contains("_m") || header.contains("_over_l"), "{name}: units in the header");
            let columns = header.split(',').count();
            assert!(lines.clone().count() > 10, "{name}: data rows");
            assert!(lines.all(|l| l.split(',').count() == columns), "{name}: rectangular CSV");
        }
        assert!(build("nonsense", &robot).is_err());
    }
}
