//! The application's side of the link: the [`Controller`], the bytes it has not consumed
//! yet, the events it decoded and the application has not taken yet, the messages waiting
//! for room in the send window, and the job's status.
//!
//! A session can be served from two places: the application's own loop
//! ([`next_event`](Session::next_event), [`flush`](Session::flush)) and, on a controller,
//! an interrupt ([`serve`](Session::serve)) that keeps the link answering (acks,
//! retransmissions, the host's messages decoded into [`events`](Session::has_events))
//! while the application plans or builds a layer for seconds. The platform keeps the
//! session behind a lock ([`Shared`](super::shared::Shared)) that both take.

use heapless::Deque;

use crate::link::controller::{Controller, Event};
use crate::link::error::LinkError;
use crate::link::message::{CtrlMsg, Phase, RemoteError, Status, StopReport};

use super::io::Io;

/// Application messages (status, telemetry, errors) waiting for the send window.
pub const OUTBOX: usize = 16;

/// Bytes read from the stream at a time.
const RX: usize = 128;

/// Events decoded and not taken by the application yet. While it is full, no more bytes
/// are consumed (they wait in the platform's receive buffer, or the link retransmits), so
/// no event is ever dropped.
pub const EVENTS: usize = 8;

/// The link side of the application (see the module docs).
pub struct Session<const HOLES: usize, const POINTS: usize, const W: usize> {
    /// The controller's end of the link.
    pub ctrl: Controller<HOLES, POINTS, W>,
    rx: [u8; RX],
    rx_start: usize,
    rx_end: usize,
    events: Deque<Event, EVENTS>,
    outbox: Deque<CtrlMsg, OUTBOX>,
    /// Messages dropped because the outbox was full (statuses first).
    pub dropped: u32,
    /// The job's status as last reported.
    pub status: Status,
    /// How the last job stopped, told to every host that greets us until the next job
    /// starts.
    pub report_on_hello: Option<StopReport>,
}

impl<const HOLES: usize, const POINTS: usize, const W: usize> Session<HOLES, POINTS, W> {
    /// A session around `ctrl`, idle.
    pub const fn new(ctrl: Controller<HOLES, POINTS, W>) -> Self {
        Session {
            ctrl,
            rx: [0; RX],
            rx_start: 0,
            rx_end: 0,
            events: Deque::new(),
            outbox: Deque::new(),
            dropped: 0,
            status: Status {
                phase: Phase::Idle,
                layer: 0,
                layers: 0,
                percent: 0,
            },
            report_on_hello: None,
        }
    }

    /// The next event: the oldest one decoded already, else the next from the bytes that
    /// arrived (reading more when all were consumed).
    pub fn next_event<I: Io>(&mut self, io: &mut I) -> Option<Event> {
        if let Some(e) = self.events.pop_front() {
            return Some(e);
        }
        self.decode(io)
    }

    /// Whether events wait for the application ([`next_event`](Self::next_event)).
    pub fn has_events(&self) -> bool {
        !self.events.is_empty()
    }

    /// Serves the link from outside the application's loop (a controller's receive or
    /// timer interrupt): decodes what arrived into the event queue (until it is full),
    /// moves queued messages into the window, runs the timers and writes what is due; the
    /// link's next deadline.
    pub fn serve<I: Io>(&mut self, io: &mut I) -> Option<u64> {
        while !self.events.is_full() {
            let Some(e) = self.decode(io) else { break };
            // Room checked above: cannot fail.
            if let Err(e) = self.events.push_back(e) {
                self.events_lost(e);
            }
        }
        self.flush(io)
    }

    /// An event that found no room (unreachable: [`serve`](Self::serve) checks first).
    /// The host is told its message was not taken, so nothing passes silently.
    fn events_lost(&mut self, _e: Event) {
        self.dropped += 1;
        self.send(CtrlMsg::Error(RemoteError::Link(
            LinkError::UnexpectedMessage,
        )));
    }

    /// The next event from the bytes that arrived, reading more when all were consumed.
    fn decode<I: Io>(&mut self, io: &mut I) -> Option<Event> {
        let now = io.now_us();
        loop {
            if self.rx_start == self.rx_end {
                self.rx_start = 0;
                self.rx_end = io.read(&mut self.rx);
                if self.rx_end == 0 {
                    return None;
                }
            }
            let bytes = &self.rx[self.rx_start..self.rx_end];
            let (event, rest) = self.ctrl.receive(now, bytes);
            let consumed = bytes.len() - rest.len();
            self.rx_start += consumed;
            if let Some(e) = event {
                if e == Event::Hello {
                    if let Some(r) = self.report_on_hello {
                        self.send(CtrlMsg::Stopped(r));
                    }
                }
                return Some(e);
            }
            if consumed == 0 {
                // The controller holds back (replies waiting for the window): later.
                return None;
            }
        }
    }

    /// Queues an application message for the host.
    pub fn send(&mut self, msg: CtrlMsg) {
        if self.outbox.is_full() {
            // Make room by dropping the oldest status (telemetry and errors are kept).
            let k = self
                .outbox
                .iter()
                .position(|m| matches!(m, CtrlMsg::Status(_)));
            match k {
                Some(k) => {
                    let n = self.outbox.len();
                    for i in 0..n {
                        if let Some(m) = self.outbox.pop_front() {
                            // Back into the room it was taken from: cannot fail (counted
                            // if it ever did).
                            if i != k && self.outbox.push_back(m).is_err() {
                                self.dropped += 1;
                            }
                        }
                    }
                    self.dropped += 1;
                }
                None => {
                    self.dropped += 1;
                    return;
                }
            }
        }
        // Room was made above: cannot fail (counted if it ever did).
        if self.outbox.push_back(msg).is_err() {
            self.dropped += 1;
        }
    }

    /// Reports a status (phase, layer, percent).
    pub fn report(&mut self, phase: Phase, layer: u16, layers: u16, percent: u8) {
        self.status = Status {
            phase,
            layer,
            layers,
            percent,
        };
        self.send(CtrlMsg::Status(self.status));
    }

    /// Moves queued messages into the send window, runs the link's timers and writes what
    /// is due; the link's next deadline.
    pub fn flush<I: Io>(&mut self, io: &mut I) -> Option<u64> {
        let now = io.now_us();
        while let Some(m) = self.outbox.front() {
            if self.ctrl.send(m).is_err() {
                break;
            }
            self.outbox.pop_front();
        }
        let next = self.ctrl.poll(now);
        while let Some(frame) = self.ctrl.transmit(now) {
            io.write(frame);
        }
        next
    }

    /// Whether messages wait for the window.
    pub fn pending(&self) -> usize {
        self.outbox.len()
    }
}
