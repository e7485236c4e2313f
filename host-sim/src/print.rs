//! `hollowpath print`: a slice printed by the controller over the link (a serial port, or
//! TCP to QEMU's `-serial tcp:...`), its progress shown as it comes, its telemetry written
//! as a report that compares key by key with `simulate`'s `telemetry`.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use hollowpath::link::endpoint::LinkConfig;
use hollowpath::link::message::{
    CtrlMsg, HostMsg, LayerTelemetry, Phase, RemoteError, StopReport, Telemetry,
};
use hollowpath::motion::PrinterConfig;
use hollowpath::Slice;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::{json, Value};

use crate::link_client::{ClientError, LinkClient};
use crate::simulate::telemetry_value;
use crate::slice_file::Contours;

/// The host's link timers: the controller's acks come at once (within a millisecond over
/// TCP to QEMU), so a frame unacknowledged for 40 ms is sent again (on a line that spoils
/// one byte in a hundred, about every other contour frame is; a nak usually asks for it
/// sooner). A keep-alive after [`KEEPALIVE_MS`] of silence keeps the controller's watchdog
/// fed; no watchdog here (a silent controller shows as a timeout).
pub const HOST_LINK: LinkConfig = LinkConfig {
    retransmit_us: 40_000,
    keepalive_us: KEEPALIVE_MS * 1_000,
    watchdog_us: 0,
};

/// `print`'s keep-alive by default (`--keepalive-ms`): 100 ms, thirty to the SKR 2's 3 s
/// host watchdog, and a 9-byte frame (an ack: header, CRC, COBS and delimiter) ten times a
/// second, under 1 % of a 115 200 baud line (every 2 ms it was 39 %). The QEMU tests and
/// README's QEMU command keep 2 ms, as before the option: under `-icount shift=0,sleep=off`
/// the controller's clock runs about a hundred times faster than the wall clock while it
/// prints and jumps over idle time while it waits.
pub const KEEPALIVE_MS: u64 = 100;

/// Longest wait for any message during a job.
pub const SILENCE: Duration = Duration::from_secs(300);

/// Longest wait for the controller to confirm an abort (Ctrl-C).
pub const ABORT_WAIT: Duration = Duration::from_secs(20);

/// A byte stream for the link: a TCP socket or a serial port.
pub trait Stream: Read + Write + Send {}
impl<T: Read + Write + Send> Stream for T {}

/// Opens `--tcp HOST:PORT` (short read timeouts, no Nagle delay).
pub fn open_tcp(addr: &str) -> Result<Box<dyn Stream>, String> {
    let s = std::net::TcpStream::connect(addr).map_err(|e| format!("connect {addr}: {e}"))?;
    s.set_nodelay(true).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_millis(1)))
        .map_err(|e| e.to_string())?;
    Ok(Box::new(s))
}

/// Opens `--port PORT` (115200 8N1, short read timeouts). A port that refuses the line
/// settings (some pseudo-terminals) is opened without them, and that is said on stderr:
/// a pty moves bytes at any rate.
pub fn open_serial(port: &str) -> Result<Box<dyn Stream>, String> {
    check_port(port)?;
    match serialport::new(port, 115_200)
        .timeout(Duration::from_millis(1))
        .open()
    {
        Ok(p) => Ok(Box::new(p)),
        Err(e) if e.kind() == serialport::ErrorKind::NoDevice => Err(format!("{port}: {e}")),
        Err(e) => {
            eprintln!(
                "{port}: the serial line settings (115200 8N1) failed ({e}); using the port as it is"
            );
            raw_port(port).map_err(|raw| format!("{port}: {e}; {raw}"))
        }
    }
}

/// Refuses a port that is not a character device: an ordinary file (a slice named by
/// mistake) would have the link's frames appended to it.
#[cfg(unix)]
fn check_port(port: &str) -> Result<(), String> {
    use std::os::unix::fs::FileTypeExt;
    match std::fs::metadata(port) {
        Ok(meta) if !meta.file_type().is_char_device() => Err(format!(
            "{port}: not a serial port (a character device such as /dev/ttyACM0); nothing \
             was written to it"
        )),
        _ => Ok(()),
    }
}

#[cfg(not(unix))]
fn check_port(_port: &str) -> Result<(), String> {
    Ok(())
}

/// A character device used as it is (no line settings), non-blocking.
#[cfg(unix)]
fn raw_port(port: &str) -> Result<Box<dyn Stream>, String> {
    use std::os::unix::fs::OpenOptionsExt;
    let f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
        .open(port)
        .map_err(|e| format!("{port}: {e}"))?;
    Ok(Box::new(RawPort(f)))
}

