//! The few mps2-an386 peripherals the link firmware uses, as QEMU models them: the CMSDK APB
//! UART0 (the link's byte stream), CMSDK timer 0 (a wake-up at a link deadline), CMSDK timer
//! 1 (the step interrupt) and the SysTick (the clock). Every register access is one `read_volatile` / `write_volatile` in
//! [`Reg`]; nothing else here is `unsafe`.
//!
//! Addresses and interrupt numbers (QEMU `hw/arm/mps2.c`, ARM AN386): UART0 at 0x4000_4000,
//! its RX interrupt IRQ 0; TIMER0 at 0x4000_0000, IRQ 8; TIMER1 at 0x4000_1000, IRQ 9. The UART (QEMU
//! `hw/char/cmsdk-apb-uart.c`): DATA 0x00, STATE 0x04 (bit 0 TX full, bit 1 RX full), CTRL
//! 0x08 (bit 0 TX enable, bit 1 RX enable, bit 3 RX interrupt enable), INTSTATUS/INTCLEAR
//! 0x0C (write 1 to clear; bit 1 RX), BAUDDIV 0x10 (at least 16, or QEMU ignores it). The
//! timer: CTRL 0x00 (bit 0 enable, bit 3 interrupt enable), VALUE 0x04 (counts down at the
//! 25 MHz APB clock), RELOAD 0x08, INTSTATUS/INTCLEAR 0x0C.

use core::sync::atomic::{AtomicU32, AtomicUsize, Ordering};

/// The core and APB clock (Hz).
pub const CLOCK_HZ: u32 = 25_000_000;

/// A memory-mapped 32-bit register.
#[derive(Clone, Copy)]
pub struct Reg(usize);

impl Reg {
    pub fn read(self) -> u32 {
        // SAFETY: `self.0` is one of the peripheral register addresses below (aligned,
        // mapped on mps2-an386); a volatile read has no other effect than the device's.
        unsafe { core::ptr::read_volatile(self.0 as *const u32) }
    }
    pub fn write(self, v: u32) {
        // SAFETY: as `read`; the register is writable and the value is what the device's
        // documentation allows.
        unsafe { core::ptr::write_volatile(self.0 as *mut u32, v) }
    }
}

const UART0: usize = 0x4000_4000;
const UART_DATA: Reg = Reg(UART0);
const UART_STATE: Reg = Reg(UART0 + 0x04);
const UART_CTRL: Reg = Reg(UART0 + 0x08);
const UART_INT: Reg = Reg(UART0 + 0x0C);
const UART_BAUDDIV: Reg = Reg(UART0 + 0x10);
/// UART0's RX interrupt.
pub const UART0_RX_IRQ: u16 = 0;

const TIMER0: usize = 0x4000_0000;
const TIMER_CTRL: Reg = Reg(TIMER0);
const TIMER_VALUE: Reg = Reg(TIMER0 + 0x04);
const TIMER_RELOAD: Reg = Reg(TIMER0 + 0x08);
const TIMER_INT: Reg = Reg(TIMER0 + 0x0C);
/// Timer 0's interrupt.
pub const TIMER0_IRQ: u16 = 8;

const TIMER1: usize = 0x4000_1000;
const STEP_CTRL: Reg = Reg(TIMER1);
const STEP_VALUE: Reg = Reg(TIMER1 + 0x04);
const STEP_RELOAD: Reg = Reg(TIMER1 + 0x08);
const STEP_INT: Reg = Reg(TIMER1 + 0x0C);
/// Timer 1's interrupt: the step interrupt.
pub const STEP_IRQ: u16 = 9;

/// Starts SysTick on the core's 25 MHz clock, wrapping every `reload + 1` ticks with its
/// interrupt, and waits for its first reload (the counter loads `reload` on its first tick:
/// from then on it counts).
pub fn start_systick(syst: &mut cortex_m::peripheral::SYST, reload: u32) {
    syst.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
    syst.set_reload(reload);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    while cortex_m::peripheral::SYST::get_current() == 0 {}
}

const NVIC_ISER0: Reg = Reg(0xE000_E100);
const NVIC_ISPR0: Reg = Reg(0xE000_E200);
const NVIC_IPR0: Reg = Reg(0xE000_E400);
const NVIC_IPR2: Reg = Reg(0xE000_E408);

