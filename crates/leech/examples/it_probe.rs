use leech::prelude::*;
fn main() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let neighbour = robot.body(0.30, 0.279).unwrap().solve(&solver).unwrap();
    let body = robot.body(0.30, 0.28).unwrap();
    let cold = body.solve(&solver).unwrap();
    let warm = {
        let mut ws = Scratch::for_system(&body);
        body.solve_from(&solver, &neighbour.q, &mut ws).unwrap().iterations
    };
    println!("cold it {} steps {} ; warm it {}", cold.iterations, cold.steps, warm);
}
