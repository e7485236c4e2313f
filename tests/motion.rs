//! Motion on a mock board: a zigzag layer of a hand-built slice planned into blocks, stepped
//! on a virtual clock, and judged from the recorded pin edges: exact steps, pulses and
//! direction setup, speed and acceleration, the planner's profiles, determinism.

mod common;

use common::board::{check_pulses, duty_at, expected_steps, positions, Driver, Pin, Trace};
use common::motion::{cfg, layer_moves, road, run_layer, run_moves, N, Z};
use hollowpath::motion::config::AXES;
use hollowpath::motion::{Planner, PrinterConfig};
use hollowpath::toolpath::moves::Move;

#[test]
fn layer_steps_equal_net_displacement_exactly() {
    // Off-grid steps per mm so that every move rounds.
    let mut c = cfg();
    c.axes[0].steps_per_mm = 401.3;
    c.axes[1].steps_per_mm = 397.7;
    let (moves, d) = run_layer(c.clone());
    let end = moves.last().unwrap().to;
    let trace = d.board.trace.borrow();
    let want = expected_steps(&c, [end.x, end.y, Z]);
    assert_eq!(trace.position, want);
    // The positions rebuilt edge by edge agree, and the engine's own count too.
    assert_eq!(positions(&trace).last().unwrap().1, want);
    let stats = d.machine.stepper().stats;
    let total: u64 = stats.steps.iter().sum();
    let rising = trace
        .edges
        .iter()
        .filter(|e| e.high && matches!(e.pin, Pin::Step(_)))
        .count() as u64;
    assert_eq!(total, rising);
    // Far more steps than displacement: the layer goes back and forth.
    let travelled: f32 = moves.iter().map(|m| m.length()).sum();
    assert!(
        total as f32 > 0.9 * travelled * 400.0,
        "{total} steps over {travelled} mm"
    );
    let seconds = trace.now as f64 / c.tick_hz as f64;
    println!(
        "layer: {} moves, {travelled:.0} mm, {} steps (x {}, y {}, z {}), {:.1} s, {} alarms, {} segments ({} stretched), shortest DDA interval {} ticks",
        moves.len(),
        total,
        stats.steps[0],
        stats.steps[1],
        stats.steps[2],
        seconds,
        d.alarms,
        stats.segments,
        stats.stretched,
        stats.min_interval
    );
}

#[test]
fn pulses_are_wide_enough_and_direction_leads_its_step() {
    let c = cfg();
    let (_, d) = run_layer(c.clone());
    let trace = d.board.trace.borrow();
    let pulse = c.ns_to_ticks(c.step_pulse_ns) as u64;
    let setup = c.ns_to_ticks(c.dir_setup_ns) as u64;
    check_pulses(&trace, pulse, setup).unwrap();
    // The check can fail: a trace with a pulse one tick too short is caught.
    assert!(check_pulses(&trace, pulse + 1, setup).is_err());
}

