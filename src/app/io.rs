//! What the application needs of its platform: a clock, the link's byte stream, a way to
//! sleep.

/// The platform under the application: the link's byte stream and the clock, both injected
/// (the application reads no peripheral and no clock of its own).
pub trait Io {
    /// Microseconds since some start, never going back (the link's clock; the machine's
    /// ticks are derived from it at the printer's `tick_hz`).
    fn now_us(&mut self) -> u64;
    /// Reads the bytes that have arrived, at most `buf.len()`, without blocking.
    fn read(&mut self, buf: &mut [u8]) -> usize;
    /// Writes a frame (may block until the line took it).
    fn write(&mut self, bytes: &[u8]);
    /// Sleeps until `until_us` or until a byte arrives, whichever is first (`None`: until a
    /// byte arrives). May return early.
    fn sleep(&mut self, until_us: Option<u64>);
}

/// Ticks of a `tick_hz` timer at `us` microseconds (wrapping, as the step timer counts).
pub fn ticks_at(us: u64, tick_hz: u32) -> u32 {
    ((us as u128 * tick_hz as u128) / 1_000_000) as u32
}

/// Microseconds from `now` ticks until `deadline` ticks (0 if it passed: a wrapping
/// difference over half the range is in the past).
pub fn us_until(now: u32, deadline: u32, tick_hz: u32) -> u64 {
    let dt = deadline.wrapping_sub(now);
    if dt >= 1 << 31 {
        return 0;
    }
    (dt as u64 * 1_000_000).div_ceil(tick_hz as u64)
}
