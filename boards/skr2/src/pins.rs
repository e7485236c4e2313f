//! The SKR 2's printer pins, and the shutdown every fault goes through.
//!
//! | what | pin | notes |
//! |---|---|---|
//! | X step / dir / enable | PE2 / PE1 / PE3 | enable active low |
//! | Y step / dir / enable | PD5 / PD4 / PD6 | enable active low |
//! | Z step / dir / enable | PA15 / PA8 / PD1 | enable active low |
//! | X / Y / Z endstop | PC1 / PC3 / PC0 | X-STOP, Y-STOP, Z-STOP, pulled up |
//! | emergency stop | PC2 | E0-STOP, pulled up |
//! | valve 0 / 1 | PB3 / PB4 | HE0 / HE1 MOSFETs, TIM2 ch 2 / TIM3 ch 1 |
//! | valve 2 / 3 | PB7 / PB6 | FAN0 / FAN1 MOSFETs, TIM4 ch 2 / ch 1 |
//! | driver and MOSFET power | PC13 | high at boot, low on any fault |
//! | link | PA9 (TX) / PA10 (RX) | USART1, the TFT header |
//!
//! The HAL sets each pin's mode, pull and alternate function at boot (`main.rs`); the pins
//! the core drives ([`Out`], [`In`], [`Valve`]) are then one register access each: a
//! `BSRR` store per step edge, an `IDR` load per endstop read, a `CCR` store per valve duty,
//! the shape of Klipper's `gpio_out_write`. They are `const`, so the step side (machine,
//! board, queue) is a plain static built before `main`. PA15, PB3 and PB4 leave their JTAG
//! functions for these; SWD (PA13, PA14) stays, for the probe and RTT.

use core::convert::Infallible;
use core::sync::atomic::{AtomicU16, Ordering};

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{self, SetDutyCycle};
use hollowpath::config::CHANNELS;
use hollowpath::motion::Pins;

/// A GPIO port's registers (RM0090 8.4): its base address.
#[derive(Clone, Copy)]
pub struct Port(usize);

const PA: Port = Port(0x4002_0000);
const PC: Port = Port(0x4002_0800);
const PD: Port = Port(0x4002_0C00);
const PE: Port = Port(0x4002_1000);

const IDR: usize = 0x10;
const BSRR: usize = 0x18;

impl Port {
    /// Sets (`high`) or resets pin `n` (a `BSRR` store: atomic, no read-modify-write).
    fn write(self, n: u8, high: bool) {
        let bit = if high { 1u32 << n } else { 1u32 << (n + 16) };
        // SAFETY: `self.0 + BSRR` is the port's bit set/reset register (aligned, mapped on
        // the STM32F407); writing it changes only the pins whose bits are set, and every
        // pin named here was made an output by the HAL at boot.
        unsafe { core::ptr::write_volatile((self.0 + BSRR) as *mut u32, bit) }
    }
    /// The level of pin `n` (an `IDR` load).
    fn read(self, n: u8) -> bool {
        // SAFETY: the port's input data register: a read has no side effect.
        unsafe { core::ptr::read_volatile((self.0 + IDR) as *const u32) & (1 << n) != 0 }
    }
}

/// An output pin.
pub struct Out(Port, u8);

impl ErrorType for Out {
    type Error = Infallible;
}

impl OutputPin for Out {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.write(self.1, false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.write(self.1, true);
        Ok(())
    }
}

/// An input pin.
pub struct In(Port, u8);

impl ErrorType for In {
    type Error = Infallible;
}

impl InputPin for In {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.read(self.1))
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.read(self.1))
    }
}

/// A general-purpose timer's capture/compare register 1 (RM0090 18.4: `CCR1` at 0x34, the
/// next channels 4 bytes apart).
const fn ccr(timer: usize, channel: usize) -> usize {
    timer + 0x34 + 4 * (channel - 1)
}
const TIM2: usize = 0x4000_0000;
const TIM3: usize = 0x4000_0400;
const TIM4: usize = 0x4000_0800;

/// The valves' compare registers, channel by channel (the table above).
const VALVE_CCR: [usize; CHANNELS] = [ccr(TIM2, 2), ccr(TIM3, 1), ccr(TIM4, 2), ccr(TIM4, 1)];

/// The PWM period in timer counts, the same on the three timers (`main.rs` sets it up):
/// a duty of this keeps the output on.
pub static FULL_DUTY: AtomicU16 = AtomicU16::new(0);

fn set_ccr(channel: usize, duty: u16) {
    // SAFETY: a timer's compare register (aligned, mapped); a duty is all it sets, in a
    // PWM mode 1 channel with preload (`main.rs`), so the output changes at the period's end.
    unsafe { core::ptr::write_volatile(VALVE_CCR[channel] as *mut u32, duty as u32) }
}

/// A valve output: a PWM channel of a MOSFET.
pub struct Valve(usize);

impl pwm::ErrorType for Valve {
    type Error = Infallible;
}

impl SetDutyCycle for Valve {
    fn max_duty_cycle(&self) -> u16 {
        FULL_DUTY.load(Ordering::Relaxed).max(1)
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        set_ccr(self.0, duty.min(self.max_duty_cycle()));
        Ok(())
    }
}

/// The stepper drivers' enable pins (active low), X, Y, Z.
const ENABLE: [(Port, u8); 3] = [(PE, 3), (PD, 6), (PD, 1)];
/// The power gate of the drivers and the MOSFETs (BTT's "anti-reversal protection").
const POWER: (Port, u8) = (PC, 13);

/// Powers the drivers and MOSFETs and enables the drivers (at boot, once the HAL made the
/// pins outputs and every valve is shut).
pub fn power_up() {
    POWER.0.write(POWER.1, true);
    for (port, n) in ENABLE {
        port.write(n, false);
    }
}

/// Every valve shut, the drivers disabled, the power gate open: the first thing every fault
/// does (panic, HardFault). Register stores only: it needs no lock, no board object and no
/// stack beyond its own frame, and it is safe to run twice.
pub fn shut_down() {
    for c in 0..CHANNELS {
        set_ccr(c, 0);
    }
    // The compare registers are preloaded (a duty takes effect at the period's end, up to
    // 10 ms later): an update event loads them now.
    for timer in [TIM2, TIM3, TIM4] {
        // SAFETY: the timer's event generation register (EGR, 0x14); UG reloads the counter
        // and the shadow registers, nothing else.
        unsafe { core::ptr::write_volatile((timer + 0x14) as *mut u32, 1) }
    }
    for (port, n) in ENABLE {
        port.write(n, true);
    }
    POWER.0.write(POWER.1, false);
}

/// The printer's pins.
pub type Skr2Board = Pins<Out, In, Valve>;

/// The board (its pins are configured at boot, before the step side runs).
pub const fn board() -> Skr2Board {
    Pins {
        step: [Out(PE, 2), Out(PD, 5), Out(PA, 15)],
        dir: [Out(PE, 1), Out(PD, 4), Out(PA, 8)],
        endstop: [In(PC, 1), In(PC, 3), In(PC, 0)],
        estop: In(PC, 2),
        valve: [Valve(0), Valve(1), Valve(2), Valve(3)],
    }
}
