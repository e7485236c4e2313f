//! The valves on a mock board, judged from the recorded duties through the valve model
//! (dead time and first-order lag): the deposit per millimetre in a slowed corner, valves
//! shut on every travel move, lead and lag.

mod common;

use common::board::{duty_at, expected_steps, positions, Driver, Trace};
use common::motion::{cfg, layer_moves_of, road, run_moves, N, Z};
use common::motion::{delivered, first_time};
use hollowpath::geometry::Point;
use hollowpath::motion::config::AXES;
use hollowpath::motion::PrinterConfig;
use hollowpath::toolpath::moves::Move;

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
