//! Motion on a mock board: a zigzag layer of a hand-built slice, and small paths, planned into
//! blocks, stepped on a virtual clock, and judged from the recorded pin edges and duties.

mod common;

use common::board::{
    check_pulses, duty_at, expected_steps, no_endstops, positions, Driver, Pin, Trace,
};
use common::two_circles;
use hollowpath::geometry::Point;
use hollowpath::motion::config::{AXES, SEGMENT_S};
use hollowpath::motion::valve::flow_for;
use hollowpath::motion::{Fault, Planner, PrinterConfig, State};
use hollowpath::toolpath::moves::{path_moves, Move};
use hollowpath::toolpath::spiral::{spiral, ControlFunction};
use hollowpath::toolpath::zigzag::zigzag;
use hollowpath::toolpath::Vertex;
use hollowpath::Settings;

const N: usize = 32;
const Z: f32 = 0.3;

fn cfg() -> PrinterConfig {
    no_endstops(PrinterConfig::default())
}

/// The moves of one zigzag layer of the two-circle slice, from home (a travel to its first
/// vertex first).
fn layer_moves() -> Vec<Move> {
    layer_moves_of(false)
}

/// The zigzag layer's moves, or the spiral layer's (with a jump between cells).
fn layer_moves_of(spiral_layer: bool) -> Vec<Move> {
    let slice = two_circles(Settings::default());
    let mut planner = Box::new(hollowpath::Planner::new());
    let plan = planner.plan(&slice).unwrap();
    let mut path = Box::new(heapless::Vec::<Vertex, 16384>::new());
    if spiral_layer {
        spiral(&slice, plan, ControlFunction::Linear, &mut *path).unwrap();
    } else {
        zigzag(&slice, plan, &mut *path).unwrap();
    }
    let mut moves = vec![Move {
        from: Point::new(0.0, 0.0),
        to: path[0].at,
        width: path[0].width,
        material: path[0].material,
        deposit: false,
    }];
    path_moves(&path, |m| moves.push(m));
    moves
}

fn run_layer(cfg: PrinterConfig) -> (Vec<Move>, Driver<N>) {
    run_moves(cfg, layer_moves())
}

fn run_moves(cfg: PrinterConfig, moves: Vec<Move>) -> (Vec<Move>, Driver<N>) {
    let mut d = Driver::<N>::new(cfg);
    d.home_in_place();
    d.run(&moves, Z, |_| false);
    assert!(d.machine.is_done());
    assert_eq!(d.machine.state(), State::Ready);
    (moves, d)
}

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
    let mut planner = Box::new(Planner::<N>::new(c.junction_deviation));
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

/// The flow each channel delivers over time, from the duty timeline through the valve model
/// (dead time, then the first-order lag towards the calibration curve's flow), integrated
/// from `t0` to `t1` (ticks), mm^3.
fn delivered(trace: &Trace, cfg: &PrinterConfig, channel: usize, t0: u64, t1: u64) -> f64 {
    let ch = &cfg.channel[channel];
    let hz = cfg.tick_hz as f64;
    let dead = (ch.dead_time_s as f64 * hz) as u64;
    let step = 10u64; // ticks
    let decay = (-(step as f64 / hz) / ch.time_constant_s as f64).exp();
    let mut q = 0.0f64;
    let mut volume = 0.0;
    let mut t = 0;
    while t < t1 {
        let duty = if t >= dead {
            duty_at(trace, channel, t - dead)
        } else {
            0.0
        };
        let target = ch.full_flow as f64 * flow_for(&ch.curve, duty) as f64;
        q = target + (q - target) * decay;
        if t >= t0 {
            volume += q * step as f64 / hz;
        }
        t += step;
    }
    volume
}

/// The first time (ticks) the trace's position satisfies `at`.
fn first_time(trace: &Trace, at: impl Fn([i64; AXES]) -> bool) -> u64 {
    positions(trace)
        .into_iter()
        .find(|(_, p)| at(*p))
        .map(|(t, _)| t)
        .expect("never there")
}

fn road(points: &[(f32, f32)], material: [f32; 4], width: f32) -> Vec<Move> {
    let mut moves = vec![Move {
        from: Point::new(0.0, 0.0),
        to: Point::new(points[0].0, points[0].1),
        width,
        material,
        deposit: false,
    }];
    for w in points.windows(2) {
        moves.push(Move {
            from: Point::new(w[0].0, w[0].1),
            to: Point::new(w[1].0, w[1].1),
            width,
            material,
            deposit: true,
        });
    }
    moves
}

