//! The serial link between the host and the controller: bytes in, bytes out, time passed in.
//!
//! ```text
//! HostMsg / CtrlMsg ──postcard──► window (seq, go-back-N) ──► frame (header, CRC-32, COBS) ──► bytes
//!   message                          window, endpoint             frame
//! ```
//!
//! * [`message`]: one enum per direction ([`HostMsg`](message::HostMsg),
//!   [`CtrlMsg`](message::CtrlMsg)), serde-derived, postcard-encoded, `heapless` types only;
//!   the hello carries the protocol version. [`wire`] mirrors the one core error that does
//!   not serialize as it is.
//! * [`contour`]: contours in integer micrometres, zigzag delta varints; [`upload`]: the
//!   messages that carry a slice.
//! * [`frame`]: COBS frames with a CRC-32, and the fixed-buffer [`FrameAccumulator`](frame::FrameAccumulator).
//! * [`window`] and [`endpoint`]: the [`Link`](endpoint::Link): sequence numbers, cumulative
//!   acks on every frame, a nak on a gap, go-back-N retransmission on timeout: in-order,
//!   exactly-once delivery both ways. `poll(now)` runs the timers and returns the next
//!   deadline, smoltcp style. [`watchdog`]: the host-silence watchdog.
//! * [`assemble`]: the [`SliceAssembler`](assemble::SliceAssembler), fixed capacity, builds
//!   the [`Slice`](crate::Slice) through its own validation only once it arrived whole.
//! * [`controller`]: the controller's end of a session in one `receive` / `poll` /
//!   `transmit` loop. The host's end is in host-sim (`link_client`).
//! * [`error`]: the one flat [`LinkError`](error::LinkError).

pub mod assemble;
pub mod contour;
pub mod controller;
pub mod endpoint;
pub mod error;
pub mod frame;
pub mod message;
pub mod upload;
pub mod watchdog;
pub mod window;
pub mod wire;
