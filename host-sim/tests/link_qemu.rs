//! End to end: the link firmware (`firmware/src/bin/link.rs`) in QEMU's mps2-an386 with
//! UART0 on a TCP socket, the real `hollowpath print` at the other end. The report's
//! telemetry (plan digest, per layer steps, valve openings and open ticks, print ticks)
//! must equal `hollowpath simulate`'s for the same slice, printer and layers, key by key, on
//! a clean line and through a relay that drops, corrupts or duplicates 1 % of the bytes.
//!
//! Needs `qemu-system-arm` (CI installs it) and the `thumbv7em-none-eabihf` target. Without
//! QEMU the test is skipped locally but fails under CI.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Instant;

use serde_json::Value;

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

/// A TCP relay from a listener to `upstream` that drops, corrupts (one bit) or duplicates
/// `per_mille` / 1000 of the bytes each way (a third each), seeded.
fn relay(listener: TcpListener, upstream: u16, per_mille: u64, seed: u64) {
    std::thread::spawn(move || {
        let Ok((client, _)) = listener.accept() else {
            return;
        };
        let Ok(server) = TcpStream::connect(("127.0.0.1", upstream)) else {
            return;
        };
        let _ = client.set_nodelay(true);
        let _ = server.set_nodelay(true);
        let pipe = |mut from: TcpStream, mut to: TcpStream, mut rng: u64| {
            std::thread::spawn(move || {
                let mut buf = [0u8; 4096];
                loop {
                    let n = match from.read(&mut buf) {
                        Ok(0) | Err(_) => break,
                        Ok(n) => n,
                    };
                    let mut out = Vec::with_capacity(2 * n);
                    for &b in &buf[..n] {
                        rng ^= rng << 13;
                        rng ^= rng >> 7;
                        rng ^= rng << 17;
                        let r = rng % 3000;
                        if r < per_mille {
                            // dropped
                        } else if r < 2 * per_mille {
                            out.push(b ^ (1 << ((rng >> 40) % 8)));
                        } else if r < 3 * per_mille {
                            out.extend([b, b]);
                        } else {
                            out.push(b);
                        }
                    }
                    if to.write_all(&out).is_err() {
                        break;
                    }
                }
                let _ = to.shutdown(std::net::Shutdown::Both);
            })
        };
        let up = pipe(
            client.try_clone().unwrap(),
            server.try_clone().unwrap(),
            seed | 1,
        );
        let down = pipe(server, client, seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
        let _ = up.join();
        let _ = down.join();
    });
}

/// Runs `hollowpath print` against 127.0.0.1:`port`; its report and the wall time.
fn print(port: u16, slice: &Path, printer: &Path, layers: &str, out: &Path) -> (Value, f64) {
    let t0 = Instant::now();
    let report = out.join(format!("report-{port}.json"));
    let print = Command::new(env!("CARGO_BIN_EXE_hollowpath"))
        .arg("print")
        .arg(slice)
        .arg("--tcp")
        .arg(format!("127.0.0.1:{port}"))
        .arg("--printer")
        .arg(printer)
        .args(["--layers", layers, "--report"])
        .arg(&report)
        .output()
        .unwrap();
    let wall = t0.elapsed().as_secs_f64();
    assert!(
        print.status.success(),
        "print failed:\n{}\n{}",
        String::from_utf8_lossy(&print.stdout),
        String::from_utf8_lossy(&print.stderr)
    );
    let v = serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    (v, wall)
}

/// The report's telemetry equals simulate's, key by key, and is a real print.
fn assert_same_telemetry(got: &Value, want: &Value) {
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
    let want: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sim/simulation.json")).unwrap())
            .unwrap();
    let want = &want["telemetry"];

    // A clean line.
    let port = free_port();
    let qemu = start_qemu(&elf, port);
    let (got, wall) = print(port, &slice, &printer, layers, &out);
    drop(qemu);
    println!(
        "clean line: {wall:.1} s wall for {layers} layers, {} frames retransmitted",
        got["retransmitted"]
    );
    assert_same_telemetry(&got, want);

    // A line that drops, corrupts or duplicates 0.2 % of the bytes each way: the same
    // print, with retransmissions. (At 1 % of the bytes a 450-byte contour frame arrives
    // whole once in 90 tries: the upload alone would take minutes.)
    let port = free_port();
    let qemu = start_qemu(&elf, port);
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let relay_port = listener.local_addr().unwrap().port();
    relay(listener, port, 2, 0x5EED);
    let (got, wall) = print(relay_port, &slice, &printer, layers, &out);
    drop(qemu);
    println!(
        "0.2 % faulty line: {wall:.1} s wall, {} frames retransmitted",
        got["retransmitted"]
    );
    assert_same_telemetry(&got, want);
    assert!(got["retransmitted"].as_u64().unwrap() > 0, "{got}");
    let _ = std::fs::remove_dir_all(&out);
}