#[test]
fn corner_deposit_per_mm_matches_the_straight_line() {
    let c = cfg();
    let (w, h) = (0.4f32, c.layer_height);
    // An L from (2, 2) along +x to (12, 2), then +y to (12, 12), in a 70:30 mix.
    let material = [0.7, 0.3, 0.0, 0.0];
    let moves = road(&[(2.0, 2.0), (12.0, 2.0), (12.0, 12.0)], material, w);
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    d.run(&moves, Z, |_| false);
    let trace = d.board.trace.borrow();
    let spm = c.axes[0].steps_per_mm as i64;
    let per_mm = |t0: u64, t1: u64, mm: f64| -> f64 {
        (0..2)
            .map(|ch| delivered(&trace, &c, ch, t0, t1))
            .sum::<f64>()
            / mm
    };
    // Straight: x from 5 to 9 mm.
    let s0 = first_time(&trace, |p| p[0] >= 5 * spm);
    let s1 = first_time(&trace, |p| p[0] >= 9 * spm);
    let straight = per_mm(s0, s1, 4.0);
    // The corner: from 0.3 mm before it to 0.3 mm after.
    let (near, far) = (11.7 * spm as f32, 2.3 * spm as f32);
    let c0 = first_time(&trace, |p| p[0] as f32 >= near);
    let c1 = first_time(&trace, |p| p[1] as f32 >= far);
    let corner = per_mm(c0, c1, 0.6);
    let ideal = (w * h) as f64;
    let hz = c.tick_hz as f64;
    let corner_speed = 0.6 / ((c1 - c0) as f64 / hz);
    let straight_speed = 4.0 / ((s1 - s0) as f64 / hz);
    println!(
        "deposit per mm: straight {straight:.5} at {straight_speed:.2} mm/s, corner {corner:.5} at {corner_speed:.2} mm/s average, ideal {ideal:.5} mm^3/mm"
    );
    assert!(
        corner_speed < 0.8 * straight_speed,
        "the corner did not slow down"
    );
    assert!(
        (straight / ideal - 1.0).abs() < 0.02,
        "straight {straight} vs {ideal}"
    );
    assert!(
        (corner / straight - 1.0).abs() < 0.05,
        "corner {corner} vs {straight}"
    );
    // The split follows the composition.
    let a = delivered(&trace, &c, 0, s0, s1);
    let b = delivered(&trace, &c, 1, s0, s1);
    assert!((a / (a + b) - 0.7).abs() < 0.01, "{a} : {b}");
    assert_eq!(duty_at(&trace, 2, trace.now), 0.0);
    // Without the advance the same valves lay a corner off by more than the tolerance.
    drop(trace);
    let mut late = c.clone();
    for ch in &mut late.channel {
        ch.dead_time_s = 0.0;
        ch.time_constant_s = 0.0;
    }
    let mut d = Driver::<N>::new(late);
    d.home_in_place();
    d.run(&moves, Z, |_| false);
    let trace = d.board.trace.borrow();
    let c0 = first_time(&trace, |p| p[0] as f32 >= near);
    let c1 = first_time(&trace, |p| p[1] as f32 >= far);
    let s0 = first_time(&trace, |p| p[0] >= 5 * spm);
    let s1 = first_time(&trace, |p| p[0] >= 9 * spm);
    // Judged with the real valves' response (c's dead time and lag).
    let per_mm = |t0: u64, t1: u64, mm: f64| -> f64 {
        (0..2)
            .map(|ch| delivered(&trace, &c, ch, t0, t1))
            .sum::<f64>()
            / mm
    };
    let uncompensated = per_mm(c0, c1, 0.6) / per_mm(s0, s1, 4.0);
    println!("uncompensated corner / straight: {uncompensated:.3}");
    assert!((uncompensated - 1.0).abs() > 0.05);
}

/// The time spans (ticks) of the travel moves, from the trace: a move ends when the
/// position first equals its target in steps.
fn travel_spans(trace: &Trace, cfg: &PrinterConfig, moves: &[Move]) -> Vec<(u64, u64)> {
    let pos = positions(trace);
    let mut spans = Vec::new();
    let mut k = 0;
    let mut start = 0;
    let mut last = [0i64; AXES];
    for m in moves {
        let target = expected_steps(cfg, [m.to.x, m.to.y, Z]);
        if target == last {
            continue;
        }
        while k < pos.len() && pos[k].1 != target {
            k += 1;
        }
        let end = pos[k].0;
        if !m.deposit {
            spans.push((start, end));
        }
        start = end;
        last = target;
    }
    spans
}

