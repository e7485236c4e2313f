//! The controller's end of a session: the link, the handshake, the printer configuration and
//! the slice assembler, behind one `receive` / `poll` / `transmit` loop.

use heapless::Deque;

use super::assemble::SliceAssembler;
use super::endpoint::{Link, LinkConfig, LinkStats};
use super::error::LinkError;
use super::message::{
    check_protocol, Capacities, CtrlMsg, HostMsg, PrinterChunk, RemoteError, Version,
    PRINTER_BYTES, PROTOCOL_VERSION,
};
use crate::config::{CHANNELS, MAX_HOLES, MAX_VERTICES};
use crate::motion::config::PrinterConfig;
use crate::slice::{Slice, SliceStore};

// The capacities go out as `u16` holes and `u32` vertices: HOLES <= MAX_HOLES and POINTS <=
// u32::MAX are asserted by the assembler; a slice stores at most this many vertices.
const _: () = assert!(MAX_HOLES <= u16::MAX as usize);
const _: () = assert!((MAX_HOLES + 1) * MAX_VERTICES <= u32::MAX as usize);

/// Replies the controller queues itself (hello, acceptances, refusals) while the send window
/// is full.
pub const REPLIES: usize = 8;

/// What a host's message means to the application. Refusals have already been queued to the
/// host when they are returned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A host opened a session (with our protocol version).
    Hello,
    /// A valid printer configuration arrived ([`Controller::printer`]).
    Printer,
    /// A whole slice arrived: call [`Controller::finish_slice`] to build and validate it.
    SliceReady,
    /// Start printing the accepted slice.
    Start,
    /// Pause.
    Pause,
    /// Resume.
    Resume,
    /// Abort: valves shut, motion dropped.
    Abort,
    /// A message was refused (already reported to the host).
    Refused(RemoteError),
}

/// The controller's end: a [`Link`] of `W` frames, a [`SliceAssembler`] of `HOLES` holes and
/// `POINTS` vertices, the printer configuration. `const fn new`: it may live in a `static`.
///
/// ```text
/// loop {
///     let now = micros();
///     let mut bytes = uart.read_available();
///     while !bytes.is_empty() {
///         let (event, rest) = ctrl.receive(now, bytes);
///         let stalled = event.is_none() && rest.len() == bytes.len();
///         bytes = rest;
///         match event {
///             Some(Event::SliceReady) => if let Ok(slice) = ctrl.finish_slice(&mut store) { plan(slice) },
///             Some(Event::Start) => start(),
///             ...
///         }
///         if stalled { break } // replies wait for the window: keep the bytes for later
///     }
///     ctrl.poll(now);
///     while let Some(frame) = ctrl.transmit(now) { uart.write_all(frame) }
///     if ctrl.is_lost(now) { close_valves() }
/// }
/// ```
pub struct Controller<const HOLES: usize, const POINTS: usize, const W: usize> {
    link: Link<CtrlMsg, HostMsg, W>,
    assembler: SliceAssembler<HOLES, POINTS>,
    firmware: Version,
    greeted: bool,
    printer: Option<PrinterConfig>,
    /// The printer configuration's encoding as its chunks arrive.
    printer_bytes: [u8; PRINTER_BYTES],
    /// Bytes of it received (`None`: a chunk was refused; wait for one at offset 0).
    printer_len: Option<usize>,
    accepted: bool,
    /// A whole slice waits for `finish_slice`: nothing more is taken before.
    slice_pending: bool,
    replies: Deque<CtrlMsg, REPLIES>,
    dropped: u32,
    /// The link's session count when last seen.
    sessions: u32,
}

impl<const HOLES: usize, const POINTS: usize, const W: usize> Controller<HOLES, POINTS, W> {
    /// A controller of firmware `firmware`, waiting for a host's hello.
    pub const fn new(config: LinkConfig, firmware: Version) -> Self {
        Controller {
            link: Link::new(config),
            assembler: SliceAssembler::new(),
            firmware,
            greeted: false,
            printer: None,
            printer_bytes: [0; PRINTER_BYTES],
            printer_len: Some(0),
            accepted: false,
            slice_pending: false,
            replies: Deque::new(),
            dropped: 0,
            sessions: 0,
        }
    }

    /// What the controller tells the host it can take.
    pub fn capacities(&self) -> Capacities {
        Capacities {
            max_holes: HOLES as u16,
            max_vertices: MAX_VERTICES as u32,
            max_points: POINTS as u32,
            channels: CHANNELS as u8,
        }
    }

