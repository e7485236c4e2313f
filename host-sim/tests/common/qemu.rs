//! QEMU for the firmware tests: the mps2-an386 (Cortex-M4F) with semihosting, the firmware
//! built once per test binary, UART0 on stdio, a TCP server or a pty, semihosting's output
//! collected as it comes. QEMU tests of one binary run one at a time ([`lock`]): the
//! machine's cores are few.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The workspace's root.
pub fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Whether `qemu-system-arm` runs: if not, the test is skipped locally (with a note naming
/// `what`) and fails under CI.
pub fn available(what: &str) -> bool {
    let ok = Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "qemu-system-arm is missing under CI"
        );
        eprintln!("note: qemu-system-arm not found; {what} skipped");
    }
    ok
}

/// One QEMU at a time in this test binary (held for the test's length).
pub fn lock() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|p| p.into_inner())
}

/// A region's start in the top-level `memory.x` (the SKR 2's): the line `NAME : ORIGIN =
/// 0x...`.
pub fn board_origin(name: &str) -> usize {
    let origin = region_field("memory.x", name, "ORIGIN =");
    let origin = origin.split(',').next().unwrap();
    usize::from_str_radix(origin.trim().trim_start_matches("0x"), 16).unwrap()
}

/// A region's length in the top-level `memory.x` (the SKR 2's), bytes: the line
/// `NAME : ORIGIN = .., LENGTH = NK` (or `NK - MK`).
pub fn board_region(name: &str) -> usize {
    region_in("memory.x", name)
}

/// What follows `key` on region `name`'s line of the linker script `file` (from the
/// workspace root).
fn region_field(file: &str, name: &str, key: &str) -> String {
    let memory = std::fs::read_to_string(workspace().join(file)).unwrap();
    let line = memory
        .lines()
        .find(|l| l.trim_start().starts_with(name) && l.contains(key))
        .unwrap_or_else(|| panic!("no region {name} in {file}"));
    line.split(key).nth(1).unwrap().to_string()
}

/// A region's length in the linker script `file` (from the workspace root), bytes.
pub fn region_in(file: &str, name: &str) -> usize {
    let length = region_field(file, name, "LENGTH =");
    length
        .split('-')
        .map(|t| t.trim().trim_end_matches('K').parse::<usize>().unwrap() * 1024)
        .reduce(|a, b| a - b)
        .unwrap()
}

/// Builds a firmware binary of `hollowpath-qemu` (`None`: the default one) for the
/// Cortex-M4F, release, once per test binary; its ELF.
pub fn firmware(bin: Option<&str>) -> PathBuf {
    built(bin, false)
}

/// [`firmware`] with the board capacities (the feature `compact`, the SKR 2 image's).
pub fn compact_firmware(bin: Option<&str>) -> PathBuf {
    built(bin, true)
}

fn built(bin: Option<&str>, compact: bool) -> PathBuf {
    type Built = Vec<((Option<String>, bool), PathBuf)>;
    static BUILT: Mutex<Built> = Mutex::new(Vec::new());
    let mut built = BUILT.lock().unwrap_or_else(|p| p.into_inner());
    let key = (bin.map(str::to_string), compact);
    if let Some((_, p)) = built.iter().find(|(k, _)| *k == key) {
        return p.clone();
    }
    let ws = workspace();
    let target_dir = ws.join(if compact {
        "target/firmware-compact"
    } else {
        "target/firmware"
    });
    let mut args = vec!["-p", "hollowpath-qemu"];
    if compact {
        args.extend(["--features", "compact"]);
    }
    if let Some(b) = bin {
        args.extend(["--bin", b]);
    }
    let elf = build_thumb(&args, &target_dir, bin.unwrap_or("hollowpath-qemu"));
    built.push((key, elf.clone()));
    elf
}

/// Builds the SKR 2 image (`boards/skr2`, a workspace of its own) for the Cortex-M4F,
/// release, into `target/skr2`; its ELF.
pub fn skr2_image() -> PathBuf {
    let ws = workspace();
    let manifest = ws.join("boards/skr2/Cargo.toml");
    let manifest = manifest.to_str().unwrap();
    build_thumb(
        &["--manifest-path", manifest],
        &ws.join("target/skr2"),
        "hollowpath-skr2",
    )
}

/// `cargo build --release --target thumbv7em-none-eabihf` with `args` into `target_dir`
/// (given explicitly: a `CARGO_TARGET_DIR` of the test run does not move it); the ELF of
/// binary `bin`.
fn build_thumb(args: &[&str], target_dir: &Path, bin: &str) -> PathBuf {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let build = Command::new(cargo)
        .current_dir(workspace())
        .args(["build", "--release", "--target", "thumbv7em-none-eabihf"])
        .args(args)
        .arg("--target-dir")
        .arg(target_dir)
        .env_remove("RUSTFLAGS")
        .output()
        .unwrap();
    assert!(
        build.status.success(),
        "firmware build failed:\n{}",
        String::from_utf8_lossy(&build.stderr)
    );
    target_dir.join("thumbv7em-none-eabihf/release").join(bin)
}

