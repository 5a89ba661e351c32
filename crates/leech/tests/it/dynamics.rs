//! Constrained dynamics: energy, constraints, rest at the static equilibrium.

use leech::chain::ChainSpec;
use leech::dynamics::{simulate, Actuation, Integrator, Motion, SimulationOptions, Simulator, Start};
use leech::linalg::quasiseparable::{self, Generators, Ldl};
use leech::prelude::*;
use proptest::prelude::*;
use serde_json::Value;

/// A small body released from its unloaded shape turned by -60 deg: it
/// swings and falls under gravity.
fn swinging_body(damping: f64) -> (Body, Motion) {
    let mut robot = Robot::builtin();
    robot.tube.joint_damping_nms_per_rad = damping;
    robot.world.gravity_m_per_s2 = 0.0;
    let unloaded = robot.body(0.06, 0.05).unwrap().solve(&Solver::default()).unwrap().q;
    robot.world.gravity_m_per_s2 = 9.81;
    robot.world.base_angle_deg = 30.0;
    let body = robot.body(0.06, 0.05).unwrap();
    let q: Vec<f64> = unloaded.iter().map(|q| q - 60f64.to_radians()).collect();
    let v = vec![0.0; q.len()];
    (body, Motion { q, v })
}

#[test]
fn energy_is_conserved_without_damping() {
    let (body, mut state) = swinging_body(0.0);
    let mut sim = Simulator::new(&body);
    sim.project(&mut state).unwrap();
    let (k0, p0) = sim.energy(&state);
    let (mut worst, mut swing) = (0.0f64, 0.0f64);
    let dt = 1e-4;
    for _ in 0..(10.0 / dt) as usize {
        sim.step(&mut state, dt, Integrator::Midpoint).unwrap();
        let (k, p) = sim.energy(&state);
        worst = worst.max((k + p - k0 - p0).abs());
        swing = swing.max(k);
        assert!(sim.violation(&state.q) < 1e-9);
    }
    // Relative to the energy that changes form (the largest kinetic energy):
    // the potential's zero is arbitrary.
    assert!(swing > 1e-6, "it moves");
    assert!(worst < 1e-6 * swing, "energy drifted by {worst:e} J of {swing:e} J over 10 s");
}

#[test]
fn damped_energy_never_increases_and_constraints_hold() {
    for (integrator, dt, duration) in [(Integrator::Implicit, 2e-3, 2.0), (Integrator::Explicit, 0.0, 0.02)] {
        let (body, mut state) = swinging_body(0.005);
        let mut sim = Simulator::new(&body);
        sim.project(&mut state).unwrap();
        let dt = if dt > 0.0 { dt } else { sim.stable_step(&state.q).unwrap() };
        let (k, p) = sim.energy(&state);
        let mut last = k + p;
        let mut t = 0.0;
        while t < duration {
            sim.step(&mut state, dt, integrator).unwrap();
            t += dt;
            let (k, p) = sim.energy(&state);
            // Never up, but for rounding in the projection (1e-11 of the energy seen).
            assert!(
                k + p <= last + 1e-9 * last.abs(),
                "{integrator:?}: energy rose at t = {t} by {:e} of {last:e}",
                k + p - last
            );
            last = k + p;
            assert!(sim.violation(&state.q) < 1e-9, "{integrator:?}: violation at t = {t}");
        }
    }
}

