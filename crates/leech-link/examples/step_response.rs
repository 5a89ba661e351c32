//! The step response of tube L1 on the Arduino firmware, on a simulated
//! ATmega2560 in real time (`leech_link::chip`), in two runs:
//!
//! * `ramp`: L1 from 200 to 210 mm with the simulated hardware's
//!   configuration (`SimConfig::tube_config`: the setpoint ramps at
//!   20 mm/s): tracking error on the way and the final error;
//! * `step`: the same tube with `max_speed_um_s` = 10^7, so the setpoint
//!   jumps 5 mm (200 to 205 mm) in one 1024 Hz tick: rise time (10 to 90 %),
//!   overshoot, settling times (to 0.1 mm and to one count, 22 um) and the
//!   steady-state error.
//!
//! The true length comes from the harness every 1 ms of simulated time, the
//! measured one from the firmware's telemetry at 100 Hz. The firmware does
//! not report its setpoint; it is rebuilt from the configuration, starting
//! one tick before the first tick that drives the motor (so it is known to
//! about 1 ms, 20 um of ramp).
//!
//! ```sh
//! cargo run --release -p leech-link --features firmware --example step_response -- \
//!     docs/firmware-step-response.svg target/firmware-step-response.csv
//! ```
//!
//! Prints the figures; writes the figure (SVG) and the samples (CSV, both
//! runs, one row per ms: `run,t_ms,length_um,setpoint_um,measured_um,
//! duty_permille`, `measured_um` empty between telemetry reports; `t_ms`
//! from the command).

use std::error::Error;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use leech_link::chip::{self, Built, Chip, ChipState};
use leech_link::host::{Event, Link, Options};
use leech_link::sim::SimConfig;
use leech_protocol::message::{Telemetry, Tube, TubeConfig};
use plotters::prelude::*;
use plotters::style::FontStyle;

/// The tubes' length at power-up, um (the harness's count 0).
const START_UM: i32 = 200_000;

/// One encoder count at 45 counts per mm, um.
const COUNT_UM: f64 = 1000.0 / 45.0;

/// How long each run records after its command.
const RECORD: Duration = Duration::from_millis(3000);

/// One run: what was asked and what the harness and telemetry saw.
struct Run {
    name: &'static str,
    target_um: i32,
    speed_um_s: f64,
    /// The harness's states, 1 ms apart, from the command on.
    states: Vec<ChipState>,
    /// The telemetry reports from the command on.
    telemetry: Vec<Telemetry>,
    /// Simulated time (the harness's `t_ms`, the device's clock) of the
    /// setpoint's start.
    t0_ms: f64,
}

impl Run {
    fn setpoint_um(&self, t_ms: f64) -> f64 {
        let moved = (t_ms - self.t0_ms).max(0.0) * self.speed_um_s / 1000.0;
        (f64::from(START_UM) + moved).min(f64::from(self.target_um))
    }

    /// (ms since the setpoint's start, true length um) per state.
    fn lengths(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.states.iter().map(|s| (s.t_ms - self.t0_ms, s.lengths_um[0]))
    }

    /// The last time the true length was farther than `band` um from the
    /// target, ms since the start (the settling time to within `band`).
    fn settled_within(&self, band: f64) -> Option<f64> {
        let target = f64::from(self.target_um);
        let last_out = self.lengths().filter(|(_, l)| (l - target).abs() > band).map(|(t, _)| t).last()?;
        // Settled only if it stayed in the band for the record's last 200 ms.
        let end = self.lengths().last()?.0;
        (last_out < end - 200.0).then_some(last_out + 1.0)
    }

