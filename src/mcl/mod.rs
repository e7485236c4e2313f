//! Material changing lines (MCLs): inserted in every cell, matched across the bisectors,
//! relaxed near the branch points.
//!
//! An MCL is built from *halves*: a half runs from a hollow feature (on its keep-out curve,
//! half a road width out) to the boundary of the feature's cell. [`insert`] traces the halves,
//! [`matching`] joins halves across each bisector through the weighted point `p*` (the paper's
//! Algorithm I) and removes the unmatched, [`relax`] spreads the ends that crowd near branch
//! points. A finished [`Mcl`] is one half ending on the wall, or two matched halves.

pub mod insert;
pub mod matching;
pub mod relax;

use heapless::Vec;

use crate::config::{HALF_POINTS, HALF_POOL_POINTS, MAX_HALVES};
use crate::geometry::{polyline, primitives, Point};
use crate::{Error, FeatureId, Limit};

/// Where a half ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HalfEnd {
    /// On the wall's keep-out curve.
    Wall,
    /// On the bisector towards the cell of this hole.
    Bisector(u8),
}

/// One half of an MCL: from hole `hole` to its cell boundary. Its polyline lives in the
/// [`Halves`]' point pool ([`Halves::points`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Half {
    /// The hole it starts from.
    pub hole: u8,
    /// Arc-length parameter of its start along the hole's boundary.
    pub s: f32,
    /// Outward unit normal of the hole at the start.
    pub start_normal: Point,
    /// Where it ends.
    pub end: HalfEnd,
    /// The matched half on the other side of the bisector (index into the halves).
    pub partner: Option<u16>,
    /// The bisector piece its end lies on, and the end's arc length along it.
    pub on_bisector: Option<(u8, f32)>,
    /// How often the density was doubled to insert it (0 for the base spacing).
    pub depth: u8,
    /// Still part of the plan.
    pub alive: bool,
    /// Its points in the pool: `at .. at + len`.
    at: u32,
    len: u8,
}

// A half's point count is a `u8`, its first point's index in the pool a `u32`.
const _: () = assert!(HALF_POINTS <= u8::MAX as usize);
const _: () = assert!(HALF_POOL_POINTS <= u32::MAX as usize);

/// The halves of a plan, their polylines in one pool of points: a half takes the points it
/// has (5-14 on average on the reference slices) rather than room for [`HALF_POINTS`] each,
/// which took 150 KiB on a controller. Reads as a slice of [`Half`] (`halves[k].hole`,
/// `halves.iter()`); the points through [`points`](Self::points).
#[derive(Clone, Debug, Default)]
pub struct Halves {
    list: Vec<Half, MAX_HALVES>,
    pool: Vec<Point, HALF_POOL_POINTS>,
}

impl Halves {
    /// No halves (no allocation: the buffers are inline).
    pub const fn new() -> Halves {
        Halves {
            list: Vec::new(),
            pool: Vec::new(),
        }
    }

    /// Forgets every half.
    pub fn clear(&mut self) {
        self.list.clear();
        self.pool.clear();
    }

    /// Points in the pool (of [`HALF_POOL_POINTS`]), those of dropped halves included until
    /// the halves are compacted.
    pub fn pool_len(&self) -> usize {
        self.pool.len()
    }

    /// The polyline of half `k`, from the hole outwards.
    pub fn points(&self, k: usize) -> &[Point] {
        self.points_of(&self.list[k])
    }

    /// The polyline of `h`, one of these halves.
    pub fn points_of(&self, h: &Half) -> &[Point] {
        &self.pool[h.at as usize..h.at as usize + h.len as usize]
    }

    /// Every half's bounding box, by index, into `out` (emptied first; filled in place, not
    /// returned: it is 16 bytes a half of capacity): for the searches that test one half
    /// against many and keep the boxes instead of measuring each half again per test.
    pub(crate) fn boxes(&self, out: &mut Vec<(Point, Point), MAX_HALVES>) -> Result<(), Error> {
        out.clear();
        for k in 0..self.len() {
            // Never full: one box per half, and the halves have the same capacity.
            out.push(primitives::bbox(self.points(k)))
                .map_err(|_| Limit::Halves.error())?;
        }
        Ok(())
    }

    /// The start of half `k`, on its hole's keep-out curve.
    pub fn start(&self, k: usize) -> Point {
        self.points(k)[0]
    }

    /// The end of half `k`, on its cell boundary.
    pub fn end_point(&self, k: usize) -> Point {
        let pts = self.points(k);
        pts[pts.len() - 1]
    }

    /// Replaces the polyline of half `k` by `pts` of the same length (a reshaped copy of it).
    pub(crate) fn set_points(&mut self, k: usize, pts: &[Point]) {
        let h = &self.list[k];
        self.pool[h.at as usize..h.at as usize + h.len as usize].copy_from_slice(pts);
    }

