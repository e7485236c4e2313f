//! The motion code on the MCU: a layer streamed from the toolpath straight into the core's
//! [`Machine`], stepped on a virtual clock against counting pins, with the instructions the
//! look-ahead (per block pushed) and the step interrupt (per step) take.
//!
//! The layer is never stored: [`Feed`] is the layer's [`PathSink`], cuts each vertex pair
//! into constant-width moves and pushes them; whenever the look-ahead is full it runs the
//! step interrupt ([`Machine::on_alarm`]) at each deadline until there is room, as the
//! board's timer interrupt would. The clock is virtual (the deadline the machine asks for is
//! the next `now`), so the figures are the motion code's own work, not time waited. The pins
//! are the link firmware's counting pins ([`LinkBoard`]).

use core::sync::atomic::Ordering;

use hollowpath::geometry::Point;
use hollowpath::motion::{Machine, PrinterConfig, Refused, State};
use hollowpath::toolpath::moves::{split, Move};
use hollowpath::toolpath::{PathSink, Vertex};

use crate::link_board::{LinkBoard, OPENINGS};

/// Blocks of look-ahead (the host's virtual printer uses the same).
pub const LOOK_AHEAD: usize = 32;

/// Moves of the layer that are stepped (bounds the emulated time of the test).
pub const MOVES: u32 = 400;

/// Rising step edges per axis on `board` (the link firmware's counting pins).
pub fn pulses(board: &LinkBoard) -> [u32; 3] {
    [0, 1, 2].map(|a| board.step[a].rises)
}

/// Openings per valve channel so far.
pub fn openings() -> [u32; 4] {
    [0, 1, 2, 3].map(|c| OPENINGS[c].load(Ordering::Relaxed))
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
    pub board: &'a mut LinkBoard,
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
        board: &'a mut LinkBoard,
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
