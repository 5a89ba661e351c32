//! The model's prediction of the body from what the robot measures: the
//! equilibrium at the measured lengths under the holds the telemetry
//! reports (the simulated body's rules, [`leech_link::body`]: a cup that
//! starts holding is fixed where its face is then), drawn as `leech shape`
//! draws it ([`leech_plot::stance::held_figure`]), and the evidence the
//! stride's interlock judges a command on: whether each free cup's face
//! lies flush on a surface, and the other cup's safety factor after each
//! holding cup would let go.

use leech::robot::Robot;
use leech::scene::Scene;
use leech::stance::{self, FreeCups, Held, Hold};
use leech::statics::Solver;
use leech::stride::{plan, Cup, Foothold};
use leech_link::body::BodyCups;
use leech_link::sim::Cups as _;
use leech_plot::figure::{Figure, SeriesStyle};
use serde::Serialize;

/// One polyline of a drawing (m), as the page draws it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Series {
    /// Legend text (may be empty).
    pub label: String,
    /// Points (m).
    pub points_m: Vec<[f64; 2]>,
    /// `line`, `line_and_dots`, `thick`, `dots`, `dashed`, `area` or `arrow`.
    pub style: &'static str,
    /// CSS colour.
    pub color: String,
}

/// The series of a figure, for the page.
pub fn series(figure: &Figure) -> Vec<Series> {
    figure
        .series
        .iter()
        .filter(|s| s.points.iter().all(|p| p[0].is_finite() && p[1].is_finite()))
        .map(|s| Series {
            label: s.label.clone(),
            points_m: s.points.clone(),
            style: match s.style {
                SeriesStyle::LineAndDots => "line_and_dots",
                SeriesStyle::Line => "line",
                SeriesStyle::Thick => "thick",
                SeriesStyle::Dots => "dots",
                SeriesStyle::Dashed => "dashed",
                SeriesStyle::Area => "area",
                SeriesStyle::Arrow => "arrow",
            },
            color: format!("rgb({},{},{})", s.color.0, s.color.1, s.color.2),
        })
        .collect()
}

/// A drawn body: its lengths, its series, its cups.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Drawing {
    /// LA, LB (m).
    pub lengths_m: [f64; 2],
    /// What to draw.
    pub series: Vec<Series>,
    /// The rear and front cups.
    pub cups: [CupPrediction; 2],
}

/// What the model says of one cup.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct CupPrediction {
    /// Centre of its face (m).
    pub centre_m: [f64; 2],
    /// Whether the model has it holding.
    pub holds: bool,
    /// Its safety factor while it holds (`null` when it does not hold, or
    /// carries nothing: an infinite factor).
    pub safety_factor: Option<f64>,
    /// Whether its face lies flush on a surface, where it may attach.
    pub flush: bool,
    /// The other cup's safety factor once this one lets go (`null` unless
    /// both hold, or when it could not be solved).
    pub other_after_release: Option<f64>,
}

/// The body drawn with its cups' verdicts and, for each free cup, whether
/// it lies flush.
pub fn drawing(robot: &Robot, scene: &Scene, held: &Held) -> Drawing {
    let cups = held.cups(robot).unwrap_or((None, None));
    let figure = leech_plot::stance::held_figure(robot, held, None, &cups);
    let cup = |c: Cup, state: &Option<stance::CupState>| {
        let (centre, angle) = plan::cup_face(robot, held, c);
        CupPrediction {
            centre_m: centre,
            holds: state.is_some(),
            safety_factor: state.as_ref().map(|s| s.verdict.safety_factor).filter(|f| f.is_finite()),
            flush: plan::flush_on(robot, scene, centre, angle),
            other_after_release: None,
        }
    };
    Drawing {
        lengths_m: [held.body.chain_a().tube_length(), held.body.chain_b().tube_length()],
        series: series(&figure),
        cups: [cup(Cup::Rear, &cups.0), cup(Cup::Front, &cups.1)],
    }
}

