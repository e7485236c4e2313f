//! RAM figures of the firmware: the statics (everything the linker places in RAM, `.data`,
//! `.bss`, `.uninit`) and the stack's peak, measured by painting the free RAM between the end
//! of the statics and the stack pointer and finding the lowest word a frame wrote. Painting
//! again before a phase measures that phase's peak ([`peak`]); [`highest`] is the peak over
//! the whole run.

use core::sync::atomic::{AtomicUsize, Ordering};

/// The paint: a word a frame is unlikely to leave behind.
const PAINT: u32 = 0xC0DE_5AFE;

extern "C" {
    static _ram_start: u32;
    static __sheap: u32;
    static _stack_start: u32;
}

fn addr(s: &u32) -> usize {
    s as *const u32 as usize
}

/// Bytes of RAM the statics take.
pub fn statics() -> usize {
    // SAFETY: only the addresses of the linker's symbols are taken, never their contents.
    unsafe { addr(&__sheap) - addr(&_ram_start) }
}

/// Bytes between the end of the statics and the top of RAM: the most the stack can take
/// before it writes over them.
pub fn room() -> usize {
    // SAFETY: only the addresses of the linker's symbols are taken, never their contents.
    unsafe { addr(&_stack_start) - addr(&__sheap) }
}

/// The highest peak [`peak`] has measured (paint is lost each time the RAM is painted again).
static HIGHEST: AtomicUsize = AtomicUsize::new(0);

/// Paints the free RAM below the current frame (with a 256-byte margin for this function's
/// own frame). Call it first thing in `main`, and again before a phase to measure its peak.
#[inline(never)]
pub fn paint() {
    // SAFETY: the words between the end of the statics and 256 bytes below the stack pointer
    // belong to nobody yet (no heap; the stack grows down from `_stack_start` and has not
    // reached them); volatile writes, so the loop is not elided.
    unsafe {
        let low = addr(&__sheap);
        let high = cortex_m::register::msp::read() as usize - 256;
        let mut p = low;
        while p < high {
            core::ptr::write_volatile(p as *mut u32, PAINT);
            p += 4;
        }
    }
}

/// The stack's peak since it was last painted, in bytes: from the top of RAM down to the
/// lowest word that is no longer paint (the frames above the painting one count in full).
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
    // SAFETY: reads of the painted region between the statics and the stack top, which is
    // RAM this firmware owns; volatile, as frames wrote it behind the compiler's back.
    unsafe {
        let top = addr(&_stack_start);
        let mut p = addr(&__sheap);
        while p < top && core::ptr::read_volatile(p as *const u32) == PAINT {
            p += 4;
        }
        top - p
    }
}
