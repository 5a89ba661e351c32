//! Every analytic derivative against central finite differences, on random
//! configurations (property tests).

use leech::chain::{ChainSpec, Discretization};
use leech::prelude::*;
use leech::statics::{Evaluation, PathTerms};
use proptest::prelude::*;

const H: f64 = 1e-6;

fn evaluate<S: StaticSystem>(sys: &S, q: &[f64], t: f64) -> Evaluation {
    let mut ev = Evaluation::with_free(sys.dim(), sys.free(), sys.rows());
    sys.evaluate(q, t, &mut ev);
    ev
}

fn path<S: Path>(sys: &S, q: &[f64], t: f64) -> PathTerms {
    let mut out = PathTerms::new(sys.dim(), sys.rows());
    sys.path(q, t, &evaluate(sys, q, t), &mut out);
    out
}

fn shifted(q: &[f64], i: usize, h: f64) -> Vec<f64> {
    let mut p = q.to_vec();
    p[i] += h;
    p
}

fn close(analytic: f64, numeric: f64, scale: f64, what: &str) -> Result<(), TestCaseError> {
    // Relative to the quantity too: a short last element's stiff spring makes
    // large, exactly quadratic terms whose differences round at that size.
    prop_assert!(
        (analytic - numeric).abs() <= 1e-6 * (scale.max(1e-3) + analytic.abs()),
        "{what}: analytic {analytic:e} vs finite difference {numeric:e}"
    );
    Ok(())
}

/// Entry `(i, j)` of the potential's Hessian: banded over the chains,
/// border and corner for the free coordinates.
fn hessian_entry(ev: &Evaluation, i: usize, j: usize) -> f64 {
    let (chains, free) = (ev.hessian_diag.len(), ev.free());
    match (i < chains, j < chains) {
        (true, true) if i == j => ev.hessian_diag[i],
        (true, true) if i + 1 == j => ev.hessian_off[i],
        (true, true) if j + 1 == i => ev.hessian_off[j],
        (true, true) => 0.0,
        (true, false) => ev.hessian_border[i * free + (j - chains)],
        (false, true) => ev.hessian_border[j * free + (i - chains)],
        (false, false) => ev.hessian_corner[(i - chains) * free + (j - chains)],
    }
}

/// Checks gradient, Hessian (tridiagonal), constraint Jacobian and constraint
/// curvature (diagonal), and the path derivatives, of any static system.
fn check_system<S: Path>(sys: &S, q: &[f64], t: f64) -> Result<(), TestCaseError> {
    let n = sys.dim();
    let m = sys.rows();
    let ev = evaluate(sys, q, t);
    let k = sys.moment_scale();
    // Differencing loses the rounding of what is differenced (1e-16 of its
    // size) over 2H: the gradient of a stiff short element can be large.
    let gradient_size = ev.gradient.iter().fold(0.0f64, |a, g| a.max(g.abs()));
    let k_gradient = k + 1e-3 * gradient_size;
    for i in 0..n {
        let (plus, minus) = (evaluate(sys, &shifted(q, i, H), t), evaluate(sys, &shifted(q, i, -H), t));
        close(ev.gradient[i], (plus.energy - minus.energy) / (2.0 * H), k + 1e-3 * ev.energy.abs(), "dV/dq")?;
        for j in 0..n {
            let fd = (plus.gradient[j] - minus.gradient[j]) / (2.0 * H);
            close(hessian_entry(&ev, i, j), fd, k_gradient, "d2V/dq2")?;
        }
        for r in 0..m {
            let fd = (plus.constraints[r] - minus.constraints[r]) / (2.0 * H);
            close(ev.jacobian[i * m + r], fd, 1.0, "dC/dq")?;
            for j in 0..n {
                let fd = (plus.jacobian[j * m + r] - minus.jacobian[j * m + r]) / (2.0 * H);
                let analytic = if i == j { ev.curvature[i * m + r] } else { 0.0 };
                close(analytic, fd, 1.0, "d2C/dq2")?;
            }
        }
    }
    let (ahead, behind) = (evaluate(sys, q, t + H), evaluate(sys, q, t - H));
    let along = path(sys, q, t);
    for i in 0..n {
        close(along.gradient[i], (ahead.gradient[i] - behind.gradient[i]) / (2.0 * H), k_gradient, "d(dV/dq)/dt")?;
        for r in 0..m {
            let idx = i * m + r;
            close(along.jacobian[idx], (ahead.jacobian[idx] - behind.jacobian[idx]) / (2.0 * H), 1.0, "d(dC/dq)/dt")?;
        }
    }
    for r in 0..m {
        close(along.constraints[r], (ahead.constraints[r] - behind.constraints[r]) / (2.0 * H), 1.0, "dC/dt")?;
        let rate = (ahead.compliance[r] - behind.compliance[r]) / (2.0 * H);
        close(along.compliance[r], rate, 0.0, "dc/dt")?;
    }
    Ok(())
}

