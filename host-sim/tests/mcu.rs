//! The firmware plans the four reference slices in QEMU's Cortex-M4F (mps2-an386) and must get
//! the bit-identical plans and layers the host gets.
//!
//! Needs `qemu-system-arm` (CI installs it) and the `thumbv7em-none-eabihf` target (from
//! `rust-toolchain.toml`). Without QEMU the test is skipped locally but fails under CI.

mod common;

use std::time::Duration;

use common::qemu::{self, Clock, Qemu, Serial};

#[test]
fn firmware_plan_and_layers_are_bit_identical_to_the_host_ones() {
    if !qemu::available("MCU comparison") {
        return;
    }
    let _one = qemu::lock();
    let out = bench_output(&qemu::firmware(None), "the firmware");
    // The FPU's square root, which the core computes with on the MCU, equals libm's, which
    // it computes with on the host, bit for bit (the firmware fails on the first input that
    // differs; this line says the check ran).
    assert!(
        out.lines()
            .any(|l| l.starts_with("sqrt checked ") && l.ends_with("the FPU's equal libm's")),
        "no square-root check in:\n{out}"
    );
    // Every reference slice: the plan and both layers, streamed on the MCU, match the host's
    // vertex for vertex, and each phase's instruction count is reported.
    for (name, text) in host_sim::REFERENCE_SLICES {
        let slice = host_sim::slice_file::parse(text).unwrap().slice;
        assert_host_plan_and_layers(&out, name, &slice);
        for phase in [
            "validate",
            "plan",
            "verify",
            "zigzag",
            "offset_spiral",
            "offset_spiral_prepared",
        ] {
            let line = format!("bench {phase} {name} ");
            let n: u64 = out
                .lines()
                .find_map(|l| l.strip_prefix(&line))
                .and_then(|n| n.trim().parse().ok())
                .unwrap_or_else(|| panic!("no `{line}N` in:\n{out}"));
            assert!(n > 0, "{line}{n}");
        }
    }
    // The RAM figures: statics and the painted stack's peak (a stack that ran out would have
    // faulted in the guard below it: `a_stack_overflow_is_caught_by_the_guard_and_reported`).
    let ram = out
        .lines()
        .find_map(|l| l.strip_prefix("ram static "))
        .unwrap_or_else(|| panic!("no ram line in:\n{out}"));
    let f: Vec<usize> = ram
        .split(" stack ")
        .map(|n| n.trim().parse().unwrap())
        .collect();
    assert!(f[0] > 0 && f[1] > 0, "{ram}");
    // Within `firmware/memory.x`: 64 KiB of stack, and the statics in the rest of 640 KiB (the
    // link fails if they do not fit).
    assert!(f[1] < 64 * 1024, "stack peak over the 64 KiB stack: {ram}");
    assert!(
        f[0] + 64 * 1024 <= 640 * 1024,
        "statics over the part's RAM: {ram}"
    );

    let slice = host_sim::slice_file::parse(host_sim::DEFAULT_SLICE)
        .unwrap()
        .slice;
    let planner = host_sim::plan(&slice).unwrap();
    let plan = planner.last_plan();

    // The motion code on the MCU steps the zigzag's first moves exactly as the host's virtual
    // printer does: the same pulses per axis and valve openings per channel.
    let motion = out
        .lines()
        .find_map(|l| l.strip_prefix("motion "))
        .unwrap_or_else(|| panic!("no motion line in:\n{out}"));
    let mut cfg = hollowpath::motion::PrinterConfig::default();
    for a in &mut cfg.axes {
        a.endstop = None;
    }
    // Layer 0 is the zigzag.
    let layer = host_sim::layers::layer(&slice, plan, host_sim::layers::Fill::Offset, 0).unwrap();
    let mut moves = host_sim::simulate::machine_moves(&cfg, &layer);
    let count: usize = motion
        .split_whitespace()
        .nth(1)
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{motion}"));
    moves.truncate(count);
    let trace = host_sim::virtual_printer::run_layer(&cfg, &moves, cfg.layer_height).unwrap();
    let mut pulses = [0u64; 3];
    for e in &trace.edges {
        if let (host_sim::virtual_printer::Pin::Step(a), true) = (e.pin, e.high) {
            pulses[a as usize] += 1;
        }
    }
    let mut openings = [0u64; 4];
    let mut duty = [0.0f32; 4];
    for d in &trace.duties {
        let c = d.channel as usize;
        if duty[c] == 0.0 && d.duty > 0.0 {
            openings[c] += 1;
        }
        duty[c] = d.duty;
    }
    let expect = format!(
        "moves {count} pulses {} {} {} openings {} {} {} {} ",
        pulses[0], pulses[1], pulses[2], openings[0], openings[1], openings[2], openings[3]
    );
    assert!(motion.starts_with(&expect), "MCU: {motion}\nhost: {expect}");
    for what in ["lookahead", "step_isr"] {
        let line = format!("bench {what} four_holes ");
        assert!(
            out.lines().any(|l| l.starts_with(&line)),
            "no {line} in:\n{out}"
        );
    }
}