/// The prediction the page shows and the interlock judges on.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Prediction {
    /// The body, when it could be solved.
    pub body: Option<Drawing>,
    /// Why it could not.
    pub error: Option<String>,
}

/// The model of one robot in one scene, following the telemetry.
pub struct Model {
    robot: Robot,
    scene: Scene,
    body: BodyCups,
    solver: Solver,
    /// LA, LB last observed (m).
    lengths: [f64; 2],
    /// The lengths and holds of the last prediction.
    last: Option<([f64; 2], Hold)>,
}

impl Model {
    /// The model of `robot` in `scene`, its rear cup on `start` until the
    /// telemetry says otherwise.
    pub fn new(robot: Robot, scene: Scene, start: Foothold) -> Model {
        let body = BodyCups::new(robot.clone(), scene.clone(), start);
        let short = robot.limits.tube_length_min_m;
        Model { robot, scene, body, solver: Solver::default(), lengths: [short; 2], last: None }
    }

    /// Hands the latest telemetry to the model: lengths (m, L1, L2, L3),
    /// pumps and holds (rear, front).
    pub fn observe(&mut self, lengths_m: [f64; 3], pumps: [bool; 2], holding: [bool; 2]) {
        self.lengths = [lengths_m[0], 0.5 * (lengths_m[1] + lengths_m[2])];
        self.body.observe(lengths_m, pumps, holding);
    }

    /// The prediction at the last lengths observed, with the equilibrium
    /// under the robot's holds (none when it was not found), or `None` when neither the lengths (beyond
    /// [`leech_link::body::RESOLVE_M`]) nor the holds changed since the last.
    ///
    /// Both holds fix the loop's length: where the tubes, within the
    /// controller's tolerance, come out a little shorter than when the
    /// front cup attached, no equilibrium joins the holds. The body is then
    /// drawn held by the rear cup alone (the error says so), and each
    /// release's evidence, which needs one hold only, is still found.
    pub fn predict(&mut self) -> Option<(Prediction, Option<Held>)> {
        let hold = self.body.hold();
        let lengths = self.lengths;
        let unchanged = self.last.is_some_and(|(l, h)| {
            h == hold && (0..2).all(|i| (l[i] - lengths[i]).abs() <= leech_link::body::RESOLVE_M)
        });
        if unchanged {
            return None;
        }
        self.last = Some((lengths, hold));
        let solve =
            |hold: Hold| stance::solve_among(&self.robot, lengths, hold, &self.scene, &self.solver, FreeCups::Rest);
        let (held, error) = match (self.body.held(), hold) {
            (Ok(held), _) => (Some(held), None),
            (Err(e), Hold::Both { rear, .. }) => {
                let note = format!("both holds: {e}; drawn held by the rear cup alone");
                (solve(Hold::Rear(rear)).ok(), Some(note))
            }
            (Err(e), _) => (None, Some(e.to_string())),
        };
        let mut drawn = held.as_ref().map(|h| drawing(&self.robot, &self.scene, h));
        if let (Some(d), Hold::Both { rear, front }) = (drawn.as_mut(), hold) {
            // What each release would leave: the other cup alone.
            let alone = |hold: Hold, cup: Cup| {
                let cups = solve(hold).ok()?.cups(&self.robot).ok()?;
                let state = match cup {
                    Cup::Rear => cups.0,
                    Cup::Front => cups.1,
                };
                // A cup carrying nothing has an infinite factor: far above any minimum.
                state.map(|s| s.verdict.safety_factor.min(f64::MAX))
            };
            d.cups[0].other_after_release = alone(Hold::Front(front), Cup::Front);
            d.cups[1].other_after_release = alone(Hold::Rear(rear), Cup::Rear);
            // The drawing's own holds may be the rear alone (above): the cups hold as the robot says.
            d.cups[1].holds = true;
        }
        // Only the body under the holds themselves says where a reach or a plan starts.
        let exact = if error.is_none() { held } else { None };
        Some((Prediction { body: drawn, error }, exact))
    }
}
