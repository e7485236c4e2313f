//! Random paths on random printers: whatever the moves (tiny, reversing, travel and road
//! mixed), the steps add up exactly, every pulse is wide enough, and no valve opens on
//! travel.

mod common;

use common::board::{check_pulses, duty_at, expected_steps, no_endstops, Driver};
use common::motion::Z;
use hollowpath::geometry::Point;
use hollowpath::motion::PrinterConfig;
use hollowpath::toolpath::moves::Move;
use proptest::prelude::*;

fn moves_from(points: &[(f32, f32, bool)]) -> Vec<Move> {
    let mut from = Point::new(0.0, 0.0);
    points
        .iter()
        .map(|&(x, y, deposit)| {
            let to = Point::new(x, y);
            let m = Move {
                from,
                to,
                width: 0.4,
                material: [0.3, 0.7, 0.0, 0.0],
                deposit,
            };
            from = to;
            m
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn random_paths_step_exactly_and_cleanly(
        points in prop::collection::vec(
            (-8.0f32..8.0, -8.0f32..8.0, any::<bool>()), 2..30),
        tiny in prop::collection::vec((-0.01f32..0.01, -0.01f32..0.01), 0..10),
        spm in (50.0f32..1600.0, 50.0f32..1600.0),
        pulse_ns in 1_000u32..5_000,
        accel in 20.0f32..500.0,
    ) {
        let mut cfg = no_endstops(PrinterConfig::default());
        cfg.axes[0].steps_per_mm = spm.0;
        cfg.axes[1].steps_per_mm = spm.1;
        cfg.axes[0].max_accel = accel;
        cfg.axes[1].max_accel = accel;
        cfg.step_pulse_ns = pulse_ns;
        // Moves of a few microns around the last point: less than a step, or a step back
        // and forth.
        let mut points = points;
        let last = *points.last().unwrap();
        for (dx, dy) in tiny {
            points.push((last.0 + dx, last.1 + dy, true));
        }
        let moves = moves_from(&points);
        let mut d = Driver::<16>::new(cfg.clone());
        d.home_in_place();
        d.run(&moves, Z, |_| false);
        prop_assert!(d.machine.is_done());
        let trace = d.board.trace.borrow();
        let end = moves.last().unwrap().to;
        prop_assert_eq!(trace.position, expected_steps(&cfg, [end.x, end.y, Z]));
        let pulse = cfg.ns_to_ticks(pulse_ns) as u64;
        let setup = cfg.ns_to_ticks(cfg.dir_setup_ns) as u64;
        if trace.edges.iter().any(|e| e.high) {
            prop_assert!(check_pulses(&trace, pulse, setup).is_ok(), "{:?}", check_pulses(&trace, pulse, setup));
        }
        for ch in 0..4 {
            prop_assert_eq!(duty_at(&trace, ch, trace.now), 0.0);
        }
    }
}