    /// The accepted printer configuration.
    pub fn printer(&self) -> Option<&PrinterConfig> {
        self.printer.as_ref()
    }

    /// The job's layer count.
    pub fn layers(&self) -> u16 {
        self.assembler.layers()
    }

    /// The link's counters.
    pub fn stats(&self) -> LinkStats {
        self.link.stats()
    }

    /// The link's timers.
    pub fn link_config(&self) -> LinkConfig {
        self.link.config()
    }

    /// When a valid frame last arrived (`None`: none since the session opened).
    pub fn last_heard(&self) -> Option<u64> {
        self.link.last_heard()
    }

    /// Replies dropped because [`REPLIES`] were already waiting: always 0, as
    /// [`receive`](Self::receive) holds back while they might not fit.
    pub fn replies_dropped(&self) -> u32 {
        self.dropped
    }

    fn reply(&mut self, msg: CtrlMsg) {
        self.flush();
        let sent = self.replies.is_empty() && self.link.send(&msg).is_ok();
        // `receive` takes no message while fewer than two replies have room, and a message
        // makes at most two: the push cannot fail (counted if it ever did).
        if !sent && self.replies.push_back(msg).is_err() {
            self.dropped += 1;
        }
    }

    fn refuse(&mut self, e: RemoteError) -> Option<Event> {
        self.reply(CtrlMsg::Error(e));
        Some(Event::Refused(e))
    }

    fn flush(&mut self) {
        while let Some(msg) = self.replies.front() {
            if self.link.send(msg).is_err() {
                break;
            }
            self.replies.pop_front();
        }
    }

    /// Sends an application message (status, telemetry, a machine fault), after any queued
    /// reply. [`LinkError::WindowFull`]: send it again later.
    pub fn send(&mut self, msg: &CtrlMsg) -> Result<(), LinkError> {
        self.flush();
        if !self.replies.is_empty() {
            return Err(LinkError::WindowFull);
        }
        self.link.send(msg)
    }

