//! hollowpath on QEMU's mps2-an386: plans the built-in four-hole slice with the same core the
//! host runs, checks the plan, builds its zigzag and spiral layers, and prints their digests and
//! the instructions each step took over semihosting, then exits QEMU with the verdict.
//!
//! The host test `host-sim/tests/mcu.rs` compares the digest with the host's: the plans must
//! be bit-identical.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use hollowpath::toolpath::offset::OffsetSpiral;
use hollowpath::toolpath::zigzag::zigzag;
use hollowpath::toolpath::DigestSink;
use hollowpath::{Feature, FeatureId, Planner, Settings, Slice};
use static_cell::{ConstStaticCell, StaticCell};

mod link_board;
mod motion_bench;

mod slice_data {
    use hollowpath::geometry::Point;
    include!(concat!(env!("OUT_DIR"), "/slice_data.rs"));
}

/// The planner's working memory, in .bss (its initial value is all zeros).
static PLANNER: ConstStaticCell<Planner> = ConstStaticCell::new(Planner::new());

/// The offset spiral's working memory, in .bss.
static OFFSET: ConstStaticCell<OffsetSpiral> = ConstStaticCell::new(OffsetSpiral::new());

/// The motion controller of the motion bench, in .bss.
static MACHINE: StaticCell<hollowpath::motion::Machine<{ motion_bench::LOOK_AHEAD }>> =
    StaticCell::new();

/// Instructions per SysTick tick under `-icount shift=0` (one instruction a nanosecond, the
/// SysTick on the 25 MHz core clock).
const INSNS_PER_TICK: u64 = 40;

/// SysTick wraps (each 2^24 ticks).
static WRAPS: AtomicU32 = AtomicU32::new(0);

const RELOAD: u32 = 0x00FF_FFFF;

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// SysTick ticks since start (under `-icount shift=0`, about 40 instructions a tick).
fn ticks() -> u64 {
    loop {
        let w1 = WRAPS.load(Ordering::Relaxed);
        let v = cortex_m::peripheral::SYST::get_current();
        // A wrap that happened but whose interrupt has not run yet.
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

fn fail(what: &str, e: impl core::fmt::Debug) -> ! {
    hprintln!("error {}: {:?}", what, e);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

fn built_in_slice() -> Slice {
    let wall = Feature::new(FeatureId::Wall, slice_data::WALL.0, slice_data::WALL.1)
        .unwrap_or_else(|e| fail("wall", e));
    let mut holes: hollowpath::heapless::Vec<Feature, { hollowpath::config::MAX_HOLES }> =
        hollowpath::heapless::Vec::new();
    for (i, (pts, m)) in slice_data::HOLES.iter().enumerate() {
        let f = Feature::new(FeatureId::Hole(i as u8), pts, *m).unwrap_or_else(|e| fail("hole", e));
        if holes.push(f).is_err() {
            fail("holes", "too many");
        }
    }
    Slice::new(
        wall,
        &holes,
        Settings::for_road_width(slice_data::ROAD_WIDTH),
    )
    .unwrap_or_else(|e| fail("slice", e))
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| fail("peripherals", ()));
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(RELOAD);
    cp.SYST.clear_current();
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();
    // The counter loads RELOAD on its first tick; count from there.
    while cortex_m::peripheral::SYST::get_current() == 0 {}

    let planner = PLANNER.take();
    let t0 = ticks();
    let slice = built_in_slice();
    let t1 = ticks();
    let plan = planner.plan(&slice).unwrap_or_else(|e| fail("plan", e));
    let t2 = ticks();
    let verdict = hollowpath::verify::verify(&slice, plan);
    let t3 = ticks();
    hprintln!(
        "mcls {} bisectors {} branch_points {}",
        plan.mcls.len(),
        plan.bisectors().len(),
        plan.cells.branch_points.len()
    );
    hprintln!("digest {:016x}", plan.digest());
    hprintln!(
        "ticks validate {} plan {} verify {}",
        t1 - t0,
        t2 - t1,
        t3 - t2
    );
    if let Err(v) = verdict {
        fail("verify", v);
    }
    hprintln!("verify ok");

    // The two layers of the demo, a zigzag and the offset spiral, streamed as a motion queue
    // would take them: no path buffer, only their length and digest.
    let mut sink = DigestSink::new();
    let t4 = ticks();
    zigzag(&slice, plan, &mut sink).unwrap_or_else(|e| fail("zigzag", e));
    let t5 = ticks();
    hprintln!(
        "layer 0 vertices {} digest {:016x} ticks {}",
        sink.len(),
        sink.digest(),
        t5 - t4
    );
    let offset = OFFSET.take();
    let mut sink = DigestSink::new();
    let t6 = ticks();
    let stats = offset
        .build(&slice, plan, &mut sink)
        .unwrap_or_else(|e| fail("offset spiral", e));
    let t7 = ticks();
    hprintln!(
        "layer 1 vertices {} digest {:016x} ticks {} jumps {}",
        sink.len(),
        sink.digest(),
        t7 - t6,
        stats.jumps
    );

    // The zigzag layer again, streamed into the motion controller and stepped against
    // counting pins (its first `motion_bench::MOVES` moves).
    let cfg = motion_bench::printer();
    let z = cfg.layer_height;
    let machine =
        MACHINE.init(hollowpath::motion::Machine::new(cfg).unwrap_or_else(|e| fail("printer", e)));
    let mut board = link_board::LinkBoard::new();
    let mut feed = motion_bench::Feed::new(machine, &mut board, z, ticks);
    feed.home();
    let homed = feed.figures;
    let result = zigzag(&slice, plan, &mut feed);
    feed.drain();
    if let Some(why) = feed.refused {
        fail("motion", why);
    }
    result.unwrap_or_else(|e| fail("zigzag (motion)", e));
    if !link_board::valves_shut() {
        fail("motion", "a valve is open after the layer");
    }
    let f = feed.figures;
    let segments = feed.machine.stepper().stats.segments;
    let (pulses, openings) = (motion_bench::pulses(&board), motion_bench::openings());
    hprintln!(
        "motion moves {} pulses {} {} {} openings {} {} {} {} segments {} alarms {}",
        f.moves,
        pulses[0],
        pulses[1],
        pulses[2],
        openings[0],
        openings[1],
        openings[2],
        openings[3],
        segments,
        f.alarms - homed.alarms
    );
    let steps = (pulses[0] + pulses[1] + pulses[2]).max(1) as u64;
    hprintln!(
        "bench lookahead four_holes {}",
        f.push_ticks * INSNS_PER_TICK / (f.moves.max(1) as u64)
    );
    hprintln!(
        "bench step_isr four_holes {}",
        (f.alarm_ticks - homed.alarm_ticks) * INSNS_PER_TICK / steps
    );
    debug::exit(debug::EXIT_SUCCESS);
    #[allow(clippy::empty_loop)]
    loop {}
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // The valves first (semihosting may hang without a debugger).
    link_board::shut_valves();
    hprintln!("panic: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}