#[test]
fn every_valve_is_closed_during_every_travel_move() {
    let c = cfg();
    // The spiral layer, then five small squares, each reached by travel.
    let mut moves = layer_moves_of(true);
    for k in 0..5 {
        let (x, y) = (-10.0 + 4.0 * k as f32, -14.0 + (k % 2) as f32);
        let square = [
            (x, y),
            (x + 2.0, y),
            (x + 2.0, y + 2.0),
            (x, y + 2.0),
            (x, y),
        ];
        let mut r = road(
            &square,
            [0.25 * k as f32, 1.0 - 0.25 * k as f32, 0.0, 0.0],
            0.4,
        );
        r[0].from = moves.last().unwrap().to;
        moves.extend(r);
    }
    let (moves, d) = run_moves(c.clone(), moves);
    let trace = d.board.trace.borrow();
    let spans = travel_spans(&trace, &c, &moves);
    assert!(spans.len() >= 2, "{} travel moves", spans.len());
    for &(t0, t1) in &spans {
        for ch in 0..c.channels as usize {
            // Closed at the start and never opened before the end.
            assert_eq!(
                duty_at(&trace, ch, t0),
                0.0,
                "channel {ch} open at travel start {t0}"
            );
            let opened = trace
                .duties
                .iter()
                .any(|&(t, cc, duty)| cc == ch && t > t0 && t <= t1 && duty > 0.0);
            assert!(!opened, "channel {ch} opened during travel {t0}..{t1}");
        }
    }
    // The valves did open on the roads.
    let openings = d.machine.valves().stats.openings;
    assert!(
        openings.iter().sum::<u32>() >= spans.len() as u32 - 1,
        "{openings:?}"
    );
}

#[test]
fn emergency_stop_closes_valves_and_stops_stepping_within_one_step_period() {
    let c = cfg();
    let moves = road(&[(2.0, 2.0), (30.0, 2.0)], [0.5, 0.5, 0.0, 0.0], 0.4);
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    // Pressed once the nozzle cruises along the road (x at 15 mm), at an odd instant.
    let spm = c.axes[0].steps_per_mm as i64;
    let mut pressed = None;
    d.run(&moves, Z, |d| {
        let mut t = d.board.trace.borrow_mut();
        if pressed.is_none() && t.position[0] >= 15 * spm {
            let at = t.now + 77;
            t.estop_at = Some(at);
            pressed = Some(at);
        }
        false
    });
    let at = pressed.unwrap();
    assert_eq!(d.machine.state(), State::Stopped(Fault::EmergencyStop));
    let trace = d.board.trace.borrow();
    // The step period there: the gap between the last two steps before the press.
    let steps: Vec<u64> = trace
        .edges
        .iter()
        .filter(|e| e.high && e.pin == Pin::Step(0) && e.t < at)
        .map(|e| e.t)
        .collect();
    let period = steps[steps.len() - 1] - steps[steps.len() - 2];
    assert!(period < 1_000, "not stepping fast at the press: {period}");
    let shut = trace
        .duties
        .iter()
        .filter(|&&(t, _, duty)| t >= at && duty == 0.0)
        .map(|&(t, _, _)| t)
        .max()
        .expect("no valve shut after the press");
    assert!(
        shut - at <= period,
        "valves shut {} ticks after the press",
        shut - at
    );
    for ch in 0..c.channels as usize {
        assert_eq!(duty_at(&trace, ch, at + period), 0.0);
    }
    let late_step = trace
        .edges
        .iter()
        .find(|e| e.high && matches!(e.pin, Pin::Step(_)) && e.t > at + period);
    assert!(late_step.is_none(), "stepped after the stop: {late_step:?}");
    // Every step pin low at the end; the machine refuses more moves.
    for a in 0..AXES {
        let last = trace.edges.iter().rev().find(|e| e.pin == Pin::Step(a));
        assert!(last.is_none_or(|e| !e.high), "axis {a} left high");
    }
    drop(trace);
    assert!(d.machine.push_move(&moves[1], Z).is_err());
}

