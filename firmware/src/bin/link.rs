//! hollowpath's link firmware on QEMU's mps2-an386: the controller application
//! (`hollowpath::app`) on UART0, the host's `hollowpath print` at the other end.
//!
//! ```sh
//! cargo build -p hollowpath-qemu --target thumbv7em-none-eabihf --release --bin link
//! qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
//!     -semihosting-config enable=on,target=native -icount shift=0,sleep=off \
//!     -serial pty -kernel target/thumbv7em-none-eabihf/release/link
//! ```
//!
//! The clock is the SysTick (25 MHz, its wraps counted). The steps run from timer 1's
//! interrupt: the job's step side ([`Stepping`]: the machine, the counting pins, a queue of
//! the layer's moves) lives in a static behind a critical section, and the interrupt runs
//! the alarms that are due, each at its own deadline, then arms the timer for the next,
//! while the main loop generates the layer and queues its moves (`hollowpath::app::steps`).
//! The link's [`Session`] lives in its own static behind the link's interrupt priority
//! (BASEPRI): PendSV serves it (acks, replies, the host's messages decoded into events),
//! pended by the UART's receive interrupt, which only moves each byte into a ring, so the
//! link keeps answering while the application plans a slice or builds a layer, seconds in
//! which its loop reads no byte; the step and receive interrupts have the higher priority,
//! so serving the link never delays a step nor a received byte. The core sleeps (`wfi`) when
//! it has nothing to do, so QEMU's `-icount sleep=off` jumps the idle time. Waiting for the
//! host it sleeps until a byte or an event is there and arms no timer: the link's own
//! timers run when the host's next byte (its keep-alive) wakes it, so an idle firmware does
//! not race through emulated time sending retransmissions. The printer's pins are counted
//! in memory (`link_board`). Semihosting prints one line at start and one per job (with how
//! late the step interrupt ran its alarms at worst, and the RAM: the statics and the painted
//! stack's peak since start, interrupts included); the UART carries nothing but the link.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::scb::SystemHandler;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use hollowpath::app::{App, Io, Session, Shared, Steps};
use hollowpath::link::controller::Controller;
use hollowpath::link::endpoint::LinkConfig;
use static_cell::ConstStaticCell;

use controller::{
    FwApp, FwSession, Masked, Platform, StepSide, FIRMWARE, LINK_PRIORITY, STEP_PRIORITY,
};

#[path = "../controller.rs"]
mod controller;
#[path = "../fault.rs"]
mod fault;
#[path = "../link_board.rs"]
mod link_board;
#[path = "../mps2.rs"]
mod mps2;
#[path = "../stack.rs"]
mod stack;

/// The UART's baud rate (QEMU moves bytes as fast as the host takes them; the divider only
/// has to be valid).
const BAUD: u32 = 115_200;

/// The link's timers in emulated microseconds. Under `-icount shift=0,sleep=off` a print
/// runs some hundred times faster than the wall clock (the step deadlines are jumped), so
/// the host's keep-alives, a few wall milliseconds apart, are emulated seconds apart: the
/// watchdog allows 30 s. No keep-alive of our own (acks answer every frame; the host keeps
/// no watchdog).
const LINK_CONFIG: LinkConfig = LinkConfig {
    retransmit_us: 2_000_000,
    keepalive_us: 0,
    watchdog_us: 30_000_000,
};

/// The application (planner, offset spiral, machine), in a static.
static APP: ConstStaticCell<FwApp> = ConstStaticCell::new(App::new());

/// The link side (controller, slice assembler, events, outbox), shared by the
/// application's loop and PendSV (priority LINK_PRIORITY, the only interrupt that touches
/// it): BASEPRI masks PendSV while a call into it runs, not the step or receive interrupts.
static LINK: Masked<FwSession, LINK_PRIORITY> =
    Masked::new(Session::new(Controller::new(LINK_CONFIG, FIRMWARE)));

/// The step side (the job's machine, the counting pins, the queue of the layer's moves),
/// shared by the application's loop and the step interrupt (timer 1).
static MOTION: StepSide<link_board::LinkBoard, Mps2> = StepSide::new(link_board::parked());

impl Platform for Mps2 {
    fn kick() {
        mps2::pend_step();
    }
    fn link_pending() -> bool {
        mps2::rx_pending() || LINK.lock(|s| s.has_events())
    }
    fn wake_at(now: u64, at: u64) {
        // Timer 0 counts APB ticks; a second at most (the loop sleeps again after it).
        mps2::wake_in((at - now).min(1_000_000) as u32 * (mps2::CLOCK_HZ / 1_000_000));
    }
    fn cancel_wake() {
        mps2::cancel_wake();
    }
}

/// The step interrupt: runs the alarms that are due and arms timer 1 for the next one.
fn on_step() {
    mps2::on_step_timer();
    if let Some((wait, hz)) = MOTION.run_alarms(|| Mps2.now_us()) {
        let apb = wait as u64 * mps2::CLOCK_HZ as u64 / hz as u64;
        mps2::step_in(apb.min(u32::MAX as u64) as u32);
    }
}

/// SysTick wraps (each 2^24 ticks).
static WRAPS: AtomicU32 = AtomicU32::new(0);
const RELOAD: u32 = 0x00FF_FFFF;

/// SysTick wraps (0.67 s apart) that found the main loop without a check-in for [`BEATS`]
/// wraps, as many instructions as `controller::MAIN_LOOP_SILENCE_US` take the SKR 2: each one
/// a heartbeat the board would not have fed its watchdog on (reported with each job; the
/// tests hold it to 0). QEMU's CMSDK watchdog is not
/// armed here: under `-icount sleep=off` the emulated clock races over idle time, and after
/// some 170 emulated seconds of it SysTick stops waking the idle firmware while the
/// watchdog's timer runs on (`tests/mcu.rs` runs the watchdog in `watchdog_drill`, without
/// `sleep=off`).
static SILENT_HEARTBEATS: AtomicU32 = AtomicU32::new(0);

