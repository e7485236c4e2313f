//! The machine: homing, the job, pause and resume, and the one shutdown every fault goes
//! through.
//!
//! [`Machine::on_alarm`] is the step interrupt: the board's timer (or the host's virtual
//! clock) calls it at the deadline it returned last, and whenever work arrives while it
//! returned `None`. Each call first reads the emergency-stop input, so an emergency stop is
//! seen within one alarm: while stepping, alarms are at most one step period apart (two per
//! step), and never more than a segment ([`MAX_SEGMENT_S`](super::config::MAX_SEGMENT_S))
//! apart while moving. A board with an emergency-stop interrupt calls
//! [`Machine::emergency_stop`] from it directly.

use super::block::{Block, BlockMaker, OutOfRange};
use super::config::{PrinterConfig, PrinterError, AXES, SEGMENT_RING};
use super::planner::Planner;
use super::stepper::{SegmentGen, StepTimer, Stepper, Ticks};
use super::valve::Valves;
use super::Board;
use crate::config::CHANNELS;
use crate::geometry::primitives::MinMax;
use crate::toolpath::moves::Move;
use embedded_hal::digital::{InputPin, OutputPin};

/// Why the machine stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fault {
    /// The emergency-stop input (or [`Machine::emergency_stop`]).
    EmergencyStop,
    /// [`Machine::abort`].
    Aborted,
    /// A step or direction pin refused a write.
    StepPin {
        /// The axis.
        axis: u8,
    },
    /// A valve output refused a duty.
    Valve {
        /// The channel.
        channel: u8,
    },
    /// The emergency-stop input or an endstop could not be read.
    Input,
    /// An axis found no endstop within `homing_travel`.
    Homing {
        /// The axis.
        axis: u8,
    },
    /// The timer kept refusing deadlines as already past.
    Late,
    /// The host went silent for longer than the link's watchdog allows during a job (the
    /// application's call: the machine itself knows no link).
    HostSilent,
}

/// Where the machine is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum State {
    /// Not homed: moves are refused.
    Unhomed,
    /// Running into the endstops.
    Homing,
    /// Homed: running the queued moves, or waiting for some.
    Ready,
    /// Stopped at a block boundary, valves shut, until [`Machine::resume`].
    Paused,
    /// Shut down (valves shut, motion dropped) until rebuilt.
    Stopped(Fault),
}

/// What the machine has driven so far: the figures a layer's telemetry reports, as the
/// difference of two readings ([`Counters::since`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Step pulses per axis.
    pub steps: [u64; AXES],
    /// Openings per valve channel (duty from 0 to more).
    pub valve_openings: [u32; CHANNELS],
    /// Timer ticks each channel was open.
    pub valve_open_ticks: [u64; CHANNELS],
    /// Timer ticks of the segments run (moves and dwells; pauses not).
    pub ticks: u64,
}

impl Counters {
    /// What happened between `earlier` and `self`.
    pub fn since(&self, earlier: &Counters) -> Counters {
        let mut d = Counters {
            ticks: self.ticks - earlier.ticks,
            ..Counters::default()
        };
        for a in 0..AXES {
            d.steps[a] = self.steps[a] - earlier.steps[a];
        }
        for c in 0..CHANNELS {
            d.valve_openings[c] = self.valve_openings[c] - earlier.valve_openings[c];
            d.valve_open_ticks[c] = self.valve_open_ticks[c] - earlier.valve_open_ticks[c];
        }
        d
    }
}

