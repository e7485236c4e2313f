//! FNV-1a digests: the fingerprint that shows a plan or a layer is bit-identical on the host
//! and on the MCU.

use crate::geometry::Point;

/// A 64-bit FNV-1a hash fed little-endian 32-bit words.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) struct Fnv(u64);

impl Fnv {
    pub(crate) const fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    pub(crate) fn word(&mut self, x: u32) {
        for b in x.to_le_bytes() {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// A point, as the IEEE bits of its coordinates.
    pub(crate) fn point(&mut self, p: Point) {
        self.word(p.x.to_bits());
        self.word(p.y.to_bits());
    }

    pub(crate) fn finish(&self) -> u64 {
        self.0
    }
}
