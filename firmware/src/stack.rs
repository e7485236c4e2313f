//! The stack: its guard, its fault entry and its RAM figures.
//!
//! **Guard.** The stack sits at the bottom of RAM, below the statics (`firmware/memory.x`),
//! and grows down towards the start of RAM. The bytes below it (from `_stack_guard`, which
//! the memory layout defines) are an MPU region
//! no code may read or write ([`install_guard`]): a stack that grows past its bottom faults at
//! once, however large the frame that overflows (up to the guard's 64 KiB; the largest frame
//! of the firmwares is the zigzag's, 31 KiB), and can never reach a static above it.
//!
//! **Fault entry.** The MPU fault escalates to HardFault (MemManage is left disabled), which
//! runs with the MPU off (`HFNMIENA` clear). Its entry (`HardFault`, in assembly) takes the
//! faulting stack pointer and, where that is inside the stack, the faulting instruction's
//! address from the exception frame, then moves the stack pointer back to the top of the
//! stack, so that the handler has a stack even when the fault was the stack running out (its
//! frames overwrite `main`'s, which never runs again), and calls the firmware's
//! `on_hard_fault(sp, pc)`, which closes the valves and says what happened (`fault.rs`).
//!
//! On QEMU the guard is the 64 KiB below RAM, where nothing is: on an STM32 that range can
//! hold system memory (the bootloader, the unique ID, calibration values), so the SKR 2's
//! stack sits in its CCM instead, above a 4 KiB guard at the CCM's start (whose lower
//! neighbour is reserved address space: a frame larger than the guard faults there too).
//!
//! **Figures.** The statics (everything the linker places in RAM, `.data`, `.bss`,
//! `.uninit`) and the stack's peak, measured by painting the free stack between its bottom
//! and the stack pointer and finding the lowest word a frame wrote. Painting again before a
//! phase measures that phase's peak ([`peak`]); [`highest`] is the peak over the whole run.

use core::sync::atomic::{AtomicUsize, Ordering};

/// The paint: a word a frame is unlikely to leave behind.
const PAINT: u32 = 0xC0DE_5AFE;

extern "C" {
    static _ram_start: u32;
    static __sheap: u32;
    static _stack_start: u32;
    static _stack_end: u32;
    /// The guard's start, from the memory layout (`memory.x`): the guard runs from here to
    /// the stack's bottom, a power of two of bytes aligned to its size (the MPU's rule),
    /// larger than any frame of the firmware (64 KiB on QEMU, 4 KiB in the SKR 2's CCM).
    static _stack_guard: u32;
}

fn addr(s: &u32) -> usize {
    s as *const u32 as usize
}

/// The stack's bottom and top addresses.
fn stack_bounds() -> (usize, usize) {
    // SAFETY: only the addresses of the linker's symbols are taken, never their contents.
    unsafe { (addr(&_stack_end), addr(&_stack_start)) }
}

/// Bytes of RAM the statics take.
pub fn statics() -> usize {
    // SAFETY: only the addresses of the linker's symbols are taken, never their contents.
    unsafe { addr(&__sheap) - addr(&_ram_start) }
}

/// The guard region, `[start, end)`: from `_stack_guard` to the stack's bottom.
pub fn guard() -> (usize, usize) {
    let (bottom, _) = stack_bounds();
    // SAFETY: only the address of the linker's symbol is taken, never its contents.
    (unsafe { addr(&_stack_guard) }, bottom)
}

/// Bytes of the stack: the most it can take.
pub fn room() -> usize {
    let (bottom, top) = stack_bounds();
    top - bottom
}

/// Makes the guard region inaccessible (MPU region 0: no access, never executed) and enables
/// the MPU with the default memory map everywhere else. Call it once, after [`paint`]ing.
/// Returns `false` (and installs nothing) if the guard is not a power of two of at least 32
/// bytes aligned to its size.
pub fn install_guard(mpu: &mut cortex_m::peripheral::MPU) -> bool {
    let (start, end) = guard();
    let size = end.wrapping_sub(start);
    if !size.is_power_of_two() || size < 32 || start % size != 0 {
        return false;
    }
    // RASR: XN (bit 28), AP = 0b000 (no access, bits 24..26), SIZE = log2(size) - 1 (bits
    // 1..5), ENABLE (bit 0).
    let rasr = (1 << 28) | ((size.trailing_zeros() - 1) << 1) | 1;
    // SAFETY: region 0 covers only the guard, below the RAM the stack and the statics use;
    // PRIVDEFENA keeps the default map for everything else, so no other access changes. The
    // barriers make the new map apply from the next instruction.
    unsafe {
        mpu.rnr.write(0);
        mpu.rbar.write(start as u32);
        mpu.rasr.write(rasr);
        // CTRL: ENABLE (bit 0), PRIVDEFENA (bit 2); HFNMIENA (bit 1) clear: the HardFault
        // handler runs without the MPU.
        mpu.ctrl.write(1 | (1 << 2));
    }
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
    true
}

