//! One end of the link: messages in, messages out, over bytes, with time passed in.

use core::marker::PhantomData;

use serde::de::DeserializeOwned;
use serde::Serialize;

use super::error::LinkError;
use super::frame::{self, Feed, FrameAccumulator, Kind, MAX_FRAME};
use super::watchdog::Watchdog;
use super::window::{Arrival, RxState, TxWindow};

/// The link's timers, microseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkConfig {
    /// A frame not acknowledged this long after it was sent is sent again (with every frame
    /// after it: go-back-N).
    pub retransmit_us: u64,
    /// An idle side sends an ack this often, so the peer's watchdog sees it alive (0: never).
    pub keepalive_us: u64,
    /// No valid frame for this long is "link lost" ([`Link::is_lost`]; 0: never).
    pub watchdog_us: u64,
}

impl LinkConfig {
    /// Timers for a line of `baud` (8N1, 10 bits a byte) and a window of `window` frames:
    /// the retransmission timeout is twice a full window of the largest frames plus 20 ms,
    /// the keepalive a quarter of the watchdog, which is four retransmission timeouts and
    /// at least a second.
    pub const fn for_baud(baud: u32, window: usize) -> LinkConfig {
        let frame_us =
            (MAX_FRAME as u64) * 10 * 1_000_000 / (if baud == 0 { 1 } else { baud as u64 });
        let retransmit_us = 2 * (window as u64) * frame_us + 20_000;
        let watchdog_us = if 4 * retransmit_us > 1_000_000 {
            4 * retransmit_us
        } else {
            1_000_000
        };
        LinkConfig {
            retransmit_us,
            keepalive_us: watchdog_us / 4,
            watchdog_us,
        }
    }
}

/// Counters of one end.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkStats {
    /// Frames written (data, acks, naks).
    pub frames_sent: u32,
    /// Data frames sent again (after a timeout or a nak).
    pub retransmissions: u32,
    /// Retransmission timeouts that ran out.
    pub timeouts: u32,
    /// Naks sent.
    pub naks_sent: u32,
    /// Naks received that made this side go back.
    pub naks_received: u32,
    /// Valid frames received.
    pub frames_received: u32,
    /// Messages delivered to the application.
    pub delivered: u32,
    /// Frames dropped for a bad CRC.
    pub crc_errors: u32,
    /// Frames dropped as not COBS, malformed or overfull.
    pub framing_errors: u32,
    /// Data frames received ahead of the one expected (dropped).
    pub out_of_order: u32,
    /// Data frames received again (dropped, acked).
    pub duplicates: u32,
    /// Sessions the peer opened ([`Link::open`]).
    pub sessions: u32,
}

/// One end of the link: sends `Out` messages and receives `In` messages, in order and exactly
/// once, over any byte stream, with a window of `W` unacknowledged frames.
///
/// No I/O and no clock: bytes and the time (`now`, microseconds) go in, frames come out.
/// `const fn new`, so it may live in a `static` (`W` from 1 to 127, checked at compile time;
/// each frame of the window keeps [`MAX_PAYLOAD`](frame::MAX_PAYLOAD) bytes, and the receive
/// and transmit buffers one [`MAX_FRAME`] each).
///
/// Sequence numbers are a wrapping `u8`: a line may repeat or delay frames, but not by more
/// than 127 frames of the other traffic (a serial line keeps their order; the tests' lossy
/// line delays up to 20 ms). The retransmission timeout is fixed, not backed off.
///
/// A firmware loop:
///
/// ```text
/// loop {
///     let now = micros();
///     let mut bytes = uart.read_available();
///     while !bytes.is_empty() {
///         let (msg, rest) = link.receive(now, bytes);
///         bytes = rest;
///         if let Ok(Some(msg)) = msg { handle(msg) }
///     }
///     let deadline = link.poll(now);          // timers; the next time to call again
///     while let Some(frame) = link.transmit(now) { uart.write_all(frame) }
///     if link.is_lost(now) { close_valves() }
/// }
/// ```
pub struct Link<Out, In, const W: usize> {
    config: LinkConfig,
    tx: TxWindow<W>,
    rx: RxState,
    acc: FrameAccumulator<MAX_FRAME>,
    out: [u8; MAX_FRAME],
    watchdog: Watchdog,
    last_tx: Option<u64>,
    /// Our session's nonce while its opening frame is not yet acknowledged.
    opening: Option<u8>,
    /// The nonce of the session the peer opened.
    peer_session: Option<u8>,
    stats: LinkStats,
    _messages: PhantomData<fn(&Out) -> In>,
}

