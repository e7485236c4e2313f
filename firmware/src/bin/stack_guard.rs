//! Proves the stack guard of the firmware (`stack.rs`): recurses until the stack reaches the
//! guard region above the statics. The MPU faults on the first word written into it; the
//! HardFault handler (the one the other firmwares have) closes the valves and prints
//! `stack overflow: the stack reached its guard at ...`, and QEMU exits with failure.
//! `host-sim/tests/mcu.rs` runs it and requires that line: an overflow is never silent and
//! never writes over a static.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};

#[path = "../link_board.rs"]
#[allow(dead_code)]
mod link_board;
#[path = "../stack.rs"]
#[allow(dead_code)]
mod stack;

/// A static just below the guard: it must keep its value through the overflow.
static SENTINEL: AtomicU32 = AtomicU32::new(0x5AFE_5AFE);

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
    }
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

/// The HardFault handler, entered through `stack.rs`'s entry on a fresh stack (`sp` the
/// faulting one): the valves first, then what happened (a stack overflow or the faulting
/// address), and QEMU exits with failure.
extern "C" fn on_hard_fault(sp: u32) -> ! {
    link_board::shut_valves();
    stack::fault_report(sp);
    hprintln!("sentinel {:#x}", SENTINEL.load(Ordering::Relaxed));
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    link_board::shut_valves();
    hprintln!("panic: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}
