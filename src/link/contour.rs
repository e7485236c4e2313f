//! Contours on the wire: integer micrometres, the first vertex of a chunk absolute and the
//! rest as deltas from the one before, every coordinate a zigzag LEB128 varint (1 byte for
//! |d| < 64 um, 2 below 8.2 mm, 3 below 1 m).

use heapless::Vec;

use super::message::{ContourChunk, CHUNK_BYTES};
use crate::config::MAX_COORD_MM;
use crate::error::{Error, FeatureId};
use crate::geometry::Point;

/// Micrometres per millimetre.
pub const UM_PER_MM: f32 = 1000.0;
/// The longest varint of a `u32`.
const MAX_VARINT: usize = 5;
// Every accepted coordinate in micrometres, and every delta of two, is an `i32`.
const _: () = assert!(2.0 * MAX_COORD_MM * UM_PER_MM < i32::MAX as f32);

/// A point in integer micrometres; `Err` (as [`Slice::new`](crate::Slice::new) would refuse
/// it) if a coordinate is not finite or beyond [`MAX_COORD_MM`].
pub fn to_um(feature: FeatureId, vertex: usize, p: Point) -> Result<(i32, i32), Error> {
    let vertex = vertex.min(u16::MAX as usize) as u16;
    if !p.is_finite() {
        return Err(Error::NonFinite { feature, vertex });
    }
    if libm::fabsf(p.x) > MAX_COORD_MM || libm::fabsf(p.y) > MAX_COORD_MM {
        return Err(Error::OutOfRange { feature, vertex });
    }
    // In range (asserted above): the casts cannot truncate.
    Ok((
        libm::roundf(p.x * UM_PER_MM) as i32,
        libm::roundf(p.y * UM_PER_MM) as i32,
    ))
}

/// The point of integer micrometres `(x, y)`, in millimetres.
pub fn from_um((x, y): (i32, i32)) -> Point {
    Point::new(x as f32 / UM_PER_MM, y as f32 / UM_PER_MM)
}

/// `p` as it arrives on the controller (rounded to whole micrometres): a host plans from
/// this to compare its digest with the controller's.
pub fn quantize(p: Point) -> Point {
    if !p.is_finite() || libm::fabsf(p.x) > MAX_COORD_MM || libm::fabsf(p.y) > MAX_COORD_MM {
        return p;
    }
    from_um((
        libm::roundf(p.x * UM_PER_MM) as i32,
        libm::roundf(p.y * UM_PER_MM) as i32,
    ))
}

const fn zigzag(v: i32) -> u32 {
    ((v << 1) ^ (v >> 31)) as u32
}

const fn unzigzag(u: u32) -> i32 {
    ((u >> 1) as i32) ^ -((u & 1) as i32)
}

fn put_varint<const N: usize>(mut v: u32, out: &mut Vec<u8, N>) -> Result<(), u8> {
    loop {
        let b = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            return out.push(b);
        }
        out.push(b | 0x80)?;
    }
}

fn get_varint(data: &[u8], pos: &mut usize) -> Option<u32> {
    let mut v: u32 = 0;
    for k in 0..MAX_VARINT {
        let b = *data.get(*pos)?;
        *pos += 1;
        let bits = u32::from(b & 0x7f);
        if k == MAX_VARINT - 1 && bits > 0x0f {
            return None;
        }
        v |= bits << (7 * k);
        if b & 0x80 == 0 {
            return Some(v);
        }
    }
    None
}

/// Encodes as many of `points` as fit into `out` (cleared first) and returns how many did.
/// `index` is the first point's index in its contour, for the error of a bad coordinate.
pub fn encode_chunk<const N: usize>(
    feature: FeatureId,
    index: usize,
    points: &[Point],
    out: &mut Vec<u8, N>,
) -> Result<usize, Error> {
    out.clear();
    let mut prev = (0, 0);
    for (k, &p) in points.iter().enumerate() {
        let q = to_um(feature, index + k, p)?;
        let d = if k == 0 {
            q
        } else {
            (q.0 - prev.0, q.1 - prev.1)
        };
        let len = out.len();
        if put_varint(zigzag(d.0), out).is_err() || put_varint(zigzag(d.1), out).is_err() {
            out.truncate(len);
            return Ok(k);
        }
        prev = q;
    }
    Ok(points.len())
}

/// The vertices of a chunk's bytes, in micrometres; an item `Err(())` (and nothing after it)
/// if the bytes are not whole varint pairs or a coordinate leaves the `i32` range.
#[derive(Clone, Debug)]
pub struct ChunkDecoder<'a> {
    data: &'a [u8],
    pos: usize,
    prev: Option<(i32, i32)>,
    failed: bool,
}

