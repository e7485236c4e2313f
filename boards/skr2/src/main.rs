//! hollowpath's controller firmware for the BigTreeTech SKR 2 (STM32F407VG, 168 MHz): the
//! application the QEMU link firmware runs (`hollowpath::app`), on this board's pins,
//! timer and UART, with the board capacities (`hollowpath/compact`).
//!
//! ```sh
//! cargo build --release --manifest-path boards/skr2/Cargo.toml --target thumbv7em-none-eabihf
//! ```
//!
//! The layers are the QEMU link firmware's (`firmware/src/bin/link.rs`), only the board
//! differs: the clock and both alarms are TIM5 ([`timer`]), the link is USART1 at
//! [`BAUD`] ([`uart`]), the pins are [`pins`] (their table), logs go out over RTT (defmt:
//! nothing blocks without a probe, unlike semihosting). The step interrupt (TIM5) and
//! USART1's receive interrupt (which only fills the ring) preempt the link's (PendSV, masked
//! by BASEPRI while the application holds the session): a frame the link writes never makes
//! it miss a byte; the main loop plans, builds each layer and queues its moves, and sleeps
//! (`wfi`) when idle.
//!
//! Memory (the top-level `memory.x`): the application and the step side in SRAM, the link's
//! session and receive ring in CCM (`.ccm`, copied from flash at reset by `__pre_init`), the
//! stack in CCM above a 4 KiB MPU guard (`firmware/src/stack.rs`, shared with QEMU). A panic or a
//! HardFault (a stack overflow included) shuts the valves, disables the drivers and opens
//! the power gate first ([`pins::shut_down`]), then logs and halts. The independent watchdog
//! ([`watchdog`], fed by TIM5's heartbeat while the main loop checks in:
//! `controller::main_loop_alive`) resets a core that stopped running interrupts, or whose
//! main loop stopped checking in for `controller::MAIN_LOOP_SILENCE_US`.
//!
//! The image is for the STM32F407VG of the first SKR 2 boards; later boards carry an
//! STM32F429VG, whose memory map (192 KiB SRAM, 64 KiB CCM, same bootloader offset) and
//! peripherals used here are a superset: the same image runs there, within the F407's RAM.
#![no_std]
#![no_main]

use core::sync::atomic::Ordering;

use cortex_m::peripheral::scb::SystemHandler;
use cortex_m_rt::{entry, exception};
use defmt_rtt as _;
use hollowpath::app::{App, Io, Session, Shared};
use hollowpath::link::controller::Controller;
use hollowpath::link::endpoint::LinkConfig;
use static_cell::ConstStaticCell;
use stm32f4xx_hal::pac::{self, interrupt, Interrupt, NVIC};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::serial::{self, RxListen};

use controller::{
    FwApp, FwSession, Masked, Platform, StepSide, FIRMWARE, LINK_PRIORITY, STEP_PRIORITY,
};

#[path = "../../../firmware/src/controller.rs"]
mod controller;
mod pins;
#[path = "../../../firmware/src/stack.rs"]
mod stack;
mod timer;
mod uart;
mod watchdog;

/// The link's baud rate on USART1: the host's `hollowpath print --port` line (115200 8N1).
const BAUD: u32 = 115_200;

/// The link's timers, microseconds: the host's keep-alives are real time here.
const LINK_CONFIG: LinkConfig = LinkConfig {
    retransmit_us: 200_000,
    keepalive_us: 0,
    watchdog_us: 3_000_000,
};

/// The application (planner, offset spiral, slice), in SRAM.
static APP: ConstStaticCell<FwApp> = ConstStaticCell::new(App::new());

/// The link side (controller, slice assembler, events, outbox), shared by the main loop and
/// PendSV (priority LINK_PRIORITY, the only interrupt that touches it), in CCM.
#[link_section = ".ccm"]
static LINK: Masked<FwSession, LINK_PRIORITY> =
    Masked::new(Session::new(Controller::new(LINK_CONFIG, FIRMWARE)));

/// The step side (machine, pins, the layer's queued moves), shared by the main loop and the
/// step interrupt (TIM5).
static MOTION: StepSide<pins::Skr2Board, Skr2Io> = StepSide::new(pins::board());

impl Platform for Skr2Io {
    fn kick() {
        timer::step_now();
    }
    fn link_pending() -> bool {
        uart::pending() || LINK.lock(|s| s.has_events())
    }
    fn wake_at(_now: u64, at: u64) {
        timer::wake_at(at as u32);
    }
    fn cancel_wake() {
        timer::cancel_wake();
    }
}

