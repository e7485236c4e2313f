//! A watchdog drill for the main loop's liveness (`controller.rs`: [`check_in`],
//! [`main_loop_alive`]): the heartbeat (SysTick, every 0.17 s) feeds QEMU's CMSDK watchdog
//! only while the main loop checked in within the drill's silence budget. The drill opens a
//! valve, checks in once and hangs its main loop (a spinning loop, as a runaway computation
//! would). The heartbeat stops feeding; the watchdog's interrupt (the NMI) shuts the valves
//! and says so; its second expiry resets the machine, and the firmware, booting again, finds
//! the drill's mark in memory the reset leaves alone (`.uninit`) and exits with success.
//! `host-sim/tests/mcu.rs` runs it.
//!
//! [`check_in`]: controller::check_in
//! [`main_loop_alive`]: controller::main_loop_alive
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{debug, hprintln};

#[path = "../controller.rs"]
#[allow(dead_code)]
mod controller;
#[path = "../fault.rs"]
mod fault;
#[path = "../link_board.rs"]
#[allow(dead_code)]
mod link_board;
#[path = "../mps2.rs"]
#[allow(dead_code)]
mod mps2;
#[path = "../stack.rs"]
#[allow(dead_code)]
mod stack;

/// The CMSDK APB watchdog (QEMU `hw/watchdog/cmsdk-apb-watchdog.c`, at 0x4000_8000 on
/// mps2-an386, its interrupt the NMI): LOAD 0x00, CONTROL 0x08 (bit 0 interrupt and count,
/// bit 1 reset), INTCLR 0x0C (any write clears the interrupt and reloads), LOCK 0xC00
/// (0x1ACC_E551 unlocks the others, anything else locks them). It counts LOAD ticks of the
/// 25 MHz clock down to zero, raises its interrupt and counts again; at zero again with the
/// interrupt still raised it resets the machine.
const WDOG: usize = 0x4000_8000;
const WDOG_LOAD: usize = WDOG;
const WDOG_CONTROL: usize = WDOG + 0x08;
const WDOG_INTCLR: usize = WDOG + 0x0C;
const WDOG_LOCK: usize = WDOG + 0xC00;
const WDOG_UNLOCK: u32 = 0x1ACC_E551;

fn wdog_write(reg: usize, v: u32) {
    // SAFETY: `reg` is one of the watchdog's registers above (aligned, mapped on
    // mps2-an386), written with what the CMSDK documentation allows.
    unsafe { core::ptr::write_volatile(reg as *mut u32, v) }
}

/// Starts the watchdog: its interrupt (the NMI) `ticks` 25 MHz ticks after the last feed, the
/// reset as long again after that.
fn watchdog_start(ticks: u32) {
    wdog_write(WDOG_LOCK, WDOG_UNLOCK);
    wdog_write(WDOG_LOAD, ticks);
    wdog_write(WDOG_CONTROL, 0b11);
    wdog_write(WDOG_LOCK, 0);
}

/// Feeds the watchdog (clears its interrupt and reloads it).
fn watchdog_feed() {
    wdog_write(WDOG_LOCK, WDOG_UNLOCK);
    wdog_write(WDOG_INTCLR, 1);
    wdog_write(WDOG_LOCK, 0);
}

/// The drill's silence budget in heartbeats: the main loop's is 10 s (100 of the SKR 2's);
/// one keeps the emulated run (the spinning loop's every instruction) short.
const BEATS: u32 = 1;
/// SysTick's reload: it wraps every 2^22 ticks of the 25 MHz clock (0.17 s), the heartbeat.
const RELOAD: u32 = 0x003F_FFFF;
/// The watchdog's period: two heartbeats, so a fed watchdog never raises its interrupt.
const WATCHDOG_TICKS: u32 = 2 * (RELOAD + 1);
/// What the drill leaves in memory before it hangs, to find after the reset.
const MARK: u32 = 0x5741_5443;

/// The mark: in `.uninit`, which neither the reset nor the start-up code touches.
#[link_section = ".uninit.WATCHDOG_DRILL"]
static MARKED: MaybeUninit<AtomicU32> = MaybeUninit::uninit();

fn marked() -> &'static AtomicU32 {
    // SAFETY: any bit pattern is a valid `u32`, so the memory, whatever a previous run or
    // power-up left there, is an initialised `AtomicU32`.
    unsafe { MARKED.assume_init_ref() }
}

static WRAPS: AtomicU32 = AtomicU32::new(0);
/// When the heartbeat first found the main loop silent (us, 0: not yet): the NMI reports
/// it, so that only one context prints once the main loop hangs.
static SILENT_AT: AtomicU32 = AtomicU32::new(0);

/// Microseconds since start on SysTick's wraps (the heartbeat's resolution is enough here).
fn now_us() -> u64 {
    let ticks = WRAPS.load(Ordering::Relaxed) as u64 * (RELOAD as u64 + 1)
        + (RELOAD - cortex_m::peripheral::SYST::get_current()) as u64;
    ticks / (mps2::CLOCK_HZ as u64 / 1_000_000)
}

#[entry]
fn main() -> ! {
    if marked().swap(0, Ordering::Relaxed) == MARK {
        hprintln!(
            "booted again after the watchdog's reset: valves shut {}",
            link_board::valves_shut()
        );
        debug::exit(debug::EXIT_SUCCESS);
    }
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| panic!("peripherals"));
    mps2::start_systick(&mut cp.SYST, RELOAD);
    if !link_board::open_half(&mut link_board::new(), 0) {
        hprintln!("error: valve 0 refused its duty");
    }
    controller::check_in();
    watchdog_start(WATCHDOG_TICKS);
    marked().store(MARK, Ordering::Relaxed);
    hprintln!(
        "valve 0 open: valves shut {}; the main loop hangs now",
        link_board::valves_shut()
    );
    #[allow(clippy::empty_loop)]
    loop {}
}

/// The heartbeat: feeds the watchdog while the main loop is alive.
#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
    let now = now_us();
    if controller::main_loop_alive(BEATS) {
        watchdog_feed();
    } else if SILENT_AT.load(Ordering::Relaxed) == 0 {
        SILENT_AT.store(now as u32, Ordering::Relaxed);
    }
}

/// The watchdog's interrupt: the valves first, then the report; the reset follows.
// SAFETY (cortex-m-rt asks NMI handlers to be `unsafe`: an NMI preempts critical sections):
// it shuts the valves (atomic stores), prints and waits for the reset. It is the only
// printer once the main loop hangs (the main loop's last line comes before the watchdog can
// expire, and the heartbeat only records when it found the loop silent), so semihosting's
// output is never entered twice.
#[exception]
unsafe fn NonMaskableInt() {
    link_board::shut_valves();
    hprintln!(
        "heartbeat at {} us: the main loop is silent, the watchdog unfed",
        SILENT_AT.load(Ordering::Relaxed)
    );
    hprintln!(
        "watchdog interrupt: valves shut {}",
        link_board::valves_shut()
    );
    #[allow(clippy::empty_loop)]
    loop {}
}

/// The HardFault handler, entered on a fresh stack by `stack.rs`'s entry.
extern "C" fn on_hard_fault(sp: u32, pc: u32) -> ! {
    fault::halt(sp, pc, || {})
}
