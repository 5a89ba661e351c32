//! The sideways maneuver on a vertical wall (paper Fig. 11, docs/model3d.md
//! section 11): strides of the three-tube body in 3D ([`crate::body3`]) that
//! move the robot along the wall without turning it.
//!
//! # Frame
//!
//! World x horizontal, y up, `z = x cross y` (as [`crate::body3`]). The wall
//! is the plane `x = x_w`, solid at `x >= x_w`, its outward normal
//! `n_w = (-1, 0, 0)`; it spans `y` (up) and `z` (sideways, the lateral
//! direction). The robot heads up (`+y`) with its cups facing the wall: the
//! driving unit's frame is `R0 = rot_z(90 deg)`, the rear cup's face centre
//! on the wall at `(x_w, y, z)`.
//!
//! # A stride
//!
//! 1. **Turn** (rear hold, [`Phase::Push`]): the side tubes made unequal,
//!    `L2 = L_t + s D / 2`, `L3 = L_t - s D / 2` (`L_t` the turn length, `D`
//!    the difference, `s = +-1` the side), bend the body in the wall's plane;
//!    `L1` is found by the secant method so that the front cup's face centre
//!    meets the wall, `x_f - x_w = 0` (to [`LANDING_TOLERANCE_M`]). The face
//!    must then lie flush within the robot file's attach tolerances: the
//!    angle between its normal `R_P e_y` and `n_w` at most
//!    `cup.attach_angle_tolerance_deg`.
//! 2. **Attach the front cup** ([`Phase::AttachFront`]): the face is taken
//!    flush (its centre on the wall, its normal `n_w`: the cup's suction
//!    pulls it there, within the tolerances just checked) and both cups
//!    hold ([`Hold3::Both`], the rear where the unit is): each cup's
//!    reaction and verdict.
//! 3. **Release the rear cup** ([`Phase::ReleaseRear`]): the body swings
//!    about the front cup's free joint (axis `n_w` through the face centre
//!    `P`) until gravity's moment about it vanishes
//!    ([`Hold3::FrontPivot`]): its centre of mass ends straight below `P`.
//!    The front cup's verdict must hold there and, checked conservatively
//!    with the joint locked ([`Hold3::Front`], the twist counted as shear),
//!    at [`SWING_SAMPLES`] turns along the way.
//! 4. **Settle** ([`Phase::Pull`]): still hanging on the free joint, the
//!    side tubes are made equal again, `L2 = L3 = L_r` (the rest length), and
//!    `L1` is found by the secant method so that the rear cup's face centre
//!    meets the wall; its normal must be within the attach angle of `n_w`.
//!    With `L2 = L3` the body is mirror-symmetric about the vertical plane
//!    through `P`, so the rear cup lands at `P`'s lateral coordinate:
//!
//!    ```text
//!    dz (stride) = z_P - z_rear,start        (m)
//!    ```
//! 5. **Attach the rear cup** ([`Phase::AttachRear`]) where it landed, both
//!    cups holding ([`Hold3::Both`] where the unit and the plate are: the
//!    loop closes without preload, so the rear cup takes next to nothing
//!    until the front lets go), and **release the front cup**
//!    ([`Phase::ReleaseFront`]): the rear hold at the settled lengths.
//!
//! Every stride starts from the same rear-held body (heading up, flush) at
//! another place, so it is the first stride moved: the lengths are searched
//! once. The lateral displacement `dz(D)` is odd in `D` (L2 and L3 swapped
//! mirror the body in z) and grows with `|D|`; a goal `G` takes
//! `n = ceil(|G| / |dz(D_max)|)` strides of `G / n` each, `D` found by
//! regula falsi on `dz(s D) = G / n` over `(0, D_max]`.
//!
//! # When there is no plan
//!
//! The plan ends [`Status::Impossible`] with a reason (never a panic) when
//! the goal or a cup's landing lies off the wall (each face wholly on it:
//! its centre at least the cup's radius inside the wall's edges), a length
//! leaves the robot's limits, a search does not converge, a face cannot lie
//! flush, a cup's verdict fails, or a 3D solve fails; it ends
//! [`Status::Stopped`] (the reason says where) when the solver's deadline
//! ran out first, as the planar plan does: no verdict on the climb.

use serde::Deserialize;

use super::machine::Phase;
use super::plan::Status;
use crate::body3::Body3;
use crate::error::{within, InputError};
use crate::geom3::{column, cross, dot, exp, mul, scale, Mat3, Vec3};
use crate::hold::{AsBuilt, Hold3, Pose3};
use crate::robot::Robot;
use crate::scene::file::parse_bounded;
use crate::scene::MAX_COORDINATE_M;
use crate::stance3::place3::front_tip;
use crate::stance3::{self, Held3};
use crate::statics::Solver;

/// The wall's outward normal `n_w` (free space at `x < x_w`).
pub const WALL_NORMAL: Vec3 = [-1.0, 0.0, 0.0];

/// How close a searched cup's face centre must come to the wall (m): far
/// below any attach tolerance, so the flush check is the tilt's alone.
pub const LANDING_TOLERANCE_M: f64 = 1e-7;

/// Secant iterations on `L1` before a landing search gives up.
const LANDING_ITERATIONS: usize = 30;

/// Regula falsi iterations on the side difference before the lateral search gives up.
const LATERAL_ITERATIONS: usize = 60;

/// The first secant step on `L1` (m).
const FIRST_STEP_M: f64 = 1e-3;