/// The firmware's output `out` has the host's plan of `slice` (its `slice NAME ...` line) and
/// both its layers (`layer NAME K vertices N digest D`), streamed on the MCU vertex for vertex.
fn assert_host_plan_and_layers(out: &str, name: &str, slice: &hollowpath::Slice) {
    let planner = host_sim::plan(slice).unwrap();
    let plan = planner.last_plan();
    let expect = format!(
        "slice {name} mcls {} bisectors {} branch_points {} digest {:016x}",
        plan.mcls.len(),
        plan.bisectors().len(),
        plan.cells.branch_points.len(),
        plan.digest()
    );
    assert!(out.lines().any(|l| l == expect), "no `{expect}` in:\n{out}");
    let mut zigzag = hollowpath::toolpath::DigestSink::new();
    hollowpath::toolpath::zigzag::zigzag(slice, plan, &mut zigzag).unwrap();
    let mut offset = hollowpath::toolpath::DigestSink::new();
    let mut work = Box::new(hollowpath::toolpath::offset::OffsetSpiral::new());
    let mut grid = Box::new(hollowpath::field::GridMemory::new());
    work.build(slice, plan, &mut grid, &mut offset).unwrap();
    for (k, sink) in [zigzag, offset].iter().enumerate() {
        let expect = format!(
            "layer {name} {k} vertices {} digest {:016x}",
            sink.len(),
            sink.digest()
        );
        assert!(
            out.lines().any(|l| l.starts_with(&expect)),
            "no `{expect}` in:\n{out}"
        );
    }
}

/// The SKR 2's flash after its 32 KiB SD-card bootloader (the top-level `memory.x`).
const BOARD_FLASH: usize = 992 * 1024;
/// The most initial values a firmware may store in flash and copy to RAM at boot (`.data`):
/// the working memory (planner, offset spiral, application, 500 KiB) must start zeroed
/// (`.bss`), or the image carries all of it. A `const fn new()` with one non-zero field (a
/// pointer, an `Option` whose `None` is a niche value) moved all of it into `.data` twice.
const MAX_DATA: usize = 64 * 1024;

/// The sections a linker placed in an ELF32 file: (name, type, flags, size).
fn elf_sections(elf: &[u8]) -> Vec<(String, u32, u32, usize)> {
    let u16_at = |o: usize| u16::from_le_bytes([elf[o], elf[o + 1]]) as usize;
    let u32_at = |o: usize| u32::from_le_bytes(elf[o..o + 4].try_into().unwrap());
    assert_eq!(&elf[..5], b"\x7fELF\x01", "not an ELF32 file");
    let (shoff, shentsize, shnum, shstrndx) = (
        u32_at(0x20) as usize,
        u16_at(0x2E),
        u16_at(0x30),
        u16_at(0x32),
    );
    let header = |k: usize| shoff + k * shentsize;
    let strings = u32_at(header(shstrndx) + 16) as usize;
    (0..shnum)
        .map(|k| {
            let h = header(k);
            let name_at = strings + u32_at(h) as usize;
            let end = name_at + elf[name_at..].iter().position(|&b| b == 0).unwrap();
            let name = String::from_utf8_lossy(&elf[name_at..end]).into_owned();
            (name, u32_at(h + 4), u32_at(h + 8), u32_at(h + 20) as usize)
        })
        .collect()
}

