//! The firmware plans the built-in slice in QEMU's Cortex-M4F (mps2-an386) and must get the
//! bit-identical plan the host gets.
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
    assert!(out.contains("verify ok"), "{out}");
    let digest = out
        .lines()
        .find_map(|l| l.strip_prefix("digest "))
        .unwrap_or_else(|| panic!("no digest in:\n{out}"));

    let slice = host_sim::slice_file::parse(host_sim::DEFAULT_SLICE)
        .unwrap()
        .slice;
    let planner = host_sim::plan(&slice).unwrap();
    assert_eq!(
        digest.trim(),
        format!("{:016x}", planner.last_plan().digest())
    );
    // The layers, streamed on the MCU, match the host's vertex for vertex.
    let plan = planner.last_plan();
    let mut zigzag = hollowpath::toolpath::DigestSink::new();
    hollowpath::toolpath::zigzag::zigzag(&slice, plan, &mut zigzag).unwrap();
    let mut offset = hollowpath::toolpath::DigestSink::new();
    let mut work = Box::new(hollowpath::toolpath::offset::OffsetSpiral::new());
    work.build(&slice, plan, &mut offset).unwrap();
    for (k, sink) in [zigzag, offset].iter().enumerate() {
        let line = out
            .lines()
            .find_map(|l| l.strip_prefix(&format!("layer {k} ")))
            .unwrap_or_else(|| panic!("no layer {k} in:\n{out}"));
        let expect = format!("vertices {} digest {:016x} ", sink.len(), sink.digest());
        assert!(
            line.starts_with(&expect),
            "layer {k}: {line}, host {expect}"
        );
    }
    let mcls = out.lines().find_map(|l| l.strip_prefix("mcls ")).unwrap();
    assert!(
        mcls.starts_with(&format!("{} ", planner.last_plan().mcls.len())),
        "{mcls}"
    );

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