impl<Out: Serialize, In: DeserializeOwned, const W: usize> Link<Out, In, W> {
    /// A link at the start of a session (both ends start at sequence number 0).
    pub const fn new(config: LinkConfig) -> Self {
        Link {
            config,
            tx: TxWindow::new(),
            rx: RxState::new(),
            acc: FrameAccumulator::new(),
            out: [0; MAX_FRAME],
            watchdog: Watchdog::new(config.watchdog_us),
            last_tx: None,
            opening: None,
            peer_session: None,
            stats: LinkStats {
                frames_sent: 0,
                retransmissions: 0,
                timeouts: 0,
                naks_sent: 0,
                naks_received: 0,
                frames_received: 0,
                delivered: 0,
                crc_errors: 0,
                framing_errors: 0,
                out_of_order: 0,
                duplicates: 0,
                sessions: 0,
            },
            _messages: PhantomData,
        }
    }

    /// Forgets the session: an empty window, sequence numbers from 0, the watchdog disarmed
    /// (the counters stay).
    pub fn reset(&mut self) {
        self.tx.reset();
        self.rx = RxState::new();
        self.acc.clear();
        self.watchdog.disarm();
        self.last_tx = None;
        self.opening = None;
        self.peer_session = None;
    }

    /// Starts a new session, numbered `nonce`: [`reset`](Self::reset), and the first
    /// message sent goes as a [`Kind::Open`] frame, which makes the peer drop whatever
    /// session it had (its unacknowledged frames too) and start from sequence number 0. A
    /// host opens; the controller never needs to. `nonce` should differ from the last
    /// session's (a peer takes an opening frame of the nonce it has as a repeat).
    pub fn open(&mut self, nonce: u8) {
        self.reset();
        self.opening = Some(nonce);
    }

    /// The timers.
    pub fn config(&self) -> LinkConfig {
        self.config
    }

    /// The counters.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// Whether [`send`](Self::send) would take a message now.
    pub fn can_send(&self) -> bool {
        self.tx.has_room()
    }

    /// Messages sent and not yet acknowledged.
    pub fn in_flight(&self) -> usize {
        self.tx.in_flight()
    }

    /// Queues a message. [`LinkError::WindowFull`] (the message is untouched: send it again
    /// later) or [`LinkError::MessageTooLarge`].
    pub fn send(&mut self, msg: &Out) -> Result<(), LinkError> {
        self.tx
            .queue(|buf| postcard::to_slice(msg, buf).ok().map(|b| b.len()))
    }