fn discretization() -> impl Strategy<Value = Discretization> {
    prop_oneof![Just(Discretization::Paper), Just(Discretization::Midpoint)]
}

fn spec(length: f64, tip_mass: f64, clamp: f64, d: Discretization) -> ChainSpec {
    ChainSpec {
        tube_length: length,
        element_length: 0.01,
        element_mass: 0.0013,
        stiffness: 0.07,
        damping: 0.003,
        tip_mass,
        clamp_point: [0.003, -0.002],
        clamp_angle: clamp,
        discretization: d,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn cantilever_derivatives(
        length in 0.01f64..0.095,
        tip_mass in 0.0f64..0.03,
        clamp in -3.0f64..3.0,
        d in discretization(),
        seed in prop::collection::vec(-4.0f64..7.0, 12),
        t in 0.1f64..1.0,
    ) {
        let tube = Cantilever::new(Chain::new(&spec(length, tip_mass, clamp, d)), 9.81);
        let q: Vec<f64> = seed[..tube.dim()].to_vec();
        check_system(&tube, &q, t)?;
    }

    #[test]
    fn body_derivatives(
        la in 0.02f64..0.075,
        lb in 0.02f64..0.075,
        clamp_deg in -180.0f64..180.0,
        d in discretization(),
        seed in prop::collection::vec(-4.0f64..7.0, 20),
        t in 0.1f64..1.0,
    ) {
        let mut robot = Robot::builtin();
        robot.world.base_angle_deg = clamp_deg;
        robot.model.discretization = d;
        let body = robot.body(la, lb).unwrap();
        let q: Vec<f64> = seed[..body.dim()].to_vec();
        check_system(&body, &q, t)?;
        // The trait's constraint values are the body's own.
        let ev = evaluate(&body, &q, t);
        let c = body.constraints(&q);
        for r in 0..3 {
            prop_assert!((ev.constraints[r] - c[r]).abs() < 1e-15);
        }
    }

    /// The mass matrix's generators give the matrix of the mass points'
    /// kinematics (plus the links' own rotational inertia), the kinetic
    /// energy is that of the mass points (positions differentiated
    /// numerically), and the velocity terms satisfy Lagrange's equation
    /// `h = dM/dt dq - dT/dq`.
    #[test]
    fn mass_matrix_and_velocity_terms(
        length in 0.01f64..0.075,
        tip_mass in 0.0f64..0.03,
        d in discretization(),
        seed in prop::collection::vec(-3.0f64..3.0, 16),
    ) {
        let chain = Chain::new(&spec(length, tip_mass, 0.4, d));
        let n = chain.len();
        let (q, dq) = (&seed[..n], &seed[8..8 + n]);
        let mass_matrix = |q: &[f64]| {
            let (sin, cos): (Vec<f64>, Vec<f64>) = q.iter().map(|phi| phi.sin_cos()).unzip();
            super::dense(chain.mass_generators(&cos, &sin))
        };
        let (mm, reference) = (mass_matrix(q), super::kinematic_mass_matrix(&chain, q, d));
        for (a, b) in mm.iter().zip(&reference) {
            prop_assert!((a - b).abs() < 1e-15, "M {a:e} vs kinematics {b:e}");
        }
        // Kinetic energy from mass-point velocities, by differencing positions in time.
        let kinetic = |q: &[f64], dq: &[f64]| -> f64 {
            let at = |s: f64| -> Vec<[f64; 2]> {
                let p: Vec<f64> = q.iter().zip(dq).map(|(a, b)| a + s * b).collect();
                mass_points(&chain, &p, d)
            };
            let (a, b) = (at(H), at(-H));
            let masses = point_masses(&chain);
            let rotational: f64 = rotational_inertias(&chain, d).iter().zip(dq).map(|(i, w)| 0.5 * i * w * w).sum();
            a.iter().zip(&b).zip(&masses).map(|((pa, pb), m)| {
                let v = [(pa[0] - pb[0]) / (2.0 * H), (pa[1] - pb[1]) / (2.0 * H)];
                0.5 * m * (v[0] * v[0] + v[1] * v[1])
            }).sum::<f64>() + rotational
        };
        let t_direct = kinetic(q, dq);
        prop_assert!((chain.kinetic_energy(q, dq) - t_direct).abs() < 1e-7 * (1.0 + t_direct));
        // Lagrange: h_j = sum_k dM_jk/dt dq_k - dT/dq_j.
        let mut h = vec![0.0; n];
        chain.velocity_terms(q, dq, &mut h);
        let qp: Vec<f64> = q.iter().zip(dq).map(|(a, b)| a + H * b).collect();
        let qn: Vec<f64> = q.iter().zip(dq).map(|(a, b)| a - H * b).collect();
        let (mp, mn) = (mass_matrix(&qp), mass_matrix(&qn));
        for j in 0..n {
            let dm_dt: f64 = (0..n).map(|k| (mp[j * n + k] - mn[j * n + k]) / (2.0 * H) * dq[k]).sum();
            let dt_dq = (chain.kinetic_energy(&shifted(q, j, H), dq) - chain.kinetic_energy(&shifted(q, j, -H), dq)) / (2.0 * H);
            prop_assert!((h[j] - (dm_dt - dt_dq)).abs() < 1e-7, "h[{j}] = {} vs {}", h[j], dm_dt - dt_dq);
        }
    }

    /// Springs and dampers: `Q = -dV_s/dq - dR/d(dq)` with the Rayleigh
    /// function `R = sum_j d_j/2 (dphi_j - dphi_{j-1})^2` (clamp rate 0).
    #[test]
    fn spring_and_damper_forces(
        length in 0.01f64..0.075,
        seed in prop::collection::vec(-3.0f64..3.0, 16),
    ) {
        let chain = Chain::new(&spec(length, 0.0, 0.3, Discretization::Paper));
        let n = chain.len();
        let (q, dq) = (&seed[..n], &seed[8..8 + n]);
        let mut forces = vec![0.0; n];
        chain.elastic_forces(q, dq, &mut forces);
        let rayleigh = |dq: &[f64]| -> f64 {
            let mut prev = 0.0;
            dq.iter().zip(chain.damping()).map(|(w, d)| {
                let r = 0.5 * d * (w - prev) * (w - prev);
                prev = *w;
                r
            }).sum()
        };
        for j in 0..n {
            let dv = (chain.spring_energy(&shifted(q, j, H)) - chain.spring_energy(&shifted(q, j, -H))) / (2.0 * H);
            let dr = (rayleigh(&shifted(dq, j, H)) - rayleigh(&shifted(dq, j, -H))) / (2.0 * H);
            // A short last element has a stiff spring: scale the finite-difference error with it.
            let stiffest = chain.stiffness().iter().chain(chain.damping()).fold(0.0f64, |a, k| a.max(*k));
            prop_assert!((forces[j] + dv + dr).abs() < 1e-7 * stiffest.max(1.0), "link {j}");
        }
    }

    /// A point force does virtual work `Q . dq = f . dr`.
    #[test]
    fn point_force_is_virtual_work(
        length in 0.02f64..0.075,
        seed in prop::collection::vec(-3.0f64..3.0, 8),
        f in prop::array::uniform2(-2.0f64..2.0),
        link_frac in 0.0f64..1.0,
        offset_frac in 0.0f64..1.0,
    ) {
        let chain = Chain::new(&spec(length, 0.0, 0.2, Discretization::Paper));
        let n = chain.len();
        let q = &seed[..n];
        let link = ((link_frac * n as f64) as usize).min(n - 1);
        let offset = offset_frac * chain.lengths()[link];
        let mut qf = vec![0.0; n];
        chain.add_point_force(q, link, offset, f, &mut qf);
        let point = |q: &[f64]| {
            let pts = chain.points(q);
            let (a, b) = (pts[link], pts[link + 1]);
            let u = [(b[0] - a[0]) / chain.lengths()[link], (b[1] - a[1]) / chain.lengths()[link]];
            [a[0] + offset * u[0], a[1] + offset * u[1]]
        };
        for j in 0..n {
            let (p, m) = (point(&shifted(q, j, H)), point(&shifted(q, j, -H)));
            let work = (f[0] * (p[0] - m[0]) + f[1] * (p[1] - m[1])) / (2.0 * H);
            prop_assert!((qf[j] - work).abs() < 1e-8);
        }
    }
}

/// Where each link's mass sits, from the public polyline.
fn mass_points(chain: &Chain, q: &[f64], d: Discretization) -> Vec<[f64; 2]> {
    let pts = chain.points(q);
    let skip = usize::from(d == Discretization::Midpoint);
    let mut out: Vec<[f64; 2]> = (0..chain.len())
        .map(|j| {
            let (a, b) = (pts[skip + j], pts[skip + j + 1]);
            match d {
                Discretization::Paper => b,
                Discretization::Midpoint => [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])],
            }
        })
        .collect();
    out.push(*pts.last().unwrap());
    out
}