/// Per-axis speed and acceleration from the step trace, over windows of `w` ticks: the
/// largest |v| per axis (mm/s), and the largest |dv/dt| per axis (mm/s^2) away from the
/// corners and across them (`corners`: the instants the nozzle passes a corner).
fn trace_kinematics(
    trace: &Trace,
    cfg: &PrinterConfig,
    w: u64,
    corners: &[u64],
) -> ([f32; AXES], [f32; AXES], [f32; AXES]) {
    let pos = positions(trace);
    let end = trace.now;
    let mut samples = Vec::new();
    let mut k = 0;
    let mut p = [0i64; AXES];
    let mut t = 0;
    while t <= end {
        while k < pos.len() && pos[k].0 <= t {
            p = pos[k].1;
            k += 1;
        }
        samples.push(p);
        t += w;
    }
    let dt = w as f32 / cfg.tick_hz as f32;
    let mut vmax = [0.0f32; AXES];
    let mut straight = [0.0f32; AXES];
    let mut corner = [0.0f32; AXES];
    let v: Vec<[f32; AXES]> = samples
        .windows(2)
        .map(|s| {
            let mut v = [0.0; AXES];
            for a in 0..AXES {
                v[a] = (s[1][a] - s[0][a]) as f32 / cfg.axes[a].steps_per_mm / dt;
            }
            v
        })
        .collect();
    let mut c = 0;
    for (i, vi) in v.iter().enumerate() {
        // The acceleration between windows i - 1 and i spans samples i - 1 to i + 1.
        let (t0, t1) = ((i as u64).saturating_sub(1) * w, (i as u64 + 1) * w);
        while c < corners.len() && corners[c] < t0 {
            c += 1;
        }
        let at_corner = c < corners.len() && corners[c] <= t1;
        for a in 0..AXES {
            vmax[a] = vmax[a].max(vi[a].abs());
            if i > 0 {
                let acc = (vi[a] - v[i - 1][a]).abs() / dt;
                let m = if at_corner {
                    &mut corner[a]
                } else {
                    &mut straight[a]
                };
                *m = m.max(acc);
            }
        }
    }
    (vmax, straight, corner)
}

/// The instants (ticks) the nozzle passes each vertex where the path turns by more than
/// `degrees`: the first time after the previous vertex that the position equals the
/// vertex's steps.
fn corner_times(trace: &Trace, cfg: &PrinterConfig, moves: &[Move], degrees: f32) -> Vec<u64> {
    let pos = positions(trace);
    let mut k = 0usize;
    let mut out = Vec::new();
    let mut last = [0i64; AXES];
    let mut prev_dir: Option<(f32, f32)> = None;
    for m in moves {
        let target = expected_steps(cfg, [m.to.x, m.to.y, Z]);
        if target == last {
            continue;
        }
        let (dx, dy) = (m.to.x - m.from.x, m.to.y - m.from.y);
        let len = (dx * dx + dy * dy).sqrt();
        let dir = (dx / len, dy / len);
        if let Some(p) = prev_dir {
            let cos = p.0 * dir.0 + p.1 * dir.1;
            if cos < degrees.to_radians().cos() {
                // The vertex this move starts from: where the previous one ended.
                out.push(pos[k.saturating_sub(1)].0);
            }
        }
        while k < pos.len() && pos[k].1 != target {
            k += 1;
        }
        k += 1;
        prev_dir = Some(dir);
        last = target;
    }
    out
}

#[test]
fn speed_and_acceleration_stay_within_limits_on_the_trace() {
    let c = cfg();
    let (moves, d) = run_layer(c.clone());
    let trace = d.board.trace.borrow();
    let corners = corner_times(&trace, &c, &moves, 3.0);
    assert!(corners.len() > 50, "{} corners", corners.len());
    // 40 ms windows. A window's position is within 1.5 steps of the profile's (Bresenham
    // inside a segment, rounding at its ends): the slack below. Away from corners each axis
    // accelerates at most at its limit. Across a corner, junction deviation lets the
    // velocity jump (the arc it stands for is not stepped): by at most
    // sqrt(8 a jd), a the block's acceleration (at most sqrt(2) x an axis' limit in XY).
    let w = 40_000;
    let (vmax, straight, corner) = trace_kinematics(&trace, &c, w, &corners);
    let dt = w as f32 / c.tick_hz as f32;
    for a in 0..2 {
        let q = 3.0 / c.axes[a].steps_per_mm;
        let v_slack = q / dt;
        let a_slack = 2.0 * q / (dt * dt);
        let jump = (8.0 * 2f32.sqrt() * c.axes[a].max_accel * c.junction_deviation).sqrt();
        println!(
            "axis {a}: max speed {:.2} mm/s (limit {}), max accel {:.1} mm/s^2 away from corners (limit {}), {:.1} across them (jump allowance {:.1} mm/s)",
            vmax[a], c.axes[a].max_speed, straight[a], c.axes[a].max_accel, corner[a], jump
        );
        assert!(
            vmax[a] <= c.axes[a].max_speed + v_slack,
            "axis {a} speed {}",
            vmax[a]
        );
        assert!(
            straight[a] <= c.axes[a].max_accel + a_slack,
            "axis {a} accel {}",
            straight[a]
        );
        assert!(
            corner[a] <= c.axes[a].max_accel + jump / dt + a_slack,
            "axis {a} accel at a corner {}",
            corner[a]
        );
    }
    // The layer really moves: X and Y reach the print speed's range.
    assert!(vmax[0] > 0.5 * c.print_speed && vmax[1] > 0.5 * c.print_speed);
    // And a printer with a third of the acceleration shows up as over the limit on the same
    // trace.
    let mut slow = c.clone();
    slow.axes[0].max_accel /= 3.0;
    slow.axes[1].max_accel /= 3.0;
    let (_, straight, _) = trace_kinematics(&trace, &slow, w, &corners);
    assert!(straight[0] > slow.axes[0].max_accel || straight[1] > slow.axes[1].max_accel);
}

