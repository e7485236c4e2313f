//! hollowpath on QEMU's mps2-an386: plans the four built-in reference slices with the same
//! core the host runs, checks each plan, builds its zigzag and spiral layers, and prints their
//! digests and the instructions each phase took over semihosting, then steps the first moves
//! of four_holes' zigzag through the motion code, and exits QEMU with the verdict.
//!
//! The lines a script reads: `bench PHASE SLICE INSTRUCTIONS` per phase (`validate`, `plan`,
//! `verify`, `zigzag`, `offset_spiral`) and slice, `bench lookahead|step_isr four_holes N`
//! per move or step, `stack PHASE SLICE BYTES` (the stack's peak during that phase, painted
//! afresh before it, the frames of `main` and `bench_slice` included), and last `ram static
//! BYTES stack BYTES` (the statics and the painted stack's peak over the whole run). Before
//! any of it the FPU's square root is checked against libm's (`sqrt checked N inputs`). The
//! host test `host-sim/tests/mcu.rs` compares the digests with the host's: the plans must be
//! bit-identical.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use hollowpath::slice::SliceStore;
use hollowpath::toolpath::offset::OffsetSpiral;
use hollowpath::toolpath::zigzag::zigzag;
use hollowpath::toolpath::DigestSink;
use hollowpath::{Planner, Settings, Slice};
use static_cell::{ConstStaticCell, StaticCell};

mod fault;
mod link_board;
mod motion_bench;
#[allow(dead_code)]
mod mps2;
mod stack;

mod slice_data {
    use hollowpath::geometry::Point;
    /// A reference slice, as `build.rs` wrote it from its JSON file.
    pub struct RefSlice {
        pub name: &'static str,
        pub wall: (&'static [Point], [f32; 4]),
        pub holes: &'static [(&'static [Point], [f32; 4])],
        pub road_width: f32,
    }
    include!(concat!(env!("OUT_DIR"), "/slice_data.rs"));
}

/// The slice being benched, built in place, in .bss.
static SLICE: ConstStaticCell<SliceStore> = ConstStaticCell::new(SliceStore::new());

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

/// Builds reference slice `r` into `store` as the controller's link does (in place).
fn built_in_slice<'s>(r: &slice_data::RefSlice, store: &'s mut SliceStore) -> &'s Slice {
    let mut holes: hollowpath::heapless::Vec<
        (&[hollowpath::geometry::Point], hollowpath::Material),
        { hollowpath::config::MAX_HOLES },
    > = hollowpath::heapless::Vec::new();
    for &(pts, m) in r.holes.iter() {
        if holes.push((pts, m)).is_err() {
            fail("holes", "too many");
        }
    }
    store
        .build_from_contours(
            r.wall.0,
            r.wall.1,
            &holes,
            Settings::for_road_width(r.road_width),
        )
        .unwrap_or_else(|e| fail("slice", e))
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| fail("peripherals", ()));
    mps2::start_systick(&mut cp.SYST, RELOAD);

    stack::paint();
    if !stack::install_guard(&mut cp.MPU) {
        fail("stack guard", "not aligned to its size");
    }
    check_sqrt();
    let store = SLICE.take();
    let planner = PLANNER.take();
    let offset = OFFSET.take();
    for (k, r) in slice_data::SLICES.iter().enumerate() {
        bench_slice(r, store, planner, offset);
        if k == 0 {
            // four_holes: it is still the store's slice and its plan the planner's.
            stack::paint();
            bench_motion(r, store, planner);
            hprintln!("stack motion {} {}", r.name, stack::peak());
        }
    }
    let (statics, peak) = (stack::statics(), stack::highest());
    // A stack that ran out faulted in the guard below it (`stack.rs`): no check needed here.
    hprintln!("ram static {} stack {}", statics, peak);
    debug::exit(debug::EXIT_SUCCESS);
    #[allow(clippy::empty_loop)]
    loop {}
}

/// The FPU's square root (`hollowpath_fpu::sqrtf`, which the core computes with) against
/// libm's software one that the host's plans are checked against: the same bits on two
/// million inputs spread over every exponent (NaN for NaN), or the bench fails.
fn check_sqrt() {
    let mut bits = 0u32;
    let mut checked = 0u32;
    loop {
        let x = f32::from_bits(bits);
        let (a, b) = (hollowpath_fpu::sqrtf(x), libm::sqrtf(x));
        if a.to_bits() != b.to_bits() && !(a.is_nan() && b.is_nan()) {
            hprintln!("sqrt {:e}: fpu {:e}, libm {:e}", x, a, b);
            fail("sqrt", "the FPU's square root differs from libm's");
        }
        checked += 1;
        match bits.checked_add(2_111) {
            Some(next) => bits = next,
            None => break,
        }
    }
    hprintln!("sqrt checked {} inputs: the FPU's equal libm's", checked);
}