#[test]
fn pause_and_resume_at_a_block_boundary() {
    let c = cfg();
    let pts: Vec<(f32, f32)> = (0..40)
        .map(|k| {
            (
                2.0 + k as f32 * 0.5,
                2.0 + if k % 2 == 0 { 0.0 } else { 0.3 },
            )
        })
        .collect();
    let moves = road(&pts, [1.0, 0.0, 0.0, 0.0], 0.4);
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    let spm = c.axes[0].steps_per_mm as i64;
    let mut asked = false;
    d.run(&moves, Z, |d| {
        if !asked && d.board.trace.borrow().position[0] >= 8 * spm {
            d.machine.pause();
            asked = true;
        }
        d.machine.state() == State::Paused
    });
    assert_eq!(d.machine.state(), State::Paused);
    let paused_at = d.now();
    let pos = d.board.trace.borrow().position;
    // Stopped on a vertex of the path (a block boundary), valves shut.
    let on_vertex = pts
        .iter()
        .any(|&(x, y)| expected_steps(&c, [x, y, Z])[..2] == pos[..2]);
    assert!(on_vertex, "paused off a vertex at {pos:?}");
    assert_eq!(duty_at(&d.board.trace.borrow(), 0, paused_at), 0.0);
    // Nothing happens while paused.
    assert!(!d.alarm());
    d.wait(200_000);
    let edges = d.board.trace.borrow().edges.len();
    d.machine.resume();
    let resumed_at = d.now();
    d.run(&moves[moves.len()..], Z, |_| false);
    assert!(d.machine.is_done());
    let trace = d.board.trace.borrow();
    assert!(trace.edges[..edges].iter().all(|e| e.t <= paused_at));
    let end = moves.last().unwrap().to;
    assert_eq!(trace.position, expected_steps(&c, [end.x, end.y, Z]));
    // Reopened with the lead: the valve opens a dwell (the dead time) before the first step.
    let open = trace
        .duties
        .iter()
        .find(|&&(t, ch, duty)| t >= resumed_at && ch == 0 && duty > 0.0)
        .unwrap()
        .0;
    let step = trace
        .edges
        .iter()
        .find(|e| e.t >= resumed_at && e.high && matches!(e.pin, Pin::Step(_)))
        .unwrap()
        .t;
    let ch = &c.channel[0];
    let hz = c.tick_hz as f32;
    // The valves look a dead time ahead (the lag is inverted, not waited for).
    let advance = (ch.dead_time_s * hz) as u64;
    let seg = (SEGMENT_S * hz) as u64;
    // From rest the first whole step comes after sqrt(2 x step / a).
    let first = (libm::sqrtf(2.0 / c.axes[0].steps_per_mm / c.axes[0].max_accel) * hz) as u64;
    assert!(
        step >= open + advance - seg,
        "opened {open}, first step {step}"
    );
    assert!(
        step <= open + advance + first + 2 * seg,
        "opened {open}, first step {step}"
    );
}

#[test]
fn homing_runs_into_every_endstop() {
    let c = PrinterConfig {
        home: [1.0, 2.0, 0.5],
        ..PrinterConfig::default()
    };
    let mut d = Driver::<N>::new(c.clone());
    assert_eq!(
        d.machine.travel_to([1.0, 1.0, 1.0]),
        Err(hollowpath::motion::Refused::NotHomed)
    );
    let start = [1234, 567, 8901];
    d.home(start);
    // Every axis moved down exactly to its switch (the trace's position was reset by
    // `home`; its edges tell how far each axis went).
    let trace = d.board.trace.borrow();
    for (a, &start) in start.iter().enumerate() {
        let n = trace
            .edges
            .iter()
            .filter(|e| e.high && e.pin == Pin::Step(a))
            .count();
        assert_eq!(n as i64, start, "axis {a}");
    }
    check_pulses(&trace, 2, 1).unwrap();
    drop(trace);
    // Then moves count from the home position.
    let moves = road(&[(1.0, 2.0), (3.0, 2.0)], [1.0, 0.0, 0.0, 0.0], 0.4);
    d.run(&moves, 0.5, |_| false);
    let trace = d.board.trace.borrow();
    assert_eq!(trace.position, [800, 0, 0]);
}