    /// Mean true and measured error to the target over the last 200 ms, um.
    fn final_errors(&self) -> (f64, f64) {
        let target = f64::from(self.target_um);
        let end = self.states.last().map_or(0.0, |s| s.t_ms);
        let true_tail: Vec<f64> =
            self.states.iter().filter(|s| s.t_ms > end - 200.0).map(|s| s.lengths_um[0] - target).collect();
        let measured_tail: Vec<f64> = self
            .telemetry
            .iter()
            .filter(|t| f64::from(t.time_ms) > end - 200.0)
            .map(|t| f64::from(t.lengths_um[0]) - target)
            .collect();
        (mean(&true_tail), mean(&measured_tail))
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

fn built() -> Result<&'static Built, Box<dyn Error>> {
    // Next to this example's binary: inside the target directory.
    let exe = std::env::current_exe()?;
    let out = exe.parent().ok_or("the example has no directory")?.join("firmware");
    Ok(chip::build_once(&out)?)
}

/// Runs the firmware, configures its tubes (L1 as `l1`), holds them at the
/// start, then moves L1 to `target_um` and records for `RECORD`.
fn run(built: &Built, name: &'static str, l1: TubeConfig, target_um: i32) -> Result<Run, Box<dyn Error>> {
    let chip = Chip::spawn_profiled(built, 1)?;
    let link = Link::open(chip.path(), Options { boot_timeout: Duration::from_millis(500), ..Options::default() })?;
    let sim = SimConfig::default();
    link.configure_tube(l1)?;
    link.configure_tube(sim.tube_config(Tube::L2))?;
    link.configure_tube(sim.tube_config(Tube::L3))?;
    link.set_lengths([START_UM; 3])?;
    link.set_telemetry(10)?;
    // Held and still before the move.
    std::thread::sleep(Duration::from_millis(300));
    let events = link.subscribe();
    let states = chip.states();
    link.set_lengths([target_um, START_UM, START_UM])?;
    let end = Instant::now() + RECORD;
    let mut telemetry = Vec::new();
    while Instant::now() < end {
        if let Ok(Event::Telemetry(t)) = events.recv_timeout(Duration::from_millis(20)) {
            telemetry.push(t);
        }
    }
    let states: Vec<ChipState> = drain(&states);
    let first_drive = states.iter().position(|s| s.duty_permille[0] != 0).ok_or("L1 never moved")?;
    let t0_ms = states[first_drive].t_ms - 1.0;
    let rate = states.iter().map(|s| s.sim_rate).fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r), hi.max(r)));
    println!(
        "{name}: {} states, {} telemetry reports, sim_rate {:.3} to {:.3}",
        states.len(),
        telemetry.len(),
        rate.0,
        rate.1
    );
    // The firmware's own cost meanwhile (three tubes under control, one
    // moving, telemetry at 100 Hz), cycle-exact.
    let ticks: u32 = states.iter().map(|s| s.ticks).sum();
    let tick_mean = states.iter().map(|s| s.tick_us_mean * f64::from(s.ticks)).sum::<f64>() / f64::from(ticks.max(1));
    let tick_max = states.iter().map(|s| s.tick_us_max).fold(0.0, f64::max);
    let busy = mean(&states.iter().map(|s| s.busy).collect::<Vec<_>>());
    println!(
        "  control tick: {ticks} ticks, mean {tick_mean:.0} us, max {tick_max:.0} us; chip busy {:.0} %",
        busy * 100.0
    );
    let end_ms = states.last().map_or(0.0, |s| s.t_ms);
    let speed_um_s = f64::from(l1.max_speed_um_s);
    telemetry.retain(|t| f64::from(t.time_ms) >= t0_ms && f64::from(t.time_ms) <= end_ms);
    let states = states.into_iter().filter(|s| s.t_ms >= t0_ms).collect();
    Ok(Run { name, target_um, speed_um_s, states, telemetry, t0_ms })
}

fn drain(states: &Receiver<ChipState>) -> Vec<ChipState> {
    states.try_iter().collect()
}

fn report_ramp(run: &Run) {
    let ramp_ms = f64::from(run.target_um - START_UM) / run.speed_um_s * 1000.0;
    let errors: Vec<f64> = run
        .states
        .iter()
        .filter(|s| s.t_ms - run.t0_ms <= ramp_ms)
        .map(|s| s.lengths_um[0] - run.setpoint_um(s.t_ms))
        .collect();
    let worst = errors.iter().fold(0.0f64, |m, e| if e.abs() > m.abs() { *e } else { m });
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    // The steady lag: the middle of the ramp, away from its two corners.
    let middle: Vec<f64> = run
        .states
        .iter()
        .filter(|s| (s.t_ms - run.t0_ms - ramp_ms / 2.0).abs() <= ramp_ms / 4.0)
        .map(|s| s.lengths_um[0] - run.setpoint_um(s.t_ms))
        .collect();
    let (true_final, measured_final) = run.final_errors();
    println!("ramp 200 -> {} mm at {} mm/s ({ramp_ms:.0} ms):", run.target_um / 1000, run.speed_um_s / 1000.0);
    println!(
        "  tracking error (true - setpoint): worst {worst:.0} um, rms {rms:.0} um, mean over the middle half {:.0} um",
        mean(&middle)
    );
    println!("  settled within 0.1 mm: {}", fmt_ms(run.settled_within(100.0)));
    println!("  within one count (22 um): {}", fmt_ms(run.settled_within(COUNT_UM)));
    println!("  final error (last 200 ms): true {true_final:.1} um, measured {measured_final:.1} um");
}

fn report_step(run: &Run) {
    let step = f64::from(run.target_um - START_UM);
    let crossing =
        |fraction: f64| run.lengths().find(|(_, l)| l - f64::from(START_UM) >= fraction * step).map(|(t, _)| t);
    let rise = crossing(0.1).zip(crossing(0.9)).map(|(a, b)| b - a);
    let peak = run.lengths().map(|(_, l)| l).fold(f64::MIN, f64::max);
    let overshoot = (peak - f64::from(run.target_um)).max(0.0);
    let (true_final, measured_final) = run.final_errors();
    println!("step 200 -> {} mm (setpoint in one tick):", run.target_um / 1000);
    println!("  rise time 10-90 %: {}", fmt_ms(rise));
    println!("  overshoot: {overshoot:.0} um ({:.1} %)", overshoot / step * 100.0);
    println!("  settled within 0.1 mm: {}", fmt_ms(run.settled_within(100.0)));
    println!("  within one count (22 um): {}", fmt_ms(run.settled_within(COUNT_UM)));
    println!("  steady-state error (last 200 ms): true {true_final:.1} um, measured {measured_final:.1} um");
}

