//! End to end: the link firmware (`firmware/src/bin/link.rs`) in QEMU's mps2-an386 with
//! UART0 on a TCP socket or a pty, the real `hollowpath print` at the other end.
//!
//! * The report's telemetry (plan digest, per layer steps, valve openings and open ticks,
//!   print ticks) equals `hollowpath simulate`'s for the same slice, printer and layers, key
//!   by key: on a clean line, through a relay that drops, corrupts or duplicates 1 % of the
//!   bytes each way, and over a pty (`print --port`).
//! * On one firmware, one after another: a bad slice comes back with the error `plan`
//!   gives; Ctrl-C mid-print aborts the job (valves shut, confirmed by the controller); a
//!   host killed mid-print has the job stopped by the watchdog in emulated time, and the
//!   next host hears when and why; then a job prints.
//!
//! Needs `qemu-system-arm` (CI installs it) and the `thumbv7em-none-eabihf` target. Without
//! QEMU the tests are skipped locally but fail under CI.

mod common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use common::qemu::{self, free_port, Clock, Qemu, Serial};
use serde_json::Value;

/// The firmware's watchdog (`firmware/src/bin/link.rs`, `LINK.watchdog_us`).
const WATCHDOG_US: u64 = 30_000_000;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

fn out_dir(what: &str) -> PathBuf {
    let out = std::env::temp_dir().join(format!(
        "hollowpath-link-qemu-{what}-{}",
        std::process::id()
    ));
    std::fs::create_dir_all(&out).unwrap();
    out
}

/// `hollowpath simulate`'s telemetry for four_holes on the CI printer, `layers` layers.
fn simulated(layers: &str) -> Value {
    simulated_slice("four_holes.json", layers, &data("ci_printer.json"))
}

/// The same for the slice file `slice` of `host-sim/data` on `printer` (computed once per
/// slice, layer count and printer).
fn simulated_slice(slice: &str, layers: &str, printer: &Path) -> Value {
    type Done = Vec<(String, String, PathBuf, Value)>;
    static DONE: Mutex<Done> = Mutex::new(Vec::new());
    let mut done = DONE.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((.., v)) = done
        .iter()
        .find(|(f, k, p, _)| f == slice && k == layers && p == printer)
    {
        return v.clone();
    }
    let name = Path::new(slice).file_name().unwrap().to_string_lossy();
    let out = out_dir(&format!("sim{layers}-{name}"));
    let sim = Command::new(env!("CARGO_BIN_EXE_hollowpath"))
        .arg("simulate")
        .arg(data(slice))
        .arg("--printer")
        .arg(printer)
        .args(["--layers", layers, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        sim.status.success(),
        "simulate failed:\n{}",
        String::from_utf8_lossy(&sim.stderr)
    );
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("simulation.json")).unwrap())
            .unwrap();
    let _ = std::fs::remove_dir_all(&out);
    let t = v["telemetry"].clone();
    done.push((
        slice.to_string(),
        layers.to_string(),
        printer.to_path_buf(),
        t.clone(),
    ));
    t
}