/// Streams the zigzag of `r`, the slice the planner planned last, into the motion controller
/// and steps it against counting pins (its first `motion_bench::MOVES` moves).
#[inline(never)]
fn bench_motion(r: &slice_data::RefSlice, store: &SliceStore, planner: &Planner) {
    let Some(slice) = store.get() else {
        fail("motion", r.name)
    };
    let plan = planner.last_plan();
    // The zigzag layer again, streamed into the motion controller and stepped against
    // counting pins (its first `motion_bench::MOVES` moves).
    let cfg = motion_bench::printer();
    let z = cfg.layer_height;
    let machine =
        MACHINE.init(hollowpath::motion::Machine::new(cfg).unwrap_or_else(|e| fail("printer", e)));
    let mut board = link_board::new();
    let mut feed = motion_bench::Feed::new(machine, &mut board, z, ticks);
    feed.home();
    let homed = feed.figures;
    let result = zigzag(slice, plan, &mut feed);
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
}

/// Validates, plans and verifies reference slice `r`, builds its two layers into digest
/// sinks (as a motion queue would take them: no path buffer), and prints the figures.
#[inline(never)]
fn bench_slice(
    r: &slice_data::RefSlice,
    store: &mut SliceStore,
    planner: &mut Planner,
    offset: &mut OffsetSpiral,
) {
    let name = r.name;
    // Each phase: the stack painted before it, its instructions and stack peak after.
    let start = || {
        stack::paint();
        ticks()
    };
    let done = |t: u64| ((ticks() - t) * INSNS_PER_TICK, stack::peak());
    let t = start();
    let slice = built_in_slice(r, store);
    let validate = done(t);
    let t = start();
    let plan = planner.plan(slice).unwrap_or_else(|e| fail("plan", e));
    let planned = done(t);
    let t = start();
    let verdict = hollowpath::verify::verify(slice, plan);
    let verified = done(t);
    hprintln!(
        "slice {} mcls {} bisectors {} branch_points {} digest {:016x}",
        name,
        plan.mcls.len(),
        plan.bisectors().len(),
        plan.cells.branch_points.len(),
        plan.digest()
    );
    if let Err(v) = verdict {
        fail("verify", v);
    }
    let mut sink = DigestSink::new();
    let t = start();
    zigzag(slice, plan, &mut sink).unwrap_or_else(|e| fail("zigzag", e));
    let zigzagged = done(t);
    hprintln!(
        "layer {} 0 vertices {} digest {:016x}",
        name,
        sink.len(),
        sink.digest()
    );
    // The plan's field is done with: its node memory becomes the spiral's distance grid.
    let (plan, grid) = planner.plan_and_grid();
    let mut sink = DigestSink::new();
    let t = start();
    let stats = offset
        .build(slice, plan, grid, &mut sink)
        .unwrap_or_else(|e| fail("offset spiral", e));
    let spiralled = done(t);
    hprintln!(
        "layer {} 1 vertices {} digest {:016x} jumps {}",
        name,
        sink.len(),
        sink.digest(),
        stats.jumps
    );
    // The next spiral layer of the job: its loops and joins are prepared already, so only
    // the walk runs (and it must lay the same path).
    let first = (sink.len(), sink.digest());
    let mut sink = DigestSink::new();
    let t = start();
    offset
        .build(slice, plan, grid, &mut sink)
        .unwrap_or_else(|e| fail("offset spiral, prepared", e));
    let prepared = done(t);
    if (sink.len(), sink.digest()) != first {
        fail(
            "offset spiral, prepared",
            "another path than the first build's",
        );
    }
    for (phase, (insns, stack)) in [
        ("validate", validate),
        ("plan", planned),
        ("verify", verified),
        ("zigzag", zigzagged),
        ("offset_spiral", spiralled),
        ("offset_spiral_prepared", prepared),
    ] {
        hprintln!("bench {} {} {}", phase, name, insns);
        hprintln!("stack {} {} {}", phase, name, stack);
    }
}

/// The HardFault handler, entered on a fresh stack by `stack.rs`'s entry (`sp` and `pc` the
/// faulting ones): the valves first, then what happened (a stack overflow or the faulting
/// address), and QEMU exits with failure.
extern "C" fn on_hard_fault(sp: u32, pc: u32) -> ! {
    fault::halt(sp, pc, || {})
}