/// Where UART0 goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Serial {
    /// QEMU's default (stdio, with `-nographic`).
    Default,
    /// A TCP server on 127.0.0.1 at this port (one client at a time; QEMU listens again
    /// when it leaves).
    Tcp(u16),
    /// A pseudo-terminal ([`Qemu::pty`]).
    Pty,
}

/// How the emulated clock runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clock {
    /// `-icount shift=0`: one instruction a nanosecond, repeatable.
    Instructions,
    /// `-icount shift=0,sleep=off`: and idle time (`wfi`) jumped to the next timer event.
    JumpIdle,
}

/// A running QEMU, killed however the test ends.
pub struct Qemu {
    child: Child,
    /// The pty UART0 is on (for [`Serial::Pty`]).
    pub pty: Option<String>,
    out: Arc<Mutex<String>>,
    err: Arc<Mutex<String>>,
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn collect(mut r: impl BufRead + Send + 'static, into: Arc<Mutex<String>>) {
    std::thread::spawn(move || {
        let mut line = String::new();
        while r.read_line(&mut line).is_ok_and(|n| n > 0) {
            into.lock().unwrap().push_str(&line);
            line.clear();
        }
    });
}

impl Qemu {
    /// Starts `elf` with UART0 on `serial`; returns once QEMU listens (TCP) or has opened
    /// its pty.
    pub fn start(elf: &Path, serial: Serial, clock: Clock) -> Qemu {
        let mut cmd = Command::new("qemu-system-arm");
        cmd.args([
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
            match clock {
                Clock::Instructions => "shift=0",
                Clock::JumpIdle => "shift=0,sleep=off",
            },
        ]);
        match serial {
            Serial::Default => {}
            Serial::Tcp(port) => {
                cmd.arg("-serial")
                    .arg(format!("tcp:127.0.0.1:{port},server=on,wait=on"));
            }
            Serial::Pty => {
                cmd.args(["-serial", "pty"]);
            }
        }
        let mut child = cmd
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let out = Arc::new(Mutex::new(String::new()));
        let err = Arc::new(Mutex::new(String::new()));
        collect(BufReader::new(child.stdout.take().unwrap()), out.clone());
        collect(BufReader::new(child.stderr.take().unwrap()), err.clone());
        // QEMU says it listens on stderr, and names its pty on stdout (among the
        // firmware's semihosting lines).
        let mut pty = None;
        let t = Instant::now();
        let mut ready = serial == Serial::Default;
        while !ready {
            if serial != Serial::Pty && err.lock().unwrap().contains("waiting for connection") {
                ready = true;
                continue;
            }
            if let Some(rest) = out
                .lock()
                .unwrap()
                .split("char device redirected to ")
                .nth(1)
            {
                pty = rest.split_whitespace().next().map(str::to_string);
                ready = true;
                continue;
            }
            if let Some(s) = child.try_wait().unwrap() {
                panic!(
                    "QEMU exited ({s}) before its UART was ready:\n{}",
                    err.lock().unwrap()
                );
            }
            assert!(
                t.elapsed() < Duration::from_secs(60),
                "QEMU's UART not ready in time:\n{}",
                err.lock().unwrap()
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        Qemu {
            child,
            pty,
            out,
            err,
        }
    }

    /// What the firmware printed over semihosting so far.
    pub fn stdout(&self) -> String {
        self.out.lock().unwrap().clone()
    }

    /// What QEMU printed on stderr so far.
    pub fn stderr(&self) -> String {
        self.err.lock().unwrap().clone()
    }

    /// Waits until semihosting's output has a line starting with `prefix` after byte
    /// `from` of it; the line.
    pub fn wait_line(&self, from: usize, prefix: &str, timeout: Duration) -> Option<String> {
        let t = Instant::now();
        loop {
            let out = self.stdout();
            if let Some(l) = out
                .get(from..)
                .and_then(|s| s.lines().find(|l| l.starts_with(prefix)))
            {
                return Some(l.to_string());
            }
            if t.elapsed() > timeout {
                return None;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Waits for QEMU to exit (the firmware's semihosting exit); its status, `None` on
    /// timeout.
    pub fn wait_exit(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let t = Instant::now();
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                // Let the readers take the last lines.
                std::thread::sleep(Duration::from_millis(100));
                return Some(s);
            }
            if t.elapsed() > timeout {
                return None;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// A free TCP port on 127.0.0.1.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Reads what a child's pipe gives into a shared string, on a thread.
pub fn drain(r: impl Read + Send + 'static) -> Arc<Mutex<String>> {
    let s = Arc::new(Mutex::new(String::new()));
    collect(BufReader::new(r), s.clone());
    s
}