    /// Consumes bytes up to the end of the first frame that delivers a message (or all of
    /// them) and returns the message, with the bytes not consumed yet. Bad frames are dropped
    /// and counted; `Err` only for a frame that passed its CRC and holds no message
    /// ([`LinkError::MessageDecode`]; it is acknowledged, so it does not come again).
    pub fn receive<'a>(
        &mut self,
        now: u64,
        mut bytes: &'a [u8],
    ) -> (Result<Option<In>, LinkError>, &'a [u8]) {
        while !bytes.is_empty() {
            let (feed, rest) = self.acc.feed(bytes);
            bytes = rest;
            let f = match feed {
                Feed::Consumed => continue,
                Feed::Error(LinkError::FrameCrc) => {
                    self.stats.crc_errors += 1;
                    continue;
                }
                Feed::Error(_) => {
                    self.stats.framing_errors += 1;
                    continue;
                }
                Feed::Frame(f) => f,
            };
            self.watchdog.feed(now);
            self.stats.frames_received += 1;
            if f.kind == Kind::Open {
                if self.peer_session != Some(f.ack) {
                    // A new session: the old one's frames either way are void.
                    self.tx.reset();
                    self.rx = RxState::new();
                    self.opening = None;
                    self.peer_session = Some(f.ack);
                    self.stats.sessions += 1;
                }
            } else if self.tx.ack(f.ack, now, self.config.retransmit_us) > 0 {
                self.opening = None;
            }
            match f.kind {
                Kind::Ack => {}
                Kind::Nak => {
                    if self.tx.nak(f.ack) {
                        self.stats.naks_received += 1;
                    }
                }
                Kind::Data | Kind::Open => match self.rx.arrive(f.seq) {
                    Arrival::InOrder => {
                        self.stats.delivered += 1;
                        let msg = postcard::from_bytes::<In>(f.payload)
                            .map(Some)
                            .map_err(|_| LinkError::MessageDecode);
                        return (msg, bytes);
                    }
                    Arrival::Ahead => self.stats.out_of_order += 1,
                    Arrival::Duplicate => self.stats.duplicates += 1,
                },
            }
        }
        (Ok(None), bytes)
    }

    /// Runs the timers at `now` and returns when to call again at the latest (`Some(now)`:
    /// frames wait, call [`transmit`](Self::transmit)); `None`: nothing is timed.
    pub fn poll(&mut self, now: u64) -> Option<u64> {
        if self.tx.on_timer(now, self.config.retransmit_us) {
            self.stats.timeouts += 1;
        }
        if self.tx.has_pending() || self.rx.ack_due || self.rx.nak_due {
            return Some(now);
        }
        let keepalive = match (self.config.keepalive_us, self.last_tx) {
            (0, _) => None,
            (_, None) => Some(now),
            (k, Some(t)) => Some(t.saturating_add(k)),
        };
        let lost = self.watchdog.deadline().map(|d| d.saturating_add(1));
        [self.tx.deadline(), keepalive, lost]
            .into_iter()
            .flatten()
            .min()
    }

    /// The next frame to write, if any: a (re)transmitted message, else a nak or an ack owed,
    /// else a keepalive when one is due. Call until `None`.
    pub fn transmit(&mut self, now: u64) -> Option<&[u8]> {
        let ack = self.rx.expected;
        let n = if self.rx.nak_due {
            // First, so the peer goes back before more frames it would send in vain.
            self.stats.naks_sent += 1;
            frame::encode(Kind::Nak, 0, ack, &[], &mut self.out)
        } else if let Some((seq, payload, again)) =
            self.tx.next_to_send(now, self.config.retransmit_us)
        {
            if again {
                self.stats.retransmissions += 1;
            }
            match self.opening {
                // Until acknowledged, frame 0 of our session opens it.
                Some(nonce) if seq == 0 => {
                    frame::encode(Kind::Open, seq, nonce, payload, &mut self.out)
                }
                _ => frame::encode(Kind::Data, seq, ack, payload, &mut self.out),
            }
        } else if self.rx.ack_due
            || (self.config.keepalive_us > 0
                && self
                    .last_tx
                    .is_none_or(|t| now >= t.saturating_add(self.config.keepalive_us)))
        {
            frame::encode(Kind::Ack, 0, ack, &[], &mut self.out)
        } else {
            return None;
        }?;
        // Every frame carries the latest ack.
        self.rx.ack_due = false;
        self.rx.nak_due = false;
        self.last_tx = Some(now);
        self.stats.frames_sent += 1;
        Some(&self.out[..n])
    }

    /// When a valid frame last arrived (`None`: none since the session was reset).
    pub fn last_heard(&self) -> Option<u64> {
        self.watchdog.last()
    }

    /// Whether no valid frame arrived within the watchdog's time before `now` (after one
    /// first did).
    pub fn is_lost(&self, now: u64) -> bool {
        self.watchdog.expired(now)
    }
}
