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
//! (BASEPRI): the UART's receive interrupt serves it (acks, replies, the host's messages
//! decoded into events), so the link keeps answering while the application plans a slice
//! or builds a layer, seconds in which its loop reads no byte; the step interrupt has the
//! higher priority, so serving the link never delays a step. The core sleeps (`wfi`) when
//! it has nothing to do, so QEMU's `-icount sleep=off` jumps the idle time. Waiting for the
//! host it sleeps until a byte or an event is there and arms no timer: the link's own
//! timers run when the host's next byte (its keep-alive) wakes it, so an idle firmware does
//! not race through emulated time sending retransmissions. The printer's pins are counted
//! in memory (`link_board`). Semihosting prints one line at start and one per job (with how
//! late the step interrupt ran its alarms at worst, and the RAM: the statics and the painted
//! stack's peak since start, interrupts included); the UART carries nothing but the link.
#![no_std]
#![no_main]

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use critical_section::Mutex;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use hollowpath::app::io::ticks_at;
use hollowpath::app::{App, Io, Session, Shared, Stepping, Steps};
use hollowpath::config::{MAX_HOLES, MAX_VERTICES};
use hollowpath::link::controller::Controller;
use hollowpath::link::endpoint::LinkConfig;
use hollowpath::link::message::Version;
use hollowpath::motion::stepper::before;
use static_cell::ConstStaticCell;

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

const FIRMWARE: Version = Version {
    major: 0,
    minor: 1,
    patch: 0,
};

const POINTS: usize = (MAX_HOLES + 1) * MAX_VERTICES;
type FwApp = App<MAX_HOLES, POINTS, 4>;
type FwSession = Session<MAX_HOLES, POINTS, 4>;

/// The application (planner, offset spiral, machine), in a static.
static APP: ConstStaticCell<FwApp> = ConstStaticCell::new(App::new());

/// The link side (controller, slice assembler, events, outbox), shared by the
/// application's loop and the receive interrupt.
static LINK: Link = Link(RefCell::new(Session::new(Controller::new(
    LINK_CONFIG,
    FIRMWARE,
))));

/// Interrupt priorities (NVIC, lower preempts): the step interrupt above the link's, so
/// that serving the link (a frame decoded, a reply written to the UART) never delays a
/// step; timer 0 (a link wake-up) with the link.
const STEP_PRIORITY: u8 = 0x00;
const LINK_PRIORITY: u8 = 0x80;

/// The session behind the link's priority: while a call into it runs, BASEPRI masks the
/// receive interrupt (and everything at its priority), not the step interrupt.
struct Link(RefCell<FwSession>);

// SAFETY: the session is touched only by the main loop and the receive interrupt (priority
// LINK_PRIORITY), and only inside `Link::lock`, which raises BASEPRI to LINK_PRIORITY first:
// the two never run inside it at once, and the step interrupt never touches it.
unsafe impl Sync for Link {}

impl Shared<FwSession> for Link {
    fn lock<R>(&self, f: impl FnOnce(&mut FwSession) -> R) -> R {
        let old = cortex_m::register::basepri::read();
        // Raising BASEPRI only masks interrupts (never lowers a mask set outside: `_max`).
        cortex_m::register::basepri_max::write(LINK_PRIORITY);
        let r = f(&mut self.0.borrow_mut());
        // SAFETY: restores the mask as it was on entry.
        unsafe { cortex_m::register::basepri::write(old) };
        r
    }
}

/// The step side (the job's machine, the counting pins, the queue of the layer's moves),
/// shared by the application's loop and the step interrupt (timer 1).
static MOTION: Motion = Motion(Mutex::new(RefCell::new(Stepping::new(
    link_board::LinkBoard::parked(),
))));

/// The step side behind a critical section.
struct Motion(Mutex<RefCell<Stepping<link_board::LinkBoard>>>);

impl Steps for Motion {
    type Board = link_board::LinkBoard;
    fn lock<R>(&self, f: impl FnOnce(&mut Stepping<Self::Board>) -> R) -> R {
        critical_section::with(|cs| f(&mut self.0.borrow_ref_mut(cs)))
    }
    fn kick(&self) {
        mps2::pend_step();
    }
    fn wait<I: Io>(&self, _io: &mut I) {
        // Until the step interrupt ran (it runs at every step) or a byte came; at once if the
        // step side is at rest.
        sleep_unless(|| link_pending() || MOTION.lock(|s| s.deadline().is_none()));
    }
}