/// The names of every symbol in an ELF32 file's `.symtab` (local ones too: after LTO a
/// library routine such as `fminf` may stay only as a local symbol), read through the string
/// table the symbol table's header links to.
fn elf_symbols(elf: &[u8]) -> Vec<String> {
    let u16_at = |o: usize| u16::from_le_bytes([elf[o], elf[o + 1]]) as usize;
    let u32_at = |o: usize| u32::from_le_bytes(elf[o..o + 4].try_into().unwrap()) as usize;
    const SHT_SYMTAB: usize = 2;
    let (shoff, shentsize, shnum) = (u32_at(0x20), u16_at(0x2E), u16_at(0x30));
    let header = |k: usize| shoff + k * shentsize;
    let Some(symtab) = (0..shnum)
        .map(header)
        .find(|&h| u32_at(h + 4) == SHT_SYMTAB)
    else {
        return Vec::new();
    };
    let (at, size, link) = (
        u32_at(symtab + 16),
        u32_at(symtab + 20),
        u32_at(symtab + 24),
    );
    let strings = u32_at(header(link) + 16);
    (at..at + size)
        .step_by(16)
        .map(|e| {
            let name_at = strings + u32_at(e);
            let end = name_at + elf[name_at..].iter().position(|&b| b == 0).unwrap();
            String::from_utf8_lossy(&elf[name_at..end]).into_owned()
        })
        .collect()
}

/// The Cortex-M4F's FPU has no `VMINNM`/`VMAXNM`: `f32::min` and `f32::max` are calls to
/// `fminf` and `fmaxf`, a dozen instructions each, and box tests make millions of them (they
/// were 15-60 % of the phases' instructions). The core uses `geometry::primitives::{fmin,
/// fmax}` (the same answers, inline comparisons); with LTO an image that calls neither
/// routine does not link them, which this checks for both firmwares.
#[test]
fn the_firmware_calls_no_min_or_max_routine() {
    if !qemu::available("firmware symbols") {
        return;
    }
    for bin in [None, Some("link")] {
        let elf = std::fs::read(qemu::firmware(bin)).unwrap();
        let symbols = elf_symbols(&elf);
        let name = bin.unwrap_or("hollowpath-qemu");
        assert!(
            symbols.iter().any(|s| s == "main"),
            "{name}: no symbols read ({} entries)",
            symbols.len()
        );
        for routine in ["fminf", "fmaxf"] {
            assert!(
                !symbols.iter().any(|s| s == routine),
                "{name} links {routine}: an f32::min or f32::max in the core (use \
                 geometry::primitives::{{fmin, fmax}} or the MinMax methods)"
            );
        }
    }
}

#[test]
fn firmware_images_fit_the_boards_flash_and_keep_working_memory_out_of_it() {
    if !qemu::available("firmware sizes") {
        return;
    }
    const SHF_ALLOC: u32 = 2;
    const SHT_NOBITS: u32 = 8;
    for bin in [None, Some("link")] {
        let elf = std::fs::read(qemu::firmware(bin)).unwrap();
        let sections = elf_sections(&elf);
        let size = |name: &str| sections.iter().find(|s| s.0 == name).map_or(0, |s| s.3);
        // What goes into flash: every allocated section with contents (`.data`'s initial
        // values included); `.bss` is only zeroed RAM.
        let flash: usize = sections
            .iter()
            .filter(|s| s.2 & SHF_ALLOC != 0 && s.1 != SHT_NOBITS)
            .map(|s| s.3)
            .sum();
        let name = bin.unwrap_or("hollowpath-qemu");
        println!(
            "{name}: flash {flash} (text {}, rodata {}, data {}), bss {}",
            size(".text"),
            size(".rodata"),
            size(".data"),
            size(".bss")
        );
        assert!(size(".text") > 0, "{name}: no .text in {sections:?}");
        assert!(
            size(".data") <= MAX_DATA,
            "{name}: {} bytes of .data: a large static's initial value is not all zeros",
            size(".data")
        );
        assert!(
            flash <= BOARD_FLASH,
            "{name}: a {flash}-byte image does not fit the SKR 2's {BOARD_FLASH} bytes of flash"
        );
    }
}

