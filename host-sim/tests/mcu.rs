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
    let elf = qemu::firmware(None);
    let mut q = Qemu::start(&elf, Serial::Default, Clock::Instructions);
    let status = q
        .wait_exit(Duration::from_secs(600))
        .unwrap_or_else(|| panic!("the firmware did not finish within 600 s"));
    let (out, err) = (q.stdout(), q.stderr());
    println!("{out}");
    assert!(status.success(), "firmware failed:\n{out}\n{err}");
    // Every reference slice: the plan and both layers, streamed on the MCU, match the host's
    // vertex for vertex, and each phase's instruction count is reported.
    for (name, text) in host_sim::REFERENCE_SLICES {
        let slice = host_sim::slice_file::parse(text).unwrap().slice;
        let planner = host_sim::plan(&slice).unwrap();
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
        hollowpath::toolpath::zigzag::zigzag(&slice, plan, &mut zigzag).unwrap();
        let mut offset = hollowpath::toolpath::DigestSink::new();
        let mut work = Box::new(hollowpath::toolpath::offset::OffsetSpiral::new());
        work.build(&slice, plan, &mut offset).unwrap();
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
    // The RAM figures: statics and the painted stack's peak, with paint left between them (the
    // firmware fails if none is: a stack that reached the statics).
    let ram = out
        .lines()
        .find_map(|l| l.strip_prefix("ram static "))
        .unwrap_or_else(|| panic!("no ram line in:\n{out}"));
    let f: Vec<usize> = ram
        .split(" stack ")
        .map(|n| n.trim().parse().unwrap())
        .collect();
    assert!(f[0] > 0 && f[1] > 0, "{ram}");
    assert!(
        f[0] + f[1] < 1024 * 1024,
        "RAM over the 1 MiB the bench firmware links in: {ram}"
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
