//! The link's one flat error type.

use core::fmt;

use serde::{Deserialize, Serialize};

use crate::error::FeatureId;

/// Everything the link can refuse, flat (postcard style): framing and transport, the
/// handshake, and the slice assembler's checks. Serde-derived, so a controller sends the very
/// value the host prints.
///
/// Noise on the line (the `Frame*` variants: a bad CRC, a broken COBS frame, an overfull
/// frame) is not an error the application sees from a [`Link`](super::endpoint::Link): such
/// frames are dropped, counted in [`LinkStats`](super::endpoint::LinkStats) and recovered by
/// retransmission; the [`FrameAccumulator`](super::frame::FrameAccumulator) reports them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum LinkError {
    /// A frame longer than [`MAX_FRAME`](super::frame::MAX_FRAME): dropped up to the next
    /// zero.
    FrameOverfull,
    /// A frame that is not valid COBS.
    FrameCobs,
    /// A frame shorter than a header and a CRC, of an unknown kind, or an ack with a
    /// payload.
    FrameMalformed,
    /// A frame whose CRC does not match.
    FrameCrc,
    /// The send window is full: the message was not queued (call `send` again after the peer
    /// has acknowledged a frame).
    WindowFull,
    /// A message does not fit a frame's payload ([`MAX_PAYLOAD`](super::frame::MAX_PAYLOAD)).
    MessageTooLarge,
    /// A frame passed its CRC but its payload is not a message of this protocol (a peer of
    /// another version, or a bug). The frame is acknowledged and dropped.
    MessageDecode,
    /// The peer speaks another protocol version.
    ProtocolMismatch {
        /// Ours ([`PROTOCOL_VERSION`](super::message::PROTOCOL_VERSION)).
        ours: u16,
        /// The peer's.
        theirs: u16,
    },
    /// A message other than hello arrived before the hello.
    NotGreeted,
    /// No valid frame arrived within the watchdog's timeout.
    LinkLost,
    /// A message that is not allowed in the current state (a contour before the job
    /// settings, a start without a validated slice, ...).
    UnexpectedMessage,
    /// A contour's features arrived out of order (the wall first, then holes 0, 1, ...).
    FeatureOrder {
        /// The feature expected next.
        expected: FeatureId,
        /// The feature that arrived.
        got: FeatureId,
    },
    /// A contour chunk does not continue its feature where the last one ended.
    ChunkOrder {
        /// The feature.
        feature: FeatureId,
        /// The vertex index expected next.
        expected: u32,
        /// The chunk's first vertex index.
        got: u32,
    },
    /// A chunk of the printer configuration does not continue it where the last one ended
    /// (or runs past its declared length, or past
    /// [`PRINTER_BYTES`](super::message::PRINTER_BYTES)).
    PrinterChunk {
        /// The offset expected next.
        expected: u16,
        /// The chunk's offset.
        got: u16,
        /// The length it declared.
        total: u16,
    },
    /// A contour chunk's bytes are not a whole number of zigzag-varint vertices.
    ContourData {
        /// The feature.
        feature: FeatureId,
    },
    /// A feature's chunks do not add up to the vertices its header declared.
    VertexCount {
        /// The feature.
        feature: FeatureId,
        /// Vertices declared.
        declared: u32,
        /// Vertices received.
        received: u32,
    },
    /// The end of the slice declared another number of holes than arrived.
    HoleCount {
        /// Holes declared.
        declared: u32,
        /// Holes received.
        received: u32,
    },
    /// The slice assembler's hole capacity (its `HOLES` parameter) is exceeded.
    AssemblerHoles {
        /// The capacity.
        capacity: u32,
    },
    /// The slice assembler's vertex pool (its `POINTS` parameter) is exceeded.
    AssemblerPoints {
        /// The capacity.
        capacity: u32,
        /// Vertices the slice needs so far.
        needed: u32,
    },
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            LinkError::FrameOverfull => write!(
                f,
                "link: a frame longer than {} bytes",
                super::frame::MAX_FRAME
            ),
            LinkError::FrameCobs => f.write_str("link: a frame that is not valid COBS"),
            LinkError::FrameMalformed => f.write_str("link: a malformed frame"),
            LinkError::FrameCrc => f.write_str("link: a frame failed its CRC"),
            LinkError::WindowFull => f.write_str("link: the send window is full"),
            LinkError::MessageTooLarge => write!(
                f,
                "link: a message is larger than a frame's {} bytes of payload",
                super::frame::MAX_PAYLOAD
            ),
            LinkError::MessageDecode => {
                f.write_str("link: a frame holds no message of this protocol version")
            }
            LinkError::ProtocolMismatch { ours, theirs } => write!(
                f,
                "link: the peer speaks protocol version {theirs}, this side {ours}: update the firmware or the host tool"
            ),
            LinkError::NotGreeted => f.write_str("link: a message arrived before the hello"),
            LinkError::LinkLost => f.write_str("link lost: no valid frame within the watchdog time"),
            LinkError::UnexpectedMessage => {
                f.write_str("link: a message not allowed in the current state")
            }
            LinkError::FeatureOrder { expected, got } => write!(
                f,
                "link: the contour of {got} arrived where {expected} was expected"
            ),
            LinkError::ChunkOrder {
                feature,
                expected,
                got,
            } => write!(
                f,
                "link: {feature}: a contour chunk starts at vertex {got}, expected {expected}"
            ),
            LinkError::PrinterChunk {
                expected,
                got,
                total,
            } => write!(
                f,
                "link: a printer configuration chunk at byte {got} of {total}, expected byte {expected}"
            ),
            LinkError::ContourData { feature } => {
                write!(f, "link: {feature}: a contour chunk's bytes are malformed")
            }
            LinkError::VertexCount {
                feature,
                declared,
                received,
            } => write!(
                f,
                "link: {feature}: {received} vertices arrived, {declared} were declared"
            ),
            LinkError::HoleCount { declared, received } => write!(
                f,
                "link: {received} holes arrived, the end of the slice declared {declared}"
            ),
            LinkError::AssemblerHoles { capacity } => write!(
                f,
                "the slice assembler holds at most {capacity} holes: raise its HOLES parameter or split the slice"
            ),
            LinkError::AssemblerPoints { capacity, needed } => write!(
                f,
                "the slice needs {needed} vertices, the slice assembler holds {capacity}: raise its POINTS parameter or simplify the contours on the host"
            ),
        }
    }
}

impl core::error::Error for LinkError {}
