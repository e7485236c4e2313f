//! The messages, one enum per direction: serde-derived, postcard-encoded, `heapless` types
//! only.
//!
//! [`HostMsg::Hello`] and [`CtrlMsg::Hello`] are variant 0 and their first field is the
//! protocol version, in every version of the protocol: a peer of another version still
//! decodes the hello and refuses with [`LinkError::ProtocolMismatch`].
//!
//! A slice goes up as: [`HostMsg::Job`] (settings and layer count), then for the wall and
//! each hole in order a [`HostMsg::Feature`] (material and vertex count) followed by its
//! [`HostMsg::Contour`] chunks, then [`HostMsg::EndSlice`]. The printer configuration goes up
//! as [`HostMsg::Printer`] chunks of its postcard encoding.
//!
//! Every host message fits in a small frame (at most [`SMALL_PAYLOAD`] bytes of payload:
//! asserted for the chunks, tested for the rest; the controller's are as small but for a
//! layer's telemetry, up to 90 bytes): on a line that spoils one byte in a hundred, a frame of `n` bytes arrives
//! whole with probability 0.99^n, about a half for a contour chunk, not 1 in 90 as for the
//! 450-byte chunks of protocol version 1.

use core::fmt;

use heapless::Vec;
use serde::{Deserialize, Serialize};

use super::error::LinkError;
use super::wire::WirePrinterError;
use crate::config::CHANNELS;
use crate::error::{Error, FeatureId};
use crate::motion::config::AXES;
use crate::motion::machine::Fault;
use crate::slice::{Material, Settings};

/// The protocol version; peers of different versions refuse each other (2: small contour
/// chunks, the printer configuration in chunks, [`CtrlMsg::Stopped`]; 3: a layer's
/// telemetry counts its starved step alarms, [`LayerTelemetry::starved`]; 4: the capacity
/// [`Limit::HalfPoolPoints`](crate::Limit::HalfPoolPoints) a refusal may name).
pub const PROTOCOL_VERSION: u16 = 4;
/// Bytes of zigzag-varint vertices in one [`ContourChunk`] (and of encoded printer
/// configuration in one [`PrinterChunk`]).
pub const CHUNK_BYTES: usize = 64;
/// The most payload bytes a message of either direction takes: a chunk message's header
/// (variant, feature or offsets: at most 1 + 2 + 5 varint bytes) and length prefix (2
/// bytes) around [`CHUNK_BYTES`].
pub const SMALL_PAYLOAD: usize = CHUNK_BYTES + 10;
/// The most bytes of a printer configuration's postcard encoding ([`PrinterChunk`]s carry
/// at most this many).
pub const PRINTER_BYTES: usize = 512;

// A chunk message fits a frame with room to spare, and a chunk holds at least one vertex
// (two varints of at most `contour::MAX_VARINT` bytes, asserted in `contour`).
const _: () = assert!(SMALL_PAYLOAD <= super::frame::MAX_PAYLOAD);
// The chunks' offsets are `u16`; the length prefix of `CHUNK_BYTES` takes at most 2 bytes.
const _: () = assert!(PRINTER_BYTES <= u16::MAX as usize && CHUNK_BYTES < 1 << 14);

/// Refuses a peer's protocol version other than ours.
pub fn check_protocol(theirs: u16) -> Result<(), LinkError> {
    if theirs == PROTOCOL_VERSION {
        Ok(())
    } else {
        Err(LinkError::ProtocolMismatch {
            ours: PROTOCOL_VERSION,
            theirs,
        })
    }
}

/// A firmware's version.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Version {
    pub major: u8,
    pub minor: u8,
    pub patch: u8,
}

/// What the controller can take.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Capacities {
    /// Most hollow features of a slice ([`MAX_HOLES`](crate::config::MAX_HOLES), or the
    /// assembler's `HOLES` if fewer).
    pub max_holes: u16,
    /// Most vertices of one stored polygon ([`MAX_VERTICES`](crate::config::MAX_VERTICES)).
    pub max_vertices: u32,
    /// Most vertices of all the uploaded contours together (the assembler's `POINTS`):
    /// contours beyond [`MAX_VERTICES`](crate::config::MAX_VERTICES) are simplified on the
    /// controller.
    pub max_points: u32,
    /// Material channels.
    pub channels: u8,
}

