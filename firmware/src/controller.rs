//! The controller application on a Cortex-M, whatever the board: the link's session behind
//! the link's interrupt priority, the step side behind a critical section, the step
//! interrupt's work, and sleeping. The QEMU link firmware (`src/bin/link.rs`) and the SKR 2
//! image (`boards/skr2`) include this file; each supplies its [`Platform`] (how to make the
//! step interrupt run, whether the link has work) and its timers.

use core::cell::RefCell;
use core::marker::PhantomData;
use core::sync::atomic::{AtomicU32, Ordering};

use critical_section::Mutex;
use hollowpath::app::io::ticks_at;
use hollowpath::app::{App, Io, Session, Shared, Stepping, Steps};
use hollowpath::config::{MAX_HOLES, MAX_VERTICES};
use hollowpath::link::message::Version;
use hollowpath::motion::machine::Counters;
use hollowpath::motion::stepper::before;
use hollowpath::motion::Board;

/// The firmware's version, sent in its hello.
pub const FIRMWARE: Version = Version {
    major: 0,
    minor: 1,
    patch: 0,
};

/// Contour points the link's slice assembler holds: every feature at its most vertices.
const POINTS: usize = (MAX_HOLES + 1) * MAX_VERTICES;
/// The application (planner, offset spiral, slice) as every firmware links it.
pub type FwApp = App<MAX_HOLES, POINTS, 4>;
/// The link side (controller, slice assembler, events, outbox).
pub type FwSession = Session<MAX_HOLES, POINTS, 4>;

/// Interrupt priorities (NVIC priority bytes, lower preempts): the step interrupt above the
/// link's, so that serving the link (a frame decoded, a reply written to the UART) never
/// delays a step.
pub const STEP_PRIORITY: u8 = 0x00;
pub const LINK_PRIORITY: u8 = 0x80;

/// A value shared by the main loop and one interrupt of priority `PRIORITY` (NVIC priority
/// byte): while [`Shared::lock`] runs, BASEPRI masks that interrupt and every one at its
/// priority or below, never those above it (the step interrupt).
pub struct Masked<T, const PRIORITY: u8>(RefCell<T>);

impl<T, const PRIORITY: u8> Masked<T, PRIORITY> {
    pub const fn new(value: T) -> Self {
        // BASEPRI 0 masks nothing: such a lock would not be one.
        const { assert!(PRIORITY != 0, "a Masked priority of 0 masks nothing") };
        Masked(RefCell::new(value))
    }
}

// SAFETY: a firmware touches the value only from its main loop and from interrupts at
// `PRIORITY` (each says so where it declares its static), and only inside `lock`, which raises
// BASEPRI to `PRIORITY` first: no two of them run inside it at once. The value moves between
// those contexts, so it must be `Send`.
unsafe impl<T: Send, const PRIORITY: u8> Sync for Masked<T, PRIORITY> {}

impl<T, const PRIORITY: u8> Shared<T> for Masked<T, PRIORITY> {
    fn lock<R>(&self, f: impl FnOnce(&mut T) -> R) -> R {
        let old = cortex_m::register::basepri::read();
        // Raising BASEPRI only masks interrupts (never lowers a mask set outside: `_max`).
        cortex_m::register::basepri_max::write(PRIORITY);
        let r = f(&mut self.0.borrow_mut());
        // SAFETY: restores the mask as it was on entry.
        unsafe { cortex_m::register::basepri::write(old) };
        r
    }
}

/// What the step side and sleeping need of a board's platform.
pub trait Platform {
    /// Makes the step interrupt run now (pends it).
    fn kick();
    /// Whether the link has work for the application (bytes not decoded, or events).
    fn link_pending() -> bool;
    /// Arms a wake-up at microsecond `at` (it is `now` now; it may come earlier).
    fn wake_at(now: u64, at: u64);
    /// Cancels [`wake_at`](Self::wake_at).
    fn cancel_wake();
}

/// The main loop's check-ins since start (wrapping): the heartbeat compares them with its
/// last look ([`main_loop_alive`]).
static CHECK_INS: AtomicU32 = AtomicU32::new(0);
/// The check-ins the heartbeat saw last, and how many heartbeats in a row saw no new one
/// (the heartbeat's own: only its interrupt touches them).
static SEEN: AtomicU32 = AtomicU32::new(0);
static SILENT_BEATS: AtomicU32 = AtomicU32::new(0);

/// How long the main loop may go without checking in before the watchdog is left unfed.
/// It checks in at every wake-up while it sleeps or waits for the step queue (the heartbeat's
/// interrupt wakes it, so an idle loop checks in at the heartbeat's pace) and every time it
/// takes the step side (each move it queues). Between two it may plan a slice and prepare
/// its spiral, which has no check-in: 0.21 G instructions on four_holes with the board's
/// capacities (1.3 s at 168 MHz), and not bounded here for every slice the capacities admit
/// (the field's solve alone may run 4 000 sweeps over 5 120 nodes, about 0.8 G instructions,
/// 5 s), hence 30 s. What it catches is a main loop stuck computing (an endless loop, a
/// runaway search); one that waits forever on a step side whose interrupt stopped still
/// checks in at every wake-up, and is not this watchdog's to see.
pub const MAIN_LOOP_SILENCE_US: u32 = 30_000_000;

