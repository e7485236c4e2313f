//! Frames on the wire: a header, a postcard payload and a CRC-32, COBS-encoded and ended by
//! a zero byte.
//!
//! ```text
//! [ kind | seq | ack | payload (0..=MAX_PAYLOAD) | crc32 (LE) ]  --COBS-->  ... 0x00
//! ```
//!
//! * `kind`: [`Kind::Data`] carries a message; [`Kind::Open`] too, the first of a session;
//!   [`Kind::Ack`] and [`Kind::Nak`] carry none.
//! * `seq`: the data frame's sequence number (wrapping `u8`; 0 in acks).
//! * `ack`: every frame acknowledges cumulatively: the sequence number the sender expects
//!   next. A [`Kind::Nak`] additionally asks for a retransmission from there. In a
//!   [`Kind::Open`] frame it is the session's nonce instead.
//! * The CRC (CRC-32/ISO-HDLC) covers the header and the payload.
//!
//! [`FrameAccumulator`] streams bytes through a fixed buffer (as postcard's
//! `CobsAccumulator` does, but the CRC is checked before anything is decoded) and yields
//! checked [`Frame`]s; a frame that is too long, not valid COBS, too short or fails its CRC
//! is dropped whole and reported as the [`LinkError`] that says which.

use crc::{Crc, CRC_32_ISO_HDLC};

use super::error::LinkError;

/// The frame check.
pub const CRC: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);
/// Largest payload (one encoded message), bytes.
pub const MAX_PAYLOAD: usize = 512;
/// Header bytes.
pub const HEADER: usize = 3;
/// CRC bytes.
pub const CRC_BYTES: usize = 4;
/// Largest decoded frame: header, payload, CRC.
pub const MAX_RAW: usize = HEADER + MAX_PAYLOAD + CRC_BYTES;
/// Largest frame on the wire: COBS adds one byte per 254 and one more, then the 0x00.
pub const MAX_FRAME: usize = cobs_max(MAX_RAW) + 1;

/// COBS's worst-case encoded length of `n` bytes.
pub const fn cobs_max(n: usize) -> usize {
    n + n / 254 + 1
}

/// What a frame carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Kind {
    /// A message, with its sequence number.
    Data,
    /// The first message of a session (sequence number 0), `ack` holding the session's
    /// nonce: a receiver that has another session (or none) starts afresh.
    Open,
    /// An acknowledgement only.
    Ack,
    /// An acknowledgement asking for a retransmission from `ack` (a gap was seen).
    Nak,
}

impl Kind {
    const fn byte(self) -> u8 {
        match self {
            Kind::Data => 0xD1,
            Kind::Open => 0x5E,
            Kind::Ack => 0xA2,
            Kind::Nak => 0x4E,
        }
    }
    const fn from_byte(b: u8) -> Option<Kind> {
        match b {
            0xD1 => Some(Kind::Data),
            0x5E => Some(Kind::Open),
            0xA2 => Some(Kind::Ack),
            0x4E => Some(Kind::Nak),
            _ => None,
        }
    }
}

/// A checked frame, borrowed from the accumulator's buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame<'a> {
    /// What it carries.
    pub kind: Kind,
    /// Sequence number (data frames).
    pub seq: u8,
    /// Cumulative acknowledgement: the sequence number expected next.
    pub ack: u8,
    /// The postcard-encoded message (empty in acks).
    pub payload: &'a [u8],
}

/// Encodes a frame into `out` (at least [`MAX_FRAME`] bytes) and returns its length, the
/// final 0x00 included. `None` if the payload is longer than [`MAX_PAYLOAD`] or `out` is too
/// short.
pub fn encode(kind: Kind, seq: u8, ack: u8, payload: &[u8], out: &mut [u8]) -> Option<usize> {
    if payload.len() > MAX_PAYLOAD {
        return None;
    }
    let mut raw = [0u8; MAX_RAW];
    raw[0] = kind.byte();
    raw[1] = seq;
    raw[2] = ack;
    let end = HEADER + payload.len();
    raw[HEADER..end].copy_from_slice(payload);
    let crc = CRC.checksum(&raw[..end]);
    raw[end..end + CRC_BYTES].copy_from_slice(&crc.to_le_bytes());
    let raw = &raw[..end + CRC_BYTES];
    if out.len() < cobs_max(raw.len()) + 1 {
        return None;
    }
    let n = cobs::encode(raw, out);
    out[n] = 0;
    Some(n + 1)
}

/// Streams bytes into frames through a fixed buffer of `N` bytes (at least [`MAX_FRAME`] to
/// take every frame).
#[derive(Debug)]
pub struct FrameAccumulator<const N: usize> {
    buf: [u8; N],
    len: usize,
    /// Dropping an overfull frame: skip to the next zero.
    skipping: bool,
}

impl<const N: usize> Default for FrameAccumulator<N> {
    fn default() -> Self {
        Self::new()
    }
}

/// What [`FrameAccumulator::feed`] found in the bytes it consumed.
#[derive(Debug, PartialEq, Eq)]
pub enum Feed<'b> {
    /// Every byte was consumed, no frame ended.
    Consumed,
    /// A checked frame; the bytes after it are not consumed yet.
    Frame(Frame<'b>),
    /// Bytes up to a zero that were no frame: [`LinkError::FrameOverfull`],
    /// [`LinkError::FrameCobs`], [`LinkError::FrameMalformed`] or [`LinkError::FrameCrc`].
    Error(LinkError),
}