// The HardFault entry (the vector table's `HardFault`, instead of cortex-m-rt's trampoline):
// r0 the faulting stack pointer; r1 the stacked PC if the frame lies inside the stack (0
// otherwise: below it is the guard, and reading there could fault again); the stack pointer
// moved to the top of the stack; then the firmware's `on_hard_fault(sp: u32, pc: u32) -> !`
// (each firmware that includes this module defines it at its crate root).
core::arch::global_asm!(
    ".section .HardFault.user, \"ax\"",
    ".global HardFault",
    ".type HardFault, %function",
    ".thumb_func",
    "HardFault:",
    "  mrs r0, msp",
    "  movs r1, #0",
    "  ldr r2, ={bottom}",
    "  cmp r0, r2",
    "  blo 1f",
    "  ldr r2, ={top}",
    "  subs r2, r2, #32",
    "  cmp r0, r2",
    "  bhi 1f",
    "  ldr r1, [r0, #24]",
    "1:",
    "  ldr r2, ={top}",
    "  msr msp, r2",
    "  b {handler}",
    bottom = sym _stack_end,
    top = sym _stack_start,
    handler = sym crate::on_hard_fault,
);

/// In the HardFault handler, `sp` the faulting stack pointer: `Some(address)` if the fault
/// was the stack running into the guard (a data access there, or stacking an exception frame
/// with the stack pointer there), else `None`.
pub fn guard_fault(sp: u32) -> Option<usize> {
    // SAFETY: reads of the SCB's fault status and address registers (no side effect on
    // read).
    let (cfsr, mmfar) = unsafe {
        let scb = &*cortex_m::peripheral::SCB::PTR;
        (scb.cfsr.read(), scb.mmfar.read())
    };
    // MMFSR: MMARVALID (bit 7) with the faulting address; MSTKERR (bit 4) for a fault while
    // stacking an exception frame.
    let (start, end) = guard();
    let at = mmfar as usize;
    if cfsr & (1 << 7) != 0 && (start..end).contains(&at) {
        Some(at)
    } else if cfsr & (1 << 4) != 0 && (start..end).contains(&(sp as usize)) {
        Some(sp as usize)
    } else {
        None
    }
}

/// The highest peak [`peak`] has measured (paint is lost each time the RAM is painted again).
static HIGHEST: AtomicUsize = AtomicUsize::new(0);

/// Paints the free stack between its bottom and the current frame (with a 256-byte margin
/// for this function's own frame and an interrupt's). Call it first thing in `main`, and
/// again before a phase to measure its peak.
#[inline(never)]
pub fn paint() {
    // SAFETY: the words between the stack's bottom and 256 bytes below the stack pointer
    // belong to nobody yet (the stack grows down from `_stack_start` and has not reached
    // them); volatile writes, so the loop is not elided.
    unsafe {
        let low = stack_bounds().0;
        let high = cortex_m::register::msp::read() as usize - 256;
        let mut p = low;
        while p < high {
            core::ptr::write_volatile(p as *mut u32, PAINT);
            p += 4;
        }
    }
}

/// The stack's peak since it was last painted, in bytes: from the top of the stack down to
/// the lowest word that is no longer paint (the frames above the painting one count in full).
pub fn peak() -> usize {
    let p = unpainted();
    HIGHEST.fetch_max(p, Ordering::Relaxed);
    p
}

/// The stack's peak over the whole run, in bytes.
pub fn highest() -> usize {
    peak().max(HIGHEST.load(Ordering::Relaxed))
}

fn unpainted() -> usize {
    // SAFETY: reads of the stack region, RAM this firmware owns; volatile, as frames wrote it
    // behind the compiler's back.
    unsafe {
        let (bottom, top) = stack_bounds();
        let mut p = bottom;
        while p < top && core::ptr::read_volatile(p as *const u32) == PAINT {
            p += 4;
        }
        top - p
    }
}
