//! The independent watchdog (IWDG, on the 32 kHz LSI): it resets the chip if it is not fed for
//! [`TIMEOUT_MS`]. TIM5's heartbeat feeds it from the step priority every 100 ms
//! (`timer.rs`) while the main loop checks in (`controller::main_loop_alive`), so what it
//! catches is a core that stopped running interrupts (a lockup: a fault while stacking a
//! fault's frame, as a frame far past the stack guard can cause; an interrupt of the step
//! priority or above that never returns) and a main loop that stopped checking in for
//! `controller::MAIN_LOOP_SILENCE_US` (stuck computing: an endless loop, a runaway search;
//! planning and preparing the spiral, the longest stretch without a check-in, took 1.3 s on
//! four_holes). After
//! a reset every pin is an input again: the MOSFETs' gates are pulled down, so the valves
//! close, and the power gate (PC13) lets go. A halted fault (`main.rs`'s `stop`) keeps feeding it, so the board stays stopped
//! with its valves shut and its log readable instead of rebooting into a printer ready to
//! move. A debugger's halt stops it (DBGMCU).
//!
//! Registers (RM0090 21.4): KR 0x00 (0xCCCC start, 0x5555 unlock PR and RLR, 0xAAAA feed), PR
//! 0x04, RLR 0x08, SR 0x0C (PVU, RVU: an update in progress). DBGMCU_APB1_FZ 0xE004_2008, bit
//! 12 DBG_IWDG_STOP.

const IWDG: usize = 0x4000_3000;
const KR: usize = IWDG;
const PR: usize = IWDG + 0x04;
const RLR: usize = IWDG + 0x08;
const SR: usize = IWDG + 0x0C;
const DBGMCU_APB1_FZ: usize = 0xE004_2008;

/// How long the chip may go unfed (nominal, at 32 kHz: the LSI runs 17-47 kHz). Short,
/// because a locked-up core leaves the valves at their duty until the reset: at most about
/// 0.5 s of a blob, not seconds.
pub const TIMEOUT_MS: u32 = 500;
/// The LSI's nominal rate over the prescaler of 64 (PR = 4): 500 counts a second.
const COUNTS_PER_S: u32 = 32_000 / 64;
const RELOAD: u32 = TIMEOUT_MS * COUNTS_PER_S / 1000 - 1;
const _: () = assert!(RELOAD <= 0x0FFF, "the IWDG's reload is 12 bits");

fn write(reg: usize, v: u32) {
    // SAFETY: `reg` is one of the IWDG's (or DBGMCU's) registers above, written with the
    // values the reference manual gives for the use at each call.
    unsafe { core::ptr::write_volatile(reg as *mut u32, v) }
}

fn read(reg: usize) -> u32 {
    // SAFETY: the IWDG's status register or DBGMCU's freeze register: reads have no effect.
    unsafe { core::ptr::read_volatile(reg as *const u32) }
}

/// Starts the watchdog (once started, only a reset stops it).
pub fn start() {
    write(DBGMCU_APB1_FZ, read(DBGMCU_APB1_FZ) | 1 << 12);
    write(KR, 0xCCCC);
    write(KR, 0x5555);
    write(PR, 4);
    write(RLR, RELOAD);
    while read(SR) & 0b11 != 0 {}
    feed();
}

/// Feeds the watchdog.
pub fn feed() {
    write(KR, 0xAAAA);
}