/// Heartbeats in `controller::MAIN_LOOP_SILENCE_US` of the SKR 2's time: QEMU's emulated
/// clock (`-icount shift=0`) counts one instruction a nanosecond, the board runs 168 M a
/// second (one a cycle at best), so 30 s on the board are 5.04 emulated seconds, 7.5 SysTick
/// wraps of 2^24 ticks: 8 (a stretch without a check-in spanning 8 wraps is at least 4.7 G
/// instructions, 28 s at 168 MHz).
const BEATS: u32 = (controller::MAIN_LOOP_SILENCE_US as u64 * BOARD_INSTRUCTIONS_PER_US
    / 1_000 // emulated us: QEMU runs 1 000 instructions an emulated us
    * (mps2::CLOCK_HZ as u64 / 1_000_000))
    .div_ceil(RELOAD as u64 + 1) as u32;
/// The SKR 2's instructions a microsecond at most (168 MHz, one a cycle).
const BOARD_INSTRUCTIONS_PER_US: u64 = 168;
const _: () = assert!(BEATS == 8);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
    if !controller::main_loop_alive(BEATS) {
        SILENT_HEARTBEATS.fetch_add(1, Ordering::Relaxed);
    }
}

/// The device interrupts (no PAC: cortex-m-rt routes them all here).
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    match irqn {
        0 => {
            // The receive interrupt, at the step priority, only fills the ring; the link is
            // served from PendSV at its own priority (as on the SKR 2, whose UART holds one
            // byte: a frame written byte by byte must not hold off the next received one).
            mps2::on_rx();
            cortex_m::peripheral::SCB::set_pendsv();
        }
        8 => mps2::on_timer(),
        9 => on_step(),
        _ => {}
    }
}

/// The link served at its own priority (LINK_PRIORITY, the only interrupt that touches the
/// session): acks, replies, the host's messages decoded into events, while the application
/// plans for seconds.
#[exception]
fn PendSV() {
    LINK.lock(|s| s.serve(&mut Mps2));
}

/// SysTick ticks since start.
fn ticks() -> u64 {
    loop {
        let w1 = WRAPS.load(Ordering::Relaxed);
        let v = cortex_m::peripheral::SYST::get_current();
        let pending = cortex_m::peripheral::SCB::is_pendst_pending();
        let w2 = WRAPS.load(Ordering::Relaxed);
        if w1 == w2 {
            let w = if pending && v > RELOAD / 2 {
                w1 + 1
            } else {
                w1
            };
            return w as u64 * (RELOAD as u64 + 1) + (RELOAD - v) as u64;
        }
    }
}

/// The platform of the application: UART0, the SysTick clock, `wfi`.
struct Mps2;

impl Io for Mps2 {
    fn now_us(&mut self) -> u64 {
        ticks() / (mps2::CLOCK_HZ as u64 / 1_000_000)
    }
    fn read(&mut self, buf: &mut [u8]) -> usize {
        mps2::read(buf)
    }
    fn write(&mut self, bytes: &[u8]) {
        mps2::write(bytes)
    }
    fn sleep(&mut self, until: Option<u64>) {
        // Without a deadline, until the host's next byte (SysTick wraps wake us on the way).
        controller::sleep::<Mps2>(until, || Mps2.now_us());
    }
}

#[entry]
fn main() -> ! {
    // Before any interrupt is enabled (painting runs below the stack pointer, where an
    // interrupt's frame would go).
    stack::paint();
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        fail("peripherals");
    };
    if !stack::install_guard(&mut cp.MPU) {
        fail("stack guard: not aligned to its size");
    }
    mps2::start_systick(&mut cp.SYST, RELOAD);
    mps2::init(BAUD, LINK_PRIORITY, STEP_PRIORITY);
    // SAFETY: set before any byte can pend it; PendSV touches only the session, behind its
    // lock.
    unsafe { cp.SCB.set_priority(SystemHandler::PendSV, LINK_PRIORITY) };
    let app = APP.take();
    MOTION.lock(|s| *s.board() = link_board::new());
    let mut io = Mps2;
    hprintln!(
        "link firmware ready: app {} bytes, uart0 {} baud",
        core::mem::size_of::<FwApp>(),
        BAUD
    );
    let mut seen = 0u64;
    loop {
        app.poll(&LINK, &mut io, &MOTION);
        if let Some(c) = MOTION.steps_changed(&mut seen) {
            hprintln!(
                "job: steps {} {} {} valves shut {} at {} us, alarms at most {} ticks late, silent heartbeats {}, ram static {} stack {}",
                c.steps[0],
                c.steps[1],
                c.steps[2],
                link_board::valves_shut(),
                io.now_us(),
                controller::LATEST.load(Ordering::Relaxed),
                SILENT_HEARTBEATS.load(Ordering::Relaxed),
                stack::statics(),
                stack::highest()
            );
        }
        io.sleep(None);
    }
}

fn fail(what: &str) -> ! {
    link_board::shut_valves();
    hprintln!("error {}", what);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

/// The HardFault handler, entered on a fresh stack by `stack.rs`'s entry (`sp` and `pc` the
/// faulting ones): the valves first, then what happened (a stack overflow or the faulting
/// address), and QEMU exits with failure.
extern "C" fn on_hard_fault(sp: u32, pc: u32) -> ! {
    fault::halt(sp, pc, || {})
}
