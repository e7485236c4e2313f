//! The clock and the two alarms: TIM5, a 32-bit timer counting microseconds, free running.
//! Its overflows (every 71.6 minutes) are counted into a 64-bit clock ([`now_us`]); compare
//! channel 1 is the step alarm ([`step_at`]), channel 2 the link's wake-up ([`wake_at`]),
//! channel 3 a heartbeat every [`HEARTBEAT_US`] that feeds the watchdog. One interrupt (TIM5,
//! the step priority) serves all four.
//!
//! Registers (RM0090 18.4): CR1 0x00 (bit 0 CEN), DIER 0x0C (bit 0 UIE, 1 CC1IE, 2 CC2IE),
//! SR 0x10 (bit 0 UIF, 1 CC1IF, 2 CC2IF, 3 CC3IF; write 0 to clear), EGR 0x14 (bit 0 UG),
//! CNT 0x24, PSC 0x28, ARR 0x2C, CCR1 0x34, CCR2 0x38, CCR3 0x3C (DIER's bit 3 CC3IE). The timer's clock is enabled in RCC APB1ENR
//! (0x4002_3840, bit 3).

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use stm32f4xx_hal::pac::{Interrupt, NVIC};

const TIM5: usize = 0x4000_0C00;
const CR1: usize = TIM5;
const DIER: usize = TIM5 + 0x0C;
const SR: usize = TIM5 + 0x10;
const EGR: usize = TIM5 + 0x14;
const CNT: usize = TIM5 + 0x24;
const PSC: usize = TIM5 + 0x28;
const ARR: usize = TIM5 + 0x2C;
const CCR1: usize = TIM5 + 0x34;
const CCR2: usize = TIM5 + 0x38;
const CCR3: usize = TIM5 + 0x3C;
const RCC_APB1ENR: usize = 0x4002_3840;

const UIF: u32 = 1 << 0;
const CC1: u32 = 1 << 1;
const CC2: u32 = 1 << 2;
const CC3: u32 = 1 << 3;

/// The watchdog's heartbeat period (well inside its timeout).
pub const HEARTBEAT_US: u32 = 100_000;
// A third of the watchdog's shortest timeout at least (the LSI runs 17-47 kHz: a 500 ms
// timeout at 32 kHz is 340 ms at 47 kHz).
const _: () = assert!(HEARTBEAT_US / 1000 * 5 <= crate::watchdog::TIMEOUT_MS);

fn read(reg: usize) -> u32 {
    // SAFETY: `reg` is one of TIM5's registers above (aligned, mapped); reads have no side
    // effect.
    unsafe { core::ptr::read_volatile(reg as *const u32) }
}

fn write(reg: usize, v: u32) {
    // SAFETY: `reg` is one of TIM5's (or RCC's APB1ENR) registers above; the values written
    // are the reference manual's for the use described at each call.
    unsafe { core::ptr::write_volatile(reg as *mut u32, v) }
}

/// Overflows of the counter.
static WRAPS: AtomicU32 = AtomicU32::new(0);
/// The step interrupt was asked to run now (the counter's compare may be in the past).
static STEP_NOW: AtomicBool = AtomicBool::new(false);

/// Starts the clock at 1 MHz from the timer's input clock `timclk_hz` (APB1's timers:
/// 84 MHz at 168 MHz system clock), its overflow and heartbeat interrupts on.
pub fn start(timclk_hz: u32) {
    write(RCC_APB1ENR, read(RCC_APB1ENR) | 1 << 3);
    cortex_m::asm::dsb();
    write(CR1, 0);
    write(PSC, timclk_hz / 1_000_000 - 1);
    write(ARR, u32::MAX);
    // Load the prescaler now (an update event), then clear the flag it raised.
    write(EGR, 1);
    write(SR, 0);
    write(CCR3, HEARTBEAT_US);
    write(DIER, UIF | CC3);
    write(CR1, 1);
}

/// Microseconds since [`start`]; never goes back.
pub fn now_us() -> u64 {
    loop {
        let w1 = WRAPS.load(Ordering::Relaxed);
        let c = read(CNT);
        let pending = read(SR) & UIF != 0;
        let w2 = WRAPS.load(Ordering::Relaxed);
        if w1 == w2 {
            // An overflow whose interrupt has not run yet (held off by a critical section).
            let w = if pending && c < 1 << 31 { w1 + 1 } else { w1 };
            return (w as u64) << 32 | c as u64;
        }
    }
}

/// Whether a counter value `at` is not after now (a wrapping difference).
fn passed(at: u32) -> bool {
    read(CNT).wrapping_sub(at) < 1 << 31
}

/// Runs the step interrupt at microsecond `at` (the counter's low 32 bits), or at once if
/// that passed. From the step interrupt only (the highest priority: nothing preempts its
/// read-modify-write of DIER).
pub fn step_at(at: u32) {
    write(CCR1, at);
    write(SR, !CC1);
    write(DIER, read(DIER) | CC1);
    if passed(at) {
        step_now();
    }
}

/// Runs the step interrupt at once.
pub fn step_now() {
    STEP_NOW.store(true, Ordering::Release);
    NVIC::pend(Interrupt::TIM5);
}

/// Wakes the core at microsecond `at` (a link deadline). From the main loop: DIER's
/// read-modify-write runs masked, or the step interrupt's own could be lost in between.
pub fn wake_at(at: u32) {
    cortex_m::interrupt::free(|_| {
        write(CCR2, at);
        write(SR, !CC2);
        write(DIER, read(DIER) | CC2);
    });
    if passed(at) {
        NVIC::pend(Interrupt::TIM5);
    }
}

/// Cancels [`wake_at`] (masked, as it).
pub fn cancel_wake() {
    cortex_m::interrupt::free(|_| write(DIER, read(DIER) & !CC2));
}

/// The interrupt's work: counts an overflow, ends a wake-up, feeds the watchdog on a
/// heartbeat while the main loop is alive, and says whether the step alarm is due (its compare matched, or [`step_now`]
/// asked), disarming it.
pub fn on_interrupt() -> bool {
    let sr = read(SR);
    let dier = read(DIER);
    // Clear only the flags seen (write 0 to clear, 1 leaves a flag as it is).
    write(SR, !(sr & (UIF | CC1 | CC2 | CC3)));
    if sr & UIF != 0 {
        WRAPS.fetch_add(1, Ordering::Relaxed);
    }
    if sr & CC2 != 0 {
        write(DIER, read(DIER) & !CC2);
    }
    if sr & CC3 != 0 {
        write(CCR3, read(CCR3).wrapping_add(HEARTBEAT_US));
        // Only while the main loop is alive: one stuck (a deadlock, a runaway computation)
        // lets the watchdog reset the board into its safe state.
        if crate::controller::main_loop_alive(
            crate::controller::MAIN_LOOP_SILENCE_US / HEARTBEAT_US,
        ) {
            crate::watchdog::feed();
        }
    }
    let due = (sr & CC1 != 0 && dier & CC1 != 0) | STEP_NOW.swap(false, Ordering::Acquire);
    if due {
        write(DIER, read(DIER) & !CC1);
    }
    due
}
