//! A fault drill for the firmware's fault path (`fault.rs`, `stack.rs`): opens a valve, then
//! executes an undefined instruction. The UsageFault (not enabled) escalates to HardFault,
//! whose entry passes the faulting PC; the handler shuts the valves first, prints `hard fault
//! at PC (sp SP)`, then whether the valves are shut, and QEMU exits with failure.
//! `host-sim/tests/mcu.rs` runs it: the PC must be the drill's own instruction, and the valve
//! it opened must be shut.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;

#[path = "../fault.rs"]
mod fault;
#[path = "../link_board.rs"]
#[allow(dead_code)]
mod link_board;
#[path = "../stack.rs"]
#[allow(dead_code)]
mod stack;

#[entry]
fn main() -> ! {
    if !link_board::open_half(&mut link_board::new(), 0) {
        hprintln!("error: valve 0 refused its duty");
    }
    hprintln!(
        "valve 0 open: valves shut {}, drill at {:#x}",
        link_board::valves_shut(),
        undefined as *const () as usize & !1
    );
    undefined()
}

/// Executes an undefined instruction (`udf`): the drill's fault.
#[inline(never)]
fn undefined() -> ! {
    // SAFETY: `udf` only raises the fault this drill is for; the fault handler never returns.
    unsafe { core::arch::asm!("udf #0", options(noreturn)) }
}

/// The HardFault handler, entered on a fresh stack by `stack.rs`'s entry: the valves first,
/// the report, then whether the valves are shut.
extern "C" fn on_hard_fault(sp: u32, pc: u32) -> ! {
    fault::halt(sp, pc, || {
        hprintln!("after the fault: valves shut {}", link_board::valves_shut())
    })
}
