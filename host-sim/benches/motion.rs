//! The core's motion code on the host (criterion): the step routine per step, and the
//! look-ahead per block. Compare runs as ratios: the machines are shared and noisy.

use std::convert::Infallible;

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{self, SetDutyCycle};
use hollowpath::geometry::Point;
use hollowpath::motion::{BlockMaker, Board, Full, Machine, Planner, PrinterConfig};
use hollowpath::toolpath::moves::Move;

/// Pins that only hold their level.
#[derive(Default)]
struct Pin(bool);

impl ErrorType for Pin {
    type Error = Infallible;
}

impl OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0 = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0 = true;
        Ok(())
    }
}

impl InputPin for Pin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0)
    }
}

#[derive(Default)]
struct Pwm(u16);

impl pwm::ErrorType for Pwm {
    type Error = Infallible;
}

impl SetDutyCycle for Pwm {
    fn max_duty_cycle(&self) -> u16 {
        1000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.0 = duty;
        Ok(())
    }
}

#[derive(Default)]
struct Quiet {
    step: [Pin; 3],
    dir: [Pin; 3],
    input: Pin,
    valves: [Pwm; 4],
}

impl Board for Quiet {
    type Out = Pin;
    type In = Pin;
    type Pwm = Pwm;
    fn step(&mut self, axis: usize) -> &mut Pin {
        &mut self.step[axis]
    }
    fn dir(&mut self, axis: usize) -> &mut Pin {
        &mut self.dir[axis]
    }
    fn endstop(&mut self, _: usize) -> &mut Pin {
        &mut self.input
    }
    fn estop(&mut self) -> &mut Pin {
        &mut self.input
    }
    fn valve(&mut self, channel: usize) -> &mut Pwm {
        &mut self.valves[channel]
    }
}

/// A 0.3 mm-pitch zigzag road, 20 mm along x.
fn road() -> Vec<Move> {
    let pts: Vec<Point> = (0..=40)
        .map(|k| Point::new(k as f32 * 0.5, (k % 2) as f32 * 0.3))
        .collect();
    pts.windows(2)
        .map(|w| Move {
            from: w[0],
            to: w[1],
            width: 0.4,
            material: [0.5, 0.5, 0.0, 0.0],
            deposit: true,
        })
        .collect()
}

fn printer() -> PrinterConfig {
    let mut cfg = PrinterConfig::default();
    for a in &mut cfg.axes {
        a.endstop = None;
    }
    cfg
}

/// Runs the road to the end on a virtual clock; the steps taken.
fn run(machine: &mut Machine<32>, board: &mut Quiet, moves: &[Move]) -> u64 {
    let mut now = 0u32;
    let mut next = 0;
    loop {
        while next < moves.len() && machine.push_move(&moves[next], 0.3).is_ok() {
            next += 1;
        }
        match machine.on_alarm(now, board) {
            Some(at) => now = at,
            None if next == moves.len() && machine.is_done() => break,
            None => {}
        }
    }
    machine.stepper().stats.steps.iter().sum()
}

fn step_routine(c: &mut Criterion) {
    let moves = road();
    let fresh = || {
        let mut m = Box::new(Machine::<32>::new(printer()).unwrap());
        let mut board = Quiet::default();
        m.start_homing();
        while m.on_alarm(0, &mut board).is_some() {}
        (m, board)
    };
    let (mut m, mut board) = fresh();
    let steps = run(&mut m, &mut board, &moves);
    let mut group = c.benchmark_group("motion");
    group.sample_size(20);
    group.throughput(Throughput::Elements(steps));
    group.bench_function("steps (a 20 mm zigzag road, per step)", |b| {
        b.iter_batched(
            fresh,
            |(mut m, mut board)| black_box(run(&mut m, &mut board, black_box(&moves))),
            criterion::BatchSize::LargeInput,
        )
    });
    group.finish();
}

fn look_ahead(c: &mut Criterion) {
    let cfg = printer();
    let moves = road();
    let mut maker = BlockMaker::new(&cfg);
    let mut planner = Box::new(Planner::<32>::new(
        cfg.junction_deviation,
        cfg.valve_time_constant(),
    ));
    let mut k = 0;
    let mut group = c.benchmark_group("motion");
    group.throughput(Throughput::Elements(1));
    group.bench_function("look-ahead (one block into a full ring of 32)", |b| {
        b.iter(|| {
            // Back and forth along the road, forever.
            let m = &moves[k % moves.len()];
            let m = if (k / moves.len()) % 2 == 0 {
                *m
            } else {
                Move {
                    from: m.to,
                    to: m.from,
                    ..*m
                }
            };
            k += 1;
            let Ok(Some(mut block)) = maker.from_move(&m, 0.3) else {
                return;
            };
            loop {
                match planner.push(black_box(block)) {
                    Ok(()) => break,
                    Err(Full(back)) => {
                        block = back;
                        black_box(planner.pop());
                    }
                }
            }
            maker.commit(&block);
        })
    });
    group.finish();
}

criterion_group!(benches, step_routine, look_ahead);
criterion_main!(benches);
