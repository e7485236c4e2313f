//! Motion test helpers: the printer, the layer and the small paths the motion tests run.
#![allow(dead_code)]

use super::board::{duty_at, no_endstops, positions, Driver, Trace};
use super::two_circles;
use hollowpath::geometry::Point;
use hollowpath::motion::config::AXES;
use hollowpath::motion::valve::flow_for;
use hollowpath::motion::{PrinterConfig, State};
use hollowpath::toolpath::moves::{path_moves, Move};
use hollowpath::toolpath::spiral::{spiral, ControlFunction};
use hollowpath::toolpath::zigzag::zigzag;
use hollowpath::toolpath::Vertex;
use hollowpath::Settings;

pub const N: usize = 32;

pub const Z: f32 = 0.3;

pub fn cfg() -> PrinterConfig {
    no_endstops(PrinterConfig::default())
}

/// The moves of one zigzag layer of the two-circle slice, from home (a travel to its first
/// vertex first).
pub fn layer_moves() -> Vec<Move> {
    layer_moves_of(false)
}

/// The zigzag layer's moves, or the spiral layer's (with a jump between cells).
pub fn layer_moves_of(spiral_layer: bool) -> Vec<Move> {
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

pub fn run_layer(cfg: PrinterConfig) -> (Vec<Move>, Driver<N>) {
    run_moves(cfg, layer_moves())
}

pub fn run_moves(cfg: PrinterConfig, moves: Vec<Move>) -> (Vec<Move>, Driver<N>) {
    let mut d = Driver::<N>::new(cfg);
    d.home_in_place();
    d.run(&moves, Z, |_| false);
    assert!(d.machine.is_done());
    assert_eq!(d.machine.state(), State::Ready);
    (moves, d)
}

pub fn road(points: &[(f32, f32)], material: [f32; 4], width: f32) -> Vec<Move> {
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

/// The flow each channel delivers over time, from the duty timeline through the valve model
/// (dead time, then the first-order lag towards the calibration curve's flow), integrated
/// from `t0` to `t1` (ticks), mm^3.
pub fn delivered(trace: &Trace, cfg: &PrinterConfig, channel: usize, t0: u64, t1: u64) -> f64 {
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
pub fn first_time(trace: &Trace, at: impl Fn([i64; AXES]) -> bool) -> u64 {
    positions(trace)
        .into_iter()
        .find(|(_, p)| at(*p))
        .map(|(t, _)| t)
        .expect("never there")
}
