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

use crate::config::HALF_POINTS;
use crate::geometry::{polyline, Point};

/// Where a half ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HalfEnd {
    /// On the wall's keep-out curve.
    Wall,
    /// On the bisector towards the cell of this hole.
    Bisector(u8),
}

/// One half of an MCL: from hole `hole` to its cell boundary.
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
    /// The polyline, from the hole outwards.
    pub points: Vec<Point, HALF_POINTS>,
    /// The matched half on the other side of the bisector (index into the halves).
    pub partner: Option<u16>,
    /// The bisector piece its end lies on, and the end's arc length along it.
    pub on_bisector: Option<(u8, f32)>,
    /// How often the density was doubled to insert it (0 for the base spacing).
    pub depth: u8,
    /// Still part of the plan.
    pub alive: bool,
}

impl Half {
    /// The start point, on the hole's keep-out curve.
    pub fn start(&self) -> Point {
        self.points[0]
    }
    /// The end point, on the cell boundary.
    pub fn end_point(&self) -> Point {
        self.points[self.points.len() - 1]
    }
    /// Moves the end to `to`, dragging the rest of the polyline by the same vector scaled by
    /// the arc-length fraction (the start stays on the hole).
    pub fn reshape_end(&mut self, to: Point) {
        let delta = to - self.end_point();
        let total = polyline::length(&self.points);
        if total <= 0.0 {
            return;
        }
        let mut acc = 0.0;
        let mut prev = self.points[0];
        for p in self.points.iter_mut().skip(1) {
            acc += prev.dist(*p);
            prev = *p;
            *p = *p + delta * (acc / total);
        }
        let last = self.points.len() - 1;
        self.points[last] = to;
    }
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