fn point_masses(chain: &Chain) -> Vec<f64> {
    let mut m = chain.masses().to_vec();
    m.push(chain.tip_mass());
    m
}

fn rotational_inertias(chain: &Chain, d: Discretization) -> Vec<f64> {
    chain
        .lengths()
        .iter()
        .zip(chain.masses())
        .map(|(l, m)| if d == Discretization::Midpoint { m * l * l / 12.0 } else { 0.0 })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// The floating body under every kind of hold, with contact rows at
    /// nodes and between nodes and the hose's stop rows (at chain A's
    /// clamp, turning from the driving unit's angle, and inside chain B),
    /// along every approach.
    #[test]
    fn floating_body_derivatives(
        la in 0.03f64..0.075,
        lb in 0.03f64..0.075,
        clamp_deg in -180.0f64..180.0,
        d in discretization(),
        seed in prop::collection::vec(-4.0f64..7.0, 20),
        pose in prop::collection::vec(-1.0f64..1.0, 6),
        hold_kind in 0usize..3,
        t in 0.1f64..1.0,
        fraction in 0.1f64..1.0,
    ) {
        use leech::hose::{Stop, StopRow};
        use leech::stance::{Approach, ContactRow, FloatingBody, Hold, Pose, Touching};
        let robot = Robot::builtin().with_base_angle(clamp_deg).unwrap().with_discretization(d);
        let body = robot.body(la, lb).unwrap();
        let rear = Pose { point_m: [pose[0], pose[1]], angle_rad: pose[2] };
        let front = Pose { point_m: [pose[3], pose[4]], angle_rad: pose[5] };
        let hold = [Hold::Rear(rear), Hold::Front(front), Hold::Both { rear, front }][hold_kind];
        let from = Pose { point_m: [0.1, -0.2], angle_rad: 0.3 };
        let approach = match (hold_kind, t) {
            (2, t) if t > 0.7 => Approach::Stiffen,
            (2, t) if t > 0.4 => Approach::Front(from),
            _ => Approach::Load,
        };
        let contacts = vec![
            ContactRow { chain: 0, link: 1, fraction: 1.0, normal: [0.6, 0.8], offset: 0.01 },
            ContactRow { chain: 1, link: 2, fraction, normal: [-0.8, 0.6], offset: -0.02 },
        ];
        let stop = Stop { limit_rad: 0.4, compliance: 0.02 };
        let stops = vec![
            StopRow { chain: 0, joint: 0, sign: 1.0, stop },
            StopRow { chain: 1, joint: 2, sign: -1.0, stop },
        ];
        let floating =
            FloatingBody::new(&body, 0.017, 0.25, hold, approach).with_stops(stops).with_contacts(contacts);
        let n = body.dim();
        let mut q: Vec<f64> = seed[..n].to_vec();
        q.extend([pose[0] + 0.1, pose[1] - 0.05, pose[2] + 0.2]);
        check_system(&floating, &q, t)?;
    }

    /// The rows on the free cups' faces (the rear cup's with the rear
    /// released, the front cup's with the front released), both rims and a
    /// point between them, and with the rear released the driving unit's
    /// outline (a corner, a point along an edge), its mass off the clamps'
    /// midpoint and its cup behind the clamp.
    #[test]
    fn cup_face_and_unit_outline_derivatives(
        la in 0.03f64..0.075,
        lb in 0.03f64..0.075,
        clamp_deg in -180.0f64..180.0,
        d in discretization(),
        seed in prop::collection::vec(-4.0f64..7.0, 20),
        pose in prop::collection::vec(-1.0f64..1.0, 3),
        front_free in any::<bool>(),
        t in 0.1f64..1.0,
        fraction in 0.05f64..0.95,
    ) {
        use leech::stance::{cup_faces, Approach, ContactRow, FloatingBody, Hold, Pose, FRONT_CUP, REAR_CUP, UNIT};
        let mut robot = Robot::builtin().with_base_angle(clamp_deg).unwrap().with_discretization(d);
        robot.driving_unit.centre_of_mass_m = Some([0.01, 0.005]);
        robot.driving_unit.rear_cup_behind_m = 0.012;
        let body = robot.body(la, lb).unwrap();
        let held = Pose { point_m: [pose[0], pose[1]], angle_rad: pose[2] };
        let (hold, cup) = if front_free { (Hold::Rear(held), FRONT_CUP) } else { (Hold::Front(held), REAR_CUP) };
        let mut contacts = vec![
            ContactRow { chain: cup, link: 0, fraction: 1.0, normal: [0.6, 0.8], offset: 0.01 },
            ContactRow { chain: cup, link: 1, fraction: 1.0, normal: [-0.8, 0.6], offset: -0.02 },
            ContactRow { chain: cup, link: 0, fraction, normal: [0.0, 1.0], offset: 0.005 },
        ];
        if !front_free {
            contacts.extend([
                ContactRow { chain: UNIT, link: 2, fraction: 1.0, normal: [0.8, -0.6], offset: 0.03 },
                ContactRow { chain: UNIT, link: 3, fraction, normal: [-0.6, -0.8], offset: -0.01 },
            ]);
        }
        let floating = FloatingBody::of(&robot, &body, hold, Approach::Load)
            .with_cup_faces(cup_faces(&robot))
            .with_contacts(contacts);
        let n = body.dim();
        let mut q: Vec<f64> = seed[..n].to_vec();
        q.extend([pose[0] + 0.1, pose[1] - 0.05, pose[2] + 0.2]);
        check_system(&floating, &q, t)?;
    }

    /// The single tube's contact rows: a node row and a row part-way along a
    /// link, on the cantilever's potential.
    #[test]
    fn tube_contact_derivatives(
        length in 0.03f64..0.095,
        clamp in -3.0f64..3.0,
        d in discretization(),
        seed in prop::collection::vec(-4.0f64..7.0, 10),
        t in 0.1f64..1.0,
        fraction in 0.1f64..1.0,
    ) {
        use leech::stance::{ContactRow, Touching, Tube};
        let cantilever = Cantilever::new(Chain::new(&spec(length, 0.004, clamp, d)), 9.81);
        let contacts = vec![
            ContactRow { chain: 0, link: 1, fraction: 1.0, normal: [0.6, 0.8], offset: 0.01 },
            ContactRow { chain: 0, link: 2, fraction, normal: [-0.8, 0.6], offset: -0.02 },
        ];
        let tube = Tube::new(&cantilever).with_contacts(contacts);
        let q: Vec<f64> = seed[..tube.dim()].to_vec();
        check_system(&tube, &q, t)?;
    }
}
