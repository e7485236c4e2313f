//! The host's end of the serial link: drives the core's [`Link`] over any byte stream
//! (`std::io::Read + Write`: a serial port, a TCP socket to QEMU, an in-memory pipe) to
//! greet the controller, upload a printer configuration and a slice, start, pause, resume or
//! abort the job, and receive its status and telemetry.
//!
//! The stream's `read` may block only briefly: `WouldBlock`, `TimedOut`, `Interrupted` and
//! `Ok(0)` all mean "nothing yet" (a serial port with a short read timeout behaves so).

use std::collections::VecDeque;
use std::fmt;
use std::io::{self, ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use hollowpath::link::endpoint::{Link, LinkConfig, LinkStats};
use hollowpath::link::error::LinkError;
use hollowpath::link::message::{
    check_protocol, Capacities, CtrlMsg, HostMsg, RemoteError, Version, PROTOCOL_VERSION,
};
use hollowpath::link::upload::{self, upload};
use hollowpath::motion::config::PrinterConfig;
use hollowpath::Slice;

use crate::slice_file::Contours;

/// Frames the host keeps unacknowledged.
pub const WINDOW: usize = 4;
/// Longest wait for the controller to accept an uploaded slice. The controller serves its
/// link while it plans (its receive interrupt), so a lost acceptance comes again within
/// its retransmit time; the bound is for a controller that serves no link while it plans
/// (minutes on an emulated one).
pub const SLICE_WAIT: Duration = Duration::from_secs(300);
/// The host's end of the link.
pub type HostLink = Link<HostMsg, CtrlMsg, WINDOW>;

/// Why a host-side step failed.
#[derive(Debug)]
pub enum ClientError {
    /// The byte stream failed.
    Io(io::Error),
    /// The link refused (a protocol mismatch, a message too large, ...).
    Link(LinkError),
    /// The controller refused, with the core's typed error.
    Remote(RemoteError),
    /// A coordinate of the slice cannot be sent (the core's error).
    Slice(hollowpath::Error),
    /// No answer within the timeout.
    Timeout {
        /// What was awaited.
        waiting_for: &'static str,
    },
}

impl fmt::Display for ClientError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClientError::Io(e) => write!(f, "link: {e}"),
            ClientError::Link(e) => e.fmt(f),
            ClientError::Remote(e) => write!(f, "the controller refused: {e}"),
            ClientError::Slice(e) => e.fmt(f),
            ClientError::Timeout { waiting_for } => {
                write!(f, "link: no {waiting_for} from the controller in time")
            }
        }
    }
}

impl std::error::Error for ClientError {}

impl From<io::Error> for ClientError {
    fn from(e: io::Error) -> Self {
        ClientError::Io(e)
    }
}

/// What the upload of a slice took.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UploadReport {
    /// Messages sent.
    pub messages: usize,
    /// Bytes written to the stream during the upload (retransmissions, acks included).
    pub bytes: u64,
    /// Holes and vertices the controller stored.
    pub holes: u8,
    /// Vertices the controller stored.
    pub vertices: u32,
}

/// The host's end of a session over `S`.
pub struct LinkClient<S> {
    stream: S,
    link: Box<HostLink>,
    start: Instant,
    /// Messages received and not yet taken.
    inbox: VecDeque<CtrlMsg>,
    /// Longest wait for one answer.
    pub timeout: Duration,
    written: u64,
    nonce: u8,
}