#[cfg(not(unix))]
fn raw_port(port: &str) -> Result<Box<dyn Stream>, String> {
    Err(format!("{port}: the line settings were refused"))
}

/// A non-blocking character device: a read of nothing is `WouldBlock` (which the link
/// client takes as "nothing yet"); a write waits until the device takes the bytes.
struct RawPort(std::fs::File);

impl Read for RawPort {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl Write for RawPort {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        loop {
            match self.0.write(buf) {
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_micros(100))
                }
                r => return r,
            }
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

/// What a print produced.
#[derive(Debug)]
pub struct PrintReport {
    /// The controller's plan digest.
    pub digest: u64,
    /// Each layer's telemetry, in order.
    pub layers: Vec<LayerTelemetry>,
    /// Frames the host sent again.
    pub retransmitted: u32,
    /// Bytes the upload of the slice wrote (retransmissions and acks included).
    pub upload_bytes: u64,
    /// Messages of the slice's upload.
    pub upload_messages: usize,
    /// How the controller's previous job stopped, as it said after the hello.
    pub last_stop: Option<StopReport>,
}

/// A stop report as JSON.
pub fn stop_value(r: &StopReport) -> Value {
    json!({
        "fault": format!("{:?}", r.fault),
        "layer": r.layer,
        "at_us": r.at_us,
        "heard_us": r.heard_us,
        "silent_us": r.silent_us(),
        "watchdog_us": r.watchdog_us,
        "steps": {"x": r.steps[0], "y": r.steps[1], "z": r.steps[2]},
    })
}

impl PrintReport {
    /// The report file's JSON.
    pub fn json(&self, channels: usize) -> Value {
        json!({
            "digest": format!("{:016x}", self.digest),
            "layers": self.layers.iter().map(|t| telemetry_value(t, channels)).collect::<Vec<_>>(),
            "retransmitted": self.retransmitted,
            "upload_bytes": self.upload_bytes,
            "upload_messages": self.upload_messages,
            "last_stop": self.last_stop.as_ref().map(stop_value),
        })
    }
}

/// Why a print failed.
#[derive(Debug)]
pub enum PrintError {
    /// The link or the controller refused.
    Client(ClientError),
    /// Ctrl-C: the job was aborted (how the controller said it stopped), or never started.
    Interrupted {
        /// The job's last phase (`None`: it had not started).
        phase: Option<Phase>,
        /// The controller's report of the stop.
        stop: Option<StopReport>,
    },
    /// The job ended other than done: its last phase, the controller's error and report.
    Ended {
        /// The last phase.
        phase: Phase,
        /// The controller's error.
        error: Option<RemoteError>,
        /// The controller's report of the stop.
        stop: Option<StopReport>,
    },
}

impl std::fmt::Display for PrintError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PrintError::Client(e) => e.fmt(f),
            PrintError::Interrupted { phase: None, .. } => {
                write!(f, "interrupted (Ctrl-C) before the job started")
            }
            PrintError::Interrupted {
                phase: Some(Phase::Done),
                ..
            } => write!(f, "interrupted (Ctrl-C): the job had already ended"),
            PrintError::Interrupted {
                phase: Some(p),
                stop,
            } => {
                write!(
                    f,
                    "interrupted (Ctrl-C): the controller ended the job {p:?}"
                )?;
                match stop {
                    Some(r) => write!(f, ": {r}"),
                    None => Ok(()),
                }
            }
            PrintError::Ended { phase, error, stop } => {
                write!(f, "the job ended {phase:?}")?;
                if let Some(e) = error {
                    write!(f, ": {e}")?;
                }
                match stop {
                    Some(r) => write!(f, "; {r}"),
                    None => Ok(()),
                }
            }
        }
    }
}

impl From<ClientError> for PrintError {
    fn from(e: ClientError) -> Self {
        PrintError::Client(e)
    }
}

