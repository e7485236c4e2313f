//! Every fault's end, the same in every firmware: a panic or a HardFault shuts the valves
//! first, then says what happened over semihosting, and QEMU exits with failure. (On a board
//! without a debugger semihosting would hang: the board crates use defmt over RTT instead.)

use cortex_m_semihosting::{debug, hprintln};

use crate::{link_board, stack};

/// The end of a HardFault, from the firmware's `on_hard_fault(sp, pc)` (which `stack.rs`'s
/// entry calls on a fresh stack): the valves shut, then the report (a stack overflow into the
/// guard, or the faulting instruction's address `pc`, 0 where the frame could not be read),
/// then `also` (a test's extra line).
pub fn halt(sp: u32, pc: u32, also: impl FnOnce()) -> ! {
    link_board::shut_valves();
    match stack::guard_fault(sp) {
        Some(at) => hprintln!(
            "stack overflow: the stack ran past its {} bytes into the guard at {:#x}",
            stack::room(),
            at
        ),
        None => hprintln!("hard fault at {:#x} (sp {:#x})", pc, sp),
    }
    also();
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
