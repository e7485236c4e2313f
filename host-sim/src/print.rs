//! `hollowpath print`: a slice printed by the controller over the link (a serial port, or
//! TCP to QEMU's `-serial tcp:...`), its progress shown as it comes, its telemetry written
//! as a report that compares key by key with `simulate`'s `telemetry`.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use hollowpath::link::endpoint::LinkConfig;
use hollowpath::link::message::{CtrlMsg, LayerTelemetry, Phase, Telemetry};
use hollowpath::motion::PrinterConfig;
use hollowpath::Slice;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::{json, Value};

use crate::link_client::{ClientError, LinkClient};
use crate::simulate::telemetry_value;

/// The host's link timers: the controller's acks come at once, a keep-alive every 2 ms
/// keeps its watchdog fed (an emulated controller's clock runs fast), no watchdog here (a
/// silent controller shows as a timeout).
pub const HOST_LINK: LinkConfig = LinkConfig {
    retransmit_us: 200_000,
    keepalive_us: 2_000,
    watchdog_us: 0,
};

/// Longest wait for any message during a job.
pub const SILENCE: Duration = Duration::from_secs(300);

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

/// Opens `--port PORT` (115200 8N1, short read timeouts).
pub fn open_serial(port: &str) -> Result<Box<dyn Stream>, String> {
    let p = serialport::new(port, 115_200)
        .timeout(Duration::from_millis(1))
        .open()
        .map_err(|e| format!("{port}: {e}"))?;
    Ok(Box::new(p))
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
}

impl PrintReport {
    /// The report file's JSON.
    pub fn json(&self, channels: usize) -> Value {
        json!({
            "digest": format!("{:016x}", self.digest),
            "layers": self.layers.iter().map(|t| telemetry_value(t, channels)).collect::<Vec<_>>(),
            "retransmitted": self.retransmitted,
        })
    }
}

/// Why a print failed.
#[derive(Debug)]
pub enum PrintError {
    /// The link or the controller refused.
    Client(ClientError),
    /// Ctrl-C: the job was aborted.
    Interrupted,
    /// The job ended other than done (its last phase).
    Ended(Phase),
}

impl std::fmt::Display for PrintError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PrintError::Client(e) => e.fmt(f),
            PrintError::Interrupted => write!(f, "interrupted: the job was aborted"),
            PrintError::Ended(p) => write!(f, "the job ended {p:?}"),
        }
    }
}

impl From<ClientError> for PrintError {
    fn from(e: ClientError) -> Self {
        PrintError::Client(e)
    }
}

/// Prints `slice` in `layers` layers on the controller at the end of `stream`.
pub fn print<S: Read + Write>(
    stream: S,
    slice: &Slice,
    printer: &PrinterConfig,
    layers: u16,
    interrupted: Arc<AtomicBool>,
) -> Result<PrintReport, PrintError> {
    let mut client = LinkClient::new(stream, HOST_LINK);
    let (fw, caps) = client.hello()?;
    eprintln!(
        "controller firmware {}.{}.{}: up to {} holes, {} points",
        fw.major, fw.minor, fw.patch, caps.max_holes, caps.max_points
    );
    client.send_printer(printer)?;
    let up = client.upload(slice, layers)?;
    eprintln!(
        "slice accepted: {} holes, {} vertices ({} bytes in {} messages)",
        up.holes, up.vertices, up.bytes, up.messages
    );
    let bar = ProgressBar::with_draw_target(Some(100), ProgressDrawTarget::stderr());
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos:>3}% {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut digest = None;
    let mut telemetry = Vec::new();
    let mut started = false;
    let mut last = Instant::now();
    loop {
        if interrupted.load(Ordering::Relaxed) {
            let _ = client.abort();
            bar.abandon_with_message("aborted");
            return Err(PrintError::Interrupted);
        }
        if digest.is_some() && !started {
            client.start()?;
            started = true;
        }
        let Some(m) = client.next_message(Duration::from_millis(50))? else {
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
                bar.println(format!("plan {d:016x}"));
                digest = Some(d);
            }
            CtrlMsg::Telemetry(Telemetry::Layer(t)) => {
                bar.println(format!(
                    "layer {}: steps {:?}, valve openings {:?}, {:.1} s",
                    t.layer,
                    t.steps,
                    t.valve_openings,
                    t.print_ticks as f64 / printer.tick_hz as f64
                ));
                telemetry.push(t);
            }
            CtrlMsg::Status(s) => {
                bar.set_position(s.percent.into());
                bar.set_message(format!("{:?} layer {}/{}", s.phase, s.layer, s.layers));
                match s.phase {
                    Phase::Done if started => break,
                    Phase::Aborted | Phase::Failed if started => {
                        bar.abandon();
                        return Err(PrintError::Ended(s.phase));
                    }
                    _ => {}
                }
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
    })
}