/// Bytes received and not read yet (the RX interrupt fills it; QEMU's UART holds one byte
/// and takes the next from the line only once it was read, so nothing is lost).
const RING: usize = 512;
static RX: [AtomicU32; RING] = [const { AtomicU32::new(0) }; RING];
static RX_HEAD: AtomicUsize = AtomicUsize::new(0);
static RX_TAIL: AtomicUsize = AtomicUsize::new(0);

/// Enables UART0 at `baud` (TX and RX, the RX interrupt) and the three interrupts: timer
/// 0's at priority `link`, the UART's receive interrupt (which only fills the ring) and the
/// step interrupt's at `step` (NVIC priority bytes, lower preempts).
pub fn init(baud: u32, link: u8, step: u8) {
    // IPR0 byte 0: IRQ 0 (UART0 RX); IPR2 bytes 0 and 1: IRQ 8 (timer 0), IRQ 9 (timer 1).
    NVIC_IPR0.write(step as u32);
    NVIC_IPR2.write(link as u32 | (step as u32) << 8);
    UART_BAUDDIV.write((CLOCK_HZ / baud).max(16));
    UART_CTRL.write(0b1011);
    TIMER_CTRL.write(0);
    TIMER_INT.write(1);
    STEP_CTRL.write(0);
    STEP_INT.write(1);
    NVIC_ISER0.write((1 << UART0_RX_IRQ) | (1 << TIMER0_IRQ) | (1 << STEP_IRQ));
}

/// The RX interrupt: cleared first (a byte arriving after the loop raises it again), then
/// the byte into the ring (dropped if the ring is full: the link retransmits).
pub fn on_rx() {
    UART_INT.write(0b10);
    while UART_STATE.read() & 0b10 != 0 {
        let b = UART_DATA.read() & 0xFF;
        let head = RX_HEAD.load(Ordering::Relaxed);
        let next = (head + 1) % RING;
        if next != RX_TAIL.load(Ordering::Acquire) {
            RX[head].store(b, Ordering::Relaxed);
            RX_HEAD.store(next, Ordering::Release);
        }
    }
}

/// The timer interrupt: one-shot, so stop it.
pub fn on_timer() {
    TIMER_CTRL.write(0);
    TIMER_INT.write(1);
}

/// Whether received bytes wait.
pub fn rx_pending() -> bool {
    RX_HEAD.load(Ordering::Acquire) != RX_TAIL.load(Ordering::Relaxed)
}

/// Reads received bytes into `buf`.
pub fn read(buf: &mut [u8]) -> usize {
    let mut n = 0;
    while n < buf.len() {
        let tail = RX_TAIL.load(Ordering::Relaxed);
        if tail == RX_HEAD.load(Ordering::Acquire) {
            break;
        }
        buf[n] = RX[tail].load(Ordering::Relaxed) as u8;
        RX_TAIL.store((tail + 1) % RING, Ordering::Release);
        n += 1;
    }
    n
}

/// Writes `bytes`, waiting while the transmitter is full.
pub fn write(bytes: &[u8]) {
    for &b in bytes {
        while UART_STATE.read() & 1 != 0 {}
        UART_DATA.write(b as u32);
    }
}

/// Arms timer 0 to interrupt in `ticks` APB ticks (one-shot).
pub fn wake_in(ticks: u32) {
    TIMER_CTRL.write(0);
    TIMER_RELOAD.write(ticks);
    TIMER_VALUE.write(ticks);
    TIMER_INT.write(1);
    TIMER_CTRL.write(0b1001);
}

/// Stops timer 0.
pub fn cancel_wake() {
    TIMER_CTRL.write(0);
}

/// The step interrupt's entry: timer 1 is one-shot, so stop it and clear its flag.
pub fn on_step_timer() {
    STEP_CTRL.write(0);
    STEP_INT.write(1);
}

/// Arms timer 1 to raise the step interrupt in `ticks` APB ticks (one-shot, at least 1).
pub fn step_in(ticks: u32) {
    let ticks = ticks.max(1);
    STEP_CTRL.write(0);
    STEP_RELOAD.write(ticks);
    STEP_VALUE.write(ticks);
    STEP_INT.write(1);
    STEP_CTRL.write(0b1001);
}

/// Raises the step interrupt now (it runs as soon as no critical section holds it off).
pub fn pend_step() {
    NVIC_ISPR0.write(1 << STEP_IRQ);
}