/// A run of one contour's vertices: `data` holds them in integer micrometres, the first
/// absolute and the rest as deltas from the one before, each coordinate a zigzag varint
/// ([`contour`](super::contour)). Each chunk decodes on its own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContourChunk {
    /// The contour.
    pub feature: FeatureId,
    /// Index of the chunk's first vertex in the contour.
    pub start: u32,
    /// The vertices.
    pub data: Vec<u8, CHUNK_BYTES>,
}

/// A run of the printer configuration's postcard encoding: `total` bytes in all, this
/// chunk's `data` from byte `offset`. The controller decodes and validates the configuration
/// when the chunk that ends it arrived.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PrinterChunk {
    /// Offset of `data` in the encoding.
    pub offset: u16,
    /// Length of the whole encoding (at most [`PRINTER_BYTES`]).
    pub total: u16,
    /// The bytes.
    pub data: Vec<u8, CHUNK_BYTES>,
}

/// Why and when a job stopped before its end: sent with the fault when it happens, and
/// again after the hello of the next host to greet the controller (until a job starts).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StopReport {
    /// Why the machine stopped.
    pub fault: Fault,
    /// The layer it stopped in (from 0).
    pub layer: u16,
    /// The controller's clock at the stop (its link clock, microseconds since it started).
    pub at_us: u64,
    /// The controller's clock when it last received a valid frame before the stop (`None`:
    /// never in this session).
    pub heard_us: Option<u64>,
    /// The link's watchdog time (microseconds; 0: none).
    pub watchdog_us: u64,
    /// Steps per axis the job had driven when it stopped (they stay so).
    pub steps: [u64; AXES],
}

impl StopReport {
    /// How long the host had been silent at the stop (microseconds).
    pub fn silent_us(&self) -> Option<u64> {
        self.heard_us.map(|h| self.at_us.saturating_sub(h))
    }
}

impl fmt::Display for StopReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "stopped ({:?}) in layer {} at {:.3} s of the controller's clock",
            self.fault,
            self.layer,
            self.at_us as f64 / 1e6
        )?;
        if let (Fault::HostSilent, Some(s)) = (self.fault, self.silent_us()) {
            write!(
                f,
                ", {:.3} s after the host was last heard (watchdog {:.3} s)",
                s as f64 / 1e6,
                self.watchdog_us as f64 / 1e6
            )?;
        }
        write!(
            f,
            "; valves shut, motion stopped at steps x {} y {} z {}",
            self.steps[0], self.steps[1], self.steps[2]
        )
    }
}

/// Host to controller.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMsg {
    /// Opens a session (variant 0, protocol first, in every version).
    Hello {
        /// [`PROTOCOL_VERSION`] of the host.
        protocol: u16,
    },
    /// A chunk of the printer to drive
    /// ([`PrinterConfig`](crate::motion::config::PrinterConfig), postcard-encoded; validated by
    /// the controller once whole).
    Printer(PrinterChunk),
    /// Starts a slice upload: its settings and the number of layers to print.
    Job {
        /// The slice's settings.
        settings: Settings,
        /// Layers to print.
        layers: u16,
    },
    /// Starts a contour: the wall first, then holes 0, 1, ...
    Feature {
        /// Which.
        feature: FeatureId,
        /// Its material.
        material: Material,
        /// How many vertices its chunks will bring.
        vertices: u32,
    },
    /// Vertices of the current contour.
    Contour(ContourChunk),
    /// Ends the slice: the controller builds and validates it.
    EndSlice {
        /// How many holes were sent.
        holes: u8,
    },
    /// Starts printing the validated slice.
    Start,
    /// Pauses at the next block boundary.
    Pause,
    /// Resumes after a pause.
    Resume,
    /// Aborts the job (valves shut, motion dropped).
    Abort,
}