#[interrupt]
fn TIM5() {
    if !timer::on_interrupt() {
        return;
    }
    if let Some((wait, hz)) = MOTION.run_alarms(timer::now_us) {
        // The deadline on the microsecond counter, from the clock after the alarms ran.
        let us = (wait as u64 * 1_000_000).div_ceil(hz as u64);
        timer::step_at(timer::now_us().wrapping_add(us.min(u32::MAX as u64 / 2)) as u32);
    }
}

/// USART1's receive interrupt, at the step interrupt's priority: it only moves the byte into
/// the ring, so that nothing at the link's priority (a frame the link writes byte by byte,
/// the main loop holding the session) can hold off the next byte past the UART's one-byte
/// buffer; neither preempts the other, and each is short.
#[interrupt]
fn USART1() {
    uart::on_rx();
    cortex_m::peripheral::SCB::set_pendsv();
}

/// The link served at its own priority (PendSV at LINK_PRIORITY, the only interrupt that
/// touches the session): acks, replies, the host's messages decoded into events, while the
/// application plans for seconds.
#[exception]
fn PendSV() {
    LINK.lock(|s| s.serve(&mut Skr2Io));
}

/// The platform of the application: USART1, TIM5's clock, `wfi`.
struct Skr2Io;

impl Io for Skr2Io {
    fn now_us(&mut self) -> u64 {
        timer::now_us()
    }
    fn read(&mut self, buf: &mut [u8]) -> usize {
        uart::take(buf)
    }
    fn write(&mut self, bytes: &[u8]) {
        uart::write(bytes)
    }
    fn sleep(&mut self, until: Option<u64>) {
        controller::sleep::<Skr2Io>(until, timer::now_us);
    }
}

/// Bytes of the statics placed in CCM.
fn ccm_statics() -> usize {
    extern "C" {
        static __sccm: u32;
        static __eccm: u32;
    }
    // SAFETY: only the addresses of the linker's symbols are taken, never their contents.
    unsafe { (&__eccm as *const u32 as usize) - (&__sccm as *const u32 as usize) }
}

#[entry]
fn main() -> ! {
    // Before any interrupt is enabled (painting runs below the stack pointer).
    stack::paint();
    let (Some(mut cp), Some(dp)) = (cortex_m::Peripherals::take(), pac::Peripherals::take()) else {
        halt("peripherals taken twice");
    };
    if !stack::install_guard(&mut cp.MPU) {
        halt("stack guard: not aligned to its size");
    }
    // The SKR 2's 8 MHz crystal, 168 MHz core, APB1 42 MHz (its timers 84 MHz).
    let mut rcc = dp
        .RCC
        .freeze(Config::hse(8.MHz()).sysclk(168.MHz()).pclk1(42.MHz()));
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);
    let gpioc = dp.GPIOC.split(&mut rcc);
    let gpiod = dp.GPIOD.split(&mut rcc);
    let gpioe = dp.GPIOE.split(&mut rcc);

    // The power gate and the drivers' enables first, then the safe state `pins::shut_down`
    // defines (power gate open, drivers disabled; an output starts low: the gate is open
    // from the start).
    let _power = (
        gpioc.pc13.into_push_pull_output(),
        gpioe.pe3.into_push_pull_output(),
        gpiod.pd6.into_push_pull_output(),
        gpiod.pd1.into_push_pull_output(),
    );
    pins::shut_down();
    // Steps and directions low; endstops and the emergency stop pulled up.
    let _outputs = (
        gpioe.pe2.into_push_pull_output(),
        gpioe.pe1.into_push_pull_output(),
        gpiod.pd5.into_push_pull_output(),
        gpiod.pd4.into_push_pull_output(),
        gpioa.pa15.into_push_pull_output(),
        gpioa.pa8.into_push_pull_output(),
    );
    let _inputs = (
        gpioc.pc1.into_pull_up_input(),
        gpioc.pc3.into_pull_up_input(),
        gpioc.pc0.into_pull_up_input(),
        gpioc.pc2.into_pull_up_input(),
    );

    // The valves: 100 Hz PWM (pneumatic valves switch at 25-200 Hz) on TIM2, TIM3, TIM4, every
    // duty 0; the pins are handed to the timers, and `pins::Valve` sets the duties.
    let (_, (_, t2c2, ..)) = dp.TIM2.pwm_hz(100.Hz(), &mut rcc);
    let (_, (t3c1, ..)) = dp.TIM3.pwm_hz(100.Hz(), &mut rcc);
    let (_, (t4c1, t4c2, ..)) = dp.TIM4.pwm_hz(100.Hz(), &mut rcc);
    let mut valves = (
        t2c2.with(gpiob.pb3.into_floating_input()),
        t3c1.with(gpiob.pb4.into_floating_input()),
        t4c2.with(gpiob.pb7),
        t4c1.with(gpiob.pb6),
    );
    let full = valves.0.get_max_duty();
    if valves.1.get_max_duty() != full
        || valves.2.get_max_duty() != full
        || valves.3.get_max_duty() != full
    {
        halt("the valve timers' periods differ");
    }
    pins::FULL_DUTY.store(full, Ordering::Relaxed);
    // Every duty 0, loaded now, before any output is enabled.
    pins::shut_down();
    valves.0.enable();
    valves.1.enable();
    valves.2.enable();
    valves.3.enable();

    // The link: USART1, 8N1, its receive interrupt.
    let config = serial::Config::default().baudrate(BAUD.bps());
    let Ok(serial) = dp
        .USART1
        .serial::<u8>((gpioa.pa9, gpioa.pa10), config, &mut rcc)
    else {
        halt("USART1: baud rate out of range");
    };
    let (_tx, mut rx) = serial.split();
    rx.listen();

    timer::start(rcc.clocks.timclk1().raw());
    controller::check_in();
    watchdog::start();
    // SAFETY: the priorities are set before the interrupts are unmasked; the three handlers
    // (TIM5, USART1, PendSV) only touch state behind their locks (`LINK`, `MOTION`) or
    // atomics and timer registers.
    unsafe {
        cp.NVIC.set_priority(Interrupt::TIM5, STEP_PRIORITY);
        cp.NVIC.set_priority(Interrupt::USART1, STEP_PRIORITY);
        cp.SCB.set_priority(SystemHandler::PendSV, LINK_PRIORITY);
        NVIC::unmask(Interrupt::TIM5);
        NVIC::unmask(Interrupt::USART1);
    }
    // Every valve shut: power the drivers and MOSFETs.
    pins::power_up();

    let app = APP.take();
    let mut io = Skr2Io;
    defmt::info!(
        "hollowpath skr2 ready: app {=usize} bytes, ram static {=usize} ccm {=usize} stack room {=usize}, usart1 {=u32} baud",
        core::mem::size_of::<FwApp>(),
        stack::statics(),
        ccm_statics(),
        stack::room(),
        BAUD
    );
    let mut seen = 0u64;
    loop {
        app.poll(&LINK, &mut io, &MOTION);
        if let Some(c) = MOTION.steps_changed(&mut seen) {
            defmt::info!(
                "job: steps {=u64} {=u64} {=u64}, alarms at most {=u32} ticks late, bytes lost {=usize}, stack peak {=usize}",
                c.steps[0],
                c.steps[1],
                c.steps[2],
                controller::LATEST.load(Ordering::Relaxed),
                uart::LOST.load(Ordering::Relaxed),
                stack::highest()
            );
        }
        io.sleep(None);
    }
}