#[test]
fn planner_profiles_respect_limits_and_join_up() {
    let c = cfg();
    let moves = layer_moves();
    let mut maker = hollowpath::motion::BlockMaker::new(&c);
    let mut planner = Box::new(Planner::<N>::new(
        c.junction_deviation,
        c.valve_time_constant(),
    ));
    let mut popped = Vec::new();
    for m in &moves {
        let Some(b) = maker.from_move(m, Z).unwrap() else {
            continue;
        };
        let mut b = b;
        loop {
            match planner.push(b) {
                Ok(()) => break,
                Err(hollowpath::motion::Full(back)) => {
                    b = back;
                    popped.push(planner.pop().unwrap());
                }
            }
        }
        maker.commit(&b);
    }
    while let Some(b) = planner.pop() {
        popped.push(b);
    }
    assert!(popped.len() > 500, "{} blocks", popped.len());
    let eps = 1e-3;
    let mut slowed = 0;
    for (k, b) in popped.iter().enumerate() {
        let speed = if b.deposit {
            c.print_speed
        } else {
            c.travel_speed
        };
        assert!(b.nominal <= speed + eps);
        for a in 0..AXES {
            assert!(b.nominal * b.unit[a].abs() <= c.axes[a].max_speed + eps);
            assert!(b.accel * b.unit[a].abs() <= c.axes[a].max_accel + eps);
        }
        assert!(
            b.entry <= b.max_entry + eps && b.entry <= b.nominal + eps,
            "block {k}: {b:?}"
        );
        assert!(b.exit <= b.nominal + eps && b.cruise <= b.nominal + eps);
        // Reachable at the block's acceleration, both ways.
        let reach = 2.0 * b.accel * b.length;
        assert!(b.exit * b.exit <= b.entry * b.entry + reach * (1.0 + 1e-4) + eps);
        assert!(b.entry * b.entry <= b.exit * b.exit + reach * (1.0 + 1e-4) + eps);
        let p = b.profile();
        assert!((p.d_acc + p.d_dec) <= b.length * (1.0 + 1e-5));
        if let Some(next) = popped.get(k + 1) {
            assert_eq!(b.exit, next.entry, "block {k}: exit and next entry");
            if b.deposit != next.deposit {
                assert_eq!(b.exit, 0.0, "block {k}: no stop between road and travel");
            }
        } else {
            assert_eq!(b.exit, 0.0);
        }
        if b.deposit && b.cruise < 0.9 * c.print_speed {
            slowed += 1;
        }
    }
    assert!(slowed > 10, "no corner slowed anything");
}

#[test]
fn same_moves_give_the_same_edges() {
    let moves = layer_moves();
    let moves = &moves[..moves.len().min(400)];
    let run = || {
        let mut d = Driver::<N>::new(cfg());
        d.home_in_place();
        d.run(moves, Z, |_| false);
        let t = d.board.trace.borrow().clone();
        t
    };
    let (a, b) = (run(), run());
    assert!(a.edges.len() > 10_000);
    assert_eq!(a, b);
}