/// Turns along the swing (besides its ends) at which the front cup's verdict
/// is checked with the joint locked.
pub const SWING_SAMPLES: usize = 3;

/// The built-in sideways scenarios (files under `crates/leech/scenarios/`).
pub const BUILTIN_SIDEWAYS: [super::scenario::BuiltinScenario; 1] = [super::scenario::BuiltinScenario {
    name: "sideways-wall",
    toml: include_str!("../../scenarios/sideways-wall.toml"),
}];

/// The largest number of strides a plan may take.
pub const MAX_STRIDES: usize = 200;

/// The wall: the plane `x = x_m` with its edges (m).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Wall {
    /// Where the wall's plane is (m); solid at `x >= x_m`.
    pub x_m: f64,
    /// Its bottom and top (m).
    pub y_range_m: [f64; 2],
    /// Its sides (m), along the lateral direction z.
    pub z_range_m: [f64; 2],
}

impl Wall {
    /// Whether a cup's face of radius `radius_m` centred at `(y, z)` lies
    /// wholly on the wall; otherwise which edge it crosses.
    fn off(&self, [y, z]: [f64; 2], radius_m: f64) -> Option<&'static str> {
        if y - radius_m < self.y_range_m[0] {
            Some("below the wall's bottom")
        } else if y + radius_m > self.y_range_m[1] {
            Some("above the wall's top")
        } else if z - radius_m < self.z_range_m[0] || z + radius_m > self.z_range_m[1] {
            Some("beyond the wall's side")
        } else {
            None
        }
    }
}

