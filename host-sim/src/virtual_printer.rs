//! The virtual printer: the core's [`Machine`] driven against virtual pins on a virtual clock,
//! and the print judged from the recorded pin trace alone.
//!
//! [`VirtualBoard`] implements [`Board`]: every step and direction edge and every valve duty
//! change is recorded with its tick time ([`Trace`]); the clock jumps from alarm to alarm
//! ([`run_layer`]). The endstops read hit wherever the axis stands at or below where it
//! started (the virtual printer starts at its endstops, so homing ends at once); the
//! emergency stop is never pressed.
//!
//! [`rebuild`] then turns the trace, and nothing else but the printer's configuration, into
//! what was printed:
//!
//! * the nozzle's position from the step edges: each rising step edge moves its axis one step
//!   in the direction its direction pin held at that instant (`steps / steps_per_mm` from
//!   home);
//! * each channel's actual flow from its duty timeline: the calibration curve's flow for the
//!   duty, delayed by the valve's dead time and passed through its first-order lag (both from
//!   the [`ChannelConfig`](hollowpath::motion::ChannelConfig)), integrated exactly between duty
//!   changes (the PWM's pulsing within a period is not modelled: its mean is the curve's
//!   flow);
//! * the path cut into 1 ms windows ([`Rebuild::window_s`]), gathered into constant-width
//!   [`Move`]s of at least [`Rebuild::min_length_mm`] (0.02 mm for 0.4 mm roads) from where
//!   the nozzle was to where it is, each axis' position interpolated between its steps; the
//!   composition is the channels' shares of the volume the move received, and its width the
//!   volume over the [`Rebuild::smooth_mm`] (0.1 mm) of path centred on it / (that length x
//!   the layer height), so that neither the step quantisation of a short length nor the
//!   segment timing of its volume shows as width; a move deposits where the width is at least
//!   [`Rebuild::min_width_mm`]. Volume delivered while the nozzle stands still is laid as a
//!   disc of that volume where it stands (a zero-length move) once it moves on.
//!
//! Those moves are measured by the same [`Meter`](crate::metrics::Meter) as the planned layer.

use std::cell::RefCell;
use std::convert::Infallible;
use std::rc::Rc;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{self, SetDutyCycle};
use hollowpath::app::job::{self, Drive, LayerError, Printed};
use hollowpath::app::steps::Stepping;
use hollowpath::config::CHANNELS;
use hollowpath::field::GridMemory;
use hollowpath::motion::config::AXES;
use hollowpath::motion::machine::Counters;
use hollowpath::motion::{Board, Machine, PrinterConfig, Refused, State};
use hollowpath::toolpath::moves::Move;
use hollowpath::toolpath::offset::OffsetSpiral;
use hollowpath::{Plan, Slice};

/// The valve outputs' full-scale duty (a 100 Hz PWM on a 1 MHz timer).
pub const MAX_DUTY: u16 = 10_000;

/// Blocks of look-ahead of the simulated machine (the MCU's).
pub const LOOK_AHEAD: usize = 32;

/// Which output an edge is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pin {
    /// Step pin of an axis.
    Step(u8),
    /// Direction pin of an axis.
    Dir(u8),
}

/// A level change of a step or direction pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// Tick time (from the start of the run, unwrapped).
    pub t: u64,
    /// The pin.
    pub pin: Pin,
    /// The new level.
    pub high: bool,
}

/// A duty written to a valve that changed it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DutyChange {
    /// Tick time.
    pub t: u64,
    /// Channel.
    pub channel: u8,
    /// New duty, 0 to 1.
    pub duty: f32,
}

/// Everything the pins saw.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    /// The virtual clock, ticks from the start (unwrapped).
    pub now: u64,
    /// Step and direction edges, in time order.
    pub edges: Vec<Edge>,
    /// Valve duty changes, in time order.
    pub duties: Vec<DutyChange>,
    levels: [[bool; 2]; AXES],
    duty: [u16; CHANNELS],
    /// Steps from the start per axis, as a motor counts them (for the endstop inputs only).
    position: [i64; AXES],
    dir_high_positive: [bool; AXES],
}

