//! The link's byte stream: USART1 (PA9 TX, PA10 RX, the SKR 2's TFT header), set up by the
//! HAL at boot (`main.rs`: baud rate, pins, the receive interrupt), then read into a ring
//! from its receive interrupt and written byte by byte.
//!
//! Registers (RM0090 30.6): SR 0x00 (bit 5 RXNE, bit 3 ORE, bit 7 TXE), DR 0x04. Reading SR
//! then DR clears RXNE and an overrun.

use core::sync::atomic::{AtomicU8, AtomicUsize, Ordering};

const USART1: usize = 0x4001_1000;
const SR: usize = USART1;
const DR: usize = USART1 + 0x04;
const RXNE: u32 = 1 << 5;
const ORE: u32 = 1 << 3;
const TXE: u32 = 1 << 7;

fn read(reg: usize) -> u32 {
    // SAFETY: USART1's status or data register (aligned, mapped); reading DR takes the
    // received byte, which is what every caller here wants.
    unsafe { core::ptr::read_volatile(reg as *const u32) }
}

/// Bytes received and not read yet: a power of two, two frames of the link at least.
const RING: usize = 1024;
const _: () = assert!(RING.is_power_of_two());
#[link_section = ".ccm"]
static RX: [AtomicU8; RING] = [const { AtomicU8::new(0) }; RING];
static HEAD: AtomicUsize = AtomicUsize::new(0);
static TAIL: AtomicUsize = AtomicUsize::new(0);
/// Bytes lost: the ring was full, or the UART overran (the link's CRC and retransmission
/// recover the frame; the count is logged).
pub static LOST: AtomicUsize = AtomicUsize::new(0);

/// The receive interrupt: moves the received byte into the ring.
pub fn on_rx() {
    let sr = read(SR);
    if sr & (RXNE | ORE) == 0 {
        return;
    }
    let byte = read(DR) as u8;
    if sr & ORE != 0 {
        LOST.fetch_add(1, Ordering::Relaxed);
    }
    let head = HEAD.load(Ordering::Relaxed);
    if head.wrapping_sub(TAIL.load(Ordering::Acquire)) >= RING {
        LOST.fetch_add(1, Ordering::Relaxed);
        return;
    }
    RX[head % RING].store(byte, Ordering::Relaxed);
    HEAD.store(head.wrapping_add(1), Ordering::Release);
}

/// Whether received bytes wait in the ring.
pub fn pending() -> bool {
    HEAD.load(Ordering::Acquire) != TAIL.load(Ordering::Relaxed)
}

/// Takes up to `buf.len()` received bytes.
pub fn take(buf: &mut [u8]) -> usize {
    let head = HEAD.load(Ordering::Acquire);
    let mut tail = TAIL.load(Ordering::Relaxed);
    let mut n = 0;
    while tail != head && n < buf.len() {
        buf[n] = RX[tail % RING].load(Ordering::Relaxed);
        tail = tail.wrapping_add(1);
        n += 1;
    }
    TAIL.store(tail, Ordering::Release);
    n
}

/// Writes `bytes`, waiting for the transmitter at each.
pub fn write(bytes: &[u8]) {
    for &b in bytes {
        while read(SR) & TXE == 0 {}
        // SAFETY: USART1's data register; writing it sends the byte (TXE was set).
        unsafe { core::ptr::write_volatile(DR as *mut u32, b as u32) }
    }
}