#[test]
fn homing_without_a_switch_is_a_fault() {
    let c = PrinterConfig {
        homing_travel: 2.0,
        ..PrinterConfig::default()
    };
    let mut d = Driver::<N>::new(c);
    d.board.trace.borrow_mut().endstop_at = [-100, -1_000_000, -100];
    d.machine.start_homing();
    while d.alarm() {}
    assert_eq!(d.machine.state(), State::Stopped(Fault::Homing { axis: 1 }));
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

/// When channel 0 first opens and last shuts (ticks).
fn open_close(trace: &Trace) -> (u64, u64) {
    let open = trace
        .duties
        .iter()
        .find(|&&(_, ch, duty)| ch == 0 && duty > 0.0)
        .unwrap()
        .0;
    let mut close = 0;
    let mut was_open = false;
    for &(t, ch, duty) in &trace.duties {
        if ch == 0 {
            if was_open && duty == 0.0 {
                close = t;
            }
            was_open = duty > 0.0;
        }
    }
    (open, close)
}

#[test]
fn lead_opens_earlier_and_lag_shuts_earlier() {
    let mut moves = road(&[(2.0, 2.0), (12.0, 2.0)], [1.0, 0.0, 0.0, 0.0], 0.4);
    moves.push(Move {
        from: Point::new(12.0, 2.0),
        to: Point::new(0.0, 0.0),
        width: 0.4,
        material: [1.0, 0.0, 0.0, 0.0],
        deposit: false,
    });
    let run = |lead: f32, lag: f32| {
        let mut c = cfg();
        c.channel[0].lead_s = lead;
        c.channel[0].lag_s = lag;
        let (_, d) = run_moves(c, moves.clone());
        let t = d.board.trace.borrow();
        let (open, close) = open_close(&t);
        (open as i64, close as i64)
    };
    let (o0, c0) = run(0.0, 0.0);
    let (o1, c1) = run(0.010, 0.0);
    let (o2, c2) = run(0.0, 0.010);
    let ms = 1_000;
    // With the lead the road starts 10 ms later (a longer dwell), the valve opens at the same
    // time: 10 ms earlier relative to the road. The close is unchanged relative to the road.
    assert!(
        ((c1 - o1) - (c0 - o0) - 10 * ms).abs() <= ms,
        "{o0} {c0} / {o1} {c1}"
    );
    // With the lag the valve shuts 10 ms earlier; the opening is unchanged.
    assert_eq!(o2, o0);
    assert!(((c0 - c2) - 10 * ms).abs() <= 2 * ms, "{c0} vs {c2}");
}

#[test]
fn abort_shuts_every_valve_and_drops_the_job() {
    let c = cfg();
    let moves = road(&[(2.0, 2.0), (30.0, 2.0)], [0.25, 0.25, 0.25, 0.25], 0.4);
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    let spm = c.axes[0].steps_per_mm as i64;
    d.run(&moves, Z, |d| {
        d.board.trace.borrow().position[0] >= 10 * spm
    });
    for ch in 0..4 {
        assert!(
            duty_at(&d.board.trace.borrow(), ch, d.now()) > 0.0,
            "channel {ch} shut"
        );
    }
    d.machine.abort(&mut d.board);
    assert_eq!(d.machine.state(), State::Stopped(Fault::Aborted));
    assert!(d.machine.is_done());
    let at = d.now();
    for ch in 0..4 {
        assert_eq!(duty_at(&d.board.trace.borrow(), ch, at), 0.0);
    }
    // Nothing more happens, whatever is asked.
    assert!(!d.alarm());
    d.machine.resume();
    assert!(!d.alarm());
    assert!(d.board.trace.borrow().edges.iter().all(|e| e.t <= at));
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
fn shutdown_shuts_the_valves_before_the_motors() {
    let c = cfg();
    let moves = road(&[(2.0, 2.0), (30.0, 2.0)], [0.5, 0.5, 0.0, 0.0], 0.4);
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    let spm = c.axes[0].steps_per_mm as i64;
    // Pressed while a step pulse is high (the clock already stands at the alarm that would
    // lower it), so the shutdown has a step pin to lower.
    let mut pressed = None;
    d.run(&moves, Z, |d| {
        let mut t = d.board.trace.borrow_mut();
        if pressed.is_none() && t.position[0] >= 12 * spm && t.levels[0][0] {
            let at = t.now;
            t.estop_at = Some(at);
            pressed = Some(at);
        }
        false
    });
    let at = pressed.unwrap();
    assert_eq!(d.machine.state(), State::Stopped(Fault::EmergencyStop));
    let trace = d.board.trace.borrow();
    let lowered = trace
        .edges
        .iter()
        .find(|e| e.t >= at && e.pin == Pin::Step(0) && !e.high)
        .expect("the step pin was not lowered");
    let shut: Vec<u64> = trace
        .duties
        .iter()
        .zip(&trace.duty_seq)
        .filter(|((t, _, duty), _)| *t >= at && *duty == 0.0)
        .map(|(_, &seq)| seq)
        .collect();
    assert_eq!(
        shut.len(),
        c.channels as usize,
        "every channel written shut once"
    );
    assert!(
        shut.iter().all(|&s| s < lowered.seq),
        "a motor stopped before a valve"
    );
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
