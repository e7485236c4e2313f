//! The core's motion code on every reference slice: each layer's moves planned, stepped on a
//! mock board with a virtual clock, and judged from the recorded edges alone.

#[path = "../../tests/common/board.rs"]
mod board;

use board::{check_pulses, duty_at, expected_steps, no_endstops, Driver, Pin};
use hollowpath::geometry::Point;
use hollowpath::motion::PrinterConfig;
use hollowpath::toolpath::moves::{path_moves, Move};
use hollowpath::toolpath::spiral::ControlFunction;
use host_sim::layers::{layer, Fill};
use host_sim::{run_on_large_stack, slice_file, REFERENCE_SLICES};

/// A layer's moves from home: a travel to its first vertex, then its moves.
fn moves_of(path: &[hollowpath::toolpath::Vertex]) -> Vec<Move> {
    let mut moves = vec![Move {
        from: Point::new(0.0, 0.0),
        to: path[0].at,
        width: path[0].width,
        material: path[0].material,
        deposit: false,
    }];
    path_moves(path, |m| moves.push(m));
    moves
}

#[test]
fn every_reference_layer_steps_exactly_its_displacement() {
    run_on_large_stack(|| {
        let cfg = no_endstops(PrinterConfig::default());
        let pulse = cfg.ns_to_ticks(cfg.step_pulse_ns) as u64;
        let setup = cfg.ns_to_ticks(cfg.dir_setup_ns) as u64;
        let z = cfg.layer_height;
        for (name, text) in REFERENCE_SLICES {
            let slice = slice_file::parse(text).unwrap().slice;
            let planner = host_sim::plan(&slice).unwrap();
            let plan = planner.last_plan();
            for (index, fill) in [
                (0, Fill::Mcl(ControlFunction::RoadWidth)),
                (1, Fill::Mcl(ControlFunction::RoadWidth)),
                (1, Fill::Offset),
            ] {
                let l = layer(&slice, plan, fill, index).unwrap();
                let moves = moves_of(&l.path);
                let mut d = Driver::<32>::new(cfg.clone());
                d.home_in_place();
                d.run(&moves, z, |_| false);
                let what = format!("{name} layer {index} {}", l.note);
                assert!(d.machine.is_done(), "{what}: not finished");
                let trace = d.board.trace.borrow();
                let end = moves.last().unwrap().to;
                assert_eq!(
                    trace.position,
                    expected_steps(&cfg, [end.x, end.y, z]),
                    "{what}"
                );
                check_pulses(&trace, pulse, setup).unwrap_or_else(|e| panic!("{what}: {e}"));
                // Shut at the end of the layer, opened at least once per road start.
                for ch in 0..cfg.channels as usize {
                    assert_eq!(duty_at(&trace, ch, trace.now), 0.0, "{what}");
                }
                let starts = (1..l.path.len())
                    .filter(|&i| l.path[i].deposit && !l.path[i - 1].deposit)
                    .count() as u32;
                let openings = d.machine.valves().stats.openings;
                assert!(
                    openings.iter().copied().max().unwrap_or(0) >= starts.min(1),
                    "{what}: {openings:?}"
                );
                // The figures: steps, the fastest step rate (shortest gap between two
                // rising edges of one axis), the print time.
                let mut shortest = [u64::MAX; 3];
                let mut last = [None::<u64>; 3];
                for e in trace.edges.iter().filter(|e| e.high) {
                    if let Pin::Step(a) = e.pin {
                        if let Some(t) = last[a] {
                            shortest[a] = shortest[a].min(e.t - t);
                        }
                        last[a] = Some(e.t);
                    }
                }
                let stats = d.machine.stepper().stats;
                let hz = cfg.tick_hz as f64;
                let rate = hz / shortest[0].min(shortest[1]) as f64;
                println!(
                    "{name} layer {index} ({}): {} moves, steps x {} y {} z {}, max step rate {:.0} Hz, {:.1} s, {} segments, valve openings {:?}, saturated {}",
                    l.pattern.name(),
                    moves.len(),
                    stats.steps[0],
                    stats.steps[1],
                    stats.steps[2],
                    rate,
                    trace.now as f64 / hz,
                    stats.segments,
                    openings,
                    d.machine.valves().stats.saturated,
                );
                // No axis ever stepped faster than its speed limit allows (with the Bresenham
                // spread of one tick).
                for (a, &gap) in shortest.iter().enumerate().take(2) {
                    let limit = cfg.axes[a].max_speed * cfg.axes[a].steps_per_mm;
                    let rate = hz / gap as f64;
                    assert!(rate <= 1.1 * limit as f64, "{what}: axis {a} at {rate} Hz");
                }
            }
        }
    });
}