    /// Consumes bytes up to the first message that means something to the application (or
    /// all of them); returns it with the bytes not consumed yet. While replies wait for room
    /// in the send window ([`REPLIES`] of them, the peer not acknowledging), nothing is
    /// consumed: [`transmit`](Self::transmit), and feed the bytes again later. Nor after
    /// [`Event::SliceReady`] until [`finish_slice`](Self::finish_slice) was called, so that a
    /// start behind it finds the slice accepted or refused.
    pub fn receive<'a>(&mut self, now: u64, bytes: &'a [u8]) -> (Option<Event>, &'a [u8]) {
        self.flush();
        if self.slice_pending || self.replies.len() + 2 > REPLIES {
            return (None, bytes);
        }
        let (msg, rest) = self.link.receive(now, bytes);
        if self.link.stats().sessions != self.sessions {
            // A host opened a new session: what was queued for the old one is void.
            self.sessions = self.link.stats().sessions;
            self.replies.clear();
            self.greeted = false;
        }
        let event = match msg {
            Ok(Some(msg)) => self.on_message(msg),
            Ok(None) => None,
            Err(e) => self.refuse(RemoteError::Link(e)),
        };
        (event, rest)
    }

    fn on_message(&mut self, msg: HostMsg) -> Option<Event> {
        if let HostMsg::Hello { protocol } = msg {
            self.reply(CtrlMsg::Hello {
                protocol: PROTOCOL_VERSION,
                firmware: self.firmware,
                capacities: self.capacities(),
            });
            self.greeted = check_protocol(protocol).is_ok();
            return match check_protocol(protocol) {
                Ok(()) => Some(Event::Hello),
                Err(e) => self.refuse(RemoteError::Link(e)),
            };
        }
        if !self.greeted {
            return self.refuse(RemoteError::Link(LinkError::NotGreeted));
        }
        let linked = |r: Result<(), LinkError>| r.err().map(RemoteError::Link);
        let refused = match msg {
            HostMsg::Hello { .. } => None,
            HostMsg::Printer(chunk) => match self.printer_chunk(&chunk) {
                Ok(None) => None,
                Ok(Some(cfg)) => match cfg.validate() {
                    Ok(()) => {
                        self.printer = Some(cfg);
                        self.reply(CtrlMsg::PrinterAccepted);
                        return Some(Event::Printer);
                    }
                    Err(e) => Some(RemoteError::Printer(e.into())),
                },
                Err(e) => Some(RemoteError::Link(e)),
            },
            HostMsg::Job { settings, layers } => {
                self.accepted = false;
                self.assembler.begin(settings, layers);
                None
            }
            HostMsg::Feature {
                feature,
                material,
                vertices,
            } => linked(self.assembler.feature(feature, material, vertices)),
            HostMsg::Contour(chunk) => linked(self.assembler.chunk(&chunk)),
            HostMsg::EndSlice { holes } => match self.assembler.end(holes) {
                Ok(true) => {
                    self.slice_pending = true;
                    return Some(Event::SliceReady);
                }
                Ok(false) => None,
                Err(e) => Some(RemoteError::Link(e)),
            },
            HostMsg::Start if self.accepted && self.printer.is_some() => return Some(Event::Start),
            HostMsg::Start => Some(RemoteError::Link(LinkError::UnexpectedMessage)),
            HostMsg::Pause => return Some(Event::Pause),
            HostMsg::Resume => return Some(Event::Resume),
            HostMsg::Abort => return Some(Event::Abort),
        };
        refused.and_then(|e| self.refuse(e))
    }

    /// Takes a chunk of the printer configuration; the configuration once its last chunk
    /// arrived. A chunk at offset 0 starts a new one; a chunk out of place is refused, and so
    /// are the chunks after it up to the next offset 0 (silently: one refusal is reported).
    fn printer_chunk(&mut self, c: &PrinterChunk) -> Result<Option<PrinterConfig>, LinkError> {
        if c.offset == 0 {
            self.printer_len = Some(0);
        }
        let Some(len) = self.printer_len else {
            return Ok(None);
        };
        let (offset, total) = (usize::from(c.offset), usize::from(c.total));
        let end = offset + c.data.len();
        if offset != len || total > PRINTER_BYTES || end > total || c.data.is_empty() {
            self.printer_len = None;
            return Err(LinkError::PrinterChunk {
                // `len <= PRINTER_BYTES <= u16::MAX` (asserted in `message`).
                expected: len as u16,
                got: c.offset,
                total: c.total,
            });
        }
        self.printer_bytes[offset..end].copy_from_slice(&c.data);
        if end < total {
            self.printer_len = Some(end);
            return Ok(None);
        }
        self.printer_len = Some(0);
        postcard::from_bytes::<PrinterConfig>(&self.printer_bytes[..total])
            .map(Some)
            .map_err(|_| LinkError::MessageDecode)
    }

    /// Builds and validates the slice after [`Event::SliceReady`] into `out` (and checks it
    /// against the printer, if one was configured). The outcome is reported to the host
    /// ([`CtrlMsg::SliceAccepted`] or the error); only an accepted slice may be started. On
    /// error `out` holds no slice.
    pub fn finish_slice<'s>(&mut self, out: &'s mut SliceStore) -> Result<&'s Slice, RemoteError> {
        self.slice_pending = false;
        let built = match self.assembler.build_into(out) {
            None => Err(RemoteError::Link(LinkError::UnexpectedMessage)),
            Some(Err(e)) => Err(RemoteError::Slice(e)),
            Some(Ok(slice)) => match self.printer.as_ref().map(|p| p.check_slice(slice)) {
                Some(Err(e)) => Err(RemoteError::Printer(e.into())),
                _ => {
                    let vertices = slice.wall().points().len()
                        + slice
                            .holes()
                            .iter()
                            .map(|h| h.points().len())
                            .sum::<usize>();
                    // At most MAX_HOLES (<= 64) holes, (MAX_HOLES + 1) * MAX_VERTICES
                    // vertices (asserted above).
                    Ok((slice.holes().len() as u8, vertices as u32))
                }
            },
        };
        match built {
            Ok((holes, vertices)) => {
                self.accepted = true;
                self.reply(CtrlMsg::SliceAccepted { holes, vertices });
                out.get()
                    .ok_or(RemoteError::Link(LinkError::UnexpectedMessage))
            }
            Err(e) => {
                out.clear();
                self.accepted = false;
                self.reply(CtrlMsg::Error(e));
                Err(e)
            }
        }
    }

    /// Runs the timers; returns when to call again at the latest.
    pub fn poll(&mut self, now: u64) -> Option<u64> {
        self.flush();
        self.link.poll(now)
    }

    /// The next frame to write, if any (call until `None`).
    pub fn transmit(&mut self, now: u64) -> Option<&[u8]> {
        self.flush();
        self.link.transmit(now)
    }

    /// Whether the host went silent for longer than the watchdog allows: close the valves.
    pub fn is_lost(&self, now: u64) -> bool {
        self.link.is_lost(now)
    }
}