fn fmt_ms(t: Option<f64>) -> String {
    t.map_or_else(|| "not within the record".into(), |t| format!("{t:.0} ms"))
}

fn csv(runs: &[Run]) -> String {
    let mut out = String::from("run,t_ms,length_um,setpoint_um,measured_um,duty_permille\n");
    for run in runs {
        for s in &run.states {
            let measured = run
                .telemetry
                .iter()
                .find(|t| (f64::from(t.time_ms) - s.t_ms).abs() < 0.5)
                .map(|t| t.lengths_um[0].to_string())
                .unwrap_or_default();
            let _ = writeln!(
                out,
                "{},{:.0},{:.1},{:.1},{measured},{}",
                run.name,
                s.t_ms - run.t0_ms,
                s.lengths_um[0],
                run.setpoint_um(s.t_ms),
                s.duty_permille[0]
            );
        }
    }
    out
}

const FONT: &str = "sans-serif";

/// Both runs side by side: true length, setpoint and measured length (mm)
/// against time since the setpoint's start (ms).
fn svg(runs: &[Run]) -> Result<String, Box<dyn Error>> {
    // The embedded font: plotters without default features has no system fonts.
    plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "the embedded font does not load")?;
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (1100, 460)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((1, runs.len()));
        for (area, run) in panels.iter().zip(runs) {
            let end = run.lengths().last().map_or(1.0, |(t, _)| t);
            let (lo, hi) = (f64::from(START_UM) / 1000.0, f64::from(run.target_um) / 1000.0);
            let pad = (hi - lo) * 0.1;
            let title = match run.name {
                "ramp" => format!("L1 200 -> {hi:.0} mm, setpoint ramp {} mm/s", run.speed_um_s / 1000.0),
                _ => format!("L1 200 -> {hi:.0} mm, setpoint step"),
            };
            let mut chart = ChartBuilder::on(area)
                .caption(title, (FONT, 18))
                .margin(14)
                .x_label_area_size(42)
                .y_label_area_size(56)
                .build_cartesian_2d(-20.0..end, lo - pad..hi + pad)?;
            chart
                .configure_mesh()
                .x_desc("time since the setpoint's start (ms)")
                .y_desc("length (mm)")
                .label_style((FONT, 13))
                .axis_desc_style((FONT, 14))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()?;
            let blue = RGBColor(0, 114, 178);
            let orange = RGBColor(213, 94, 0);
            let green = RGBColor(0, 158, 115);
            let setpoint: Vec<(f64, f64)> =
                run.states.iter().map(|s| (s.t_ms - run.t0_ms, run.setpoint_um(s.t_ms) / 1000.0)).collect();
            chart
                .draw_series(DashedLineSeries::new(setpoint, 6, 4, orange.stroke_width(2)))?
                .label("setpoint (rebuilt)")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], orange.stroke_width(2)));
            chart
                .draw_series(LineSeries::new(run.lengths().map(|(t, l)| (t, l / 1000.0)), blue.stroke_width(2)))?
                .label("true length (harness, 1 ms)")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], blue.stroke_width(2)));
            chart
                .draw_series(run.telemetry.iter().map(|t| {
                    let at = (f64::from(t.time_ms) - run.t0_ms, f64::from(t.lengths_um[0]) / 1000.0);
                    Circle::new(at, 3, green.filled())
                }))?
                .label("measured (telemetry, 100 Hz)")
                .legend(move |(x, y)| Circle::new((x + 9, y), 3, green.filled()));
            chart
                .configure_series_labels()
                .label_font((FONT, 13))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(180, 180, 180))
                .position(SeriesLabelPosition::LowerRight)
                .draw()?;
        }
        root.present()?;
    }
    Ok(out)
}

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args_os().skip(1).map(PathBuf::from);
    let (Some(svg_path), Some(csv_path)) = (args.next(), args.next()) else {
        return Err("usage: step_response FIGURE.svg SAMPLES.csv".into());
    };
    let built = built()?;
    let normal = SimConfig::default().tube_config(Tube::L1);
    let ramp = run(built, "ramp", normal, 210_000)?;
    let step = run(built, "step", TubeConfig { max_speed_um_s: 10_000_000, ..normal }, 205_000)?;
    report_ramp(&ramp);
    report_step(&step);
    let runs = [ramp, step];
    std::fs::write(&csv_path, csv(&runs))?;
    std::fs::write(&svg_path, svg(&runs)?)?;
    println!("wrote {} and {}", svg_path.display(), csv_path.display());
    Ok(())
}