/// A sideways climb to plan: the wall, where the rear cup starts, the goal.
#[derive(Clone, Debug, PartialEq)]
pub struct SidewaysScenario {
    /// Display name.
    pub name: String,
    /// One line saying what it is.
    pub description: String,
    /// The wall.
    pub wall: Wall,
    /// The rear cup's face centre `(y, z)` on the wall at the start (m); the body heads up.
    pub start_m: [f64; 2],
    /// How far to move along `+z` (m; negative: along `-z`).
    pub lateral_m: f64,
    /// How close to `start z + lateral_m` the rear cup must end (m).
    pub tolerance_m: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSideways {
    name: String,
    #[serde(default)]
    description: String,
    wall: RawWall,
    start: RawSidewaysStart,
    goal: RawLateral,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWall {
    x_m: f64,
    y_range_m: Vec<f64>,
    z_range_m: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSidewaysStart {
    rear_cup_m: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLateral {
    lateral_m: f64,
    tolerance_m: f64,
}

impl SidewaysScenario {
    /// Parses and validates a sideways scenario file (`source` starts every
    /// error message). Keys: `name`, `description`; `[wall] x_m`,
    /// `y_range_m = [bottom, top]`, `z_range_m = [side, side]`;
    /// `[start] rear_cup_m = [y, z]`; `[goal] lateral_m`, `tolerance_m`
    /// (above 0, at most [`super::scenario::MAX_TOLERANCE_M`]). Coordinates
    /// within [`MAX_COORDINATE_M`]; unknown keys are errors.
    pub fn parse(text: &str, source: &str) -> Result<SidewaysScenario, InputError> {
        let raw: RawSideways = parse_bounded(text, source, "scenario")?;
        let m = MAX_COORDINATE_M;
        let coordinate = |key: &str, v: f64| within(&format!("{source}: {key} (m)"), v, -m, m);
        let pair = |key: &str, v: &[f64], what: &str| -> Result<[f64; 2], InputError> {
            match v {
                [a, b] => Ok([coordinate(key, *a)?, coordinate(key, *b)?]),
                other => Err(InputError::Invalid {
                    field: format!("{source}: {key}"),
                    value: format!("{} numbers", other.len()),
                    allowed: what.into(),
                }),
            }
        };
        let range = |key: &str, v: &[f64]| -> Result<[f64; 2], InputError> {
            let [lo, hi] = pair(key, v, "[low, high] (m), low below high")?;
            if lo < hi {
                Ok([lo, hi])
            } else {
                Err(InputError::Invalid {
                    field: format!("{source}: {key}"),
                    value: format!("[{lo}, {hi}]"),
                    allowed: "[low, high] (m), low below high".into(),
                })
            }
        };
        let wall = Wall {
            x_m: coordinate("wall.x_m", raw.wall.x_m)?,
            y_range_m: range("wall.y_range_m", &raw.wall.y_range_m)?,
            z_range_m: range("wall.z_range_m", &raw.wall.z_range_m)?,
        };
        let start_m = pair("start.rear_cup_m", &raw.start.rear_cup_m, "[y, z] (m) on the wall")?;
        let lateral_m = within(&format!("{source}: goal.lateral_m"), raw.goal.lateral_m, -m, m)?;
        let tolerance_m = super::scenario::goal_tolerance(source, raw.goal.tolerance_m)?;
        crate::error::printable(&format!("{source}: name"), &raw.name)?;
        crate::error::printable(&format!("{source}: description"), &raw.description)?;
        Ok(SidewaysScenario { name: raw.name, description: raw.description, wall, start_m, lateral_m, tolerance_m })
    }

    /// The built-in sideways scenario called `name`, if there is one ([`BUILTIN_SIDEWAYS`]).
    pub fn builtin(name: &str) -> Option<Result<SidewaysScenario, InputError>> {
        let b = BUILTIN_SIDEWAYS.iter().find(|b| b.name == name)?;
        Some(SidewaysScenario::parse(b.toml, &format!("built-in scenario {name}")))
    }

    /// Whether a scenario file's text is a sideways one: it has a `[wall]`
    /// table (a planar scenario has a `scene`).
    pub fn is_sideways(text: &str) -> bool {
        text.parse::<toml::Table>().is_ok_and(|t| t.contains_key("wall"))
    }
}

/// The stride's lengths: what the planner may choose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SidewaysOptions {
    /// The side tubes' length at rest, before and after a stride (m).
    pub rest_length_m: f64,
    /// The side tubes' mean length while turning, `L_t` (m).
    pub turn_length_m: f64,
    /// The largest side difference `D = |L2 - L3|` (m).
    pub max_difference_m: f64,
}

impl Default for SidewaysOptions {
    /// For the built-in robot: 0.10 m at rest, 0.15 m turning, at most
    /// 0.02 m between the side tubes (a turn of about a radian: chosen so a
    /// stride moves a few centimetres and the hanging body stays short).
    fn default() -> Self {
        SidewaysOptions { rest_length_m: 0.10, turn_length_m: 0.15, max_difference_m: 0.02 }
    }
}

/// One phase's end: its lengths and the held body.
#[derive(Clone, Debug, PartialEq)]
pub struct SidewaysStep {
    /// The phase that ended here ([`Phase::Start`] for the start).
    pub phase: Phase,
    /// The stride it belongs to (0 for the start).
    pub stride: usize,
    /// Tube lengths `[L1, L2, L3]` (m).
    pub lengths_m: [f64; 3],
    /// The body held by its cup: frames, cup states with verdicts.
    pub held: Held3,
    /// For the swing: the smallest safety factor of the front cup along it
    /// (the joint locked at [`SWING_SAMPLES`] turns, and the end).
    pub swing_safety_factor: Option<f64>,
}

/// A planned sideways climb, or the reason there is none.
#[derive(Clone, Debug, PartialEq)]
pub struct SidewaysPlan {
    /// Reached, impossible, or stopped by the solver's deadline.
    pub status: Status,
    /// Why it is impossible, or where it stopped.
    pub reason: Option<String>,
    /// Strides planned (for an impossible plan: those that succeeded).
    pub strides: usize,
    /// The lateral move of one stride (m, signed along z).
    pub stride_lateral_m: f64,
    /// The rear cup's lateral move from the start to the last step (m).
    pub lateral_m: f64,
    /// Every phase's end, from the start.
    pub steps: Vec<SidewaysStep>,
}

/// A stride's lengths: turning and settled.
#[derive(Clone, Copy, Debug, PartialEq)]
struct StrideLengths {
    turn: [f64; 3],
    settle: [f64; 3],
}

/// Why planning stopped: a reason for the plan.
type Blocked = String;

/// The sideways climbs' planner for `robot` (its cups, tubes, limits).
struct Planner<'a> {
    robot: Robot,
    solver: &'a Solver,
    wall: Wall,
    radius_m: f64,
}

/// The unit vector turned minimally onto `WALL_NORMAL`: the rotation taking
/// `a` (unit) there, `Exp(angle axis)`.
fn onto_wall(a: Vec3) -> Mat3 {
    let axis = cross(a, WALL_NORMAL);
    let sin = dot(axis, axis).sqrt();
    let angle = sin.atan2(dot(a, WALL_NORMAL));
    if sin == 0.0 {
        return exp([0.0; 3]);
    }
    exp(scale(angle / sin, axis))
}

/// Angle between the unit vector `a` and the wall's normal (rad).
fn tilt(a: Vec3) -> f64 {
    dot(cross(a, WALL_NORMAL), cross(a, WALL_NORMAL)).sqrt().atan2(dot(a, WALL_NORMAL))
}

impl<'a> Planner<'a> {
    fn new(robot: &Robot, solver: &'a Solver, wall: Wall) -> Planner<'a> {
        let mut robot = robot.clone();
        // Heading up the wall: +x of the unit turned to +y.
        robot.world.base_angle_deg = 90.0;
        let radius_m = 0.5 * robot.cup.diameter_m;
        Planner { robot, solver, wall, radius_m }
    }

    /// The body at `lengths` with its rear cup's face centre at `(y, z)` on
    /// the wall, heading up.
    fn body_at(&self, lengths: [f64; 3], [y, z]: [f64; 2]) -> Result<Body3, Blocked> {
        let body = Body3::from_robot(&self.robot, lengths).map_err(|e| format!("{e}"))?;
        let c = body.rear_cup_centre(&self.robot);
        Ok(body.placed(&exp([0.0; 3]), [self.wall.x_m - c[0], y - c[1], z - c[2]]))
    }

    fn solve(&self, body: &Body3, hold: Hold3, lengths: [f64; 3]) -> Result<Held3, Blocked> {
        stance3::solve(&self.robot, body, hold, self.solver)
            .map_err(|e| format!("the 3D solve at lengths {} failed: {e}", show(lengths)))
    }

    /// The rear hold at `lengths` from `(y, z)`.
    fn rear(&self, lengths: [f64; 3], at: [f64; 2]) -> Result<Held3, Blocked> {
        self.solve(&self.body_at(lengths, at)?, Hold3::Rear(AsBuilt), lengths)
    }

    /// The front cup's face of a rear-held body: centre and normal.
    fn front_face(&self, held: &Held3) -> (Vec3, Vec3) {
        held.body.front_face(&self.robot, &held.equilibrium.frames)
    }

    /// Secant on `L1` (from `guess`) for a face (`face` of a solved state) at
    /// the wall: returns the lengths and the state there.
    fn land(
        &self,
        what: &str,
        guess: f64,
        sides: [f64; 2],
        solve: impl Fn([f64; 3]) -> Result<Held3, Blocked>,
        face: impl Fn(&Held3) -> (Vec3, Vec3),
    ) -> Result<([f64; 3], Held3), Blocked> {
        let lengths = |l1: f64| [l1, sides[0], sides[1]];
        let gap = |l1: f64| -> Result<(f64, Held3), Blocked> {
            let l = lengths(l1);
            self.check_lengths(l)?;
            let held = solve(l)?;
            Ok((face(&held).0[0] - self.wall.x_m, held))
        };
        let (mut a, (mut fa, mut held)) = (guess, gap(guess)?);
        let mut b = guess + FIRST_STEP_M;
        for _ in 0..LANDING_ITERATIONS {
            if fa.abs() <= LANDING_TOLERANCE_M {
                self.flush(what, &held, face(&held))?;
                return Ok((lengths(a), held));
            }
            let (fb, held_b) = gap(b)?;
            let next = b - fb * (b - a) / (fb - fa);
            if !next.is_finite() {
                break;
            }
            (a, fa, held) = (b, fb, held_b);
            b = next;
        }
        Err(format!(
            "the {what} cup's landing search did not converge: {:.2e} m from the wall after {LANDING_ITERATIONS} \
             secant steps on L1 (sides {})",
            fa.abs(),
            show_pair(sides)
        ))
    }

    /// Every length within the robot's limits.
    fn check_lengths(&self, l: [f64; 3]) -> Result<(), Blocked> {
        let lim = &self.robot.limits;
        if l.iter().all(|x| (lim.tube_length_min_m..=lim.tube_length_max_m).contains(x)) {
            return Ok(());
        }
        Err(format!(
            "a turn the tubes cannot make: lengths {} leave the robot's limits [{}, {}] m",
            show(l),
            lim.tube_length_min_m,
            lim.tube_length_max_m
        ))
    }

    /// The turn with side difference `d` (signed: `L2 - L3`) from the
    /// canonical start: its lengths and the front cup's flush landing.
    fn turn(&self, d: f64, start: [f64; 2], options: &SidewaysOptions) -> Result<([f64; 3], Held3), Blocked> {
        let sides = [options.turn_length_m + 0.5 * d, options.turn_length_m - 0.5 * d];
        self.land("front", options.turn_length_m, sides, |l| self.rear(l, start), |h| self.front_face(h))
    }

    /// The front cup attached flush where `held` (rear hold) put it: its face
    /// centre on the wall and the plate turned so its normal is the wall's.
    fn attached_front(&self, held: &Held3) -> (Vec3, Mat3) {
        let (centre, normal) = self.front_face(held);
        let plate = held.body.plate_frame(&held.equilibrium.frames);
        ([self.wall.x_m, centre[1], centre[2]], mul(&onto_wall(normal), &plate))
    }

    /// Both cups holding ([`Hold3::Both`]): `body` (at `lengths`) with its
    /// driving unit where it is, its front cup's face centre at `centre`
    /// with the plate's frame `plate`; each cup must hold.
    fn both(&self, body: &Body3, lengths: [f64; 3], centre: Vec3, plate: &Mat3) -> Result<Held3, Blocked> {
        let hold = Hold3::Both {
            rear: AsBuilt,
            front: Pose3 { point_m: front_tip(&self.robot, centre, plate), frame: *plate },
        };
        let held = self.solve(body, hold, lengths)?;
        self.holding("rear (both holding)", &held, held.rear.as_ref())?;
        self.holding("front (both holding)", &held, held.front.as_ref())?;
        Ok(held)
    }

    /// The swing from the flush front cup: the free joint's rest, and the
    /// smallest safety factor of the front cup along it.
    fn swing(&self, lengths: [f64; 3], centre: Vec3, plate: &Mat3) -> Result<(Held3, f64), Blocked> {
        let body = Body3::from_robot(&self.robot, lengths).map_err(|e| format!("{e}"))?;
        let tip = front_tip(&self.robot, centre, plate);
        let held = self.solve(&body, Hold3::FrontPivot(Pose3 { point_m: tip, frame: *plate }), lengths)?;
        let turn = held.pivot_turn_rad.unwrap_or(0.0);
        let mut worst = self.holding("front", &held, held.front.as_ref())?;
        for k in 1..=SWING_SAMPLES {
            let psi = turn * k as f64 / (SWING_SAMPLES + 1) as f64;
            let locked = Hold3::Front(Pose3 { point_m: tip, frame: mul(&exp(scale(psi, WALL_NORMAL)), plate) });
            let at = self.solve(&body, locked, lengths)?;
            worst = worst.min(self.holding("front (along the swing)", &at, at.front.as_ref())?);
        }
        Ok((held, worst))
    }

    /// The safety factor of a cup that must hold.
    fn holding(&self, what: &str, held: &Held3, cup: Option<&crate::stance3::CupState3>) -> Result<f64, Blocked> {
        let Some(cup) = cup else {
            return Err(format!("the {what} cup does not hold in {:?}", held.hold));
        };
        if cup.verdict.holds {
            Ok(cup.verdict.safety_factor)
        } else {
            Err(format!(
                "the {what} cup at ({:.4}, {:.4}) m lets go: safety factor {:.3}",
                cup.centre_m[1], cup.centre_m[2], cup.verdict.safety_factor
            ))
        }
    }

    /// The body hanging on the free joint at `centre` at `lengths`, its
    /// swing starting where `swung` came to rest.
    fn hang(&self, lengths: [f64; 3], centre: Vec3, swung: &Held3) -> Result<Held3, Blocked> {
        let plate = swung.body.plate_frame(&swung.equilibrium.frames);
        let body = Body3::from_robot(&self.robot, lengths).map_err(|e| format!("{e}"))?;
        let pivot = Pose3 { point_m: front_tip(&self.robot, centre, &plate), frame: plate };
        self.solve(&body, Hold3::FrontPivot(pivot), lengths)
    }

    /// The rear cup's face of a body: centre and the surface's normal.
    fn rear_face(&self, held: &Held3) -> (Vec3, Vec3) {
        (held.body.rear_cup_centre(&self.robot), column(&held.body.base_frame(), 1))
    }

    /// Whether a face (centre, normal) lies flush on the wall within the
    /// robot file's attach tolerances.
    fn flush(&self, what: &str, held: &Held3, (centre, normal): (Vec3, Vec3)) -> Result<(), Blocked> {
        let cup = &self.robot.cup;
        let (gap, angle) = (centre[0] - self.wall.x_m, tilt(normal));
        if gap.abs() <= cup.attach_distance_tolerance_m && angle <= cup.attach_angle_tolerance_deg.to_radians() {
            return Ok(());
        }
        Err(format!(
            "the {what} cup meets the wall at ({:.4}, {:.4}) m {:.2e} m off it and tilted {:.2} deg (at most {} m \
             and {} deg) in {:?}",
            centre[1],
            centre[2],
            gap,
            angle.to_degrees(),
            cup.attach_distance_tolerance_m,
            cup.attach_angle_tolerance_deg,
            held.hold
        ))
    }

    /// The settle: the side tubes at the rest length, still on the free
    /// joint, `L1` found so the rear cup's face meets the wall.
    fn settle(&self, centre: Vec3, swung: &Held3, options: &SidewaysOptions) -> Result<([f64; 3], Held3), Blocked> {
        let rest = options.rest_length_m;
        self.land("rear", rest, [rest, rest], |l| self.hang(l, centre, swung), |h| self.rear_face(h))
    }

    /// The lengths of a stride moving `target` (m, signed) sideways, and the
    /// move of the largest turn, searched from the canonical start.
    fn lengths(&self, target: f64, options: &SidewaysOptions) -> Result<(StrideLengths, f64), Blocked> {
        // Any place will do: every stride is this one moved.
        let origin = [0.0, 0.0];
        let moved = |d: f64| -> Result<([f64; 3], Held3, f64), Blocked> {
            let (l, held) = self.turn(d, origin, options)?;
            let dz = self.front_face(&held).0[2] - origin[1];
            Ok((l, held, dz))
        };
        let d_max = options.max_difference_m;
        let (_, _, widest) = moved(d_max)?;
        if widest == 0.0 || !widest.is_finite() {
            return Err(format!(
                "a turn the tubes cannot make: side difference {d_max} m moves the front cup {widest} m"
            ));
        }
        // dz is odd in D: the side to turn to is the goal's.
        let side = (target * widest).signum();
        let n = (target.abs() / widest.abs()).ceil().max(1.0);
        let per = target / n;
        let mut bracket = crate::root::Bracket::new((0.0, -per.abs()), (d_max, widest.abs() - per.abs()));
        let mut found = None;
        for _ in 0..LATERAL_ITERATIONS {
            let (b, fb) = bracket.b();
            let c = if fb.abs() <= LANDING_TOLERANCE_M { b } else { bracket.next() };
            let (l, held, dz) = moved(side * c)?;
            let fc = dz.abs() - per.abs();
            if fc.abs() <= LANDING_TOLERANCE_M {
                found = Some((l, held));
                break;
            }
            bracket.narrow(c, fc);
        }
        let Some((turn, held)) = found else {
            return Err(format!("the lateral search did not converge on a stride of {per:.4} m"));
        };
        let (centre, plate) = self.attached_front(&held);
        let (swung, _) = self.swing(turn, centre, &plate)?;
        let (settle, _) = self.settle(centre, &swung, options)?;
        Ok((StrideLengths { turn, settle }, per))
    }
}

fn show(l: [f64; 3]) -> String {
    format!("{:.4}/{:.4}/{:.4} m", l[0], l[1], l[2])
}

fn show_pair(l: [f64; 2]) -> String {
    format!("{:.4}/{:.4} m", l[0], l[1])
}

/// Plans the sideways climb `scenario` for `robot` with `options`, every
/// body solved by `solver` (module doc). Bad input (options, a start off
/// the wall) is an error naming the field; a climb that cannot be made is a
/// plan with [`Status::Impossible`] and its reason.
pub fn plan_sideways(
    robot: &Robot,
    scenario: &SidewaysScenario,
    options: &SidewaysOptions,
    solver: &Solver,
) -> Result<SidewaysPlan, InputError> {
    for (field, v) in [
        ("rest_length_m", options.rest_length_m),
        ("turn_length_m", options.turn_length_m),
        ("max_difference_m", options.max_difference_m),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= 1.0) {
            return Err(InputError::invalid(format!("sideways options: {field}"), v, "a number of m in (0, 1]"));
        }
    }
    // The robot must make a 3D body (the paper's discretization).
    Body3::from_robot(
        robot,
        [options.rest_length_m.clamp(robot.limits.tube_length_min_m, robot.limits.tube_length_max_m); 3],
    )?;
    let planner = Planner::new(robot, solver, scenario.wall);
    if let Some(where_) = scenario.wall.off(scenario.start_m, planner.radius_m) {
        return Err(InputError::Invalid {
            field: format!("{}: start.rear_cup_m", scenario.name),
            value: format!("[{}, {}] ({where_})", scenario.start_m[0], scenario.start_m[1]),
            allowed: format!(
                "a point where the rear cup's face ({} m across) lies wholly on the wall",
                robot.cup.diameter_m
            ),
        });
    }
    let mut plan = SidewaysPlan {
        status: Status::Impossible,
        reason: None,
        strides: 0,
        stride_lateral_m: 0.0,
        lateral_m: 0.0,
        steps: Vec::new(),
    };
    if let Err(reason) = fill(&planner, scenario, options, &mut plan) {
        // A solve the deadline cut short proves nothing about the climb.
        if solver.options.deadline.expired() {
            plan.status = Status::Stopped;
        }
        plan.reason = Some(reason);
    }
    Ok(plan)
}

/// The plan's steps into `plan`; `Err` with the reason where it stops.
fn fill(
    planner: &Planner,
    scenario: &SidewaysScenario,
    options: &SidewaysOptions,
    plan: &mut SidewaysPlan,
) -> Result<(), Blocked> {
    let [y0, z0] = scenario.start_m;
    let goal_z = z0 + scenario.lateral_m;
    if let Some(where_) = planner.wall.off([y0, goal_z], planner.radius_m) {
        return Err(format!("the goal (rear cup at z = {goal_z} m) is {where_}"));
    }
    let rest = [options.rest_length_m; 3];
    let start = planner.rear(rest, scenario.start_m)?;
    let step =
        |phase, stride, lengths_m, held| SidewaysStep { phase, stride, lengths_m, held, swing_safety_factor: None };
    planner.holding("rear", &start, start.rear.as_ref())?;
    plan.steps.push(step(Phase::Start, 0, rest, start));
    if scenario.lateral_m.abs() <= scenario.tolerance_m {
        plan.status = Status::Reached;
        return Ok(());
    }
    if !planner.robot.cup.front_free_joint {
        return Err("the sideways maneuver swings the body back on the front cup's free joint, which this robot's \
                    front cup has not (cup.front_free_joint = false)"
            .into());
    }
    let (lengths, per) = planner.lengths(scenario.lateral_m, options)?;
    let n = (scenario.lateral_m / per).round() as usize;
    if n > MAX_STRIDES {
        return Err(format!("the goal needs {n} strides of {per:.4} m, more than {MAX_STRIDES}"));
    }
    plan.stride_lateral_m = per;
    let mut at = scenario.start_m;
    for stride in 1..=n {
        let turned = planner.rear(lengths.turn, at)?;
        planner.holding("rear", &turned, turned.rear.as_ref())?;
        let (centre, plate) = planner.attached_front(&turned);
        if let Some(where_) = planner.wall.off([centre[1], centre[2]], planner.radius_m) {
            return Err(format!(
                "stride {stride}: the front cup would land at ({:.4}, {:.4}) m, {where_}",
                centre[1], centre[2]
            ));
        }
        let attached = planner.both(&turned.body, lengths.turn, centre, &plate)?;
        plan.steps.push(step(Phase::Push, stride, lengths.turn, turned));
        plan.steps.push(step(Phase::AttachFront, stride, lengths.turn, attached));
        let (swung, worst) = planner.swing(lengths.turn, centre, &plate)?;
        let mut release = step(Phase::ReleaseRear, stride, lengths.turn, swung.clone());
        release.swing_safety_factor = Some(worst);
        plan.steps.push(release);
        // Every stride is the first one moved: its settled lengths land it.
        let settle = lengths.settle;
        let settled = planner.hang(settle, centre, &swung)?;
        planner.flush("rear", &settled, planner.rear_face(&settled))?;
        planner.holding("front", &settled, settled.front.as_ref())?;
        let rear = settled.body.rear_cup_centre(&planner.robot);
        let landed = [rear[1], rear[2]];
        if let Some(where_) = planner.wall.off(landed, planner.radius_m) {
            return Err(format!(
                "stride {stride}: the rear cup would land at ({:.4}, {:.4}) m, {where_}",
                landed[0], landed[1]
            ));
        }
        let hanging_plate = settled.body.plate_frame(&settled.equilibrium.frames);
        let attached = planner.both(&settled.body, settle, centre, &hanging_plate)?;
        plan.steps.push(step(Phase::Pull, stride, settle, settled));
        plan.steps.push(step(Phase::AttachRear, stride, settle, attached));
        let held = planner.rear(settle, landed)?;
        planner.holding("rear", &held, held.rear.as_ref())?;
        plan.steps.push(step(Phase::ReleaseFront, stride, settle, held));
        at = landed;
        plan.strides = stride;
        plan.lateral_m = at[1] - z0;
    }
    if (plan.lateral_m - scenario.lateral_m).abs() <= scenario.tolerance_m {
        plan.status = Status::Reached;
        Ok(())
    } else {
        Err(format!(
            "the strides end {:.4} m sideways, not within {} m of the goal's {} m",
            plan.lateral_m, scenario.tolerance_m, scenario.lateral_m
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom3::axpy;

    fn scenario(lateral_m: f64) -> SidewaysScenario {
        SidewaysScenario {
            name: "t".into(),
            description: String::new(),
            wall: Wall { x_m: 0.0, y_range_m: [-1.0, 1.0], z_range_m: [-1.0, 1.0] },
            start_m: [0.0, 0.0],
            lateral_m,
            tolerance_m: 0.005,
        }
    }

    fn plan(lateral_m: f64) -> SidewaysPlan {
        plan_sideways(&Robot::builtin(), &scenario(lateral_m), &SidewaysOptions::default(), &Solver::default()).unwrap()
    }

    fn com(held: &Held3) -> Vec3 {
        let (mass, first) =
            held.body.first_moment(&held.equilibrium.frames, Robot::builtin().unit_mass_kg(held.body.tube_lengths()));
        scale(1.0 / mass, first)
    }

    #[test]
    fn a_stride_moves_to_the_pivot_and_hangs_below_it() {
        let robot = Robot::builtin();
        let p = plan(0.1);
        assert_eq!(p.status, Status::Reached, "{:?}", p.reason);
        assert!(p.strides >= 2, "{}", p.strides);
        assert!((p.lateral_m - 0.1).abs() <= 0.005, "{}", p.lateral_m);
        let mut rear_z = 0.0;
        for s in &p.steps {
            // Every held state's cups hold.
            for cup in [&s.held.rear, &s.held.front].into_iter().flatten() {
                assert!(cup.verdict.holds, "{:?} {}", s.phase, cup.verdict.safety_factor);
            }
            match s.phase {
                Phase::ReleaseRear => {
                    let pivot = s.held.front.as_ref().unwrap().centre_m;
                    let c = com(&s.held);
                    assert!((c[2] - pivot[2]).abs() < 1e-9 && (c[0] - pivot[0]).abs() < 0.05, "{c:?} {pivot:?}");
                    assert!(c[1] < pivot[1] - 0.01, "{c:?} {pivot:?}");
                    assert!(s.swing_safety_factor.unwrap() >= 1.0);
                    assert!(s.lengths_m[1] != s.lengths_m[2]);
                    // The stride moves the rear cup to the pivot's z.
                    assert!((pivot[2] - rear_z - p.stride_lateral_m).abs() < 1e-6, "{pivot:?} {rear_z}");
                }
                Phase::Pull => {
                    let (centre, normal) = (s.held.body.rear_cup_centre(&robot), column(&s.held.body.base_frame(), 1));
                    assert!((centre[0] - 0.0).abs() <= robot.cup.attach_distance_tolerance_m, "{centre:?}");
                    assert!(tilt(normal) <= robot.cup.attach_angle_tolerance_deg.to_radians());
                    let pivot = s.held.front.as_ref().unwrap().centre_m;
                    assert!((centre[2] - pivot[2]).abs() < 1e-9, "{centre:?} {pivot:?}");
                    assert_eq!(s.lengths_m[1], s.lengths_m[2]);
                }
                Phase::ReleaseFront => rear_z = s.held.rear.as_ref().unwrap().centre_m[2],
                _ => {}
            }
        }
        assert!((rear_z - p.lateral_m).abs() < 1e-12);
    }

    /// In the attach steps both cups hold and the two reactions carry the
    /// whole robot (force, and moment about the rear cup's centre, from the
    /// masses alone); the front face pulled flush shares the weight, the
    /// rear cup attached where the unit hangs carries nothing.
    #[test]
    fn attaching_a_cup_shares_the_weight_between_both() {
        let robot = Robot::builtin();
        let p = plan(0.05);
        assert_eq!(p.status, Status::Reached, "{:?}", p.reason);
        let mut seen = 0;
        for s in p.steps.iter().filter(|s| matches!(s.phase, Phase::AttachFront | Phase::AttachRear)) {
            assert!(matches!(s.held.hold, Hold3::Both { .. }), "{:?}", s.held.hold);
            let (rear, front) = (s.held.rear.clone().unwrap(), s.held.front.clone().unwrap());
            assert!(rear.verdict.holds && front.verdict.holds, "{:?}", s.phase);
            // Both faces lie on the wall; the front one flush, the rear one
            // within the attach angle (flush when the front attaches).
            let angle = robot.cup.attach_angle_tolerance_deg.to_radians();
            for (cup, most) in [(&rear, if s.phase == Phase::AttachFront { 1e-9 } else { angle }), (&front, 1e-9)] {
                assert!(cup.centre_m[0].abs() < 1e-9 && tilt(cup.normal) <= most, "{:?}: {cup:?}", s.phase);
            }
            let eq = &s.held.equilibrium;
            assert!(eq.stable, "{:?}", s.phase);
            let (mass, first) = s.held.body.first_moment(&eq.frames, robot.unit_mass_kg(s.held.body.tube_lengths()));
            let up = [0.0, s.held.body.gravity(), 0.0];
            let weight = scale(mass, up);
            let about = rear.centre_m;
            let moment = cross(axpy(-mass, about, first), up);
            let front_about = cross(axpy(-1.0, about, front.centre_m), front.reaction.force_n);
            let total = axpy(1.0, rear.reaction.force_n, front.reaction.force_n);
            let turning = axpy(1.0, rear.reaction.moment_nm, axpy(1.0, front_about, front.reaction.moment_nm));
            for a in 0..3 {
                assert!((total[a] - weight[a]).abs() < 1e-8 * weight[1], "{:?}: {total:?}", s.phase);
                assert!(
                    (turning[a] - moment[a]).abs() < 1e-8 * weight[1] * 0.2,
                    "{:?}: {turning:?} {moment:?}",
                    s.phase
                );
            }
            if s.phase == Phase::AttachFront {
                // The front face pulled flush loads the loop: each cup takes a share.
                assert!(
                    rear.reaction.force_n[1] > 0.1 * weight[1] && front.reaction.force_n[1].abs() > 0.1 * weight[1]
                );
            } else {
                // The rear cup attached where the unit hangs: no preload, no load.
                assert!(dot(rear.reaction.force_n, rear.reaction.force_n).sqrt() < 1e-8 * weight[1], "{rear:?}");
            }
            seen += 1;
        }
        assert_eq!(seen, 2 * p.strides);
    }

    #[test]
    fn a_goal_to_the_other_side_mirrors_the_lengths_and_z() {
        let (right, left) = (plan(0.07), plan(-0.07));
        assert_eq!(right.steps.len(), left.steps.len());
        assert!((right.lateral_m + left.lateral_m).abs() < 1e-9);
        for (r, l) in right.steps.iter().zip(&left.steps) {
            let [a, b] = [r.lengths_m, l.lengths_m];
            assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[2]).abs() < 1e-9 && (a[2] - b[1]).abs() < 1e-9);
            for (cr, cl) in [(&r.held.rear, &l.held.rear), (&r.held.front, &l.held.front)] {
                let (Some(cr), Some(cl)) = (cr, cl) else {
                    assert!(cr.is_none() && cl.is_none());
                    continue;
                };
                let [x, y, z] = cl.centre_m;
                let mirrored = [x, y, -z];
                assert!(
                    cr.centre_m.iter().zip(mirrored).all(|(p, q)| (p - q).abs() < 1e-9),
                    "{:?} {:?}",
                    cr.centre_m,
                    mirrored
                );
            }
        }
    }

    #[test]
    fn the_builtin_parses_and_bad_files_name_the_field() {
        let s = SidewaysScenario::builtin("sideways-wall").unwrap().unwrap();
        assert!(s.lateral_m > s.tolerance_m && s.wall.x_m == 0.0 && !s.description.is_empty());
        assert!(SidewaysScenario::is_sideways(BUILTIN_SIDEWAYS[0].toml));
        assert!(!SidewaysScenario::is_sideways(super::super::BUILTIN_SCENARIOS[0].toml));
        assert!(SidewaysScenario::builtin("crawl-floor").is_none());
        let text = BUILTIN_SIDEWAYS[0].toml;
        let bad =
            |from: &str, to: &str| SidewaysScenario::parse(&text.replace(from, to), "s.toml").unwrap_err().to_string();
        let e = bad("[-1.0, 1.0]  # bottom", "[1.0, -1.0]  # bottom");
        assert!(e.contains("s.toml: wall.y_range_m: got [1, -1]"), "{e}");
        let e = bad("[0.0, 0.0]", "[0.0]");
        assert!(e.contains("start.rear_cup_m: got 1 numbers"), "{e}");
        let e = bad("tolerance_m = 0.005", "tolerance_m = -1");
        assert!(e.contains("goal.tolerance_m: got -1"), "{e}");
        let e = bad("x_m = 0.0", "x_m = 0.0\ncolour = 1");
        assert!(e.contains("unknown field `colour`") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn impossible_climbs_end_with_a_reason() {
        let robot = Robot::builtin();
        let run = |s: &SidewaysScenario, o: &SidewaysOptions| plan_sideways(&robot, s, o, &Solver::default()).unwrap();
        let reason = |p: SidewaysPlan| {
            assert_eq!(p.status, Status::Impossible);
            p.reason.unwrap()
        };
        let mut short = scenario(0.1);
        short.wall.y_range_m = [-0.5, 0.1];
        let r = reason(run(&short, &SidewaysOptions::default()));
        assert!(r.contains("front cup would land") && r.contains("above the wall's top"), "{r}");
        let r = reason(run(&scenario(1.5), &SidewaysOptions::default()));
        assert!(r.contains("goal") && r.contains("beyond the wall's side"), "{r}");
        let wide = SidewaysOptions { max_difference_m: 0.4, ..SidewaysOptions::default() };
        let r = reason(run(&scenario(0.1), &wide));
        assert!(r.contains("a turn the tubes cannot make"), "{r}");
        let mut off = scenario(0.1);
        off.start_m = [0.0, 0.995];
        let e = plan_sideways(&robot, &off, &SidewaysOptions::default(), &Solver::default()).unwrap_err().to_string();
        assert!(e.contains("start.rear_cup_m") && !e.contains('\n'), "{e}");
        let bad = SidewaysOptions { rest_length_m: f64::NAN, ..SidewaysOptions::default() };
        let e = plan_sideways(&robot, &scenario(0.1), &bad, &Solver::default()).unwrap_err().to_string();
        assert!(e.contains("rest_length_m"), "{e}");
        // Within the tolerance already: no stride.
        let p = run(&scenario(0.004), &SidewaysOptions::default());
        assert_eq!((p.status, p.strides, p.steps.len()), (Status::Reached, 0, 1));
    }

    #[test]
    fn a_plan_cut_short_by_its_deadline_is_stopped_not_impossible() {
        use crate::statics::SolverOptions;
        let deadline = crate::budget::Deadline::after(std::time::Duration::ZERO);
        let solver = Solver::new(SolverOptions { deadline, ..SolverOptions::default() });
        let p = plan_sideways(&Robot::builtin(), &scenario(0.1), &SidewaysOptions::default(), &solver).unwrap();
        assert_eq!(p.status, Status::Stopped, "{:?}", p.reason);
        assert!(p.reason.unwrap().contains("time limit"));
    }
}
