//! The three-tube body in 3D: its derivatives against finite differences,
//! the reduction to the planar model, the mirror symmetry, the difference
//! from the planar model where `b != c`.

use leech::body3::Body3;
use leech::geom3::rot_z;
use leech::prelude::*;
use leech::stance3::planar::{compare, planar_difference};
use leech::statics::Stage;

fn planar_frames(body3: &Body3, body: &leech::body::Body, q: &[f64]) -> leech::body3::Frames {
    let (qa, qb) = body.split(q);
    let mut frames = vec![rot_z(0.0); body3.links()];
    for (t, q) in [(0, qa), (1, qb), (2, qb)] {
        for (j, phi) in q.iter().enumerate() {
            frames[body3.index(t, j)] = rot_z(*phi);
        }
    }
    body3.frames_from(frames).unwrap()
}

/// The planar references with `b = c` (paper scheme), solved in 3D: equal
/// to 1e-9 m and rad where the planar equilibrium is stable in 3D. The two
/// soft flat bodies (`Pi` = 510 and 51) are not: their planar equilibrium is
/// an equilibrium of the 3D body (a warm start from it converges at once)
/// but a saddle, left sideways, and the default path says so.
#[test]
fn equals_the_planar_body_where_b_equals_c() {
    let text = std::fs::read_to_string(format!("{}/tests/data/two_chain.json", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let (mut equal, mut sideways) = (0, 0);
    for case in v["cases"].as_array().unwrap() {
        if case["discretization"] != "paper" || case["base_spacing_m"] != case["tip_spacing_m"] {
            continue;
        }
        let name = case["name"].as_str().unwrap();
        let robot = super::robot_from_case(case);
        let l: Vec<f64> = case["lengths_m"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let body3 = Body3::from_robot(&robot, [l[0], l[1], l[1]]).unwrap();
        let body = robot.body(l[0], l[1]).unwrap();
        let solver = Solver::default();
        let eq3 = body3.solve(&solver).unwrap_or_else(|e| panic!("{name}: {e}"));
        let eq = body.solve(&solver).unwrap();
        assert!(eq3.stable && eq3.residual < 1e-10, "{name}");
        let d = compare(&body3, &eq3, &body, &eq);
        let from_planar = body3.solve_from(&solver, &planar_frames(&body3, &body, &eq.q)).unwrap();
        if ["n10_n13_flat_pi510", "n8_n10_flat_pi51"].contains(&name) {
            assert!(!eq3.events.is_empty() && d.out_of_plane_m > 0.01, "{name}: {d:?}");
            assert!(matches!(from_planar.events[..], [Event::Bifurcation { jump_rad, .. }] if jump_rad > 1.0));
            sideways += 1;
        } else {
            assert!(d.max_point_m < 1e-9 && d.max_angle_rad < 1e-9, "{name}: {d:?}");
            assert!(eq3.events.is_empty() && from_planar.events.is_empty() && from_planar.iterations <= 3, "{name}");
            equal += 1;
        }
    }
    assert_eq!((equal, sideways), (2, 2));
}

/// Whether two events are the same decision: kind, stage, parameter (to
/// 1e-9), side, and jump (to 1e-6 rad).
fn same_event(a: &Event, b: &Event) -> bool {
    match (a, b) {
        (Event::Snap { stage: s, at: t, jump_rad: j }, Event::Snap { stage: s2, at: t2, jump_rad: j2 }) => {
            s == s2 && (t - t2).abs() < 1e-9 && (j - j2).abs() < 1e-6
        }
        (
            Event::Bifurcation { stage: s, at: t, side, jump_rad: j },
            Event::Bifurcation { stage: s2, at: t2, side: side2, jump_rad: j2 },
        ) => s == s2 && (t - t2).abs() < 1e-9 && side == side2 && (j - j2).abs() < 1e-6,
        _ => false,
    }
}

/// Where `a` comes before `b` on the path (feeding, then gravity).
fn before(a: &Event, b: &Event) -> bool {
    let key = |e: &Event| match e {
        Event::Snap { stage, at, .. } | Event::Bifurcation { stage, at, .. } => (*stage == Stage::Load, *at),
    };
    key(a) < key(b)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// The built-in robot with `c = b` at random lengths and clamp angles.
    /// The 3D path makes the planar path's decisions (the same folds and
    /// bifurcations at the same load) until it leaves the plane at a
    /// sideways bifurcation, which it reports; it ends on the planar
    /// equilibrium to 1e-9 m and rad whenever that is a 3D minimum, and
    /// where it is a 3D saddle (found by a warm start from it) the path
    /// has reported leaving it.
    #[test]
    fn equals_the_planar_body_at_random_lengths(
        l1 in 0.05f64..0.30, l23 in 0.05f64..0.30, angle in -180.0f64..180.0,
    ) {
        let mut robot = Robot::builtin().with_base_angle(angle).unwrap();
        robot.body.tip_spacing_m = robot.body.base_spacing_m;
        let body3 = Body3::from_robot(&robot, [l1, l23, l23]).unwrap();
        let body = robot.body(l1, l23).unwrap();
        let solver = Solver::default();
        let (eq3, eq) = (body3.solve(&solver).unwrap(), body.solve(&solver).unwrap());
        proptest::prop_assert!(eq3.stable && eq3.residual < 1e-10);
        let d = compare(&body3, &eq3, &body, &eq);
        // In-plane decisions: the leading events agree; the first that does
        // not is a 3D bifurcation (out of the plane, where the planar model
        // sees nothing) before the planar path's next event.
        let agreed = eq3.events.iter().zip(&eq.events).take_while(|(a, b)| same_event(a, b)).count();
        let left = eq3.events.get(agreed);
        if let Some(first) = left {
            proptest::prop_assert!(
                matches!(first, Event::Bifurcation { .. }) && eq.events.get(agreed).is_none_or(|e| before(first, e)),
                "3D {:?} planar {:?}", eq3.events, eq.events
            );
        } else {
            proptest::prop_assert_eq!(agreed, eq.events.len(), "3D {:?} planar {:?}", &eq3.events, &eq.events);
        }
        // The planar equilibrium is always one of the 3D body: warm-started
        // from it, the 3D solver stays there (to 1e-9), or finds it a saddle
        // and leaves it sideways, reporting a bifurcation.
        let from_planar = body3.solve_from(&solver, &planar_frames(&body3, &body, &eq.q)).unwrap();
        let equal = d.max_point_m < 1e-9 && d.max_angle_rad < 1e-9;
        if from_planar.events.is_empty() {
            let dp = compare(&body3, &from_planar, &body, &eq);
            proptest::prop_assert!(dp.max_point_m < 1e-9 && dp.max_angle_rad < 1e-9, "{:?}", dp);
            proptest::prop_assert!(equal, "{:?} 3D {:?} planar {:?}", d, eq3.events, eq.events);
        } else {
            proptest::prop_assert!(
                matches!(from_planar.events[..], [Event::Bifurcation { .. }]),
                "{:?}", from_planar.events
            );
            proptest::prop_assert!(left.is_some(), "a saddle reached without a reported bifurcation: {:?}", eq3.events);
        }
    }
}

/// The planar model's error where `b != c` (the built-in robot: b = 17 mm,
/// c = 12 mm): the side tubes converge sideways, which moves the endpoint
/// by 7.9e-5 m at 0.30/0.28/0.28 m and 2.2e-4 m at 0.25 m equal tubes
/// (the independent estimates: about 7e-5 and 2e-4 m), with the
/// body still symmetric about its plane.
#[test]
fn built_in_robot_differs_from_the_planar_model_where_b_differs_from_c() {
    let robot = Robot::builtin();
    for (l1, l23, lo, hi) in [(0.30, 0.28, 7.0e-5, 9.0e-5), (0.25, 0.25, 1.9e-4, 2.4e-4)] {
        let (body3, body) = (Body3::from_robot(&robot, [l1, l23, l23]).unwrap(), robot.body(l1, l23).unwrap());
        let d = planar_difference(&body3, &body, &Solver::default()).unwrap();
        println!("{l1} {l23}: {d:?}");
        assert!((lo..hi).contains(&d.endpoint_m), "{l1} {l23}: {d:?}");
        assert!(d.out_of_plane_m < 1e-12 && d.max_twist_rad < 1e-3, "{d:?}");
    }
}

/// Swapping L2 and L3 mirrors the body in z: `(x, y, z) -> (x, y, -z)` for
/// every point, tubes 2 and 3 exchanged.
#[test]
fn swapping_the_side_tubes_mirrors_the_body() {
    let robot = Robot::builtin();
    for (angle, lengths) in [(90.0, [0.25, 0.28, 0.22]), (0.0, [0.20, 0.15, 0.18]), (45.0, [0.12, 0.10, 0.14])] {
        let robot = robot.with_base_angle(angle).unwrap();
        let solver = Solver::default();
        let body = Body3::from_robot(&robot, lengths).unwrap();
        let swapped = Body3::from_robot(&robot, [lengths[0], lengths[2], lengths[1]]).unwrap();
        let (eq, eq_s) = (body.solve(&solver).unwrap(), swapped.solve(&solver).unwrap());
        assert!(eq.stable && eq_s.stable && eq.events.is_empty());
        let end = body.endpoint(&eq.frames);
        assert!(end[2].abs() > 1e-3, "{angle}: the unequal side tubes turn the body ({end:?})");
        for (t, mirror) in [(0, 0), (1, 2), (2, 1)] {
            for (p, q) in body.points(&eq.frames, t).iter().zip(swapped.points(&eq_s.frames, mirror)) {
                let gap = [(p[0] - q[0]).abs(), (p[1] - q[1]).abs(), (p[2] + q[2]).abs()];
                assert!(gap.iter().all(|g| *g < 1e-12), "{angle} tube {t}: {p:?} vs {q:?}");
            }
        }
    }
}

mod derivatives {
    use leech::body3::{Body3, Derivatives, Frames, PLATE_ROWS};
    use leech::geom3::{exp, mul, Mat3};
    use leech::hold::front3::Hanging;
    use leech::prelude::*;
    use proptest::prelude::*;

    const H: f64 = 1e-4;

    /// `frames` with link `u` turned by `Exp(v)` on the right.
    fn turned(body: &Body3, frames: &Frames, moves: &[(usize, [f64; 3])]) -> Frames {
        let mut out: Vec<Mat3> = frames.as_slice().to_vec();
        for (u, v) in moves {
            out[*u] = mul(&out[*u], &exp(*v));
        }
        body.frames_from(out).unwrap()
    }

    fn unit(c: usize, h: f64) -> [f64; 3] {
        let mut e = [0.0; 3];
        e[c] = h;
        e
    }

    /// The derivatives at `f`: the fixed unit's gravity, or hanging from the front cup.
    fn derive(body: &Body3, f: &Frames, lambda: &[f64; PLATE_ROWS], hang: Option<Hanging>) -> Derivatives {
        match hang {
            Some(hang) => body.hanging_derivatives(f, lambda, hang),
            None => body.derivatives(f, lambda),
        }
    }

    /// `L` with coordinates `i` and `j` (3 per link) moved by `si H`, `sj H`
    /// in one chart: one combined rotation vector where they share a link.
    #[allow(clippy::too_many_arguments)]
    fn lagrangian(
        body: &Body3,
        f: &Frames,
        lambda: &[f64; PLATE_ROWS],
        hang: Option<Hanging>,
        i: usize,
        si: f64,
        j: usize,
        sj: f64,
    ) -> f64 {
        let (a, b) = (unit(i % 3, si * H), unit(j % 3, sj * H));
        let moves = if i / 3 == j / 3 {
            vec![(i / 3, [a[0] + b[0], a[1] + b[1], a[2] + b[2]])]
        } else {
            vec![(i / 3, a), (j / 3, b)]
        };
        derive(body, &turned(body, f, &moves), lambda, hang).lagrangian
    }

    fn setup(lengths: [f64; 3], angle: f64, seed: &[f64], lambda: &[f64]) -> (Body3, Frames, [f64; PLATE_ROWS]) {
        let robot = Robot::builtin().with_base_angle(angle).unwrap();
        let body = Body3::from_robot(&robot, lengths).unwrap();
        let straight = body.straight();
        let moves: Vec<_> = (0..body.links())
            .map(|u| {
                (
                    u,
                    [
                        0.3 * seed[(3 * u) % seed.len()],
                        0.3 * seed[(3 * u + 1) % seed.len()],
                        0.3 * seed[(3 * u + 2) % seed.len()],
                    ],
                )
            })
            .collect();
        let frames = turned(&body, &straight, &moves);
        let mut l = [0.0; PLATE_ROWS];
        l.iter_mut().zip(lambda).for_each(|(a, b)| *a = *b);
        (body, frames, l)
    }

    /// Gradient, Hessian and Jacobian at `frames` against central
    /// differences in the local chart.
    fn check(
        body: &Body3,
        frames: &Frames,
        lambda: &[f64; PLATE_ROWS],
        hang: Option<Hanging>,
    ) -> Result<(), TestCaseError> {
        let d = derive(body, frames, lambda, hang);
        let n = d.gradient.len();
        let scale = d.hessian.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let l = |i, si, j, sj| lagrangian(body, frames, lambda, hang, i, si, j, sj);
        for i in 0..n {
            let fd = (l(i, 1.0, i, 0.0) - l(i, -1.0, i, 0.0)) / (2.0 * H);
            prop_assert!(
                (fd - d.gradient[i]).abs() < 1e-8 + 1e-7 * d.gradient[i].abs(),
                "gradient {i}: {} vs {fd}",
                d.gradient[i]
            );
            let plus = derive(body, &turned(body, frames, &[(i / 3, unit(i % 3, H))]), lambda, hang).constraints;
            let minus = derive(body, &turned(body, frames, &[(i / 3, unit(i % 3, -H))]), lambda, hang).constraints;
            for r in 0..PLATE_ROWS {
                let fd = (plus[r] - minus[r]) / (2.0 * H);
                let ours = d.jacobian[i * PLATE_ROWS + r];
                prop_assert!((fd - ours).abs() < 1e-7, "jacobian ({i}, {r}): {ours} vs {fd}");
            }
            for j in i..n {
                let fd =
                    (l(i, 1.0, j, 1.0) - l(i, 1.0, j, -1.0) - l(i, -1.0, j, 1.0) + l(i, -1.0, j, -1.0)) / (4.0 * H * H);
                let ours = d.hessian[i * n + j];
                // Second differences lose digits in proportion to the whole
                // Hessian's size (up to 1e3 J/rad^2 for short stiff links),
                // not the entry's: a small entry next to large ones has the
                // large ones' rounding.
                prop_assert!(
                    (fd - ours).abs() < 1e-6 + 1e-8 * scale + 1e-6 * ours.abs(),
                    "hessian ({i}, {j}): {ours} vs {fd} (scale {scale})"
                );
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        /// Gradient, Hessian (every block: joints, gravity, both kinds of
        /// weld row, the plate's border) and Jacobian against central
        /// differences in the local chart.
        #[test]
        fn every_term_matches_finite_differences(
            l1 in 0.025f64..0.06, l2 in 0.025f64..0.06, l3 in 0.025f64..0.06,
            angle in -180.0f64..180.0,
            seed in proptest::collection::vec(-1.0f64..1.0, 31),
            lambda in proptest::collection::vec(-2.0f64..2.0, PLATE_ROWS),
        ) {
            let (body, frames, lambda) = setup([l1, l2, l3], angle, &seed, &lambda);
            check(&body, &frames, &lambda, None)?;
        }

        /// The same with the body hanging from the front cup (gravity turning
        /// with the plate: its cross blocks with every link), for any
        /// direction of up in the plate's frame and any driving-unit mass.
        #[test]
        fn hanging_terms_match_finite_differences(
            l1 in 0.025f64..0.06, l2 in 0.025f64..0.06, l3 in 0.025f64..0.06,
            seed in proptest::collection::vec(-1.0f64..1.0, 31),
            lambda in proptest::collection::vec(-2.0f64..2.0, PLATE_ROWS),
            up in proptest::collection::vec(-1.0f64..1.0, 3),
            unit_mass in 0.0f64..0.5,
        ) {
            let (body, frames, lambda) = setup([l1, l2, l3], 30.0, &seed, &lambda);
            let norm = (up[0] * up[0] + up[1] * up[1] + up[2] * up[2]).sqrt().max(1e-3);
            let hang = Hanging { up: [up[0] / norm, up[1] / norm, up[2] / norm], unit_mass_kg: unit_mass };
            check(&body, &frames, &lambda, Some(hang))?;
        }
    }
}

/// The tubes' axial rotation left free at the driving unit: a softer body
/// (no lower energy is lost: the free body's minimum is at most the held
/// one's), still a stable, converged equilibrium, turning the same way.
#[test]
fn free_axial_rotation_softens_the_body() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let held = Body3::from_robot(&robot, [0.25, 0.30, 0.22]).unwrap();
    let free = held.clone().with_free_axial_rotation();
    let (a, b) = (held.solve(&solver).unwrap(), free.solve(&solver).unwrap());
    assert!(a.stable && b.stable && b.residual < 1e-10);
    assert!(b.energy <= a.energy + 1e-12, "{} vs {}", b.energy, a.energy);
    let (ea, eb) = (held.endpoint(&a.frames), free.endpoint(&b.frames));
    assert!(ea[2] * eb[2] > 0.0 && eb[2].abs() >= ea[2].abs(), "{ea:?} {eb:?}");
}

/// `[tube] torsion_stiffness_nm_per_rad`: optional, `k / 1.3` when missing,
/// positive when given, kept by `to_toml_string` and scaled like `k`.
#[test]
fn robot_files_take_the_torsional_stiffness() {
    let builtin = Robot::builtin();
    assert_eq!(builtin.tube.torsion_stiffness_nm_per_rad, None);
    assert!((builtin.tube.torsion_stiffness() - 0.5 / 1.3).abs() < 1e-15);
    let line = "# torsion_stiffness_nm_per_rad = 0.38";
    let text = leech::robot::BUILTIN_TOML.replace(line, "torsion_stiffness_nm_per_rad = 0.2");
    let robot = Robot::from_toml_str(&text).unwrap();
    assert_eq!(robot.tube.torsion_stiffness(), 0.2);
    assert_eq!(Robot::from_toml_str(&robot.to_toml_string()).unwrap(), robot);
    assert_eq!(robot.scaled(2.0).unwrap().tube.torsion_stiffness(), 0.8);
    let bad = leech::robot::BUILTIN_TOML.replace(line, "torsion_stiffness_nm_per_rad = -1");
    let err = Robot::from_toml_str(&bad).unwrap_err().to_string();
    assert!(err.contains("tube.torsion_stiffness_nm_per_rad"), "{err}");
    // The 3D body refuses the midpoint scheme, naming the field.
    let midpoint = builtin.with_discretization(Discretization::Midpoint);
    let err = Body3::from_robot(&midpoint, [0.2, 0.2, 0.2]).unwrap_err().to_string();
    assert!(err.contains("model.discretization"), "{err}");
}

/// The files of `dir` (under `src/`) in `order`, the order its module doc
/// gives ("Layout"): each imports only files before it, so none imports
/// another in a circle.
fn files_import_only_earlier_ones(dir: &str, order: &[&str]) {
    let dir = format!("{}/src/{dir}", env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter_map(|n| n.strip_suffix(".rs").map(str::to_string))
        .filter(|n| n != "mod")
        .collect();
    files.sort();
    let mut listed: Vec<String> = order.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(files, listed, "every file of {dir} has its place in the order");
    for (at, file) in order.iter().enumerate() {
        let text = std::fs::read_to_string(format!("{dir}/{file}.rs")).unwrap();
        // The module's own code: its tests may use anything.
        let code = text.split("#[cfg(test)]").next().unwrap();
        for (place, other) in order.iter().enumerate() {
            let used = code.contains(&format!("super::{other}::")) || code.contains(&format!("super::{other};"));
            assert!(!used || place < at, "{file} uses {other}, which comes after it");
        }
    }
}

#[test]
fn body3_and_stance3_files_import_only_earlier_ones() {
    files_import_only_earlier_ones("body3", &["tube3", "body3", "constant_curvature3"]);
    files_import_only_earlier_ones("stance3", &["equilibrium3", "system3", "solve", "place3", "held3", "planar"]);
}

/// The modules of the layers the holds, the contacts and the 3D body sit
/// in import only modules above them (ARCHITECTURE.md): the body knows no
/// hold solve or contact, the contact rows no situation, the holds' vocabulary
/// no body.
#[test]
fn holds_and_contacts_are_composed_onto_the_bodies() {
    let below = |module: &str, forbidden: &[&str]| {
        let dir = format!("{}/src/{module}", env!("CARGO_MANIFEST_DIR"));
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap();
            for other in forbidden {
                // Doc links may name a later module; code may not use one.
                let uses = code
                    .lines()
                    .filter(|l| !l.trim_start().starts_with("//"))
                    .any(|l| l.contains(&format!("crate::{other}::")));
                assert!(!uses, "{} uses {other}", path.display());
            }
        }
    };
    below("hold", &["body3", "contact", "stance", "stance3", "stride"]);
    below("body3", &["contact", "stance", "stance3", "stride"]);
    below("contact", &["stance", "stance3", "stride"]);
    below("stance3", &["stance", "stride"]);
    below("stance", &["stance3", "stride"]);
}