type Shared = Rc<RefCell<Trace>>;

/// A step or direction output.
pub struct OutPin {
    pin: Pin,
    trace: Shared,
}

impl ErrorType for OutPin {
    type Error = Infallible;
}

impl OutPin {
    fn set(&mut self, high: bool) {
        let mut t = self.trace.borrow_mut();
        let (axis, k) = match self.pin {
            Pin::Step(a) => (a as usize, 0),
            Pin::Dir(a) => (a as usize, 1),
        };
        if t.levels[axis][k] == high {
            return;
        }
        t.levels[axis][k] = high;
        if k == 0 && high {
            let forward = t.levels[axis][1] == t.dir_high_positive[axis];
            t.position[axis] += if forward { 1 } else { -1 };
        }
        let now = t.now;
        t.edges.push(Edge {
            t: now,
            pin: self.pin,
            high,
        });
    }
}

impl OutputPin for OutPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.set(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.set(true);
        Ok(())
    }
}

/// An endstop or the emergency-stop input.
pub struct InPin {
    /// `Some(axis)`: that axis' endstop; `None`: the emergency stop.
    axis: Option<usize>,
    active_high: bool,
    trace: Shared,
}

impl ErrorType for InPin {
    type Error = Infallible;
}

impl InputPin for InPin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        let hit = match self.axis {
            Some(a) => self.trace.borrow().position[a] <= 0,
            None => false,
        };
        Ok(hit == self.active_high)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        self.is_high().map(|h| !h)
    }
}

/// A valve's PWM output.
pub struct ValvePin {
    channel: u8,
    trace: Shared,
}

impl pwm::ErrorType for ValvePin {
    type Error = Infallible;
}

impl SetDutyCycle for ValvePin {
    fn max_duty_cycle(&self) -> u16 {
        MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        let mut t = self.trace.borrow_mut();
        let c = self.channel as usize;
        if t.duty[c] == duty {
            return Ok(());
        }
        t.duty[c] = duty;
        let now = t.now;
        t.duties.push(DutyChange {
            t: now,
            channel: self.channel,
            duty: duty as f32 / MAX_DUTY as f32,
        });
        Ok(())
    }
}

/// The virtual printer's pins.
pub struct VirtualBoard {
    trace: Shared,
    step: Vec<OutPin>,
    dir: Vec<OutPin>,
    endstop: Vec<InPin>,
    estop: InPin,
    valves: Vec<ValvePin>,
}

impl VirtualBoard {
    /// The pins of printer `cfg`, at rest at its endstops, every valve shut.
    pub fn new(cfg: &PrinterConfig) -> VirtualBoard {
        let trace: Shared = Rc::new(RefCell::new(Trace {
            dir_high_positive: [0, 1, 2].map(|a| !cfg.axes[a].invert_dir),
            ..Trace::default()
        }));
        let out = |pin| OutPin {
            pin,
            trace: trace.clone(),
        };
        VirtualBoard {
            step: (0..AXES as u8).map(|a| out(Pin::Step(a))).collect(),
            dir: (0..AXES as u8).map(|a| out(Pin::Dir(a))).collect(),
            endstop: (0..AXES)
                .map(|a| InPin {
                    axis: Some(a),
                    active_high: cfg.axes[a].endstop.is_none_or(|e| e.active_high),
                    trace: trace.clone(),
                })
                .collect(),
            estop: InPin {
                axis: None,
                active_high: cfg.estop_active_high,
                trace: trace.clone(),
            },
            valves: (0..CHANNELS as u8)
                .map(|channel| ValvePin {
                    channel,
                    trace: trace.clone(),
                })
                .collect(),
            trace,
        }
    }

