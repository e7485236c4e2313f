//! Motion and outputs: a layer's moves turned into step pulses and valve duties, through
//! `embedded-hal` 1.0 pins and a step timer of our own.
//!
//! ```text
//! Move stream ──► Block (whole steps) ──► look-ahead ring ──► Segment (~1 ms, constant rate)
//!   moves::path_moves   BlockMaker          Planner            SegmentGen
//!                                                                  │
//!         step + dir pins ◄── Bresenham DDA ◄── segment ring ──────┤
//!           (OutputPin)         Stepper         (128 ahead)        │
//!         valve PWM ◄── duty by inverse calibration ◄── flow of segment j + advance
//!         (SetDutyCycle)        Valves
//! ```
//!
//! * [`config`]: the [`PrinterConfig`] (axes, speeds, pulse widths, valve channels with
//!   their calibration curves and response) and its validation; [`error`]: the
//!   [`PrinterError`] that names the key.
//! * [`planner`]: [`BlockMaker`] rounds each move's absolute target to whole steps, so steps
//!   never drift over a path; the [`Planner`] ring replans corner speeds (junction deviation)
//!   and trapezoids as blocks arrive, the tail always able to stop.
//! * [`stepper`]: [`SegmentGen`] cuts each trapezoid into constant-rate segments that carry
//!   their steps and the flow per channel they deposit; the [`Stepper`] is the integer routine
//!   of the step interrupt, behind the [`StepTimer`] trait (absolute wrapping deadlines, so a
//!   virtual clock can jump from alarm to alarm).
//! * [`valve`]: per channel the flow (road width x layer height x actual speed x the
//!   channel's share) turned into a duty by the inverse of its calibration curve, commanded a
//!   dead time ahead on the path with the valve's first-order lag inverted.
//! * [`machine`]: the [`Machine`] ties them to a [`Board`]: homing, emergency stop,
//!   pause/resume at a block boundary, and one [`shutdown`](Machine::shutdown) (valves first,
//!   then motors) for every fault.
//!
//! Driving it: implement [`Board`] for the pins, home, push moves whenever the look-ahead
//! has room, and call [`Machine::on_alarm`] at each deadline it returns (a virtual clock
//! jumps straight there; a board sets its timer's compare, or uses
//! [`Machine::service`] with a [`StepTimer`]). The controller application keeps the machine
//! on its step side ([`app::steps`](crate::app::steps)): the step interrupt tops the
//! look-ahead up from a queue of the layer's moves at every alarm while the application's
//! loop generates them.
//!
//! ```
//! use core::convert::Infallible;
//! use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
//! use embedded_hal::pwm::{self, SetDutyCycle};
//! use hollowpath::geometry::Point;
//! use hollowpath::motion::{Board, Machine, PrinterConfig};
//! use hollowpath::toolpath::moves::Move;
//!
//! #[derive(Default)]
//! struct Pin(bool);
//! impl ErrorType for Pin { type Error = Infallible; }
//! impl OutputPin for Pin {
//!     fn set_low(&mut self) -> Result<(), Infallible> { self.0 = false; Ok(()) }
//!     fn set_high(&mut self) -> Result<(), Infallible> { self.0 = true; Ok(()) }
//! }
//! impl InputPin for Pin {
//!     fn is_high(&mut self) -> Result<bool, Infallible> { Ok(self.0) }
//!     fn is_low(&mut self) -> Result<bool, Infallible> { Ok(!self.0) }
//! }
//! #[derive(Default)]
//! struct Valve(u16);
//! impl pwm::ErrorType for Valve { type Error = Infallible; }
//! impl SetDutyCycle for Valve {
//!     fn max_duty_cycle(&self) -> u16 { 1000 }
//!     fn set_duty_cycle(&mut self, d: u16) -> Result<(), Infallible> { self.0 = d; Ok(()) }
//! }
//! #[derive(Default)]
//! struct Pins { step: [Pin; 3], dir: [Pin; 3], input: Pin, valve: [Valve; 4] }
//! impl Board for Pins {
//!     type Out = Pin;
//!     type In = Pin;
//!     type Pwm = Valve;
//!     fn step(&mut self, axis: usize) -> &mut Pin { &mut self.step[axis] }
//!     fn dir(&mut self, axis: usize) -> &mut Pin { &mut self.dir[axis] }
//!     fn endstop(&mut self, _: usize) -> &mut Pin { &mut self.input }
//!     fn estop(&mut self) -> &mut Pin { &mut self.input }
//!     fn valve(&mut self, c: usize) -> &mut Valve { &mut self.valve[c] }
//! }
//!
//! let mut cfg = PrinterConfig::default();
//! for axis in &mut cfg.axes {
//!     axis.endstop = None; // homing takes the start as home
//! }
//! let mut machine = Machine::<16>::new(cfg).unwrap();
//! let mut pins = Pins::default();
//! let mut now = 0u32;
//! machine.start_homing();
//! while let Some(at) = machine.on_alarm(now, &mut pins) {
//!     now = at;
//! }
//! let road = Move {
//!     from: Point::new(0.0, 0.0),
//!     to: Point::new(2.0, 1.0),
//!     width: 0.4,
//!     material: [0.5, 0.5, 0.0, 0.0],
//!     deposit: true,
//! };
//! machine.push_move(&road, 0.0).unwrap();
//! while let Some(at) = machine.on_alarm(now, &mut pins) {
//!     now = at;
//! }
//! assert!(machine.is_done());
//! // 2 mm x 400 steps/mm and 1 mm x 400 steps/mm, exactly.
//! assert_eq!(machine.stepper().position, [800, 400, 0]);
//! ```
//!
//! Motion depends on [`toolpath`](crate::toolpath) and [`geometry`](crate::geometry), never
//! the other way. No allocation, no `unsafe`, all math through `libm`: the same moves give the
//! same edges on the host and on the MCU.