impl<'a> ChunkDecoder<'a> {
    /// Decodes `data`.
    pub fn new(data: &'a [u8]) -> Self {
        ChunkDecoder {
            data,
            pos: 0,
            prev: None,
            failed: false,
        }
    }
}

impl Iterator for ChunkDecoder<'_> {
    type Item = Result<(i32, i32), ()>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.pos >= self.data.len() {
            return None;
        }
        let pair = get_varint(self.data, &mut self.pos)
            .zip(get_varint(self.data, &mut self.pos))
            .map(|(x, y)| (unzigzag(x), unzigzag(y)));
        let q = match (pair, self.prev) {
            (Some(d), None) => Some(d),
            (Some(d), Some(p)) => p.0.checked_add(d.0).zip(p.1.checked_add(d.1)),
            (None, _) => None,
        };
        match q {
            Some(q) => {
                self.prev = Some(q);
                Some(Ok(q))
            }
            None => {
                self.failed = true;
                Some(Err(()))
            }
        }
    }
}

/// The chunks of one contour, in order; `Err` for a coordinate
/// [`Slice::new`](crate::Slice::new) would refuse (then nothing after it).
#[derive(Clone, Debug)]
pub struct Chunks<'a> {
    feature: FeatureId,
    points: &'a [Point],
    next: usize,
    failed: bool,
}

/// The chunks of `points`, the contour of `feature`.
pub fn chunks(feature: FeatureId, points: &[Point]) -> Chunks<'_> {
    Chunks {
        feature,
        points,
        next: 0,
        failed: false,
    }
}

impl Iterator for Chunks<'_> {
    type Item = Result<ContourChunk, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.next >= self.points.len() {
            return None;
        }
        let mut data: Vec<u8, CHUNK_BYTES> = Vec::new();
        match encode_chunk(
            self.feature,
            self.next,
            &self.points[self.next..],
            &mut data,
        ) {
            Ok(n) => {
                // A chunk holds at least one vertex (2 varints of at most 5 bytes).
                const _: () = assert!(CHUNK_BYTES >= 2 * MAX_VARINT);
                let start = self.next;
                self.next += n;
                Some(Ok(ContourChunk {
                    feature: self.feature,
                    start: start.min(u32::MAX as usize) as u32,
                    data,
                }))
            }
            Err(e) => {
                self.failed = true;
                Some(Err(e))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zigzag_round_trips_at_the_extremes() {
        for v in [0, 1, -1, 63, -64, 64, i32::MAX, i32::MIN] {
            assert_eq!(unzigzag(zigzag(v)), v);
        }
        let mut out: Vec<u8, 8> = Vec::new();
        put_varint(u32::MAX, &mut out).unwrap();
        assert_eq!(out.len(), MAX_VARINT);
        assert_eq!(get_varint(&out, &mut 0), Some(u32::MAX));
    }

    #[test]
    fn contour_round_trips_in_chunks() {
        let pts: std::vec::Vec<Point> = (0..1000)
            .map(|k| {
                let a = k as f32 * 0.00628;
                Point::new(500.0 * libm::cosf(a), -999.9 * libm::sinf(a))
            })
            .collect();
        let mut back = std::vec::Vec::new();
        for c in chunks(FeatureId::Wall, &pts) {
            let c = c.unwrap();
            assert_eq!(c.start as usize, back.len());
            for q in ChunkDecoder::new(&c.data) {
                back.push(from_um(q.unwrap()));
            }
        }
        assert_eq!(back.len(), pts.len());
        for (a, b) in pts.iter().zip(&back) {
            assert_eq!(*b, quantize(*a));
            assert!((a.x - b.x).abs() <= 0.0005 + 1e-4 && (a.y - b.y).abs() <= 0.0005 + 1e-4);
        }
    }

    #[test]
    fn bad_coordinates_and_bytes_are_refused() {
        let pts = [Point::new(0.0, 0.0), Point::new(f32::NAN, 1.0)];
        let r: std::vec::Vec<_> = chunks(FeatureId::Hole(2), &pts).collect();
        assert_eq!(
            r[0],
            Err(Error::NonFinite {
                feature: FeatureId::Hole(2),
                vertex: 1
            })
        );
        assert_eq!(
            ChunkDecoder::new(&[0x80]).collect::<std::vec::Vec<_>>(),
            [Err(())]
        );
        assert_eq!(
            ChunkDecoder::new(&[2, 2, 0xff]).collect::<std::vec::Vec<_>>(),
            [Ok((1, 1)), Err(())]
        );
    }
}
