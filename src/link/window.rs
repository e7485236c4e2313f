//! Go-back-N: the sender's window of unacknowledged frames and the receiver's expected
//! sequence number (Klipper's host-MCU scheme: sequence numbers, cumulative acks,
//! retransmission on timeout, plus a nak that asks for it at once).

use super::error::LinkError;
use super::frame::MAX_PAYLOAD;

// A slot's payload length is a `u16`.
const _: () = assert!(MAX_PAYLOAD <= u16::MAX as usize);

/// Sequence numbers are a wrapping `u8`: a window must be less than half of their range for
/// "ahead" and "behind" to be told apart.
pub const MAX_WINDOW: usize = 127;

/// The frames sent and not yet acknowledged, `W` of them at most, kept as encoded messages
/// (the frame around them is rebuilt on every transmission, with the latest ack).
#[derive(Debug)]
pub struct TxWindow<const W: usize> {
    slots: [[u8; MAX_PAYLOAD]; W],
    lens: [u16; W],
    /// Ring index of the oldest unacknowledged frame.
    head: usize,
    /// Its sequence number.
    base: u8,
    /// Frames queued (sent or not).
    len: usize,
    /// Offset from the oldest of the next frame to transmit.
    next: usize,
    /// Frames (from the oldest) transmitted at least once.
    sent: usize,
    /// When the oldest transmitted frame is due for retransmission.
    deadline: Option<u64>,
}

impl<const W: usize> Default for TxWindow<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> TxWindow<W> {
    const VALID: () = assert!(W >= 1 && W <= MAX_WINDOW, "window of 1 to 127 frames");

    /// An empty window (`const`: it may live in a `static`).
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::VALID;
        TxWindow {
            slots: [[0; MAX_PAYLOAD]; W],
            lens: [0; W],
            head: 0,
            base: 0,
            len: 0,
            next: 0,
            sent: 0,
            deadline: None,
        }
    }

    /// Whether another frame fits.
    pub fn has_room(&self) -> bool {
        self.len < W
    }

    /// Frames queued and not yet acknowledged.
    pub fn in_flight(&self) -> usize {
        self.len
    }

    /// Whether a frame waits for its (re)transmission.
    pub fn has_pending(&self) -> bool {
        self.next < self.len
    }

    /// The retransmission deadline.
    pub fn deadline(&self) -> Option<u64> {
        self.deadline
    }

    /// Queues a payload written by `write` (which returns its length, `None` if it does not
    /// fit); nothing is queued if the window is full or `write` failed.
    pub fn queue(
        &mut self,
        write: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Result<(), LinkError> {
        if !self.has_room() {
            return Err(LinkError::WindowFull);
        }
        let idx = (self.head + self.len) % W;
        match write(&mut self.slots[idx]) {
            Some(n) if n <= MAX_PAYLOAD => {
                self.lens[idx] = n as u16;
                self.len += 1;
                Ok(())
            }
            _ => Err(LinkError::MessageTooLarge),
        }
    }

    /// Takes a cumulative ack (the sequence number the peer expects next) and returns how
    /// many frames it acknowledged. An ack of frames never sent (or stale) is ignored.
    pub fn ack(&mut self, ack: u8, now: u64, rto: u64) -> usize {
        let d = ack.wrapping_sub(self.base) as usize;
        if d == 0 || d > self.sent {
            return 0;
        }
        self.head = (self.head + d) % W;
        // `d <= sent <= W <= MAX_WINDOW`: the cast cannot truncate.
        self.base = self.base.wrapping_add(d as u8);
        self.len -= d;
        self.sent -= d;
        self.next = self.next.saturating_sub(d);
        self.deadline = if self.sent > 0 {
            Some(now.saturating_add(rto))
        } else {
            None
        };
        d
    }

    /// A nak for `from`: go back to it if it is the oldest frame in flight (after the ack it
    /// carries). Returns whether it did.
    pub fn nak(&mut self, from: u8) -> bool {
        if from == self.base && self.sent > 0 {
            self.next = 0;
            true
        } else {
            false
        }
    }

    /// The retransmission timer at `now`: when it has run out, go back to the oldest frame
    /// and restart it. Returns whether it ran out.
    pub fn on_timer(&mut self, now: u64, rto: u64) -> bool {
        match self.deadline {
            Some(d) if now >= d && self.sent > 0 => {
                self.next = 0;
                self.deadline = Some(now.saturating_add(rto));
                true
            }
            _ => false,
        }
    }

    /// The next frame to transmit: its sequence number, payload and whether it is a
    /// retransmission. Starts the timer if none runs.
    pub fn next_to_send(&mut self, now: u64, rto: u64) -> Option<(u8, &[u8], bool)> {
        if self.next >= self.len {
            return None;
        }
        let off = self.next;
        let idx = (self.head + off) % W;
        let again = off < self.sent;
        self.next += 1;
        self.sent = self.sent.max(self.next);
        if self.deadline.is_none() || (again && off == 0) {
            self.deadline = Some(now.saturating_add(rto));
        }
        // `off < len <= W <= 127`: the cast cannot truncate.
        let seq = self.base.wrapping_add(off as u8);
        Some((seq, &self.slots[idx][..self.lens[idx] as usize], again))
    }

    /// Empties the window and starts again from sequence number 0.
    pub fn reset(&mut self) {
        self.head = 0;
        self.base = 0;
        self.len = 0;
        self.next = 0;
        self.sent = 0;
        self.deadline = None;
    }
}

/// What a data frame's sequence number is to the receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arrival {
    /// The one expected: deliver it.
    InOrder,
    /// Ahead of it (a frame before was lost): drop it, nak.
    Ahead,
    /// Behind it (already delivered; our ack was lost): drop it, ack again.
    Duplicate,
}

/// The receiver's side: the sequence number expected next and the acks owed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RxState {
    /// The sequence number expected next (what every frame we send acknowledges).
    pub expected: u8,
    /// An ack is owed.
    pub ack_due: bool,
    /// A nak is owed.
    pub nak_due: bool,
    /// A nak was sent for `expected` (one per gap: the sender goes back once).
    nak_sent: bool,
}

impl RxState {
    /// A receiver expecting sequence number 0.
    pub const fn new() -> RxState {
        RxState {
            expected: 0,
            ack_due: false,
            nak_due: false,
            nak_sent: false,
        }
    }

    /// Classifies a data frame and updates the acks owed; an in-order frame advances
    /// `expected`.
    pub fn arrive(&mut self, seq: u8) -> Arrival {
        let d = seq.wrapping_sub(self.expected) as usize;
        if d == 0 {
            self.expected = self.expected.wrapping_add(1);
            self.ack_due = true;
            self.nak_sent = false;
            Arrival::InOrder
        } else if d <= MAX_WINDOW {
            if !self.nak_sent {
                self.nak_due = true;
                self.nak_sent = true;
            }
            Arrival::Ahead
        } else {
            self.ack_due = true;
            Arrival::Duplicate
        }
    }
}
