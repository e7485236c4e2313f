//! Proves the stack guard of the firmware (`stack.rs`): recurses until the stack runs past its
//! bottom into the MPU guard region below it. The MPU faults on the first word written there;
//! the HardFault entry and handler the other firmwares have (valves first) print
//! `stack overflow: the stack ran past its N bytes into the guard at ADDRESS`, and QEMU exits
//! with failure. `host-sim/tests/mcu.rs` runs it and requires that line, and that a static
//! kept the value `main` gave it: an overflow is never silent and never writes over a static.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};

#[path = "../fault.rs"]
mod fault;
#[path = "../link_board.rs"]
#[allow(dead_code)]
mod link_board;
#[path = "../stack.rs"]
#[allow(dead_code)]
mod stack;

/// A static (above the stack, as every static): `main` sets it, the fault handler prints it,
/// and it must have kept its value through the overflow.
static SENTINEL: AtomicU32 = AtomicU32::new(0);

#[entry]
fn main() -> ! {
    stack::paint();
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        hprintln!("error peripherals");
        debug::exit(debug::EXIT_FAILURE);
        #[allow(clippy::empty_loop)]
        loop {}
    };
    if !stack::install_guard(&mut cp.MPU) {
        hprintln!("error: stack guard not aligned to its size");
        debug::exit(debug::EXIT_FAILURE);
        #[allow(clippy::empty_loop)]
        loop {}
    }
    // Set at run time (an opaque value), so that the handler's read is a real load.
    SENTINEL.store(core::hint::black_box(0x5AFE_5AFE), Ordering::SeqCst);
    let (start, end) = stack::guard();
    hprintln!(
        "guard {:#x}..{:#x}, statics {} bytes, room {} bytes",
        start,
        end,
        stack::statics(),
        stack::room()
    );
    let depth = dive(0);
    // Never reached: the recursion faults first.
    hprintln!("error: {} frames deep and no fault", depth);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

/// One more 1 KiB frame, written to, until the stack runs out.
#[inline(never)]
fn dive(depth: u32) -> u32 {
    let mut frame = [0u8; 1024];
    frame[depth as usize % 1024] = depth as u8;
    let frame = core::hint::black_box(frame);
    if depth == u32::MAX {
        return 0;
    }
    dive(depth + 1) + frame[(depth as usize + 1) % 1024] as u32
}

/// The HardFault handler, entered on a fresh stack by `stack.rs`'s entry: the valves first,
/// the report, then the sentinel's value.
extern "C" fn on_hard_fault(sp: u32, pc: u32) -> ! {
    fault::halt(sp, pc, || {
        hprintln!("sentinel {:#x}", SENTINEL.load(Ordering::SeqCst))
    })
}