/// A move the machine did not queue.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refused {
    /// The look-ahead ring is full: step on, then push it again.
    Full,
    /// The target is out of range or not a finite number.
    OutOfRange,
    /// The machine is not homed.
    NotHomed,
    /// The machine was shut down.
    Stopped(Fault),
    /// A depositing move asks for material from a channel the printer does not have
    /// (`channels`).
    Channel {
        /// The channel.
        channel: u8,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Homing {
    axis: usize,
    steps: u32,
    high: bool,
    dir_set: bool,
}

/// The whole motion and valve controller, with a look-ahead of `N` blocks.
#[derive(Clone, Debug)]
pub struct Machine<const N: usize> {
    cfg: PrinterConfig,
    maker: BlockMaker,
    planner: Planner<N>,
    gen: SegmentGen,
    stepper: Stepper,
    valves: Valves,
    state: State,
    homing: Homing,
    /// A pause was asked for and not reached yet.
    pause_pending: bool,
}

impl<const N: usize> Machine<N> {
    /// A machine for `cfg` (validated here), not homed.
    pub fn new(cfg: PrinterConfig) -> Result<Machine<N>, PrinterError> {
        cfg.validate()?;
        let valves = Valves::new(&cfg);
        Ok(Machine {
            maker: BlockMaker::new(&cfg),
            planner: Planner::new(cfg.junction_deviation, cfg.valve_time_constant()),
            gen: SegmentGen::new(&cfg, valves.dwell_segments()),
            stepper: Stepper::new(&cfg),
            valves,
            state: State::Unhomed,
            pause_pending: false,
            homing: Homing {
                axis: 0,
                steps: 0,
                high: false,
                dir_set: false,
            },
            cfg,
        })
    }

    /// What it has driven so far (a layer's figures are the difference of two readings).
    pub fn counters(&self) -> Counters {
        let (s, v) = (&self.stepper.stats, &self.valves.stats);
        Counters {
            steps: s.steps,
            valve_openings: v.openings,
            valve_open_ticks: v.open_ticks,
            ticks: s.ticks,
        }
    }

    /// The printer.
    pub fn config(&self) -> &PrinterConfig {
        &self.cfg
    }

    /// Where it is.
    pub fn state(&self) -> State {
        self.state
    }

    /// The step engine (its position and figures).
    pub fn stepper(&self) -> &Stepper {
        &self.stepper
    }

    /// The valves' figures.
    pub fn valves(&self) -> &Valves {
        &self.valves
    }

    /// The look-ahead ring.
    pub fn planner(&self) -> &Planner<N> {
        &self.planner
    }

    /// Whether everything queued has been stepped.
    pub fn is_done(&self) -> bool {
        self.planner.is_empty()
            && !self.gen.is_busy()
            && self.stepper.ring.is_empty()
            && self.stepper.is_idle()
    }

    /// Starts homing (from `Unhomed`, or again once homed and idle): the axes with an
    /// endstop run into it one after the other, X first. Call [`on_alarm`](Self::on_alarm)
    /// to run it.
    pub fn start_homing(&mut self) {
        if matches!(self.state, State::Unhomed) || (self.state == State::Ready && self.is_done()) {
            self.homing = Homing {
                axis: 0,
                steps: 0,
                high: false,
                dir_set: false,
            };
            self.state = State::Homing;
        }
    }

    /// Queues a layer's move at height `z`. A move of no whole step is dropped (`Ok`).
    pub fn push_move(&mut self, m: &Move, z: f32) -> Result<(), Refused> {
        self.check_accepting()?;
        if m.deposit {
            let used = self.cfg.channels().len();
            if let Some(c) = (used..m.material.len()).find(|&c| m.material[c] > 0.0) {
                // At most CHANNELS (asserted u8 in `config`).
                return Err(Refused::Channel { channel: c as u8 });
            }
        }
        let block = self.maker.from_move(m, z);
        self.queue(block)
    }

    /// Queues a travel move to `to` (mm).
    pub fn travel_to(&mut self, to: [f32; AXES]) -> Result<(), Refused> {
        self.check_accepting()?;
        let block = self
            .maker
            .block(to, self.cfg.travel_speed, 0.0, [0.0; 4], false);
        self.queue(block)
    }

    /// Queues a block the maker made (none for a move shorter than a step), and moves the
    /// maker's position on only once the look-ahead took it.
    fn queue(&mut self, block: Result<Option<Block>, OutOfRange>) -> Result<(), Refused> {
        match block {
            Err(_) => Err(Refused::OutOfRange),
            Ok(None) => Ok(()),
            Ok(Some(b)) => {
                self.planner.push(b).map_err(|_| Refused::Full)?;
                self.maker.commit(&b);
                Ok(())
            }
        }
    }

    fn check_accepting(&self) -> Result<(), Refused> {
        match self.state {
            State::Ready | State::Paused => Ok(()),
            State::Unhomed | State::Homing => Err(Refused::NotHomed),
            State::Stopped(f) => Err(Refused::Stopped(f)),
        }
    }

    /// Asks to pause at the first block boundary the machine can stop at (once: asking
    /// again before it is reached changes nothing).
    pub fn pause(&mut self) {
        if self.state != State::Ready || self.pause_pending {
            return;
        }
        self.pause_pending = true;
        if !self.planner.request_pause() {
            // The ring is empty: the block being cut ends at rest.
            self.gen.pause_after_current();
        }
    }

    /// Continues once [`Paused`](State::Paused) (the valves reopen with their lead during a
    /// dwell); call [`on_alarm`](Self::on_alarm) to restart the alarms.
    pub fn resume(&mut self) {
        if self.state == State::Paused {
            self.gen.resume();
            self.stepper.resume();
            self.state = State::Ready;
        }
    }

    /// Stops the job: valves shut, motion dropped.
    pub fn abort<B: Board>(&mut self, board: &mut B) {
        self.shutdown(board, Fault::Aborted);
    }

    /// The emergency stop (from its interrupt, or the input seen at an alarm).
    pub fn emergency_stop<B: Board>(&mut self, board: &mut B) {
        self.shutdown(board, Fault::EmergencyStop);
    }

    /// The one way down: every valve shut first, then the motors (step pins low, every
    /// queued block and segment dropped). The first fault is kept.
    pub fn shutdown<B: Board>(&mut self, board: &mut B, fault: Fault) {
        // A valve that refuses cannot be helped here; `close_all` still tries every other.
        let closed = self.valves.close_all(board).is_ok();
        self.stepper.stop(board);
        self.planner.clear();
        self.gen.clear();
        self.pause_pending = false;
        if !matches!(self.state, State::Stopped(_)) {
            self.state = State::Stopped(fault);
        }
        if !closed {
            debug!("a valve refused to shut");
        }
        debug!("motion shut down");
    }

    /// Runs [`on_alarm`](Self::on_alarm) at the timer's `now` and sets the timer's alarm to
    /// the deadline it returns; a deadline the timer calls late is retried from the new
    /// `now` a few times, then the machine shuts down ([`Fault::Late`]).
    pub fn service<B: Board, T: StepTimer>(&mut self, board: &mut B, timer: &mut T) {
        let mut now = timer.now();
        for _ in 0..8 {
            match self.on_alarm(now, board) {
                None => return,
                Some(at) => match timer.set_alarm(at) {
                    Ok(()) => return,
                    Err(_) => now = timer.now(),
                },
            }
        }
        self.shutdown(board, Fault::Late);
    }

    /// The step interrupt at `now`: returns the next deadline, or `None` when there is
    /// nothing to do until more moves, a resume or a homing start arrive.
    pub fn on_alarm<B: Board>(&mut self, now: Ticks, board: &mut B) -> Option<Ticks> {
        if let State::Stopped(_) = self.state {
            return None;
        }
        match board.estop().is_high() {
            Ok(level) if level == self.cfg.estop_active_high => {
                self.shutdown(board, Fault::EmergencyStop);
                return None;
            }
            Ok(_) => {}
            Err(_) => {
                self.shutdown(board, Fault::Input);
                return None;
            }
        }
        let result = match self.state {
            State::Unhomed | State::Paused | State::Stopped(_) => Ok(None),
            State::Homing => self.home(now, board),
            State::Ready => self.run(now, board),
        };
        match result {
            Ok(at) => at,
            Err(fault) => {
                self.shutdown(board, fault);
                None
            }
        }
    }

    fn run<B: Board>(&mut self, now: Ticks, board: &mut B) -> Result<Option<Ticks>, Fault> {
        if self.stepper.is_idle() {
            // Starting from rest: prepare the whole look-ahead first (the valves read it).
            self.stepper
                .fill(&mut self.gen, &mut self.planner, SEGMENT_RING);
        }
        let loaded = self.stepper.stats.segments;
        let mut at_pause = false;
        let next = self
            .stepper
            .on_alarm(now, board, &mut at_pause)
            .map_err(|e| Fault::StepPin { axis: e.axis })?;
        if at_pause {
            self.valves
                .close_all(board)
                .map_err(|e| Fault::Valve { channel: e.channel })?;
            self.state = State::Paused;
            self.pause_pending = false;
            return Ok(None);
        }
        if self.stepper.stats.segments != loaded {
            // A new segment: keep the look-ahead full (two for the one taken, so a ring
            // that ran short while blocks were missing catches up), then command the
            // valves from it. Bounded: this runs in the step interrupt.
            self.stepper.fill(&mut self.gen, &mut self.planner, 2);
            let flows = self.valves.frame(&self.stepper.current, &self.stepper.ring);
            self.valves
                .apply(board, &flows)
                .map_err(|e| Fault::Valve { channel: e.channel })?;
            self.valves.account(self.stepper.segment_ticks());
        }
        if next.is_none() {
            // Out of segments: at rest, nothing to deposit.
            self.valves
                .close_all(board)
                .map_err(|e| Fault::Valve { channel: e.channel })?;
        }
        Ok(next)
    }

    fn home<B: Board>(&mut self, now: Ticks, board: &mut B) -> Result<Option<Ticks>, Fault> {
        let pulse = self.cfg.ns_to_ticks(self.cfg.step_pulse_ns);
        loop {
            let h = &mut self.homing;
            if h.axis >= AXES {
                // Every axis is at home (those without an endstop are taken to be).
                let home = self.maker.to_steps(self.cfg.home).unwrap_or([0; AXES]);
                self.maker.position = home;
                self.stepper.set_position(home);
                self.state = State::Ready;
                return Ok(None);
            }
            let axis = h.axis;
            let cfg = &self.cfg.axes[axis];
            let Some(endstop) = cfg.endstop else {
                h.axis += 1;
                continue;
            };
            let rate = self.cfg.homing_speed.fmin(cfg.max_speed) * cfg.steps_per_mm;
            // At least one pulse and one gap: validated step rates keep this above 2 pulses.
            let interval = (libm::roundf(self.cfg.tick_hz as f32 / rate) as u32).max(2 * pulse + 1);
            if h.high {
                board
                    .step(axis)
                    .set_low()
                    .map_err(|_| Fault::StepPin { axis: axis as u8 })?;
                h.high = false;
                return Ok(Some(now.wrapping_add(interval - pulse)));
            }
            let hit = board.endstop(axis).is_high().map_err(|_| Fault::Input)?;
            if hit == endstop.active_high {
                *h = Homing {
                    axis: axis + 1,
                    steps: 0,
                    high: false,
                    dir_set: false,
                };
                continue;
            }
            // Homing travel over the axis' step size, far below u32::MAX (validated ranges).
            let limit = libm::ceilf(self.cfg.homing_travel * cfg.steps_per_mm) as u32;
            if h.steps >= limit {
                return Err(Fault::Homing { axis: axis as u8 });
            }
            if !h.dir_set {
                // Towards the endstop: the negative direction.
                let pin = board.dir(axis);
                let r = if cfg.invert_dir {
                    pin.set_high()
                } else {
                    pin.set_low()
                };
                r.map_err(|_| Fault::StepPin { axis: axis as u8 })?;
                h.dir_set = true;
                return Ok(Some(
                    now.wrapping_add(self.cfg.ns_to_ticks(self.cfg.dir_setup_ns)),
                ));
            }
            board
                .step(axis)
                .set_high()
                .map_err(|_| Fault::StepPin { axis: axis as u8 })?;
            h.steps += 1;
            h.high = true;
            return Ok(Some(now.wrapping_add(pulse)));
        }
    }
}