    /// The trace so far.
    pub fn trace(&self) -> std::cell::Ref<'_, Trace> {
        self.trace.borrow()
    }

    /// Takes the trace out, leaving an empty one (the pins' levels kept).
    pub fn take_trace(&mut self) -> Trace {
        let mut t = self.trace.borrow_mut();
        let fresh = Trace {
            now: t.now,
            levels: t.levels,
            duty: t.duty,
            position: t.position,
            dir_high_positive: t.dir_high_positive,
            ..Trace::default()
        };
        std::mem::replace(&mut *t, fresh)
    }

    /// Moves the board's clock on by `dt` ticks (whoever drives the machine keeps the board at
    /// the alarm's time: the edges an alarm drives are recorded at the board's clock).
    pub fn advance(&mut self, dt: u64) {
        self.trace.borrow_mut().now += dt;
    }
}

impl Board for VirtualBoard {
    type Out = OutPin;
    type In = InPin;
    type Pwm = ValvePin;
    fn step(&mut self, axis: usize) -> &mut OutPin {
        &mut self.step[axis]
    }
    fn dir(&mut self, axis: usize) -> &mut OutPin {
        &mut self.dir[axis]
    }
    fn endstop(&mut self, axis: usize) -> &mut InPin {
        &mut self.endstop[axis]
    }
    fn estop(&mut self) -> &mut InPin {
        &mut self.estop
    }
    fn valve(&mut self, channel: usize) -> &mut ValvePin {
        &mut self.valves[channel]
    }
}

/// Why a simulated run failed.
#[derive(Clone, Debug, PartialEq)]
pub enum SimError {
    /// The printer configuration was refused.
    Printer(hollowpath::motion::PrinterError),
    /// The machine refused move `index`.
    Refused {
        /// Index of the move.
        index: usize,
        /// Why.
        why: Refused,
    },
    /// The machine stopped or did not finish (its state at the end).
    Unfinished(State),
    /// An alarm asked for a deadline in the past or implausibly far ahead (ticks).
    Deadline(u32),
    /// A layer's path could not be built.
    Path(hollowpath::Error),
    /// The layer takes more steps than the virtual printer records.
    TooManySteps {
        /// Steps of the X and Y axes the layer's moves take, at least.
        steps: f64,
    },
    /// The layer takes longer to print than the virtual printer runs.
    TooLong {
        /// Seconds the layer's moves take at least, at the printer's speeds and
        /// accelerations.
        seconds: f64,
    },
}

/// Most X and Y steps one simulated layer may take: every step is two recorded pin edges in
/// the trace (a 100 mm slice at 0.4 mm roads, estimated from its road length, about 20 m at
/// 400 steps/mm, takes some 11 M).
pub const MAX_LAYER_STEPS: f64 = 32e6;
/// Longest a simulated layer may take to print, s (the virtual clock runs every 1 ms segment
/// of it; the four_holes zigzag at the default printer takes 264 s).
pub const MAX_LAYER_SECONDS: f64 = 24.0 * 3600.0;