/// Damped dynamics run to rest land on the static solver's equilibrium (the
/// two-chain reference bodies), with gravity ramped over 2 s so that the
/// motion follows the same loading path. A sudden load can overshoot: for the
/// soft `n8_n10_flat_pi51` body it settles in a second, lower-energy stable
/// equilibrium, also checked here.
#[test]
fn settling_from_the_unloaded_body_reaches_the_static_equilibrium() {
    let path = format!("{}/tests/data/two_chain.json", env!("CARGO_MANIFEST_DIR"));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    for case in v["cases"].as_array().unwrap() {
        let num = |k: &str| case[k].as_f64().unwrap();
        let mut robot = super::robot_from_case(case);
        // Damping about as the paper: enough to settle in a few seconds.
        robot.tube.joint_damping_nms_per_rad = 0.02 * robot.tube.joint_stiffness_nm_per_rad;
        let lengths: Vec<f64> = case["lengths_m"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let mut unloaded = robot.clone();
        unloaded.world.gravity_m_per_s2 = 0.0;
        let q0 = unloaded.body(lengths[0], lengths[1]).unwrap().solve(&Solver::default()).unwrap().q;
        robot.world.gravity_m_per_s2 = num("gravity_m_per_s2");
        let body = robot.body(lengths[0], lengths[1]).unwrap();
        let mut sim = Simulator::new(&body);
        let mut state = Motion { v: vec![0.0; q0.len()], q: q0 };
        let start = state.clone();
        let rest = sim.run_to_rest(&mut state, 2e-3, Integrator::Implicit, 2.0, 60.0).unwrap();
        assert!(rest.is_some(), "{} did not come to rest", case["name"]);
        let expected: Vec<f64> = case["endpoint_m"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let e = body.endpoint(&state.q);
        assert!((e[0] - expected[0]).hypot(e[1] - expected[1]) < 1e-6, "{}: {e:?} vs {expected:?}", case["name"]);
        if case["name"] == "n8_n10_flat_pi51" {
            let mut sudden = start;
            sim.run_to_rest(&mut sudden, 2e-3, Integrator::Implicit, 0.0, 60.0).unwrap().unwrap();
            let other = body.endpoint(&sudden.q);
            assert!((other[0] - e[0]).hypot(other[1] - e[1]) > 1e-2);
            let mut ws = leech::statics::Scratch::for_system(&body);
            let eq = body.solve_from(&Solver::default(), &sudden.q, &mut ws).unwrap();
            assert!(eq.stable && body.energy(&eq.q) < body.energy(&state.q));
        }
    }
}

/// Tip trajectories against MuJoCo (RK4 at 1e-5 and 2e-6 s, point masses,
/// cross-checked there with SciPy's Radau): `validation/dynamics_references.py`.
#[test]
fn trajectories_match_mujoco() {
    let path = format!("{}/tests/data/dynamics.json", env!("CARGO_MANIFEST_DIR"));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    for case in v["cases"].as_array().unwrap() {
        let num = |k: &str| case[k].as_f64().unwrap();
        let list = |k: &str| -> Vec<f64> { case[k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
        let robot = super::robot_from_case(case);
        let times = list("times_s");
        let tips: Vec<[f64; 2]> = case["tip_m"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
            .collect();
        let dt = 1e-5;
        let per_sample = ((times[1] - times[0]) / dt).round() as usize;
        let mut worst: f64 = 0.0;
        let mut check = |tip: [f64; 2], i: usize| worst = worst.max((tip[0] - tips[i][0]).hypot(tip[1] - tips[i][1]));
        if case["kind"] == "chain" {
            let tube = robot.cantilever(num("tube_length_m"), 0.0).unwrap();
            let mut sim = Simulator::new(&tube);
            let mut state = Motion { q: list("initial_angles_rad"), v: vec![0.0; tube.dim()] };
            for i in 1..times.len() {
                for _ in 0..per_sample {
                    sim.step(&mut state, dt, Integrator::Implicit).unwrap();
                }
                check(tube.chain().tip(&state.q), i);
            }
        } else {
            let lengths = list("lengths_m");
            let body = robot.body(lengths[0], lengths[1]).unwrap();
            let mut q = list("initial_angles_a_rad");
            q.extend(list("initial_angles_b_rad"));
            let mut sim = Simulator::new(&body);
            let mut state = Motion { v: vec![0.0; q.len()], q };
            sim.project(&mut state).unwrap();
            for i in 1..times.len() {
                for _ in 0..per_sample {
                    sim.step(&mut state, dt, Integrator::Implicit).unwrap();
                }
                check(body.endpoint(&state.q), i);
            }
        }
        assert!(worst < 1e-4, "{}: tip differs from MuJoCo by up to {worst:e} m", case["name"]);
        eprintln!("{}: largest tip difference from MuJoCo {worst:e} m", case["name"]);
    }
}

#[test]
fn inconsistent_initial_states_are_rejected() {
    let (body, mut state) = swinging_body(0.005);
    let mut sim = Simulator::new(&body);
    state.q[0] += 0.1;
    assert!(matches!(sim.check(&state), Err(leech::dynamics::StepError::Inconsistent { .. })));
    sim.project(&mut state).unwrap();
    assert!(sim.check(&state).is_ok());
    state.v[0] = 1.0;
    assert!(matches!(sim.check(&state), Err(leech::dynamics::StepError::Inconsistent { .. })));
}

fn sup(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn dense_product(a: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n).map(|j| (0..n).map(|k| a[j * n + k] * x[k]).sum()).collect()
}

/// `|A x - b|` against `|A| |x|` (sup norms): the backward error of a solve.
fn backward_error(a: &[f64], x: &[f64], b: &[f64]) -> f64 {
    let n = x.len();
    let residual: Vec<f64> = dense_product(a, x).iter().zip(b).map(|(ax, b)| ax - b).collect();
    let norm = (0..n).map(|j| (0..n).map(|k| a[j * n + k].abs()).sum::<f64>()).fold(0.0, f64::max);
    sup(&residual) / (norm * sup(x))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// A chain's mass matrix and the backward-Euler matrix `M + dt D +
    /// dt^2 K` as quasiseparable generators (orders 2 and 3) against the
    /// dense matrices of the mass points' kinematics: entries, products,
    /// kinetic energy, and solves by the O(n) factorizations.
    #[test]
    fn mass_matrix_generators_factor_solve_and_multiply_like_dense_matrices(
        n in 1usize..200,
        element_length in 0.002f64..0.05,
        last in 0.05f64..1.0,
        element_mass in 1e-4f64..1e-2,
        tip_mass in 0.0f64..0.05,
        stiffness in 0.01f64..10.0,
        damping in 0.0f64..0.1,
        midpoint in any::<bool>(),
        dt in 1e-5f64..0.1,
        seed in prop::collection::vec(-3.0f64..3.0, 400),
    ) {
        let d = if midpoint { Discretization::Midpoint } else { Discretization::Paper };
        let chain = Chain::new(&ChainSpec {
            tube_length: element_length * ((n - 1) as f64 + last),
            element_length,
            element_mass,
            stiffness,
            damping,
            tip_mass,
            clamp_point: [0.0, 0.0],
            clamp_angle: seed[399],
            discretization: d,
        });
        let n = chain.len();
        let (q, x) = (&seed[..n], &seed[200..200 + n]);
        let (sin, cos): (Vec<f64>, Vec<f64>) = q.iter().map(|phi| phi.sin_cos()).unzip();
        let mass = super::kinematic_mass_matrix(&chain, q, d);
        let scale = sup(&mass);
        let generated = super::dense(chain.mass_generators(&cos, &sin));
        for (a, b) in generated.iter().zip(&mass) {
            prop_assert!((a - b).abs() <= 1e-13 * scale, "M {a:e} vs kinematics {b:e}");
        }
        let (expected, mut product) = (dense_product(&mass, x), vec![0.0; n]);
        quasiseparable::multiply(chain.mass_generators(&cos, &sin), x, &mut product);
        for (a, b) in product.iter().zip(&expected) {
            prop_assert!((a - b).abs() <= 1e-12 * scale * sup(x) * n as f64, "M x {a:e} vs {b:e}");
        }
        let kinetic: f64 = 0.5 * x.iter().zip(&expected).map(|(a, b)| a * b).sum::<f64>();
        prop_assert!((chain.kinetic_energy(q, x) - kinetic).abs() <= 1e-12 * scale * (n * n) as f64);
        let mut ldl = Ldl::<2>::default();
        ldl.factor(chain.mass_generators(&cos, &sin)).unwrap();
        let mut solved = expected.clone();
        ldl.solve(&mut solved);
        prop_assert!(backward_error(&mass, &solved, &expected) < 1e-13 * n as f64);
        // The tridiagonal dt D + dt^2 K reaches the first subdiagonal only.
        let (mut diag, mut off) = (vec![0.0; n], vec![0.0; n]);
        chain.add_spring_hessian(&mut diag, &mut off);
        let c = chain.damping();
        let mut iteration = mass.clone();
        for j in 0..n {
            let (dj, oj) = (dt * dt * diag[j] + dt * (c[j] + c.get(j + 1).unwrap_or(&0.0)), dt * dt * off[j]);
            diag[j] = dj;
            off[j] = if j + 1 < n { oj - dt * c[j + 1] } else { 0.0 };
            iteration[j * n + j] += dj;
            if j + 1 < n {
                iteration[j * n + j + 1] += off[j];
                iteration[(j + 1) * n + j] += off[j];
            }
        }
        let rows = chain.mass_generators(&cos, &sin).enumerate().map(|(j, m)| Generators {
            diagonal: m.diagonal + diag[j],
            p: [m.p[0], m.p[1], 1.0],
            q: [m.q[0], m.q[1], off[j]],
            a: [1.0, 1.0, 0.0],
        });
        let generated = super::dense(rows.clone());
        for (a, b) in generated.iter().zip(&iteration) {
            prop_assert!((a - b).abs() <= 1e-13 * sup(&iteration), "M + T {a:e} vs {b:e}");
        }
        let mut ldl = Ldl::<3>::default();
        ldl.factor(rows).unwrap();
        let rhs = dense_product(&iteration, x);
        let mut solved = rhs.clone();
        ldl.solve(&mut solved);
        prop_assert!(backward_error(&iteration, &solved, &rhs) < 1e-13 * n as f64);
    }
}

/// Bodies far beyond the old dense limit of 500 links per chain: the same
/// 0.3 m tubes cut into 2000 links each (continuum stiffness, mass and
/// damping per length kept), released from the unloaded shape with gravity
/// on, stay on the constraints through a few implicit steps.
#[test]
fn a_body_of_2000_links_per_chain_steps_on_its_constraints() {
    let mut robot = Robot::builtin();
    let l0 = robot.tube.element_length_m;
    let l = 0.30 / 2000.0;
    robot.tube.element_length_m = l;
    robot.tube.element_mass_kg *= l / l0;
    robot.tube.joint_stiffness_nm_per_rad *= l0 / l;
    robot.tube.joint_damping_nms_per_rad *= l0 / l;
    let options = SimulationOptions {
        integrator: Integrator::Implicit,
        dt: Some(2e-3),
        duration: 0.01,
        until_rest: false,
        gravity_ramp: 0.0,
        sample_interval: 2e-3,
        rest_rate: 1e-6,
        deadline: leech::budget::Deadline::none(),
    };
    let run = simulate(&robot, [0.30, 0.30], Start::Unloaded, Actuation::Hold, &options, &|_| {}).unwrap();
    let last = run.samples.last().unwrap();
    assert_eq!((last.angles_a_rad.len(), last.angles_b_rad.len()), (2000, 2000));
    assert_eq!(run.steps, 5);
    assert!(run.max_violation < 1e-9, "violation {:e}", run.max_violation);
    assert!(last.kinetic_j > 0.0, "it falls");
}

/// Counts the allocations of the thread that asks for it, for the test
/// below; every other allocation passes straight to the system allocator.
struct CountingAllocator;

thread_local! {
    static COUNTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    static ALLOCATIONS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

// SAFETY: defers every call to the system allocator unchanged.
unsafe impl std::alloc::GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        if COUNTING.with(|c| c.get()) {
            ALLOCATIONS.with(|a| a.set(a.get() + 1));
        }
        // SAFETY: the caller's contract is passed on.
        unsafe { std::alloc::System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: the caller's contract is passed on.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// How many times `f` allocates on this thread.
fn allocations(f: impl FnOnce()) -> usize {
    ALLOCATIONS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(|a| a.get())
}

/// Steps of every integrator, the projection, the rest check and the
/// stability estimate work in the simulator's scratch: none allocates.
#[test]
fn steps_do_not_allocate() {
    assert_eq!(allocations(|| drop(std::hint::black_box(vec![0.0; 8]))), 1, "the counter counts");
    let (body, mut motion) = swinging_body(0.005);
    let mut sim = Simulator::new(&body);
    sim.project(&mut motion).unwrap();
    let dt = sim.stable_step(&motion.q).unwrap();
    let count = allocations(|| {
        // The midpoint's fixed-point iteration needs a third of RK4's step.
        for (integrator, dt) in
            [(Integrator::Explicit, dt), (Integrator::Implicit, 2e-3), (Integrator::Midpoint, 0.3 * dt)]
        {
            for _ in 0..3 {
                sim.step(&mut motion, dt, integrator).unwrap();
            }
        }
        sim.at_rest(&motion, 1e-9).unwrap();
        sim.stable_step(&motion.q).unwrap();
        sim.energy(&motion);
    });
    assert_eq!(count, 0);
}

/// Backward Euler at long steps: near rest the corrections reach the
/// rounding floor, where their ratio is noise and may exceed one; a
/// correction below the tolerance has converged whatever that ratio.
#[test]
fn backward_euler_takes_long_steps_to_rest() {
    let robot = Robot::builtin();
    let unloaded = robot.with_gravity(0.0).unwrap().body(0.25, 0.20).unwrap();
    let q = unloaded.solve(&Solver::default()).unwrap().q;
    let body = robot.body(0.25, 0.20).unwrap();
    let mut sim = Simulator::new(&body);
    let mut state = Motion { v: vec![0.0; q.len()], q };
    for dt in [0.3, 0.1, 0.03] {
        for step in 0..50 {
            sim.step(&mut state, dt, Integrator::Implicit).unwrap_or_else(|e| panic!("dt {dt} step {step}: {e}"));
        }
    }
}

/// The largest energy gain between samples, relative to the body's energy
/// scale, allowed as round-off. The energies are sums of about a hundred
/// terms (relative rounding 1e-16 each, on J-sized partial sums), the
/// backward-Euler velocities are converged to 1e-10 relative and the
/// positions projected to 1e-13 m: each changes the energy between two
/// samples by far less than 1e-11 of the potential's scale (the payload
/// lifted by the tubes' length, about 0.1 J), which leaves a margin of
/// ten over what round-off can do and none for a real gain (those seen
/// on a long step grow with dt^2 |v|^2, 1e-3 J and more).
const ROUND_OFF: f64 = 1e-10;

/// Soft (Pi = 1, 30) and stiff (the built-in robot, Pi about 5e3) bodies
/// settling from the unloaded shape at base angles 0, 90 and 270 deg, with
/// backward Euler at its default step (`IMPLICIT_STEP_S`, 5 ms) and the implicit
/// midpoint rule at its own: the damped body's total energy never rises
/// between samples by more than round-off.
#[test]
fn the_damped_simulation_never_gains_energy() {
    let robots = [None, Some(30.0), Some(1.0)];
    for (integrator, dt, duration) in [(Integrator::Implicit, None, 3.0), (Integrator::Midpoint, None, 2e-3)] {
        for pi in robots {
            for angle in [0.0, 90.0, 270.0] {
                let mut robot = Robot::builtin().with_base_angle(angle).unwrap();
                if let Some(pi) = pi {
                    robot = robot.with_shape_parameter(pi).unwrap();
                }
                let options = SimulationOptions {
                    integrator,
                    dt,
                    duration,
                    until_rest: false,
                    gravity_ramp: 0.0,
                    sample_interval: duration / 300.0,
                    rest_rate: 1e-6,
                    deadline: leech::budget::Deadline::none(),
                };
                let run = simulate(&robot, [0.3, 0.2], Start::Unloaded, Actuation::Hold, &options, &|_| ()).unwrap();
                let scale = run.samples.iter().map(|s| s.kinetic_j + s.potential_j.abs()).fold(0.0, f64::max);
                let gain = run.max_energy_gain_j.unwrap();
                let case = format!("{integrator:?} Pi {pi:?} at {angle} deg");
                assert!(gain <= ROUND_OFF * scale, "{case}: gained {gain:e} J of {scale:e} J");
                // The measure itself: the largest difference of the samples' totals.
                let totals: Vec<f64> = run.samples.iter().map(|s| s.kinetic_j + s.potential_j).collect();
                let largest = totals.windows(2).map(|w| w[1] - w[0]).fold(f64::NEG_INFINITY, f64::max);
                assert_eq!(gain, largest, "{case}");
                // And it fell: the body started away from its equilibrium.
                assert!(totals.last().unwrap() < &totals[0], "{case}");
            }
        }
    }
}

/// The measure counts only pairs of samples with the inputs settled: the
/// lengths those of the end and gravity fully on.
#[test]
fn an_energy_gain_is_measured_between_settled_samples() {
    let sample = |t: f64, e: f64, la: f64| leech::dynamics::Sample {
        time_s: t,
        lengths_m: [la, 0.2],
        angles_a_rad: vec![],
        angles_b_rad: vec![],
        points_a_m: vec![],
        points_b_m: vec![],
        endpoint_m: [0.0; 2],
        kinetic_j: e / 2.0,
        potential_j: e / 2.0,
        violation: 0.0,
    };
    // Fed from 0.25 m to 0.3 m (the inputs do work: 1 J gained, not counted),
    // then 0.5 J gained while settled.
    let samples = [sample(0.0, 1.0, 0.25), sample(0.1, 2.0, 0.3), sample(0.2, 1.5, 0.3), sample(0.3, 2.0, 0.3)];
    assert_eq!(leech::dynamics::energy_gain(&samples, 0.0), Some(0.5));
    // Gravity still rising until 0.25 s: no two samples after it.
    assert_eq!(leech::dynamics::energy_gain(&samples, 0.25), None);
    assert_eq!(leech::dynamics::energy_gain(&samples[..3], 0.0), Some(-0.5));
}