/// A stack that overflows is caught at once: the MPU guard below the stack (the stack is at the
/// bottom of RAM, the statics above it: `firmware/memory.x`, `firmware/src/stack.rs`) faults
/// on the first word written into it, and the HardFault handler, entered on a fresh stack,
/// closes the valves and says so; QEMU exits with failure, and the static above the stack
/// kept its value. The `stack_guard` firmware recurses until that happens.
#[test]
fn a_stack_overflow_is_caught_by_the_guard_and_reported() {
    let Some(out) = failing_firmware("stack_guard", "the overflow") else {
        return;
    };
    let report = out
        .lines()
        .find(|l| l.starts_with("stack overflow: the stack ran past its "))
        .unwrap_or_else(|| panic!("no overflow report in:\n{out}"));
    // The fault is in the guard, below the stack's bottom (QEMU's RAM starts at 0x2000_0000).
    let at = u32::from_str_radix(report.rsplit("0x").next().unwrap(), 16).unwrap();
    assert!((0x1FFF_0000..0x2000_0000).contains(&at), "{report}");
    assert!(
        out.contains("sentinel 0x5afe5afe"),
        "a static was overwritten:\n{out}"
    );
}

/// Any other fault takes the same path: the `fault_drill` firmware opens a valve and executes
/// an undefined instruction; the HardFault handler shuts the valve first and reports the
/// faulting instruction's address, read from the exception frame (`firmware/src/fault.rs`,
/// `stack.rs`), and QEMU exits with failure.
#[test]
fn a_fault_shuts_the_valves_and_names_the_faulting_instruction() {
    let Some(out) = failing_firmware("fault_drill", "the fault") else {
        return;
    };
    let hex = |line: &str, after: &str| {
        let rest = line.split(after).nth(1).unwrap_or_else(|| panic!("{line}"));
        let digits: String = rest.chars().take_while(|c| c.is_ascii_hexdigit()).collect();
        u32::from_str_radix(&digits, 16).unwrap()
    };
    let find = |prefix: &str| {
        out.lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("no `{prefix}` in:\n{out}"))
            .to_string()
    };
    let opened = find("valve 0 open: ");
    assert!(opened.contains("valves shut false"), "{opened}");
    let drill = hex(&opened, "drill at 0x");
    let fault = find("hard fault at 0x");
    let pc = hex(&fault, "hard fault at 0x");
    // The faulting instruction is the drill's `udf`, after at most its prologue.
    assert!(
        (drill..drill + 16).contains(&pc),
        "{fault} (drill at {drill:#x})"
    );
    assert_eq!(
        find("after the fault: "),
        "after the fault: valves shut true"
    );
}

/// A main loop that hangs is caught: the firmwares feed their watchdog from a heartbeat only
/// while the main loop checked in lately (`firmware/src/controller.rs`, `check_in`,
/// `main_loop_alive`). The `watchdog_drill` firmware opens a valve and spins in its main
/// loop without checking in: the heartbeat stops feeding QEMU's CMSDK watchdog, whose
/// interrupt (the NMI) shuts the valve, and whose second expiry resets the machine; the
/// firmware boots again, finds the mark it left in `.uninit`, and exits with success.
#[test]
fn a_hung_main_loop_leaves_the_watchdog_unfed_which_shuts_the_valves_and_resets() {
    let Some((status, out)) = drill("watchdog_drill", "the hung main loop") else {
        return;
    };
    assert!(status.success(), "no reset, or not the drill's:\n{out}");
    let lines: Vec<&str> = out.lines().collect();
    let at = |prefix: &str| {
        lines
            .iter()
            .position(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("no `{prefix}` in:\n{out}"))
    };
    let (opened, silent, caught, again) = (
        at("valve 0 open: valves shut false"),
        at("heartbeat at "),
        at("watchdog interrupt: valves shut true"),
        at("booted again after the watchdog's reset"),
    );
    assert!(
        opened < silent && silent < caught && caught < again,
        "{out}"
    );
    // The heartbeat went on feeding while the main loop's last check-in was recent: the
    // first heartbeats (0.17 s apart) fed it, one within 0.6 s found the loop silent.
    let us: u64 = lines[silent]
        .trim_start_matches("heartbeat at ")
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{}", lines[silent]));
    assert!((300_000..600_000).contains(&us), "{}", lines[silent]);
}

