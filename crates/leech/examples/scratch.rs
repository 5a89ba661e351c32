use leech::prelude::*;
fn main() {
    let mut robot = Robot::builtin();
    robot.world.gravity_m_per_s2 = 0.0;
    let s = Solver::default();
    for (la, lb) in [(0.3, 0.2), (0.2, 0.3), (0.05, 0.2), (0.1, 0.3), (0.05, 0.3)] {
        let body = robot.body(la, lb).unwrap();
        let eq = body.solve(&s).unwrap();
        println!("{la} {lb}: E {:.4} angle {:.3} events {:?}", eq.energy, body.endpoint_angle(&eq.q), eq.events);
    }
    robot.body.base_spacing_m = 0.008; robot.body.tip_spacing_m = 0.008;
    for (la, lb) in [(0.05, 0.15), (0.05, 0.2), (0.1, 0.2)] {
        let body = robot.body(la, lb).unwrap();
        let eq = body.solve(&s).unwrap();
        println!("narrow {la} {lb}: E {:.4} angle {:.3} events {:?}", eq.energy, body.endpoint_angle(&eq.q), eq.events);
    }
}
