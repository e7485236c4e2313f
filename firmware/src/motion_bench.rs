//! The motion code on the MCU: a layer streamed from the toolpath straight into the core's
//! [`Machine`], stepped on a virtual clock against counting pins, with the instructions the
//! look-ahead (per block pushed) and the step interrupt (per step) take.
//!
//! The layer is never stored: [`Feed`] is the layer's [`PathSink`], cuts each vertex pair
//! into constant-width moves and pushes them; whenever the look-ahead is full it runs the
//! step interrupt ([`Machine::on_alarm`]) at each deadline until there is room, as the
//! board's timer interrupt would. The clock is virtual (the deadline the machine asks for is
//! the next `now`), so the figures are the motion code's own work, not time waited.

use core::convert::Infallible;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{self, SetDutyCycle};
use hollowpath::geometry::Point;
use hollowpath::motion::{Board, Machine, PrinterConfig, Refused, State};
use hollowpath::toolpath::moves::{split, Move};
use hollowpath::toolpath::{PathSink, Vertex};

/// Blocks of look-ahead (the host's virtual printer uses the same).
pub const LOOK_AHEAD: usize = 32;

/// Moves of the layer that are stepped (bounds the emulated time of the test).
pub const MOVES: u32 = 400;

/// A pin that counts its rising edges.
#[derive(Default)]
pub struct Pin {
    high: bool,
    rises: u32,
}

impl ErrorType for Pin {
    type Error = Infallible;
}

impl OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.high = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        if !self.high {
            self.rises += 1;
        }
        self.high = true;
        Ok(())
    }
}

impl InputPin for Pin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.high)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.high)
    }
}

/// A valve output that counts its openings (duty from 0 to more).
#[derive(Default)]
pub struct Valve {
    duty: u16,
    openings: u32,
}

impl pwm::ErrorType for Valve {
    type Error = Infallible;
}

impl SetDutyCycle for Valve {
    fn max_duty_cycle(&self) -> u16 {
        10_000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        if self.duty == 0 && duty > 0 {
            self.openings += 1;
        }
        self.duty = duty;
        Ok(())
    }
}

/// The counting board (QEMU has no printer pins). The inputs read low: no endstop is
/// configured and the emergency stop is active high.
#[derive(Default)]
pub struct CountingBoard {
    step: [Pin; 3],
    dir: [Pin; 3],
    input: Pin,
    valve: [Valve; 4],
}

impl Board for CountingBoard {
    type Out = Pin;
    type In = Pin;
    type Pwm = Valve;
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
    fn valve(&mut self, c: usize) -> &mut Valve {
        &mut self.valve[c]
    }
}

impl CountingBoard {
    /// Rising step edges per axis.
    pub fn pulses(&self) -> [u32; 3] {
        [self.step[0].rises, self.step[1].rises, self.step[2].rises]
    }

    /// Openings per valve channel.
    pub fn openings(&self) -> [u32; 4] {
        [
            self.valve[0].openings,
            self.valve[1].openings,
            self.valve[2].openings,
            self.valve[3].openings,
        ]
    }
}

/// The printer of the bench: the default one, no endstops (homing takes the start).
pub fn printer() -> PrinterConfig {
    let mut cfg = PrinterConfig::default();
    for a in &mut cfg.axes {
        a.endstop = None;
    }
    cfg
}

/// What the feed counted.
#[derive(Clone, Copy, Default)]
pub struct Figures {
    /// Moves pushed.
    pub moves: u32,
    /// Step-interrupt calls.
    pub alarms: u32,
    /// Clock ticks (of `ticks`) spent in `push_move` and in `on_alarm`.
    pub push_ticks: u64,
    pub alarm_ticks: u64,
}

/// The layer's sink that drives the machine (the module's essay).
pub struct Feed<'a, F: Fn() -> u64> {
    pub machine: &'a mut Machine<LOOK_AHEAD>,
    pub board: &'a mut CountingBoard,
    /// The virtual clock, timer ticks.
    pub now: u32,
    pub z: f32,
    pub ticks: F,
    pub figures: Figures,
    /// The first refusal other than a full look-ahead.
    pub refused: Option<Refused>,
    last: Option<Vertex>,
    idle: bool,
}

impl<'a, F: Fn() -> u64> Feed<'a, F> {
    pub fn new(
        machine: &'a mut Machine<LOOK_AHEAD>,
        board: &'a mut CountingBoard,
        z: f32,
        ticks: F,
    ) -> Self {
        Feed {
            machine,
            board,
            now: 0,
            z,
            ticks,
            figures: Figures::default(),
            refused: None,
            last: None,
            idle: true,
        }
    }

    /// One step interrupt at the virtual `now`; whether it asked for another.
    fn alarm(&mut self) -> bool {
        let t0 = (self.ticks)();
        let next = self.machine.on_alarm(self.now, self.board);
        self.figures.alarm_ticks += (self.ticks)() - t0;
        self.figures.alarms += 1;
        match next {
            Some(at) => {
                self.now = at;
                self.idle = false;
                true
            }
            None => {
                self.idle = true;
                false
            }
        }
    }

    fn push(&mut self, m: &Move) {
        if self.refused.is_some() || self.figures.moves >= MOVES {
            return;
        }
        loop {
            let t0 = (self.ticks)();
            let r = self.machine.push_move(m, self.z);
            self.figures.push_ticks += (self.ticks)() - t0;
            match r {
                Ok(()) => break,
                Err(Refused::Full) => {
                    if !self.alarm() && self.machine.planner().is_full() {
                        self.refused = Some(Refused::Full);
                        return;
                    }
                }
                Err(why) => {
                    self.refused = Some(why);
                    return;
                }
            }
        }
        self.figures.moves += 1;
        if self.idle {
            // Start the interrupt chain on what is queued.
            self.alarm();
        }
    }

    /// Homes (no endstops: at once).
    pub fn home(&mut self) {
        self.machine.start_homing();
        while self.machine.state() == State::Homing {
            if !self.alarm() {
                break;
            }
        }
    }

    /// Steps out what is queued.
    pub fn drain(&mut self) {
        while self.alarm() {}
    }
}

impl<F: Fn() -> u64> PathSink for Feed<'_, F> {
    fn push_vertex(&mut self, v: Vertex) -> Result<(), Vertex> {
        match self.last {
            // The layer's first vertex: travel there from home.
            None => {
                let home = self.machine.config().home;
                let m = Move {
                    from: Point::new(home[0], home[1]),
                    to: v.at,
                    width: v.width,
                    material: v.material,
                    deposit: false,
                };
                self.push(&m);
            }
            Some(a) => split(&a, &v, |m| self.push(&m)),
        }
        self.last = Some(v);
        Ok(())
    }

    fn last_vertex(&self) -> Option<Vertex> {
        self.last
    }
}