/// Runs the firmware `bin`, which provokes `what` on purpose, to its end: it must end QEMU with
/// failure (the fault handler's exit) within two minutes; its semihosting output, or `None`
/// where QEMU is not installed.
fn failing_firmware(bin: &str, what: &str) -> Option<String> {
    let (status, out) = drill(bin, what)?;
    assert!(!status.success(), "{what} ended in success:\n{out}");
    Some(out)
}

/// Runs the drill firmware `bin` (which provokes `what`) to its end within two minutes: its
/// exit status and semihosting output, or `None` where QEMU is not installed.
fn drill(bin: &str, what: &str) -> Option<(std::process::ExitStatus, String)> {
    if !qemu::available(what) {
        return None;
    }
    let _one = qemu::lock();
    let elf = qemu::firmware(Some(bin));
    let mut q = Qemu::start(&elf, Serial::Default, Clock::Instructions);
    let status = q
        .wait_exit(Duration::from_secs(120))
        .unwrap_or_else(|| panic!("{what} went unnoticed (QEMU still runs):\n{}", q.stdout()));
    let out = q.stdout();
    println!("{out}");
    Some((status, out))
}

/// Runs the bench firmware `elf` (`what`, for messages) to its end under QEMU, counting
/// instructions: its semihosting output, which it must end in success.
fn bench_output(elf: &std::path::Path, what: &str) -> String {
    let mut q = Qemu::start(elf, Serial::Default, Clock::Instructions);
    let status = q
        .wait_exit(Duration::from_secs(600))
        .unwrap_or_else(|| panic!("{what} did not finish within 600 s"));
    let (out, err) = (q.stdout(), q.stderr());
    println!("{out}");
    assert!(status.success(), "{what} failed:\n{out}\n{err}");
    out
}

/// The board capacities (`hollowpath/compact`, the SKR 2 image's) run the same application
/// code under QEMU: the four reference slices at 2.5 times their road width (1.0 mm, the
/// shapes of slices 0.4 of their size at 0.4 mm) plan and lay bit-identically to the host,
/// and the painted stack's peak fits the SKR 2's stack region (`memory.x`), which QEMU
/// cannot run.
#[test]
fn the_board_capacities_plan_like_the_host_within_the_skr2_stack() {
    if !qemu::available("board capacities") {
        return;
    }
    let _one = qemu::lock();
    let out = bench_output(&qemu::compact_firmware(None), "the compact firmware");
    for (name, text) in host_sim::REFERENCE_SLICES {
        let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
        let w = json["settings"]["road_width"].as_f64().unwrap();
        json["settings"]["road_width"] = (w * 2.5).into();
        let slice = host_sim::slice_file::parse(&json.to_string())
            .unwrap()
            .slice;
        assert_host_plan_and_layers(&out, name, &slice);
    }
    let ram = out
        .lines()
        .find_map(|l| l.strip_prefix("ram static "))
        .unwrap_or_else(|| panic!("no ram line in:\n{out}"));
    let peak: usize = ram.split(" stack ").nth(1).unwrap().trim().parse().unwrap();
    let room = qemu::board_region("STACK");
    println!("compact: stack peak {peak} of the SKR 2's {room}");
    assert!(
        peak > 0 && peak <= room,
        "the board capacities' stack peak {peak} is over the SKR 2's stack region {room}"
    );
}

