//! The application's side of the link: the [`Controller`], the bytes it has not consumed
//! yet, the messages waiting for room in the send window, and the job's status.

use heapless::Deque;

use crate::link::controller::{Controller, Event};
use crate::link::message::{CtrlMsg, Phase, Status, StopReport};

use super::io::Io;

/// Application messages (status, telemetry, errors) waiting for the send window.
pub const OUTBOX: usize = 16;

/// Bytes read from the stream at a time.
const RX: usize = 128;

/// The link side of the application (see the module docs).
pub struct Session<const HOLES: usize, const POINTS: usize, const W: usize> {
    /// The controller's end of the link.
    pub ctrl: Controller<HOLES, POINTS, W>,
    rx: [u8; RX],
    rx_start: usize,
    rx_end: usize,
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

    /// The next event from the bytes that arrived, reading more when all were consumed.
    pub fn next_event<I: Io>(&mut self, io: &mut I) -> Option<Event> {
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
