//! The host-silence watchdog: "link lost" when no valid frame arrived for a while.

/// Reports the link lost when no valid frame arrived for `timeout` microseconds. Armed by
/// the first valid frame (before it there is no host to lose). The application closes the
/// valves and stops on it; the core only tells.
///
/// ```
/// use hollowpath::link::watchdog::Watchdog;
/// let mut w = Watchdog::new(500_000);
/// assert!(!w.expired(10_000_000)); // never fed: not armed
/// w.feed(1_000);
/// assert_eq!(w.deadline(), Some(501_000));
/// assert!(!w.expired(501_000));
/// assert!(w.expired(501_001));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Watchdog {
    timeout: u64,
    last: Option<u64>,
}

impl Watchdog {
    /// A watchdog of `timeout` microseconds; 0 never expires.
    pub const fn new(timeout: u64) -> Watchdog {
        Watchdog {
            timeout,
            last: None,
        }
    }

    /// A valid frame arrived at `now`.
    pub fn feed(&mut self, now: u64) {
        self.last = Some(self.last.map_or(now, |l| l.max(now)));
    }

    /// Disarms it (a new session starts).
    pub fn disarm(&mut self) {
        self.last = None;
    }

    /// When a valid frame last arrived (`None`: not since it was armed).
    pub fn last(&self) -> Option<u64> {
        self.last
    }

    /// When it expires if nothing arrives (`None`: not armed, or no timeout).
    pub fn deadline(&self) -> Option<u64> {
        match (self.timeout, self.last) {
            (0, _) | (_, None) => None,
            (t, Some(l)) => Some(l.saturating_add(t)),
        }
    }

    /// Whether no valid frame arrived for longer than the timeout before `now`.
    pub fn expired(&self, now: u64) -> bool {
        self.deadline().is_some_and(|d| now > d)
    }
}