/// The SKR 2 image (`boards/skr2`, its own workspace) builds and fits the STM32F407: its
/// statics in the 128 KiB of SRAM, its `.ccm` statics, stack and guard in the 64 KiB of CCM,
/// the image in the flash after the bootloader (the linker fails if a region overflows; this
/// reads the figures from the ELF and says them).
#[test]
fn the_skr2_image_fits_the_stm32f407() {
    let elf = std::fs::read(qemu::skr2_image()).unwrap();
    const SHF_ALLOC: u32 = 2;
    const SHT_NOBITS: u32 = 8;
    let sections = elf_sections(&elf);
    let size = |name: &str| sections.iter().find(|s| s.0 == name).map_or(0, |s| s.3);
    let flash: usize = sections
        .iter()
        .filter(|s| s.2 & SHF_ALLOC != 0 && s.1 != SHT_NOBITS && s.0 != ".defmt")
        .map(|s| s.3)
        .sum();
    let sram = size(".data") + size(".bss") + size(".uninit");
    let ccm = size(".ccm");
    let (stack, guard) = (qemu::board_region("STACK"), qemu::board_region("GUARD"));
    println!(
        "skr2: flash {flash} of {}, sram {sram} of {} (data {}, bss {}, uninit {}), ccm {} \
         of {}: statics {ccm}, stack {stack}, guard {guard}; RAM in all {} of {}",
        qemu::board_region("FLASH"),
        qemu::board_region("RAM"),
        size(".data"),
        size(".bss"),
        size(".uninit"),
        ccm + stack + guard,
        64 * 1024,
        sram + ccm + stack + guard,
        192 * 1024
    );
    assert!(size(".text") > 0 && size(".bss") > 0, "{sections:?}");
    assert!(flash <= qemu::board_region("FLASH"), "flash {flash}");
    assert!(sram <= qemu::board_region("RAM"), "sram {sram}");
    assert!(ccm <= qemu::board_region("CCMRAM"), "ccm {ccm}");
    assert!(sram + ccm + stack + guard <= 192 * 1024);
    // The QEMU firmwares with the board capacities link in the same budget
    // (`firmware/memory-compact.x`): the board's stack, and its SRAM and CCM statics together.
    let compact = "firmware/memory-compact.x";
    assert_eq!(
        qemu::region_in(compact, "STACK"),
        stack,
        "{compact}'s stack"
    );
    assert_eq!(
        qemu::region_in(compact, "RAM"),
        qemu::board_region("RAM") + qemu::board_region("CCMRAM"),
        "{compact}'s statics: the board's SRAM and CCM statics"
    );

    // What the bootloader and a probe see: no loadable byte below the image's start (a probe
    // flashing the ELF would write into the bootloader's sector), and a vector table at the
    // start whose initial stack pointer is the top of the stack region and whose reset
    // vector is a Thumb address in the image.
    let u16_at = |o: usize| u16::from_le_bytes([elf[o], elf[o + 1]]) as usize;
    let u32_at = |o: usize| u32::from_le_bytes(elf[o..o + 4].try_into().unwrap()) as usize;
    let flash_start = qemu::board_origin("FLASH");
    let (phoff, phentsize, phnum) = (u32_at(0x1C), u16_at(0x2A), u16_at(0x2C));
    let mut vectors = None;
    for k in 0..phnum {
        let h = phoff + k * phentsize;
        let (kind, offset, paddr, filesz) =
            (u32_at(h), u32_at(h + 4), u32_at(h + 12), u32_at(h + 16));
        if kind != 1 || filesz == 0 {
            continue;
        }
        assert!(
            paddr >= flash_start,
            "a loadable segment at {paddr:#x}, below the image's start {flash_start:#x}"
        );
        if paddr == flash_start {
            vectors = Some(offset);
        }
    }
    let vectors = vectors.expect("no loadable segment at the image's start");
    let (sp, reset) = (u32_at(vectors), u32_at(vectors + 4));
    let stack_top = qemu::board_origin("STACK") + stack;
    assert_eq!(sp, stack_top, "initial stack pointer {sp:#x}");
    assert!(
        reset & 1 == 1 && (flash_start..flash_start + qemu::board_region("FLASH")).contains(&reset),
        "reset vector {reset:#x}"
    );
}
