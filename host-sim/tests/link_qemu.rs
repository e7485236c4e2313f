//! End to end: the link firmware (`firmware/src/bin/link.rs`) in QEMU's mps2-an386 with
//! UART0 on a TCP socket, the real `hollowpath print` at the other end. The report's
//! telemetry (plan digest, per layer steps, valve openings and open ticks, print ticks)
//! must equal `hollowpath simulate`'s for the same slice, printer and layers, key by key.
//!
//! Needs `qemu-system-arm` (CI installs it) and the `thumbv7em-none-eabihf` target. Without
//! QEMU the test is skipped locally but fails under CI.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Instant;

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn qemu_available() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Kills QEMU however the test ends.
struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn build_firmware() -> PathBuf {
    let ws = workspace();
    let target_dir = ws.join("target/firmware");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let build = Command::new(cargo)
        .current_dir(&ws)
        .args([
            "build",
            "-p",
            "hollowpath-qemu",
            "--bin",
            "link",
            "--release",
            "--target",
            "thumbv7em-none-eabihf",
            "--target-dir",
        ])
        .arg(&target_dir)
        .env_remove("RUSTFLAGS")
        .output()
        .unwrap();
    assert!(
        build.status.success(),
        "firmware build failed:\n{}",
        String::from_utf8_lossy(&build.stderr)
    );
    target_dir.join("thumbv7em-none-eabihf/release/link")
}

/// QEMU with UART0 on a TCP server at `port`, once it listens.
fn start_qemu(elf: &std::path::Path, port: u16) -> Qemu {
    let mut child = Command::new("qemu-system-arm")
        .args([
            "-machine",
            "mps2-an386",
            "-cpu",
            "cortex-m4",
            "-nographic",
            "-monitor",
            "none",
            "-semihosting-config",
            "enable=on,target=native",
            "-icount",
            "shift=0,sleep=off",
            "-serial",
        ])
        .arg(format!("tcp:127.0.0.1:{port},server=on,wait=on"))
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    loop {
        line.clear();
        let n = err.read_line(&mut line).unwrap();
        assert!(n > 0, "QEMU exited before listening");
        if line.contains("waiting for connection") {
            break;
        }
    }
    // Keep draining stderr so QEMU never blocks on it.
    std::thread::spawn(move || {
        let mut sink = String::new();
        while err.read_line(&mut sink).is_ok_and(|n| n > 0) {
            sink.clear();
        }
    });
    Qemu(child)
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

#[test]
fn printing_on_the_firmware_reports_the_telemetry_simulate_computes() {
    if !qemu_available() {
        assert!(
            std::env::var_os("CI").is_none(),
            "qemu-system-arm is missing under CI"
        );
        eprintln!("note: qemu-system-arm not found; link firmware test skipped");
        return;
    }
    let elf = build_firmware();
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data");
    let slice = data.join("four_holes.json");
    let printer = data.join("ci_printer.json");
    let out = std::env::temp_dir().join(format!("hollowpath-link-qemu-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let layers = "2";

    let port = free_port();
    let qemu = start_qemu(&elf, port);
    let t0 = Instant::now();
    let report = out.join("report.json");
    let print = Command::new(env!("CARGO_BIN_EXE_hollowpath"))
        .arg("print")
        .arg(&slice)
        .arg("--tcp")
        .arg(format!("127.0.0.1:{port}"))
        .arg("--printer")
        .arg(&printer)
        .args(["--layers", layers, "--report"])
        .arg(&report)
        .output()
        .unwrap();
    let print_s = t0.elapsed().as_secs_f64();
    assert!(
        print.status.success(),
        "print failed:\n{}\n{}",
        String::from_utf8_lossy(&print.stdout),
        String::from_utf8_lossy(&print.stderr)
    );
    drop(qemu);

    let sim = Command::new(env!("CARGO_BIN_EXE_hollowpath"))
        .arg("simulate")
        .arg(&slice)
        .arg("--printer")
        .arg(&printer)
        .args(["--layers", layers, "--out"])
        .arg(out.join("sim"))
        .output()
        .unwrap();
    assert!(
        sim.status.success(),
        "simulate failed:\n{}",
        String::from_utf8_lossy(&sim.stderr)
    );
    let read = |p: PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let got = read(report);
    let want = read(out.join("sim/simulation.json"))["telemetry"].clone();
    println!(
        "print took {print_s:.1} s wall for {layers} layers; {} frames retransmitted",
        got["retransmitted"]
    );
    assert_eq!(got["digest"], want["digest"]);
    let (g, w) = (
        got["layers"].as_array().unwrap(),
        want["layers"].as_array().unwrap(),
    );
    assert_eq!(g.len(), 2);
    assert_eq!(g.len(), w.len());
    for (k, (g, w)) in g.iter().zip(w).enumerate() {
        for key in [
            "layer",
            "steps",
            "valve_openings",
            "valve_open_ticks",
            "print_ticks",
        ] {
            assert_eq!(g[key], w[key], "layer {k} {key}");
        }
        // A real print: steps on every axis, valves opened.
        assert!(g["steps"]["x"].as_u64().unwrap() > 10_000, "{g}");
        assert!(g["steps"]["z"].as_u64().unwrap() > 0, "{g}");
        assert!(g["valve_openings"][0].as_u64().unwrap() > 0, "{g}");
    }
    assert!(got["retransmitted"].is_u64());
    let _ = std::fs::remove_dir_all(&out);
}