impl<S: Read + Write> LinkClient<S> {
    /// A client over `stream` with the link's timers `config`. It opens a new session
    /// (numbered from the clock), so a controller still in an older one follows.
    pub fn new(stream: S, config: LinkConfig) -> Self {
        let nonce = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_micros() as u8);
        let mut link = Box::new(HostLink::new(config));
        link.open(nonce);
        LinkClient {
            stream,
            link,
            start: Instant::now(),
            inbox: VecDeque::new(),
            timeout: Duration::from_secs(10),
            written: 0,
            nonce,
        }
    }

    fn now(&self) -> u64 {
        self.start.elapsed().as_micros() as u64
    }

    /// The link's counters (retransmissions among them).
    pub fn stats(&self) -> LinkStats {
        self.link.stats()
    }

    /// Bytes written to the stream so far.
    pub fn bytes_written(&self) -> u64 {
        self.written
    }

    /// Reads what has arrived, runs the timers and writes what is due. Returns whether any
    /// byte moved.
    pub fn pump(&mut self) -> Result<bool, ClientError> {
        let mut buf = [0u8; 1024];
        let mut moved = false;
        let n = match self.stream.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) =>
            {
                0
            }
            Err(e) => return Err(e.into()),
        };
        let now = self.now();
        let mut rest = &buf[..n];
        moved |= n > 0;
        while !rest.is_empty() {
            let (msg, r) = self.link.receive(now, rest);
            rest = r;
            match msg {
                Ok(Some(m)) => self.inbox.push_back(m),
                Ok(None) => {}
                Err(e) => return Err(ClientError::Link(e)),
            }
        }
        self.link.poll(now);
        while let Some(frame) = self.link.transmit(now) {
            self.stream.write_all(frame)?;
            self.written += frame.len() as u64;
            moved = true;
        }
        self.stream.flush()?;
        Ok(moved)
    }

    fn idle(&mut self, moved: bool) {
        if !moved {
            std::thread::sleep(Duration::from_micros(200));
        }
    }

    /// Queues a message, pumping while the window is full.
    pub fn send(&mut self, msg: &HostMsg) -> Result<(), ClientError> {
        let t = Instant::now();
        loop {
            match self.link.send(msg) {
                Ok(()) => {
                    self.pump()?;
                    return Ok(());
                }
                Err(LinkError::WindowFull) if t.elapsed() < self.timeout => {
                    let moved = self.pump()?;
                    self.idle(moved);
                }
                Err(LinkError::WindowFull) => {
                    return Err(ClientError::Timeout {
                        waiting_for: "acknowledgement",
                    })
                }
                Err(e) => return Err(ClientError::Link(e)),
            }
        }
    }

    /// The next message from the controller within `timeout` (`None` if none came).
    pub fn next_message(&mut self, timeout: Duration) -> Result<Option<CtrlMsg>, ClientError> {
        let t = Instant::now();
        loop {
            if let Some(m) = self.inbox.pop_front() {
                return Ok(Some(m));
            }
            if t.elapsed() >= timeout {
                return Ok(None);
            }
            let moved = self.pump()?;
            self.idle(moved);
        }
    }

    /// Pumps until every message sent is acknowledged.
    pub fn flush(&mut self) -> Result<(), ClientError> {
        let t = Instant::now();
        while self.link.in_flight() > 0 {
            if t.elapsed() >= self.timeout {
                return Err(ClientError::Timeout {
                    waiting_for: "acknowledgement",
                });
            }
            let moved = self.pump()?;
            self.idle(moved);
        }
        Ok(())
    }

    /// Waits for the first message `pick` takes (others stay in the inbox, in order); a
    /// [`CtrlMsg::Error`] before it is the step's failure.
    fn wait_for<T>(
        &mut self,
        waiting_for: &'static str,
        mut pick: impl FnMut(&CtrlMsg) -> Option<T>,
    ) -> Result<T, ClientError> {
        let t = Instant::now();
        loop {
            if let Some(k) = self
                .inbox
                .iter()
                .position(|m| pick(m).is_some() || matches!(m, CtrlMsg::Error(_)))
            {
                let m = self.inbox.remove(k).expect("position is in the inbox");
                if let CtrlMsg::Error(e) = m {
                    return Err(ClientError::Remote(e));
                }
                return Ok(pick(&m).expect("picked above"));
            }
            if t.elapsed() >= self.timeout {
                return Err(ClientError::Timeout { waiting_for });
            }
            let moved = self.pump()?;
            self.idle(moved);
        }
    }

    /// Opens the session: sends our hello, and checks the controller's protocol version.
    /// If no answer comes within a second, the session is opened again under another nonce
    /// (the controller may have had the one first drawn) and the hello sent once more.
    pub fn hello(&mut self) -> Result<(Version, Capacities), ClientError> {
        let full = self.timeout;
        self.timeout = full.min(Duration::from_secs(1));
        let first = self.try_hello();
        self.timeout = full;
        match first {
            Err(ClientError::Timeout { .. }) => {
                self.nonce = self.nonce.wrapping_add(1);
                self.link.open(self.nonce);
                self.inbox.clear();
                self.try_hello()
            }
            other => other,
        }
    }

    fn try_hello(&mut self) -> Result<(Version, Capacities), ClientError> {
        self.send(&HostMsg::Hello {
            protocol: PROTOCOL_VERSION,
        })?;
        let (protocol, firmware, capacities) = self.wait_for("hello", |m| match *m {
            CtrlMsg::Hello {
                protocol,
                firmware,
                capacities,
            } => Some((protocol, firmware, capacities)),
            _ => None,
        })?;
        check_protocol(protocol).map_err(ClientError::Link)?;
        Ok((firmware, capacities))
    }

    /// Sends the printer configuration (in [`HostMsg::Printer`] chunks) and waits for the
    /// controller to accept it.
    pub fn send_printer(&mut self, printer: &PrinterConfig) -> Result<(), ClientError> {
        for msg in upload::printer(printer).map_err(ClientError::Link)? {
            self.send(&msg)?;
        }
        self.wait_for("printer acceptance", |m| {
            matches!(m, CtrlMsg::PrinterAccepted).then_some(())
        })
    }

    /// Uploads `slice` (to be printed in `layers` layers) and waits until the controller
    /// has built and validated it.
    pub fn upload(&mut self, slice: &Slice, layers: u16) -> Result<UploadReport, ClientError> {
        self.upload_messages(upload(slice, layers))
    }

    /// Uploads a slice file's contours as they are, not validated on the host (the
    /// controller's verdict: a slice the host would refuse comes back refused with the same
    /// typed error), and waits until the controller has built and validated it.
    pub fn upload_contours(
        &mut self,
        c: &Contours,
        layers: u16,
    ) -> Result<UploadReport, ClientError> {
        let holes = c.hole_refs();
        self.upload_messages(upload::upload_contours(
            &c.wall.0, c.wall.1, &holes, c.settings, layers,
        ))
    }

    fn upload_messages(
        &mut self,
        msgs: impl Iterator<Item = Result<HostMsg, hollowpath::Error>>,
    ) -> Result<UploadReport, ClientError> {
        let before = self.written;
        let mut messages = 0;
        for msg in msgs {
            self.send(&msg.map_err(ClientError::Slice)?)?;
            messages += 1;
        }
        // The acceptance goes out just before the controller plans the slice. It serves its
        // link meanwhile from an interrupt; one that does not would send a lost acceptance
        // again only after the planning.
        let full = self.timeout;
        self.timeout = full.max(SLICE_WAIT);
        let accepted = self.wait_for("slice acceptance", |m| match *m {
            CtrlMsg::SliceAccepted { holes, vertices } => Some((holes, vertices)),
            _ => None,
        });
        self.timeout = full;
        let (holes, vertices) = accepted?;
        Ok(UploadReport {
            messages,
            bytes: self.written - before,
            holes,
            vertices,
        })
    }

    /// Starts the job (after [`upload`](Self::upload)).
    pub fn start(&mut self) -> Result<(), ClientError> {
        self.send(&HostMsg::Start)?;
        self.flush()
    }

    /// Pauses the job.
    pub fn pause(&mut self) -> Result<(), ClientError> {
        self.send(&HostMsg::Pause)?;
        self.flush()
    }

    /// Resumes the job.
    pub fn resume(&mut self) -> Result<(), ClientError> {
        self.send(&HostMsg::Resume)?;
        self.flush()
    }

    /// Aborts the job.
    pub fn abort(&mut self) -> Result<(), ClientError> {
        self.send(&HostMsg::Abort)?;
        self.flush()
    }
}