/// What `print` sends: a validated slice, or a file's contours as they are (`--no-check`).
#[derive(Clone, Copy, Debug)]
pub enum Job<'a> {
    /// A slice the host validated.
    Slice(&'a Slice),
    /// Contours the controller alone validates.
    Unchecked(&'a Contours),
}

/// Prints `job` in `layers` layers on the controller at the end of `stream`. On Ctrl-C
/// (`interrupted`) during the job it sends an abort, waits for the controller to confirm
/// the stop (valves shut) and returns [`PrintError::Interrupted`] with its report.
pub fn print<S: Read + Write>(
    stream: S,
    job: Job<'_>,
    printer: &PrinterConfig,
    layers: u16,
    link: LinkConfig,
    interrupted: Arc<AtomicBool>,
) -> Result<PrintReport, PrintError> {
    let mut client = LinkClient::new(stream, link);
    let (fw, caps) = client.hello()?;
    eprintln!(
        "controller firmware {}.{}.{}: up to {} holes, {} points",
        fw.major, fw.minor, fw.patch, caps.max_holes, caps.max_points
    );
    client.send_printer(printer)?;
    let up = match job {
        Job::Slice(slice) => client.upload(slice, layers)?,
        Job::Unchecked(c) => client.upload_contours(c, layers)?,
    };
    eprintln!(
        "slice accepted: {} holes, {} vertices ({} bytes in {} messages, {} frames retransmitted so far)",
        up.holes,
        up.vertices,
        up.bytes,
        up.messages,
        client.stats().retransmissions
    );
    let bar = ProgressBar::with_draw_target(Some(100), ProgressDrawTarget::stderr());
    let hidden = !std::io::IsTerminal::is_terminal(&std::io::stderr());
    if hidden {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos:>3}% {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    // A hidden bar prints nothing: then the lines go to stderr as they are.
    let say = |line: String| {
        if hidden {
            eprintln!("{line}");
        } else {
            bar.println(line);
        }
    };
    let mut digest = None;
    let mut telemetry = Vec::new();
    let mut started = false;
    let mut aborting: Option<Instant> = None;
    let mut last_stop = None;
    let mut stop = None;
    let mut error = None;
    let mut last = Instant::now();
    loop {
        if interrupted.load(Ordering::Relaxed) && aborting.is_none() {
            if !started {
                bar.abandon();
                return Err(PrintError::Interrupted {
                    phase: None,
                    stop: None,
                });
            }
            say("Ctrl-C: aborting the job (the controller shuts the valves)".into());
            client.send(&HostMsg::Abort)?;
            aborting = Some(Instant::now());
        }
        if aborting.is_some_and(|t| t.elapsed() > ABORT_WAIT) {
            bar.abandon();
            return Err(ClientError::Timeout {
                waiting_for: "confirmation of the abort",
            }
            .into());
        }
        if digest.is_some() && !started {
            client.start()?;
            started = true;
        }
        let Some(m) = client.next_message(Duration::from_millis(20))? else {
            if last.elapsed() > SILENCE {
                return Err(ClientError::Timeout {
                    waiting_for: "status",
                }
                .into());
            }
            continue;
        };
        last = Instant::now();
        match m {
            CtrlMsg::Telemetry(Telemetry::Plan { digest: d }) => {
                say(format!("plan {d:016x}"));
                digest = Some(d);
            }
            CtrlMsg::Telemetry(Telemetry::Layer(t)) => {
                say(format!(
                    "layer {}: steps {:?}, valve openings {:?}, {:.1} s",
                    t.layer,
                    t.steps,
                    t.valve_openings,
                    t.print_ticks as f64 / printer.tick_hz as f64
                ));
                telemetry.push(t);
            }
            CtrlMsg::Stopped(r) if !started => {
                say(format!("the controller's last job {r}"));
                last_stop = Some(r);
            }
            CtrlMsg::Stopped(r) => {
                say(format!("the controller: the job {r}"));
                stop = Some(r);
            }
            CtrlMsg::Status(s) => {
                bar.set_position(s.percent.into());
                let phase = format!("{:?} layer {}/{}", s.phase, s.layer, s.layers);
                if hidden && started {
                    say(phase.clone());
                }
                bar.set_message(phase);
                match s.phase {
                    Phase::Done if started && aborting.is_none() => break,
                    Phase::Done | Phase::Aborted | Phase::Failed if started => {
                        bar.abandon();
                        if aborting.is_some() {
                            return Err(PrintError::Interrupted {
                                phase: Some(s.phase),
                                stop,
                            });
                        }
                        return Err(PrintError::Ended {
                            phase: s.phase,
                            error,
                            stop,
                        });
                    }
                    _ => {}
                }
            }
            CtrlMsg::Error(e) if started => {
                // The stop's report and final status follow.
                say(format!("the controller: {e}"));
                error = Some(e);
            }
            CtrlMsg::Error(e) => {
                bar.abandon();
                return Err(ClientError::Remote(e).into());
            }
            _ => {}
        }
    }
    bar.finish_with_message("done");
    Ok(PrintReport {
        digest: digest.unwrap_or(0),
        layers: telemetry,
        retransmitted: client.stats().retransmissions,
        upload_bytes: up.bytes,
        upload_messages: up.messages,
        last_stop,
    })
}