/// Shuts everything down, logs `why`, and halts with interrupts off.
fn halt(why: &str) -> ! {
    pins::shut_down();
    defmt::error!("halted: {=str}", why);
    stop()
}

/// Halts with interrupts off, the watchdog fed (a stopped board stays stopped, its log
/// readable, rather than rebooting into one ready to move).
fn stop() -> ! {
    cortex_m::interrupt::disable();
    loop {
        watchdog::feed();
        // At least 25 ms at 168 MHz, a few times that with flash wait states: well inside
        // the watchdog's timeout.
        cortex_m::asm::delay(4_200_000);
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    pins::shut_down();
    match info.location() {
        Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("panic"),
    }
    stop()
}

/// The HardFault handler, entered on a fresh stack by `stack.rs`'s entry: the valves shut
/// and the drivers off first, then what happened.
extern "C" fn on_hard_fault(sp: u32, pc: u32) -> ! {
    pins::shut_down();
    match stack::guard_fault(sp) {
        Some(at) => defmt::error!(
            "stack overflow: the stack ran past its {=usize} bytes into the guard at {=usize:#x}",
            stack::room(),
            at
        ),
        None => defmt::error!("hard fault at {=u32:#x} (sp {=u32:#x})", pc, sp),
    }
    stop()
}

// Before RAM is initialised (cortex-m-rt's `__pre_init`, called from `Reset`): copies the
// `.ccm` statics' initial values from flash (`__siccm`) to the CCM (`__sccm..__eccm`), as
// cortex-m-rt does for `.data` in SRAM. Assembly: no Rust may run before RAM is initialised.
core::arch::global_asm!(
    ".section .text.__pre_init, \"ax\"",
    ".global __pre_init",
    ".type __pre_init, %function",
    ".thumb_func",
    "__pre_init:",
    "  ldr r0, =__sccm",
    "  ldr r1, =__eccm",
    "  ldr r2, =__siccm",
    "1:",
    "  cmp r0, r1",
    "  bhs 2f",
    "  ldr r3, [r2], #4",
    "  str r3, [r0], #4",
    "  b 1b",
    "2:",
    "  bx lr",
);