/// Refuses a layer the virtual printer would take too long or too much memory to run: its
/// X and Y steps, and a lower bound of its print time (each move at most at its speed and at
/// the speed its axes' `max_speed` allow, and from rest to rest at most at the lesser of the X
/// and Y accelerations).
fn check_size(cfg: &PrinterConfig, moves: &[Move]) -> Result<(), SimError> {
    let (sx, sy) = (
        f64::from(cfg.axes[0].steps_per_mm),
        f64::from(cfg.axes[1].steps_per_mm),
    );
    let accel = f64::from(cfg.axes[0].max_accel.min(cfg.axes[1].max_accel));
    let (mut steps, mut seconds) = (0.0f64, 0.0f64);
    for m in moves {
        let (dx, dy) = (
            f64::from(m.to.x) - f64::from(m.from.x),
            f64::from(m.to.y) - f64::from(m.from.y),
        );
        steps += dx.abs() * sx + dy.abs() * sy;
        let len = dx.hypot(dy);
        // No faster than the move's feed, nor than lets each axis keep to its `max_speed`
        // along its share of the move.
        let mut speed = f64::from(if m.deposit {
            cfg.print_speed
        } else {
            cfg.travel_speed
        });
        for (d, axis) in [(dx, &cfg.axes[0]), (dy, &cfg.axes[1])] {
            if len > 0.0 && d != 0.0 {
                speed = speed.min(f64::from(axis.max_speed) * len / d.abs());
            }
        }
        // Rest to rest at `accel`: no faster than half the way accelerating, half braking.
        seconds += (len / speed).max(2.0 * (len / accel).sqrt());
    }
    if steps > MAX_LAYER_STEPS {
        return Err(SimError::TooManySteps { steps });
    }
    if seconds > MAX_LAYER_SECONDS {
        return Err(SimError::TooLong { seconds });
    }
    Ok(())
}

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SimError::Printer(e) => write!(f, "printer: {e}"),
            SimError::Refused { index, why } => write!(f, "move {index} refused: {why:?}"),
            SimError::Unfinished(s) => write!(f, "the machine did not finish (state {s:?})"),
            SimError::Deadline(dt) => write!(f, "an alarm {dt} ticks ahead"),
            SimError::Path(e) => write!(f, "layer path: {e}"),
            SimError::TooManySteps { steps } => write!(
                f,
                "the layer takes {:.1} M steps of X and Y, more than the virtual printer \
                 records ({:.0} M): simulate a smaller slice, or a printer with fewer steps_per_mm",
                steps / 1e6,
                MAX_LAYER_STEPS / 1e6
            ),
            SimError::TooLong { seconds } => write!(
                f,
                "the layer takes at least {:.1} h to print at the printer's speeds and \
                 accelerations, more than the virtual printer runs ({:.0} h): raise print_speed, \
                 travel_speed, the axes' max_speed or max_accel, or simulate a smaller slice",
                seconds / 3600.0,
                MAX_LAYER_SECONDS / 3600.0
            ),
        }
    }
}

impl std::error::Error for SimError {}

/// The virtual printer: a machine and its board, on one virtual clock.
pub struct VirtualPrinter {
    /// The machine (boxed: its rings are some tens of KiB).
    pub machine: Box<Machine<LOOK_AHEAD>>,
    /// The board.
    pub board: VirtualBoard,
    ticks: u32,
}

impl VirtualPrinter {
    /// A printer for `cfg`, homed (it starts at its endstops).
    pub fn new(cfg: &PrinterConfig) -> Result<VirtualPrinter, SimError> {
        let machine = Box::new(Machine::new(cfg.clone()).map_err(SimError::Printer)?);
        let mut p = VirtualPrinter {
            machine,
            board: VirtualBoard::new(cfg),
            // Near the wrap, so a long run wraps the timer.
            ticks: u32::MAX - 1_000_000,
        };
        p.machine.start_homing();
        while p.alarm()? {}
        if p.machine.state() != State::Ready {
            return Err(SimError::Unfinished(p.machine.state()));
        }
        Ok(p)
    }

    /// One alarm now; the deadline it asks for is jumped to. Whether there was one.
    fn alarm(&mut self) -> Result<bool, SimError> {
        match self.machine.on_alarm(self.ticks, &mut self.board) {
            Some(at) => {
                let dt = at.wrapping_sub(self.ticks);
                if dt >= 1 << 30 {
                    return Err(SimError::Deadline(dt));
                }
                self.ticks = at;
                self.board.advance(dt as u64);
                Ok(true)
            }
            None => Ok(false),
        }
    }

    /// Runs `moves` at height `z` to the end, pushing them whenever the look-ahead has room.
    pub fn run(&mut self, moves: &[Move], z: f32) -> Result<(), SimError> {
        let mut next = 0;
        loop {
            while next < moves.len() {
                match self.machine.push_move(&moves[next], z) {
                    Ok(()) => next += 1,
                    Err(Refused::Full) => break,
                    Err(why) => return Err(SimError::Refused { index: next, why }),
                }
            }
            if !self.alarm()? {
                if next == moves.len() {
                    break;
                }
                // Idle with moves left and room for none: cannot happen on a ready machine.
                if self.machine.planner().is_full() {
                    return Err(SimError::Unfinished(self.machine.state()));
                }
            }
        }
        if !self.machine.is_done() || self.machine.state() != State::Ready {
            return Err(SimError::Unfinished(self.machine.state()));
        }
        Ok(())
    }
}