/// Where the controller's job is.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    Idle,
    Receiving,
    Planning,
    Homing,
    Printing,
    Paused,
    Done,
    Aborted,
    Failed,
}

/// Status and progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// Where the job is.
    pub phase: Phase,
    /// The layer being printed (from 0).
    pub layer: u16,
    /// Layers of the job.
    pub layers: u16,
    /// Progress of the job, 0 to 100.
    pub percent: u8,
}

/// One printed layer, as counted by the step engine and the valves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LayerTelemetry {
    /// The layer.
    pub layer: u16,
    /// Steps per axis (X, Y, Z).
    pub steps: [u32; AXES],
    /// Valve openings per channel.
    pub valve_openings: [u32; CHANNELS],
    /// Time each valve was open, timer ticks.
    pub valve_open_ticks: [u64; CHANNELS],
    /// The layer's print time, timer ticks.
    pub print_ticks: u64,
    /// Step alarms that ran with the look-ahead short of moves because the layer's
    /// generator fell behind ([`Stepping::starved`](crate::app::steps::Stepping::starved));
    /// 0 when the controller kept ahead, as the host's `simulate` always does.
    pub starved: u32,
}

impl LayerTelemetry {
    /// Layer `layer`'s figures from what the machine drove over it
    /// ([`Counters::since`](crate::motion::machine::Counters::since)) and its starved
    /// alarms; a count past `u32` saturates (a layer of more than 4 billion steps on an axis
    /// is not a layer).
    pub fn from_counters(
        layer: u16,
        c: &crate::motion::machine::Counters,
        starved: u32,
    ) -> LayerTelemetry {
        let mut steps = [0u32; AXES];
        for (s, &n) in steps.iter_mut().zip(c.steps.iter()) {
            *s = u32::try_from(n).unwrap_or(u32::MAX);
        }
        LayerTelemetry {
            layer,
            steps,
            valve_openings: c.valve_openings,
            valve_open_ticks: c.valve_open_ticks,
            print_ticks: c.ticks,
            starved,
        }
    }
}

/// Telemetry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Telemetry {
    /// The plan of the slice ([`Plan::digest`](crate::Plan::digest)): the host compares it
    /// with its own.
    Plan {
        /// The digest.
        digest: u64,
    },
    /// A printed layer.
    Layer(LayerTelemetry),
}

/// A typed error of the controller, the same values the host prints.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum RemoteError {
    /// The slice was refused (or could not be planned).
    Slice(Error),
    /// The printer configuration was refused ([`From`] gives the
    /// [`PrinterError`](crate::motion::config::PrinterError)).
    Printer(WirePrinterError),
    /// The machine stopped.
    Machine(Fault),
    /// The link or the slice assembler refused a message.
    Link(LinkError),
}

impl fmt::Display for RemoteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RemoteError::Slice(e) => e.fmt(f),
            RemoteError::Printer(e) => e.fmt(f),
            RemoteError::Machine(e) => write!(f, "the machine stopped: {e:?}"),
            RemoteError::Link(e) => e.fmt(f),
        }
    }
}

/// Controller to host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum CtrlMsg {
    /// Answers the host's hello (variant 0, protocol first, in every version).
    Hello {
        /// [`PROTOCOL_VERSION`] of the controller.
        protocol: u16,
        /// The firmware's version.
        firmware: Version,
        /// What it can take.
        capacities: Capacities,
    },
    /// The printer configuration was accepted.
    PrinterAccepted,
    /// The slice arrived whole and validated.
    SliceAccepted {
        /// Its holes.
        holes: u8,
        /// Its vertices as stored (after any simplification).
        vertices: u32,
    },
    /// Status and progress.
    Status(Status),
    /// Telemetry.
    Telemetry(Telemetry),
    /// A refusal or a fault.
    Error(RemoteError),
    /// A job stopped before its end (after its [`CtrlMsg::Error`]), or, after a hello, the
    /// last job did.
    Stopped(StopReport),
}
