//! The link firmware's printer pins: QEMU has none, so the step, direction and valve outputs
//! are counted in memory (the motion code drives them exactly as it would real pins). The
//! endstops read hit (homing ends at once, as the host's virtual printer, which starts at its
//! endstops) and the emergency stop released. The valve duties live in statics so that the
//! panic and fault handlers can shut them first ([`shut_valves`]).

use core::convert::Infallible;
use core::sync::atomic::{AtomicU16, AtomicU32, Ordering};

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{self, SetDutyCycle};
use hollowpath::config::CHANNELS;
use hollowpath::motion::{Pins, PrinterConfig};

// `parked` names one valve per channel.
const _: () = assert!(CHANNELS == 4);

/// The valve outputs' duties (full scale [`MAX_DUTY`]).
static DUTY: [AtomicU16; CHANNELS] = [const { AtomicU16::new(0) }; CHANNELS];
/// Openings per valve (duty from 0 to more).
pub static OPENINGS: [AtomicU32; CHANNELS] = [const { AtomicU32::new(0) }; CHANNELS];

/// Full-scale duty.
pub const MAX_DUTY: u16 = 10_000;

/// Shuts every valve (the panic and fault handlers call it before anything else).
pub fn shut_valves() {
    for d in &DUTY {
        d.store(0, Ordering::SeqCst);
    }
}

/// Whether every valve is shut.
pub fn valves_shut() -> bool {
    DUTY.iter().all(|d| d.load(Ordering::SeqCst) == 0)
}

/// An output pin counting its rising edges.
pub struct Out {
    high: bool,
    pub rises: u32,
}

impl Out {
    const LOW: Out = Out {
        high: false,
        rises: 0,
    };
}

impl ErrorType for Out {
    type Error = Infallible;
}

impl OutputPin for Out {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.high = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.rises += u32::from(!self.high);
        self.high = true;
        Ok(())
    }
}

/// An input at a fixed level.
pub struct In(bool);

impl ErrorType for In {
    type Error = Infallible;
}

impl InputPin for In {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0)
    }
}

/// A valve output (its duty in [`DUTY`]).
pub struct Valve(usize);

impl pwm::ErrorType for Valve {
    type Error = Infallible;
}

impl SetDutyCycle for Valve {
    fn max_duty_cycle(&self) -> u16 {
        MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        if DUTY[self.0].swap(duty, Ordering::SeqCst) == 0 && duty > 0 {
            OPENINGS[self.0].fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    }
}

/// The board (the module's essay).
pub type LinkBoard = Pins<Out, In, Valve>;

/// Every output low, every input low: the board in its static until [`new`] replaces it at
/// boot (the link firmware's; the bench firmware builds its boards at run time).
#[allow(dead_code)]
pub const fn parked() -> LinkBoard {
    Pins {
        step: [Out::LOW, Out::LOW, Out::LOW],
        dir: [Out::LOW, Out::LOW, Out::LOW],
        endstop: [In(false), In(false), In(false)],
        estop: In(false),
        valve: [Valve(0), Valve(1), Valve(2), Valve(3)],
    }
}

/// Opens valve `k` of `board` at half its duty (the drills' valve, which their fault or
/// watchdog must shut); whether it took the duty.
#[allow(dead_code)] // the drills' only
pub fn open_half(board: &mut LinkBoard, k: usize) -> bool {
    use hollowpath::motion::Board;
    board.valve(k).set_duty_cycle(MAX_DUTY / 2).is_ok()
}

/// Pins for the default printer's polarities (endstops active high, the emergency stop
/// active high): endstops hit, emergency stop released.
pub fn new() -> LinkBoard {
    let cfg = PrinterConfig::default();
    Pins {
        step: [Out::LOW, Out::LOW, Out::LOW],
        dir: [Out::LOW, Out::LOW, Out::LOW],
        endstop: [0, 1, 2].map(|a| In(cfg.axes[a].endstop.is_none_or(|e| e.active_high))),
        estop: In(!cfg.estop_active_high),
        valve: [0, 1, 2, 3].map(Valve),
    }
}