/// `slice` as the controller rebuilds it from the upload (whole micrometres, contours over
/// [`SIMPLIFY_ABOVE_VERTICES`](hollowpath::config::SIMPLIFY_ABOVE_VERTICES) simplified):
/// the slice the controller plans and prints, so the host's simulation of it is the
/// controller's to the bit.
pub fn as_uploaded(slice: &Slice, layers: u16) -> Result<Slice, ClientError> {
    use hollowpath::config::{MAX_HOLES, MAX_VERTICES};
    use hollowpath::link::assemble::SliceAssembler;
    let mut asm: Box<SliceAssembler<MAX_HOLES, { (MAX_HOLES + 1) * MAX_VERTICES }>> =
        Box::default();
    for m in upload(slice, layers) {
        match m.map_err(ClientError::Slice)? {
            HostMsg::Job { settings, layers } => asm.begin(settings, layers),
            HostMsg::Feature {
                feature,
                material,
                vertices,
            } => asm
                .feature(feature, material, vertices)
                .map_err(ClientError::Link)?,
            HostMsg::Contour(c) => asm.chunk(&c).map_err(ClientError::Link)?,
            HostMsg::EndSlice { holes } => {
                asm.end(holes).map_err(ClientError::Link)?;
            }
            _ => {}
        }
    }
    match asm.build() {
        Some(r) => r.map_err(ClientError::Slice),
        None => Err(ClientError::Link(LinkError::UnexpectedMessage)),
    }
}