pub mod block;
pub mod config;
pub mod error;
pub mod machine;
pub mod planner;
pub mod stepper;
pub mod valve;

pub use block::{Block, BlockMaker, Profile};
pub use config::{AxisConfig, ChannelConfig, CurvePoint, Endstop, PrinterConfig, PrinterError};
pub use machine::{Fault, Machine, Refused, State};
pub use planner::{Full, Planner};
pub use stepper::{Late, Segment, SegmentGen, StepTimer, Stepper, Ticks};

use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::pwm::SetDutyCycle;

use crate::config::CHANNELS;

/// The printer's pins, as the motion code drives them: the board's HAL pins (type-erased, one
/// type per kind), or a host's virtual pins that record every edge.
pub trait Board {
    /// Step and direction outputs.
    type Out: OutputPin;
    /// Endstop and emergency-stop inputs.
    type In: InputPin;
    /// Valve PWM outputs.
    type Pwm: SetDutyCycle;
    /// The step pin of axis `axis` (0 = X, 1 = Y, 2 = Z).
    fn step(&mut self, axis: usize) -> &mut Self::Out;
    /// The direction pin of axis `axis`.
    fn dir(&mut self, axis: usize) -> &mut Self::Out;
    /// The endstop input of axis `axis` (read only if the axis has one configured).
    fn endstop(&mut self, axis: usize) -> &mut Self::In;
    /// The emergency-stop input.
    fn estop(&mut self) -> &mut Self::In;
    /// The valve output of channel `channel`.
    fn valve(&mut self, channel: usize) -> &mut Self::Pwm;
}

/// A board as a firmware has one: its pins in arrays, one type per kind (the HAL's pins, or
/// the board's own thin ones). A board crate builds one of these (a `const` one, where its
/// pin types allow, so the step side can be a static) instead of writing out [`Board`].
pub struct Pins<O, I, P> {
    /// Step outputs, X, Y, Z.
    pub step: [O; 3],
    /// Direction outputs, X, Y, Z.
    pub dir: [O; 3],
    /// Endstop inputs, X, Y, Z.
    pub endstop: [I; 3],
    /// The emergency-stop input.
    pub estop: I,
    /// Valve outputs, one per material channel.
    pub valve: [P; CHANNELS],
}

impl<O: OutputPin, I: InputPin, P: SetDutyCycle> Board for Pins<O, I, P> {
    type Out = O;
    type In = I;
    type Pwm = P;
    fn step(&mut self, axis: usize) -> &mut O {
        &mut self.step[axis]
    }
    fn dir(&mut self, axis: usize) -> &mut O {
        &mut self.dir[axis]
    }
    fn endstop(&mut self, axis: usize) -> &mut I {
        &mut self.endstop[axis]
    }
    fn estop(&mut self) -> &mut I {
        &mut self.estop
    }
    fn valve(&mut self, channel: usize) -> &mut P {
        &mut self.valve[channel]
    }
}

/// A board lent out (the host's virtual printer lends its board to a job's step side).
impl<B: Board> Board for &mut B {
    type Out = B::Out;
    type In = B::In;
    type Pwm = B::Pwm;
    fn step(&mut self, axis: usize) -> &mut Self::Out {
        (**self).step(axis)
    }
    fn dir(&mut self, axis: usize) -> &mut Self::Out {
        (**self).dir(axis)
    }
    fn endstop(&mut self, axis: usize) -> &mut Self::In {
        (**self).endstop(axis)
    }
    fn estop(&mut self) -> &mut Self::In {
        (**self).estop()
    }
    fn valve(&mut self, channel: usize) -> &mut Self::Pwm {
        (**self).valve(channel)
    }
}