/// The step interrupt: runs the alarms that are due (at their own deadlines, however late
/// this runs) and arms timer 1 for the next one; at rest it arms nothing (the application
/// kicks it when work arrives).
fn on_step() {
    mps2::on_step_timer();
    MOTION.lock(|s| {
        let Some(hz) = s.tick_hz() else {
            return;
        };
        let now = ticks_at(Mps2.now_us(), hz);
        let moving = s.machine().is_some_and(|m| !m.stepper().is_idle());
        if let Some(d) = s.deadline().filter(|&d| moving && !before(now, d)) {
            // How late the interrupt ran an alarm of a moving machine (held off by a
            // critical section of the main loop's, or by its own last run; a start from
            // rest is as late as the main loop's top-up before it, and no step waits on it).
            LATEST.fetch_max(now.wrapping_sub(d), Ordering::Relaxed);
        }
        if let Some(d) = s.run_due(now, 64) {
            // From the clock after the alarms ran (they took time of their own).
            let now = ticks_at(Mps2.now_us(), hz);
            let wait = if before(now, d) {
                d.wrapping_sub(now)
            } else {
                0
            };
            let apb = wait as u64 * mps2::CLOCK_HZ as u64 / hz as u64;
            mps2::step_in(apb.min(u32::MAX as u64) as u32);
        }
    });
}

/// The latest the step interrupt ran an alarm after its deadline, machine ticks (reported
/// with each job's line).
static LATEST: AtomicU32 = AtomicU32::new(0);

/// Sleeps (`wfi`) until the next interrupt unless `ready()`; whether it was ready. The
/// check runs with interrupts masked, so an interrupt that makes it true between the check
/// and the `wfi` still ends the sleep (a pending interrupt wakes `wfi` even while masked).
fn sleep_unless(ready: impl Fn() -> bool) -> bool {
    cortex_m::interrupt::disable();
    let r = ready();
    if !r {
        cortex_m::asm::wfi();
    }
    // SAFETY: unmasks what `disable` masked above; no critical section is open across this
    // function (`ready` opens and closes its own), so nothing relies on them staying masked.
    unsafe { cortex_m::interrupt::enable() };
    r
}

/// Whether the link has events for the application (or bytes not yet decoded).
fn link_pending() -> bool {
    mps2::rx_pending() || LINK.lock(|s| s.has_events())
}

/// SysTick wraps (each 2^24 ticks).
static WRAPS: AtomicU32 = AtomicU32::new(0);
const RELOAD: u32 = 0x00FF_FFFF;

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// The device interrupts (no PAC: cortex-m-rt routes them all here).
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    match irqn {
        0 => {
            mps2::on_rx();
            // Serve the link here too: the application may be planning for seconds.
            LINK.lock(|s| s.serve(&mut Mps2));
        }
        8 => mps2::on_timer(),
        9 => on_step(),
        _ => {}
    }
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
        match until {
            None => {
                // Until the host's next byte (SysTick wraps wake us on the way).
                while !sleep_unless(link_pending) {}
            }
            Some(t) => {
                let now = self.now_us();
                if t <= now || link_pending() {
                    return;
                }
                let ticks = (t - now).min(1_000_000) as u32 * (mps2::CLOCK_HZ / 1_000_000);
                mps2::wake_in(ticks);
                while self.now_us() < t && !sleep_unless(link_pending) {}
                mps2::cancel_wake();
            }
        }
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
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(RELOAD);
    cp.SYST.clear_current();
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();
    mps2::init(BAUD, LINK_PRIORITY, STEP_PRIORITY);
    let app = APP.take();
    MOTION.lock(|s| *s.board() = link_board::LinkBoard::new());
    let mut io = Mps2;
    hprintln!(
        "link firmware ready: app {} bytes, uart0 {} baud",
        core::mem::size_of::<FwApp>(),
        BAUD
    );
    let mut jobs = 0u32;
    loop {
        app.poll(&LINK, &mut io, &MOTION);
        if let Some(c) = MOTION.lock(|s| s.machine().map(|m| m.counters())) {
            let n = c.steps.iter().sum::<u64>() as u32;
            if n != jobs {
                jobs = n;
                hprintln!(
                    "job: steps {} {} {} valves shut {} at {} us, alarms at most {} ticks late, ram static {} stack {}",
                    c.steps[0],
                    c.steps[1],
                    c.steps[2],
                    link_board::valves_shut(),
                    io.now_us(),
                    LATEST.load(Ordering::Relaxed),
                    stack::statics(),
                    stack::highest()
                );
            }
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