/// Runs one layer's `moves` at height `z` on a fresh virtual printer from home; the trace of
/// the layer (homing excluded).
pub fn run_layer(cfg: &PrinterConfig, moves: &[Move], z: f32) -> Result<Trace, SimError> {
    run_layer_counted(cfg, moves, z).map(|(t, _)| t)
}

/// As [`run_layer`], with what the machine counted over the layer (its telemetry: steps,
/// valve openings and open ticks, print ticks; homing excluded).
pub fn run_layer_counted(
    cfg: &PrinterConfig,
    moves: &[Move],
    z: f32,
) -> Result<(Trace, Counters), SimError> {
    let mut p = VirtualPrinter::new(cfg)?;
    check_size(cfg, moves)?;
    let start = p.board.take_trace();
    let before = p.machine.counters();
    p.run(moves, z)?;
    let counted = p.machine.counters().since(&before);
    let mut t = p.board.take_trace();
    // Times from the layer's start.
    let t0 = start.now;
    for e in &mut t.edges {
        e.t -= t0;
    }
    for d in &mut t.duties {
        d.t -= t0;
    }
    t.now -= t0;
    Ok((t, counted))
}

/// The virtual clock as the core's job routine drives it: the step side's interrupt runs
/// whenever the routine waits, at the deadline it asked for, the clock jumped there (so
/// every alarm finds the move queue full: the host never starves).
struct Clocked<'a> {
    steps: Box<Stepping<&'a mut VirtualBoard>>,
    ticks: u32,
}

impl<'a> Drive for Clocked<'a> {
    type Board = &'a mut VirtualBoard;
    type Stop = SimError;
    fn lock<R>(&mut self, f: impl FnOnce(&mut Stepping<Self::Board>) -> R) -> R {
        f(&mut self.steps)
    }
    fn now(&mut self) -> u32 {
        self.ticks
    }
    fn kick(&mut self) {}
    fn wait(&mut self) -> Result<(), SimError> {
        let Some(at) = self.steps.deadline() else {
            // At rest with nothing to start: the routine would wait for ever.
            let state = self.steps.state().unwrap_or(State::Unhomed);
            return Err(SimError::Unfinished(state));
        };
        let dt = at.wrapping_sub(self.ticks);
        if dt >= 1 << 30 {
            return Err(SimError::Deadline(dt));
        }
        self.ticks = at;
        self.steps.board().advance(dt as u64);
        self.steps.on_alarm(at);
        Ok(())
    }
}

/// Prints `layers` layers of the job on one virtual printer, homed once, layer after layer
/// with z rising, through the core's own job routine ([`hollowpath::app::job`], the one the
/// controller prints with, and its step side [`Stepping`]): what the machine drove over each
/// layer, the controller's telemetry exactly.
pub fn run_job_counted(
    cfg: &PrinterConfig,
    slice: &Slice,
    plan: &Plan,
    layers: usize,
) -> Result<Vec<Printed>, SimError> {
    let VirtualPrinter {
        machine,
        mut board,
        ticks,
    } = VirtualPrinter::new(cfg)?;
    let mut offset = Box::new(OffsetSpiral::new());
    let mut grid = Box::new(GridMemory::new());
    let mut steps = Box::new(Stepping::new(&mut board));
    steps.install(*machine);
    let mut drive = Clocked { steps, ticks };
    (0..layers)
        .map(|k| {
            job::print_layer(slice, plan, &mut offset, &mut grid, k, &mut drive).map_err(
                |e| match e {
                    LayerError::Path(e) => SimError::Path(e),
                    LayerError::Refused(why) => SimError::Refused { index: k, why },
                    LayerError::Stopped(e) => e,
                    LayerError::Unfinished(s) => SimError::Unfinished(s),
                },
            )
        })
        .collect()
}

pub use crate::virtual_rebuild::{rebuild, Rebuild, Rebuilt, TraceFigures};