/// A TCP relay from a listener to `upstream` that drops, corrupts (one bit) or duplicates
/// `percent` % of the bytes each way (a third of them each), seeded.
fn relay(listener: TcpListener, upstream: u16, percent: f64, seed: u64) {
    // Out of 3 000 000: each kind takes `per` of them.
    let per = (percent * 10_000.0) as u64;
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
                        let r = rng % 3_000_000;
                        if r < per {
                            // dropped
                        } else if r < 2 * per {
                            out.push(b ^ (1 << ((rng >> 40) % 8)));
                        } else if r < 3 * per {
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

/// `hollowpath print` of `slice` on the CI printer over `link` (`--tcp 127.0.0.1:PORT` or
/// `--port PTY`), `layers` layers, reporting to `report`.
fn print_cmd(link: &[String], slice: &Path, layers: &str, report: &Path) -> Command {
    print_on(link, slice, &data("ci_printer.json"), layers, report)
}

/// The same on `printer`.
fn print_on(link: &[String], slice: &Path, printer: &Path, layers: &str, report: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hollowpath"));
    cmd.arg("print")
        .arg(slice)
        .args(link)
        .arg("--printer")
        .arg(printer)
        .args(["--layers", layers, "--report"])
        .arg(report)
        // QEMU's clock outruns the wall clock while it prints (`print::KEEPALIVE_MS`).
        .args(["--keepalive-ms", "2"]);
    cmd
}

fn tcp(port: u16) -> Vec<String> {
    vec!["--tcp".into(), format!("127.0.0.1:{port}")]
}

/// Runs a print of four_holes on the CI printer to its end; its report, stderr and the wall
/// time.
fn print_ok(link: &[String], layers: &str, out: &Path) -> (Value, String, f64) {
    print_slice_ok(
        link,
        "four_holes.json",
        &data("ci_printer.json"),
        layers,
        out,
    )
}

/// The same for the slice file `slice` of `host-sim/data` on `printer`.
fn print_slice_ok(
    link: &[String],
    slice: &str,
    printer: &Path,
    layers: &str,
    out: &Path,
) -> (Value, String, f64) {
    let t0 = Instant::now();
    let report = out.join("report.json");
    let _ = std::fs::remove_file(&report);
    let p = print_on(link, &data(slice), printer, layers, &report)
        .output()
        .unwrap();
    let wall = t0.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&p.stderr).to_string();
    assert!(
        p.status.success(),
        "print failed:\n{}\n{err}",
        String::from_utf8_lossy(&p.stdout)
    );
    let v = serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    (v, err, wall)
}

/// The report's telemetry equals simulate's, key by key, and is a real print.
fn assert_same_telemetry(got: &Value, want: &Value, layers: usize) {
    assert_eq!(got["digest"], want["digest"]);
    let (g, w) = (
        got["layers"].as_array().unwrap(),
        want["layers"].as_array().unwrap(),
    );
    assert_eq!(g.len(), layers);
    assert_eq!(g.len(), w.len());
    for (k, (g, w)) in g.iter().zip(w).enumerate() {
        for key in [
            "layer",
            "steps",
            "valve_openings",
            "valve_open_ticks",
            "print_ticks",
            "starved",
        ] {
            assert_eq!(g[key], w[key], "layer {k} {key}");
        }
        // The step interrupt never ran short of moves: the generator kept ahead.
        assert_eq!(g["starved"], 0, "layer {k}");
        // A real print: steps on every axis, valves opened.
        assert!(g["steps"]["x"].as_u64().unwrap() > 10_000, "{g}");
        assert!(g["steps"]["z"].as_u64().unwrap() > 0, "{g}");
        let opened: u64 = g["valve_openings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_u64().unwrap())
            .sum();
        assert!(opened > 0, "{g}");
    }
}

#[test]
fn printing_on_the_firmware_reports_the_telemetry_simulate_computes() {
    if !qemu::available("link firmware test") {
        return;
    }
    let _one = qemu::lock();
    let elf = qemu::firmware(Some("link"));
    let out = out_dir("telemetry");

    // A clean line, two layers (z rises between them).
    let port = free_port();
    let q = Qemu::start(&elf, Serial::Tcp(port), Clock::JumpIdle);
    let (got, _, wall) = print_ok(&tcp(port), "2", &out);
    // The firmware's RAM after a job of both layer kinds: its statics and the painted stack's
    // peak (receiving, planning, preparing the spiral, printing, the interrupts).
    let line = q
        .wait_line(0, "job:", Duration::from_secs(10))
        .unwrap_or_else(|| panic!("no job line from the firmware:\n{}", q.stdout()));
    let (statics, stack) = ram_figures(&line);
    drop(q);
    // The main loop never went as many instructions without a check-in as the SKR 2's 30 s
    // (`firmware/src/bin/link.rs`, BEATS): a board's watchdog would have been fed throughout
    // (receiving, planning, preparing, printing both layers).
    assert!(line.contains("silent heartbeats 0,"), "{line}");
    println!(
        "clean line: {wall:.1} s wall for 2 layers, {} frames retransmitted, upload {} bytes in {} messages; ram static {statics} stack {stack}",
        got["retransmitted"], got["upload_bytes"], got["upload_messages"]
    );
    assert!(stack > 1024 && statics > 100 * 1024, "{line}");
    assert_same_telemetry(&got, &simulated("2"), 2);

    // A line that drops, corrupts or duplicates 1 % of the bytes each way: the same print,
    // with retransmissions, which the host counts.
    let port = free_port();
    let q = Qemu::start(&elf, Serial::Tcp(port), Clock::JumpIdle);
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let relay_port = listener.local_addr().unwrap().port();
    relay(listener, port, 1.0, 0x5EED);
    let (got, err, wall) = print_ok(&tcp(relay_port), "1", &out);
    drop(q);
    println!(
        "1 % faulty line: {wall:.1} s wall for 1 layer, {} frames retransmitted, upload {} bytes in {} messages",
        got["retransmitted"], got["upload_bytes"], got["upload_messages"]
    );
    assert_same_telemetry(&got, &simulated("1"), 1);
    let retransmitted = got["retransmitted"].as_u64().unwrap();
    assert!(retransmitted > 0, "{got}");
    assert!(err.contains("frames retransmitted"), "{err}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn every_reference_slice_prints_on_the_firmware_as_simulate_computes() {
    if !qemu::available("link firmware test") {
        return;
    }
    let _one = qemu::lock();
    let elf = qemu::firmware(Some("link"));
    let out = out_dir("every-slice");
    let printer = data("ci_printer.json");
    // One firmware, one job after the other (four_holes, the largest, prints in the test
    // above): each slice is uploaded, planned on the controller and printed, one zigzag
    // layer, and its telemetry is simulate's exactly.
    let port = free_port();
    let q = Qemu::start(&elf, Serial::Tcp(port), Clock::JumpIdle);
    for slice in ["two_holes.json", "three_holes.json", "vessel_ring.json"] {
        let (got, _, wall) = print_slice_ok(&tcp(port), slice, &printer, "1", &out);
        println!(
            "{slice}: {wall:.1} s wall for 1 layer, {} frames retransmitted, upload {} bytes",
            got["retransmitted"], got["upload_bytes"]
        );
        assert_same_telemetry(&got, &simulated_slice(slice, "1", &printer), 1);
    }
    drop(q);
    let _ = std::fs::remove_dir_all(&out);
}

/// The link firmware with the board capacities (`compact`: the SKR 2 image's application)
/// prints a slice they hold, four_holes at 2.5 times its road width (1.0 mm), two layers,
/// with simulate's telemetry; and the painted stack's peak over the job (receiving,
/// planning, preparing the spiral, printing, the interrupts on top) fits the SKR 2's stack
/// region (the top-level `memory.x`), which the board itself cannot report here.
#[test]
fn the_board_capacities_print_within_the_skr2_stack() {
    if !qemu::available("link firmware test, board capacities") {
        return;
    }
    let _one = qemu::lock();
    let elf = qemu::compact_firmware(Some("link"));
    let out = out_dir("compact");
    let mut json: Value =
        serde_json::from_str(&std::fs::read_to_string(data("four_holes.json")).unwrap()).unwrap();
    let w = json["settings"]["road_width"].as_f64().unwrap();
    json["settings"]["road_width"] = (w * 2.5).into();
    let slice = out.join("four_holes_1mm.json");
    std::fs::write(&slice, json.to_string()).unwrap();
    let slice = slice.to_str().unwrap();
    let printer = data("ci_printer.json");
    let port = free_port();
    let q = Qemu::start(&elf, Serial::Tcp(port), Clock::JumpIdle);
    let (got, _, wall) = print_slice_ok(&tcp(port), slice, &printer, "2", &out);
    let line = q
        .wait_line(0, "job:", Duration::from_secs(10))
        .unwrap_or_else(|| panic!("no job line from the firmware:\n{}", q.stdout()));
    let (statics, stack) = ram_figures(&line);
    drop(q);
    assert!(line.contains("silent heartbeats 0,"), "{line}");
    let room = qemu::board_region("STACK");
    println!(
        "board capacities: {wall:.1} s wall for 2 layers of four_holes at 1.0 mm; ram static {statics} stack {stack} (the SKR 2's stack region {room})"
    );
    assert_same_telemetry(&got, &simulated_slice(slice, "2", &printer), 2);
    assert!(
        stack > 1024 && stack <= room,
        "the stack's peak {stack} is over the SKR 2's stack region {room}: {line}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// A running `hollowpath print`, its stderr collected.
struct Running {
    child: Child,
    err: std::sync::Arc<Mutex<String>>,
}

impl Running {
    fn start(port: u16, layers: &str, report: &Path) -> Running {
        let mut child = print_cmd(&tcp(port), &data("four_holes.json"), layers, report)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let err = qemu::drain(child.stderr.take().unwrap());
        Running { child, err }
    }

    /// Waits until stderr has `what` (the print still running).
    fn wait_for(&mut self, what: &str, timeout: Duration) {
        let t = Instant::now();
        while !self.err.lock().unwrap().contains(what) {
            if let Some(s) = self.child.try_wait().unwrap() {
                panic!("print exited ({s}) before {what:?}:\n{}", self.stderr());
            }
            assert!(
                t.elapsed() < timeout,
                "no {what:?} in time:\n{}",
                self.stderr()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn stderr(&self) -> String {
        self.err.lock().unwrap().clone()
    }

    fn wait(mut self) -> (ExitStatus, String) {
        let status = self.child.wait().unwrap();
        // Let the reader take the last lines.
        std::thread::sleep(Duration::from_millis(100));
        (status, self.stderr())
    }
}

/// The steps of the firmware's semihosting line after a job: `job: steps X Y Z valves shut
/// B at T us`; (steps, valves shut).
fn job_line(line: &str) -> ([u64; 3], bool) {
    let w: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(&w[..2], ["job:", "steps"], "{line}");
    let n = |i: usize| w[i].parse::<u64>().unwrap();
    ([n(2), n(3), n(4)], w[7] == "true")
}

/// The RAM figures at the end of a job line (`... ram static S stack P`): (S, P).
fn ram_figures(line: &str) -> (usize, usize) {
    let w: Vec<&str> = line.split_whitespace().collect();
    let n = w.len();
    assert!(n >= 5, "{line}");
    assert_eq!(
        [w[n - 5], w[n - 4], w[n - 2]],
        ["ram", "static", "stack"],
        "{line}"
    );
    (w[n - 3].parse().unwrap(), w[n - 1].parse().unwrap())
}

/// The steps a stop report names in stderr (`motion stopped at steps x X y Y z Z`).
fn stopped_steps(err: &str) -> [u64; 3] {
    let tail = err
        .split("motion stopped at steps x ")
        .nth(1)
        .unwrap_or_else(|| panic!("no stop report in:\n{err}"));
    let w: Vec<&str> = tail.split_whitespace().collect();
    [w[0], w[2], w[4]].map(|s| s.parse().unwrap())
}

#[test]
fn a_bad_slice_ctrl_c_and_a_silent_host_each_leave_the_firmware_ready_for_the_next_job() {
    if !qemu::available("link firmware recovery test") {
        return;
    }
    let _one = qemu::lock();
    let elf = qemu::firmware(Some("link"));
    let out = out_dir("recovery");
    let port = free_port();
    let q = Qemu::start(&elf, Serial::Tcp(port), Clock::JumpIdle);
    let t0 = Instant::now();

    // 1. A bad slice (two holes that overlap), sent as it is (`--no-check`): the firmware
    //    refuses it with the core's error, the one `plan` gives on the host.
    let bad = out.join("overlap.json");
    std::fs::write(
        &bad,
        r#"{"outer": {"points": [[0,0],[20,0],[20,20],[0,20]], "material": [1,0,0,0]},
           "holes": [{"points": [[4,4],[10,4],[10,10],[4,10]], "material": [0,1,0,0]},
                     {"points": [[8,8],[14,8],[14,14],[8,14]], "material": [0,1,0,0]}]}"#,
    )
    .unwrap();
    let plan = Command::new(env!("CARGO_BIN_EXE_hollowpath"))
        .arg("plan")
        .arg(&bad)
        .arg("--out")
        .arg(out.join("plan"))
        .output()
        .unwrap();
    assert!(!plan.status.success());
    let plan_err = String::from_utf8_lossy(&plan.stderr).to_string();
    let why = plan_err
        .split("invalid slice: ")
        .nth(1)
        .unwrap_or_else(|| panic!("{plan_err}"))
        .trim()
        .to_string();
    assert!(why.contains("overlap"), "{why}");
    let p = print_cmd(&tcp(port), &bad, "1", &out.join("bad.json"))
        .arg("--no-check")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&p.stderr).to_string();
    assert!(!p.status.success(), "{err}");
    assert!(
        err.contains(&format!("the controller refused: {why}")),
        "print said:\n{err}\nplan said:\n{plan_err}"
    );
    println!(
        "bad slice refused: {why} ({:.1} s)",
        t0.elapsed().as_secs_f64()
    );

    // 2. Ctrl-C mid-print: the host sends an abort, the controller stops (valves shut) and
    //    confirms; the host says so and exits non-zero.
    let t = Instant::now();
    let seen = q.stdout().len();
    let mut run = Running::start(port, "2", &out.join("int.json"));
    run.wait_for("Printing layer 0/2", Duration::from_secs(120));
    std::thread::sleep(Duration::from_millis(500));
    // SAFETY: a signal to our own child, which is still running.
    assert_eq!(
        unsafe { libc::kill(run.child.id() as i32, libc::SIGINT) },
        0
    );
    let (status, err) = run.wait();
    assert!(!status.success(), "{err}");
    assert!(
        err.contains("interrupted (Ctrl-C): the controller ended the job Aborted"),
        "{err}"
    );
    assert!(err.contains("stopped (Aborted) in layer 0"), "{err}");
    let line = q
        .wait_line(seen, "job:", Duration::from_secs(10))
        .unwrap_or_else(|| panic!("no job line from the firmware:\n{}", q.stdout()));
    let (steps, shut) = job_line(&line);
    assert!(shut, "{line}");
    assert_eq!(steps, stopped_steps(&err), "{line}\n{err}");
    assert!(steps[0] > 0, "{line}");
    println!(
        "Ctrl-C: aborted at steps {steps:?}, valves shut ({:.1} s)",
        t.elapsed().as_secs_f64()
    );

    // 3. The host dies mid-print: the firmware's watchdog stops the job (valves shut,
    //    motion stopped) within its time, in emulated time.
    let t = Instant::now();
    let seen = q.stdout().len();
    let mut run = Running::start(port, "2", &out.join("silent.json"));
    run.wait_for("Printing layer 0/2", Duration::from_secs(120));
    std::thread::sleep(Duration::from_millis(500));
    run.child.kill().unwrap();
    let _ = run.wait();
    let line = q
        .wait_line(seen, "job:", Duration::from_secs(120))
        .unwrap_or_else(|| panic!("the firmware did not stop:\n{}", q.stdout()));
    let (steps, shut) = job_line(&line);
    assert!(shut, "{line}");
    println!(
        "silent host: stopped at steps {steps:?}, valves shut ({:.1} s after the kill)",
        t.elapsed().as_secs_f64()
    );

    // 4. The next host hears why and when, then prints: the firmware is ready again.
    let (got, err, wall) = print_ok(&tcp(port), "1", &out);
    let last = &got["last_stop"];
    assert_eq!(last["fault"], "HostSilent", "{got}");
    assert_eq!(last["watchdog_us"], WATCHDOG_US, "{got}");
    let silent = last["silent_us"].as_u64().unwrap();
    assert!(
        silent > WATCHDOG_US && silent < WATCHDOG_US + 1_000_000,
        "stopped {silent} us after the host was last heard: {got}"
    );
    assert_eq!(
        [
            last["steps"]["x"].as_u64().unwrap(),
            last["steps"]["y"].as_u64().unwrap(),
            last["steps"]["z"].as_u64().unwrap()
        ],
        steps,
        "{got}"
    );
    assert!(
        err.contains("the controller's last job stopped (HostSilent)"),
        "{err}"
    );
    assert_same_telemetry(&got, &simulated("1"), 1);
    println!(
        "next job: printed 1 layer in {wall:.1} s; the last job stopped {:.3} s after the host was last heard; {:.1} s in all",
        silent as f64 / 1e6,
        t0.elapsed().as_secs_f64()
    );
    drop(q);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn printing_over_a_pty_with_the_serialport_crate() {
    if !qemu::available("link firmware pty test") {
        return;
    }
    let _one = qemu::lock();
    let elf = qemu::firmware(Some("link"));
    let out = out_dir("pty");
    // Over a pty QEMU's emulated clock runs near the wall clock's pace even under
    // `sleep=off` (a layer of the CI printer, 100 emulated seconds, takes 80-100 s): the CI
    // printer at three times its print speed keeps the test short.
    let printer = out.join("fast_printer.json");
    let mut cfg: Value =
        serde_json::from_str(&std::fs::read_to_string(data("ci_printer.json")).unwrap()).unwrap();
    cfg["print_speed"] = 120.into();
    cfg["travel_speed"] = 120.into();
    std::fs::write(&printer, cfg.to_string()).unwrap();
    let q = Qemu::start(&elf, Serial::Pty, Clock::JumpIdle);
    let pty = q.pty.clone().unwrap_or_else(|| panic!("{}", q.stderr()));
    let (got, err, wall) = print_slice_ok(
        &["--port".into(), pty.clone()],
        "four_holes.json",
        &printer,
        "1",
        &out,
    );
    drop(q);
    println!(
        "pty {pty}: {wall:.1} s wall for 1 layer, {} frames retransmitted",
        got["retransmitted"]
    );
    if err.contains("line settings") {
        println!("note: {pty} refused the line settings; printed on the raw device");
    }
    assert_same_telemetry(&got, &simulated_slice("four_holes.json", "1", &printer), 1);
    let _ = std::fs::remove_dir_all(&out);
}

/// The firmware's receive interrupt serves the link while its loop plans a slice: a message
/// the host sends after the slice was accepted is acknowledged before the plan is done.
/// (Before, the firmware read no byte while it planned: the host retransmitted every 40 ms
/// for the whole planning, and the ack came after the plan's digest.)
#[test]
fn while_the_firmware_plans_its_receive_interrupt_acknowledges_the_host() {
    use hollowpath::link::message::{CtrlMsg, HostMsg, Telemetry};
    use host_sim::link_client::LinkClient;
    if !qemu::available("link firmware planning test") {
        return;
    }
    let _one = qemu::lock();
    let elf = qemu::firmware(Some("link"));
    let port = free_port();
    let q = Qemu::start(&elf, Serial::Tcp(port), Clock::JumpIdle);
    let stream = host_sim::print::open_tcp(&format!("127.0.0.1:{port}")).unwrap();
    let link = hollowpath::link::endpoint::LinkConfig {
        keepalive_us: 2_000,
        ..host_sim::print::HOST_LINK
    };
    let mut client = LinkClient::new(stream, link);
    client.timeout = Duration::from_secs(120);
    client.hello().unwrap();
    let slice = host_sim::slice_file::parse(host_sim::REFERENCE_SLICES[0].1)
        .unwrap()
        .slice;
    client.upload(&slice, 1).unwrap();
    let t = Instant::now();
    // Outside a job a pause changes nothing; the firmware plans four_holes now (about
    // 2.7 G emulated instructions with its check).
    client.send(&HostMsg::Pause).unwrap();
    client.flush().unwrap();
    let acked = t.elapsed();
    let mut early = false;
    while let Some(m) = client.next_message(Duration::ZERO).unwrap() {
        early |= matches!(m, CtrlMsg::Telemetry(Telemetry::Plan { .. }));
    }
    let mut planned = early;
    while !planned {
        match client.next_message(Duration::from_secs(120)).unwrap() {
            Some(CtrlMsg::Telemetry(Telemetry::Plan { .. })) => planned = true,
            Some(CtrlMsg::Error(e)) => panic!("{e}"),
            Some(_) => {}
            None => panic!("no plan digest: {}", q.stderr()),
        }
    }
    let stats = client.stats();
    println!(
        "acknowledged after {:.2} s, plan digest after {:.2} s; host retransmissions {}, timeouts {}",
        acked.as_secs_f64(),
        t.elapsed().as_secs_f64(),
        stats.retransmissions,
        stats.timeouts
    );
    assert!(!early, "the ack came after the plan");
    drop(q);
}