/// The main loop is alive (from the main loop only: an interrupt's call would vouch for it).
pub fn check_in() {
    CHECK_INS.fetch_add(1, Ordering::Relaxed);
}

/// The heartbeat's test before it feeds the watchdog, called once per heartbeat from its
/// interrupt: whether the main loop checked in within the last `beats` heartbeats.
pub fn main_loop_alive(beats: u32) -> bool {
    let n = CHECK_INS.load(Ordering::Relaxed);
    if SEEN.swap(n, Ordering::Relaxed) != n {
        SILENT_BEATS.store(0, Ordering::Relaxed);
        true
    } else {
        SILENT_BEATS.fetch_add(1, Ordering::Relaxed) + 1 < beats
    }
}

/// `Io::sleep` on a Cortex-M: until microsecond `until` (read on `now_us`) or until the link
/// has work, whichever is first (`None`: until the link has work); `wfi` between interrupts,
/// checking in ([`check_in`]) at every wake-up.
pub fn sleep<P: Platform>(until: Option<u64>, now_us: impl Fn() -> u64) {
    check_in();
    match until {
        None => {
            while !sleep_unless(P::link_pending) {
                check_in();
            }
        }
        Some(t) => {
            let now = now_us();
            if t <= now || P::link_pending() {
                return;
            }
            P::wake_at(now, t);
            while now_us() < t && !sleep_unless(P::link_pending) {
                check_in();
            }
            P::cancel_wake();
        }
    }
}

/// The step side (the job's machine, the board, the queue of the layer's moves) behind a
/// critical section, shared by the application's loop and the step interrupt.
pub struct StepSide<B, P>(Mutex<RefCell<Stepping<B>>>, PhantomData<P>);

impl<B: Board, P: Platform> StepSide<B, P> {
    pub const fn new(board: B) -> Self {
        StepSide(Mutex::new(RefCell::new(Stepping::new(board))), PhantomData)
    }

    /// The step interrupt's work ([`run_step_alarms`]) on the step side, behind the same
    /// critical section as [`Steps::lock`] but without its check-in: the interrupt must not
    /// vouch for the main loop. The next alarm's wait, as `run_step_alarms` gives it.
    pub fn run_alarms(&self, now_us: impl Fn() -> u64) -> Option<(u32, u32)> {
        critical_section::with(|cs| run_step_alarms(&mut self.0.borrow_ref_mut(cs), now_us))
    }

    /// The machine's counters if its steps changed since `*seen` (a job ran or went on since
    /// the last look), `*seen` updated: the firmware's per-job report.
    pub fn steps_changed(&self, seen: &mut u64) -> Option<Counters> {
        let c = self.lock(|s| s.machine().map(|m| m.counters()))?;
        let n = c.steps.iter().sum::<u64>();
        (n != core::mem::replace(seen, n)).then_some(c)
    }
}

impl<B: Board, P: Platform> Steps for StepSide<B, P> {
    type Board = B;
    fn lock<R>(&self, f: impl FnOnce(&mut Stepping<B>) -> R) -> R {
        // The main loop takes the step side for every move it queues: alive. (The step
        // interrupt takes it through `run_alarms`, which does not check in.)
        check_in();
        critical_section::with(|cs| f(&mut self.0.borrow_ref_mut(cs)))
    }
    fn kick(&self) {
        P::kick();
    }
    fn wait<I: Io>(&self, _io: &mut I) {
        // Until the step interrupt ran (it runs at every step) or a byte came; at once if the
        // step side is at rest (the test takes the step side: a check-in).
        sleep_unless(|| P::link_pending() || self.lock(|s| s.deadline().is_none()));
    }
}

/// The latest the step interrupt ran an alarm of a moving machine after its deadline, in
/// machine ticks (held off by a critical section of the main loop's, or by its own last
/// run; a start from rest is as late as the main loop's top-up before it, and no step waits
/// on it). Reported with each job.
pub static LATEST: AtomicU32 = AtomicU32::new(0);

/// The step interrupt's work: runs the alarms that are due (each at its own deadline,
/// however late this runs) at `now_us()`; then, unless the step side is at rest, the next
/// alarm's wait from the clock after the alarms ran, in ticks of the machine's `hz` (the
/// platform arms its timer for it). At rest it arms nothing: the application kicks it.
pub fn run_step_alarms<B: Board>(
    s: &mut Stepping<B>,
    now_us: impl Fn() -> u64,
) -> Option<(u32, u32)> {
    let hz = s.tick_hz()?;
    let now = ticks_at(now_us(), hz);
    let moving = s.machine().is_some_and(|m| !m.stepper().is_idle());
    if let Some(d) = s.deadline().filter(|&d| moving && !before(now, d)) {
        LATEST.fetch_max(now.wrapping_sub(d), Ordering::Relaxed);
    }
    let d = s.run_due(now, 64)?;
    let now = ticks_at(now_us(), hz);
    let wait = if before(now, d) {
        d.wrapping_sub(now)
    } else {
        0
    };
    Some((wait, hz))
}

/// Sleeps (`wfi`) until the next interrupt unless `ready()`; whether it was ready. The
/// check runs with interrupts masked, so an interrupt that makes it true between the check
/// and the `wfi` still ends the sleep (a pending interrupt wakes `wfi` even while masked).
pub fn sleep_unless(ready: impl Fn() -> bool) -> bool {
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