impl<const N: usize> FrameAccumulator<N> {
    /// An empty accumulator (`const`: it may live in a `static`).
    pub const fn new() -> Self {
        FrameAccumulator {
            buf: [0; N],
            len: 0,
            skipping: false,
        }
    }

    /// Forgets a partial frame.
    pub fn clear(&mut self) {
        self.len = 0;
        self.skipping = false;
    }

    /// Consumes bytes up to and including the next zero (or all of them) and returns what
    /// they made, with the bytes not yet consumed.
    pub fn feed<'a, 'b>(&'b mut self, input: &'a [u8]) -> (Feed<'b>, &'a [u8]) {
        let Some(zero) = input.iter().position(|&b| b == 0) else {
            self.push(input);
            return (Feed::Consumed, &[]);
        };
        self.push(&input[..zero]);
        let rest = &input[zero + 1..];
        let (len, skipping) = (self.len, self.skipping);
        self.len = 0;
        self.skipping = false;
        if skipping {
            return (Feed::Error(LinkError::FrameOverfull), rest);
        }
        if len == 0 {
            // Back-to-back zeros (a sender may lead a frame with one to flush noise).
            return (Feed::Consumed, rest);
        }
        (check(&mut self.buf[..len]), rest)
    }

    fn push(&mut self, bytes: &[u8]) {
        if self.skipping {
            return;
        }
        if self.len + bytes.len() > N {
            self.skipping = true;
            self.len = 0;
            return;
        }
        self.buf[self.len..self.len + bytes.len()].copy_from_slice(bytes);
        self.len += bytes.len();
    }
}

/// Decodes one COBS frame in place and checks it.
fn check(buf: &mut [u8]) -> Feed<'_> {
    let Ok(n) = cobs::decode_in_place(buf) else {
        return Feed::Error(LinkError::FrameCobs);
    };
    if !(HEADER + CRC_BYTES..=MAX_RAW).contains(&n) {
        return Feed::Error(LinkError::FrameMalformed);
    }
    let body = n - CRC_BYTES;
    let mut crc = [0u8; CRC_BYTES];
    crc.copy_from_slice(&buf[body..n]);
    if CRC.checksum(&buf[..body]) != u32::from_le_bytes(crc) {
        return Feed::Error(LinkError::FrameCrc);
    }
    let Some(kind) = Kind::from_byte(buf[0]) else {
        return Feed::Error(LinkError::FrameMalformed);
    };
    let payload = &buf[HEADER..body];
    if matches!(kind, Kind::Ack | Kind::Nak) && !payload.is_empty() {
        return Feed::Error(LinkError::FrameMalformed);
    }
    Feed::Frame(Frame {
        kind,
        seq: buf[1],
        ack: buf[2],
        payload,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(bytes: &[u8]) -> Result<(Kind, u8, u8, std::vec::Vec<u8>), LinkError> {
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        match acc.feed(bytes).0 {
            Feed::Frame(f) => Ok((f.kind, f.seq, f.ack, f.payload.to_vec())),
            Feed::Error(e) => Err(e),
            Feed::Consumed => panic!("no frame"),
        }
    }

    #[test]
    fn round_trip_and_every_single_bit_flip_is_refused() {
        let payload = [0u8, 1, 2, 0, 255, 7];
        let mut out = [0u8; MAX_FRAME];
        let n = encode(Kind::Data, 9, 4, &payload, &mut out).unwrap();
        assert_eq!(out[n - 1], 0);
        assert!(!out[..n - 1].contains(&0));
        assert_eq!(one(&out[..n]), Ok((Kind::Data, 9, 4, payload.to_vec())));
        for byte in 0..n - 1 {
            for bit in 0..8 {
                let mut m = out;
                m[byte] ^= 1 << bit;
                if m[byte] == 0 {
                    continue; // a zero ends the frame early: covered by the fuzz tests
                }
                assert!(one(&m[..n]).is_err(), "byte {byte} bit {bit}");
            }
        }
    }

    #[test]
    fn largest_payload_fits_and_larger_is_refused() {
        let payload = [0xAAu8; MAX_PAYLOAD];
        let mut out = [0u8; MAX_FRAME];
        let n = encode(Kind::Data, 1, 2, &payload, &mut out).unwrap();
        assert!(n <= MAX_FRAME);
        assert_eq!(one(&out[..n]).unwrap().3.len(), MAX_PAYLOAD);
        assert_eq!(
            encode(Kind::Data, 1, 2, &[0; MAX_PAYLOAD + 1], &mut out),
            None
        );
    }

    #[test]
    fn overfull_frame_is_dropped_and_the_next_one_taken() {
        let mut acc = FrameAccumulator::<16>::new();
        let (r, rest) = acc.feed(&[1u8; 40]);
        assert_eq!((r, rest.len()), (Feed::Consumed, 0));
        let mut out = [0u8; MAX_FRAME];
        let n = encode(Kind::Ack, 0, 3, &[], &mut out).unwrap();
        let mut stream = std::vec![1u8, 1, 0];
        stream.extend_from_slice(&out[..n]);
        let (r, rest) = acc.feed(&stream);
        assert_eq!(r, Feed::Error(LinkError::FrameOverfull));
        match acc.feed(rest).0 {
            Feed::Frame(f) => assert_eq!((f.kind, f.ack), (Kind::Ack, 3)),
            other => panic!("{other:?}"),
        }
    }
}
