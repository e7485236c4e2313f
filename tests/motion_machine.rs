//! The machine on a mock board: emergency stop, pause and resume, homing, abort, and the
//! order of the one shutdown.

mod common;

use common::board::{check_pulses, duty_at, expected_steps, Driver, Pin};
use common::motion::{cfg, delivered, first_time, road, N, Z};
use hollowpath::motion::config::{AXES, SEGMENT_S};
use hollowpath::motion::{Fault, PrinterConfig, State};

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
    let mut asks = 0;
    d.run(&moves, Z, |d| {
        if d.board.trace.borrow().position[0] >= 8 * spm {
            // Asked at every alarm until it is reached: still one pause.
            d.machine.pause();
            asks += 1;
        }
        d.machine.state() == State::Paused
    });
    assert_eq!(d.machine.state(), State::Paused);
    assert!(asks > 100, "{asks}");
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
    d.run(&moves[moves.len()..], Z, |d| {
        d.machine.state() == State::Paused
    });
    assert!(d.machine.is_done(), "{:?}", d.machine.state());
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
fn pause_and_resume_leave_no_blob_and_no_gap() {
    let c = cfg();
    let (w, h) = (0.4f32, c.layer_height);
    let pts: Vec<(f32, f32)> = (0..40)
        .map(|k| (2.0 + k as f32 * 0.5, 2.0 + (k % 2) as f32 * 0.3))
        .collect();
    let moves = road(&pts, [0.6, 0.4, 0.0, 0.0], w);
    let spm = c.axes[0].steps_per_mm;
    // Volume deposited while the nozzle's x runs from `lo` to `hi` mm.
    let volume = |d: &Driver<N>, lo: f32, hi: f32| -> f64 {
        let trace = d.board.trace.borrow();
        let t0 = first_time(&trace, |p| p[0] as f32 >= lo * spm);
        let t1 = first_time(&trace, |p| p[0] as f32 >= hi * spm);
        (0..2).map(|ch| delivered(&trace, &c, ch, t0, t1)).sum()
    };
    // Straight through.
    let mut plain = Driver::<N>::new(c.clone());
    plain.home_in_place();
    plain.run(&moves, Z, |_| false);
    // Paused once x passes 8 mm, for 300 ms, then resumed.
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    let mut asked = false;
    d.run(&moves, Z, |d| {
        if !asked && d.board.trace.borrow().position[0] as f32 >= 8.0 * spm {
            d.machine.pause();
            asked = true;
        }
        d.machine.state() == State::Paused
    });
    assert_eq!(d.machine.state(), State::Paused);
    let x = d.board.trace.borrow().position[0] as f32 / spm;
    d.wait(300_000);
    d.machine.resume();
    d.run(&moves[moves.len()..], Z, |_| false);
    assert!(d.machine.is_done());
    // Around the pause point the deposit differs from the uninterrupted road's by less than
    // a road width's length of road (w x h x w): no blob, no gap.
    let (lo, hi) = (x - 1.5, x + 1.5);
    let (a, b) = (volume(&plain, lo, hi), volume(&d, lo, hi));
    let piece = (w * h * w) as f64;
    println!(
        "around the pause at x = {x:.2} mm: {b:.4} mm^3 paused, {a:.4} straight through (a road width's piece is {piece:.4})"
    );
    assert!(a > 5.0 * piece, "nothing deposited: {a}");
    assert!((b - a).abs() < piece, "paused {b} vs {a}");
}

#[test]
fn a_broken_valve_shuts_the_machine_down_and_the_others_are_still_shut() {
    let c = cfg();
    let moves = road(
        &[(2.0, 2.0), (12.0, 2.0), (12.0, 6.0)],
        [0.25, 0.25, 0.25, 0.25],
        0.4,
    );
    let mut d = Driver::<N>::new(c.clone());
    d.home_in_place();
    let spm = c.axes[0].steps_per_mm as i64;
    let mut broke = None;
    d.run(&moves, Z, |d| {
        let mut t = d.board.trace.borrow_mut();
        if broke.is_none() && t.position[0] >= 5 * spm {
            t.broken_valve = Some(1);
            broke = Some(t.now);
        }
        false
    });
    assert_eq!(
        d.machine.state(),
        State::Stopped(Fault::Valve { channel: 1 })
    );
    let trace = d.board.trace.borrow();
    let end = trace.now;
    for ch in [0, 2, 3] {
        assert_eq!(duty_at(&trace, ch, end), 0.0, "channel {ch} left open");
    }
    // Stopped short of the road's end, every step pin low.
    assert!(trace.position[0] < 12 * spm);
    for a in 0..AXES {
        let last = trace.edges.iter().rev().find(|e| e.pin == Pin::Step(a));
        assert!(last.is_none_or(|e| !e.high));
    }
}

#[test]
fn a_move_needing_a_missing_channel_is_refused() {
    let mut c = cfg();
    c.channels = 2;
    let mut d = Driver::<N>::new(c);
    d.home_in_place();
    let moves = road(&[(2.0, 2.0), (4.0, 2.0)], [0.5, 0.0, 0.5, 0.0], 0.4);
    // The travel is fine, the road needs channel 2.
    assert_eq!(d.machine.push_move(&moves[0], Z), Ok(()));
    assert_eq!(
        d.machine.push_move(&moves[1], Z),
        Err(hollowpath::motion::Refused::Channel { channel: 2 })
    );
}

#[test]
fn a_printer_with_fewer_channels_than_the_slice_uses_is_refused() {
    // The two-circle slice deposits channels 0 (wall), 1 and 2 (the holes).
    let slice = common::two_circles(hollowpath::Settings::default());
    let mut c = PrinterConfig::default();
    c.check_slice(&slice).unwrap();
    c.channels = 3;
    c.check_slice(&slice).unwrap();
    c.channels = 2;
    let e = c.check_slice(&slice).unwrap_err();
    assert_eq!(
        e,
        hollowpath::motion::PrinterError::SliceChannel {
            feature: hollowpath::FeatureId::Hole(1),
            channel: 2,
            channels: 2
        }
    );
    assert_eq!(
        e.to_string(),
        "channels: 2, but the material of hole 1 uses channel 2"
    );
}