/// A virtual step timer: the host's clock jumps to the alarm; an alarm already past is
/// refused as the hardware would.
struct VirtualTimer {
    now: u32,
    alarm: Option<u32>,
}

impl hollowpath::motion::StepTimer for VirtualTimer {
    fn now(&self) -> u32 {
        self.now
    }
    fn set_alarm(&mut self, at: u32) -> Result<(), hollowpath::motion::Late> {
        if hollowpath::motion::stepper::before(at, self.now) {
            return Err(hollowpath::motion::Late);
        }
        self.alarm = Some(at);
        Ok(())
    }
}

#[test]
fn a_step_timer_drives_the_same_edges() {
    let moves = road(
        &[(2.0, 2.0), (6.0, 2.0), (6.0, 5.0), (2.0, 3.0)],
        [0.5, 0.0, 0.5, 0.0],
        0.4,
    );
    // Through on_alarm at the deadlines...
    let (_, direct) = run_moves(cfg(), moves.clone());
    let direct = direct.board.trace.borrow().clone();
    // ...and through the StepTimer trait, starting at the same instant.
    let mut d = Driver::<N>::new(cfg());
    d.home_in_place();
    let mut timer = VirtualTimer {
        now: d.ticks,
        alarm: None,
    };
    let mut next = 0;
    loop {
        while next < moves.len() && d.machine.push_move(&moves[next], Z).is_ok() {
            next += 1;
        }
        timer.alarm = None;
        d.machine.service(&mut d.board, &mut timer);
        match timer.alarm {
            Some(at) => {
                let dt = at.wrapping_sub(timer.now);
                d.board.trace.borrow_mut().now += dt as u64;
                timer.now = at;
            }
            None if next == moves.len() => break,
            None => {}
        }
    }
    assert!(d.machine.is_done());
    assert_eq!(*d.board.trace.borrow(), direct);
}

#[test]
fn a_starved_queue_stops_and_restarts_without_losing_a_step() {
    // The layer's first moves, each pushed only once the machine has run dry.
    let c = cfg();
    let all = layer_moves();
    let moves = &all[..60];
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    let mut restarts = 0;
    for m in moves {
        d.machine.push_move(m, Z).unwrap();
        restarts += 1;
        while d.alarm() {}
        assert!(d.machine.is_done());
        // Dry: every valve is shut while it waits.
        let t = d.board.trace.borrow();
        for ch in 0..c.channels as usize {
            assert_eq!(duty_at(&t, ch, t.now), 0.0);
        }
    }
    assert_eq!(restarts, 60);
    let trace = d.board.trace.borrow();
    let end = moves.last().unwrap().to;
    assert_eq!(trace.position, expected_steps(&c, [end.x, end.y, Z]));
    check_pulses(&trace, 2, 1).unwrap();
}

#[test]
fn inverted_directions_and_a_finer_timer_keep_steps_and_pulses() {
    let mut c = cfg();
    c.axes[0].invert_dir = true;
    c.axes[2].invert_dir = true;
    c.tick_hz = 8_000_000;
    c.step_pulse_ns = 2_500;
    c.dir_setup_ns = 600;
    let moves = layer_moves();
    let moves = moves[..moves.len().min(600)].to_vec();
    let (moves, d) = run_moves(c.clone(), moves);
    let trace = d.board.trace.borrow();
    let end = moves.last().unwrap().to;
    assert_eq!(trace.position, expected_steps(&c, [end.x, end.y, Z]));
    check_pulses(&trace, 20, 5).unwrap();
    assert!(check_pulses(&trace, 21, 5).is_err());
    // Inverted: X's direction pin is low while x grows (the first move goes to +x).
    let first_x_dir = trace.edges.iter().find(|e| e.pin == Pin::Dir(0)).unwrap();
    let first_move = &moves[0];
    assert_eq!(first_x_dir.high, first_move.to.x < 0.0);
}