    /// The polyline of half `k`, copied (to reshape it and test the result before keeping it
    /// with [`set_points`](Self::set_points)).
    pub(crate) fn points_copy(&self, k: usize) -> PointsCopy {
        let h = &self.list[k];
        let mut copy = PointsCopy {
            points: [Point::new(0.0, 0.0); HALF_POINTS],
            len: h.len,
        };
        copy.copy_from_slice(self.points_of(h));
        copy
    }

    /// Appends `half` with the polyline `pts`; a full buffer is the capacity error naming
    /// the hole.
    pub(crate) fn push(&mut self, mut half: Half, pts: &[Point]) -> Result<(), Error> {
        let hole = half.hole;
        let full = |limit| Error::Capacity {
            limit,
            feature: Some(FeatureId::Hole(hole)),
        };
        // A traced half has at least its start and its end (`polyline::simplify` keeps both).
        debug_assert!(pts.len() >= 2, "a half of {} points", pts.len());
        if pts.len() > HALF_POINTS {
            return Err(full(Limit::HalfPoints));
        }
        if self.list.is_full() {
            return Err(full(Limit::Halves));
        }
        // In range: the pool holds at most HALF_POOL_POINTS (asserted above to fit a u32),
        // a half at most HALF_POINTS (<= 255).
        half.at = self.pool.len() as u32;
        half.len = pts.len() as u8;
        self.pool
            .extend_from_slice(pts)
            .map_err(|_| full(Limit::HalfPoolPoints))?;
        self.list.push(half).map_err(|_| full(Limit::Halves))
    }

    /// Removes the half pushed last, and its points.
    pub(crate) fn pop_last(&mut self) {
        if let Some(h) = self.list.pop() {
            self.pool.truncate(h.at as usize);
        }
    }

    /// Drops the halves no longer alive, and their points (the order of the rest kept).
    /// The halves' points lie in the pool in the order of the halves (`push` appends both,
    /// and nothing reorders halves: the slice view lets a field change, not a half move), so
    /// each kept half's points move down, never over points not yet moved.
    pub(crate) fn retain_alive(&mut self) {
        let mut next = 0usize;
        for k in 0..self.list.len() {
            if !self.list[k].alive {
                continue;
            }
            let (at, len) = (self.list[k].at as usize, self.list[k].len as usize);
            debug_assert!(
                at >= next,
                "halves reordered: half {k} at {at}, pool at {next}"
            );
            self.pool.copy_within(at..at + len, next);
            // Below the old `at`: fits the u32 as that did.
            self.list[k].at = next as u32;
            next += len;
        }
        self.pool.truncate(next);
        self.list.retain(|h| h.alive);
    }
}

impl core::ops::Deref for Halves {
    type Target = [Half];
    fn deref(&self) -> &[Half] {
        &self.list
    }
}

impl core::ops::DerefMut for Halves {
    fn deref_mut(&mut self) -> &mut [Half] {
        &mut self.list
    }
}

/// A copy of one half's polyline ([`Halves::points_copy`]), read and written as a slice.
pub(crate) struct PointsCopy {
    points: [Point; HALF_POINTS],
    /// At most HALF_POINTS: the length of a pushed half.
    len: u8,
}

impl core::ops::Deref for PointsCopy {
    type Target = [Point];
    fn deref(&self) -> &[Point] {
        &self.points[..self.len as usize]
    }
}

impl core::ops::DerefMut for PointsCopy {
    fn deref_mut(&mut self) -> &mut [Point] {
        &mut self.points[..self.len as usize]
    }
}

/// Moves the end of the polyline `points` to `to`, dragging the rest by the same vector
/// scaled by the arc-length fraction (the start stays on the hole).
pub fn reshape_end(points: &mut [Point], to: Point) {
    let n = points.len();
    let delta = to - points[n - 1];
    let total = polyline::length(points);
    if total <= 0.0 {
        return;
    }
    let mut acc = 0.0;
    let mut prev = points[0];
    for p in points.iter_mut().skip(1) {
        acc += prev.dist(*p);
        prev = *p;
        *p = *p + delta * (acc / total);
    }
    points[n - 1] = to;
}

/// What the far end of an MCL touches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Target {
    /// The wall.
    Wall,
    /// Another hollow feature, through `p*` on their bisector.
    Hole(u8),
}

/// A finished material changing line: from hole `from` to the wall or to another hole.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mcl {
    /// The hole it starts from.
    pub from: u8,
    /// Where it ends.
    pub to: Target,
    /// The half starting at `from` (index into [`Plan::halves`](crate::Plan::halves)).
    pub first: u16,
    /// The matched half starting at `to`, for a hole-to-hole MCL.
    pub second: Option<u16>,
    /// `p*` on the bisector for a hole-to-hole MCL, else the wall end.
    pub joint: Point,
}
