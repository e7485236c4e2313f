//! Voronoi cells of the hollow features: the bisectors between them and the branch points.
//!
//! The cell of hole `i` is the part of the printable region nearer to hole `i` than to any
//! other hole (distances to the polygons, not to points). The [`Field`] labels grid nodes by
//! cell; wherever two neighbouring nodes belong to different cells a bisector passes between
//! them. From such a seed the bisector `d_i = d_j` is traced both ways by predictor-corrector
//! steps (a step along the tangent, then Newton steps back onto `d_i - d_j = 0`) until it
//! reaches the wall's keep-out boundary or a third cell: those ends are the branch points.

use heapless::Vec;

use crate::config::{
    BISECTOR_POINTS, BISECTOR_SEEDS, MAX_BISECTORS, MAX_BRANCH_POINTS, TRACE_POINTS,
};
use crate::field::{Field, KEEP_OUT};
use crate::geometry::primitives::{bisect, MinMax};
use crate::geometry::{polyline, Point};
use crate::{Error, Limit, Slice};

/// The boundary between the cells of holes `a < b`, as a polyline from one branch point to the
/// other.
///
/// ```
/// # use hollowpath::{cells::Bisector, geometry::Point};
/// let b = Bisector { a: 0, b: 1, points: heapless::Vec::from_slice(&[Point::new(0.0, -1.0), Point::new(0.0, 1.0)]).unwrap(), tolerance: 0.0 };
/// assert_eq!(b.length(), 2.0);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Bisector {
    /// The lower hole index.
    pub a: u8,
    /// The higher hole index.
    pub b: u8,
    /// The polyline.
    pub points: Vec<Point, BISECTOR_POINTS>,
    /// How far the traced bisector may lie from the polyline, mm: the tolerance it was
    /// simplified with, from 2 µm, doubled until its points fit [`BISECTOR_POINTS`] (a long,
    /// winding bisector at fine roads is stored coarser).
    pub tolerance: f32,
}

impl Bisector {
    /// Arc length.
    pub fn length(&self) -> f32 {
        polyline::length(&self.points)
    }
}

/// Bisectors and branch points of a slice.
#[derive(Clone, Debug, Default)]
pub struct Cells {
    /// The bisector pieces, in the order they were found (by grid node).
    pub bisectors: Vec<Bisector, MAX_BISECTORS>,
    /// Where three cells meet or a bisector meets the wall.
    pub branch_points: Vec<Point, MAX_BRANCH_POINTS>,
}

#[derive(Clone, Copy)]
struct Seed {
    a: u8,
    b: u8,
    at: Point,
    used: bool,
}

/// Unit vector away from the nearest point of hole `i` (the gradient of the distance).
pub(crate) fn away_from_hole(slice: &Slice, i: usize, p: Point) -> (Point, f32) {
    let near = slice.holes()[i].nearest(p);
    (near.gradient(p), near.distance)
}

/// `p` moved onto the bisector `d_a = d_b` of holes `a` and `b` by Newton steps along the
/// gradient of `d_a - d_b` (the stored polylines are simplified; points placed on them are
/// pulled back onto the exact bisector).
pub(crate) fn onto_bisector(slice: &Slice, a: usize, b: usize, mut p: Point) -> Point {
    for _ in 0..4 {
        let (na, da) = away_from_hole(slice, a, p);
        let (nb, db) = away_from_hole(slice, b, p);
        let gr = na - nb;
        let g2 = gr.norm2();
        if g2 < 1e-8 || libm::fabsf(da - db) < 1e-6 {
            break;
        }
        p = p - gr * ((da - db) / g2);
    }
    p
}

impl Cells {
    /// An empty decomposition.
    pub const fn new() -> Cells {
        Cells {
            bisectors: Vec::new(),
            branch_points: Vec::new(),
        }
    }

    /// Traces every bisector of the labelled field.
    // Not inlined: its working set stays in a frame of its own, which the planner's other
    // phases then share instead of adding to (`Planner::plan`'s frame).
    #[inline(never)]
    pub fn build(
        &mut self,
        slice: &Slice,
        field: &Field,
        scratch: &mut Vec<Point, TRACE_POINTS>,
    ) -> Result<(), Error> {
        self.bisectors.clear();
        self.branch_points.clear();
        let grid = *field.grid();
        let mut seeds: Vec<Seed, BISECTOR_SEEDS> = Vec::new();
        for k in 0..grid.len() {
            let la = field.label(k);
            if la >= KEEP_OUT {
                continue;
            }
            for nb in [k + 1, k + grid.nx] {
                if nb >= grid.len() {
                    continue;
                }
                let lb = field.label(nb);
                if lb < KEEP_OUT && lb != la {
                    let (p, q) = (grid.node(k), grid.node(nb));
                    let (a, b) = (la.min(lb), la.max(lb));
                    let g = |x: Point| {
                        slice.holes()[a as usize].signed_distance(x)
                            - slice.holes()[b as usize].signed_distance(x)
                    };
                    // g < 0 on a's side.
                    let (p, q) = if la == a { (q, p) } else { (p, q) };
                    let at = bisect(p, q, g);
                    seeds
                        .push(Seed {
                            a,
                            b,
                            at,
                            used: false,
                        })
                        .map_err(|_| Error::Capacity {
                            limit: Limit::BisectorSeeds,
                            feature: None,
                        })?;
                }
            }
        }
        let w = slice.settings().road_width;
        let step = 0.5 * grid.h.fmin(w);
        for s in 0..seeds.len() {
            if seeds[s].used {
                continue;
            }
            let (a, b) = (seeds[s].a as usize, seeds[s].b as usize);
            let start = seeds[s].at;
            scratch.clear();
            let back_end = march(slice, a, b, start, -1.0, step, scratch)?;
            scratch.reverse();
            push_point(scratch, start)?;
            let fwd_end = march(slice, a, b, start, 1.0, step, scratch)?;
            let mut bis = Bisector {
                a: a as u8,
                b: b as u8,
                points: Vec::new(),
                tolerance: 0.002,
            };
            while polyline::simplify(scratch, bis.tolerance, &mut bis.points).is_err() {
                bis.tolerance *= 2.0;
                if bis.tolerance > 0.1 {
                    return Err(Error::Capacity {
                        limit: Limit::BisectorPoints,
                        feature: None,
                    });
                }
            }
            for seed in seeds.iter_mut() {
                if seed.a as usize == a
                    && seed.b as usize == b
                    && polyline::project(scratch, seed.at).2 < 1.5 * grid.h
                {
                    seed.used = true;
                }
            }
            if bis.points.len() < 2 || bis.length() < 0.5 * step {
                continue;
            }
            for (end, is_branch) in [
                (bis.points[0], back_end),
                (bis.points[bis.points.len() - 1], fwd_end),
            ] {
                if is_branch && !self.branch_points.iter().any(|q| q.dist(end) < 0.05) {
                    self.branch_points.push(end).map_err(|_| Error::Capacity {
                        limit: Limit::BranchPoints,
                        feature: None,
                    })?;
                }
            }
            self.bisectors.push(bis).map_err(|_| Error::Capacity {
                limit: Limit::Bisectors,
                feature: None,
            })?;
        }
        debug!(
            "cells: {} bisectors, {} branch points",
            self.bisectors.len(),
            self.branch_points.len()
        );
        Ok(())
    }

    /// The bisector pieces between holes `a` and `b` (any order), with their indices.
    pub fn between(&self, a: usize, b: usize) -> impl Iterator<Item = (usize, &Bisector)> {
        let (a, b) = (a.min(b) as u8, a.max(b) as u8);
        self.bisectors
            .iter()
            .enumerate()
            .filter(move |(_, x)| x.a == a && x.b == b)
    }
}

fn push_point(buf: &mut Vec<Point, TRACE_POINTS>, p: Point) -> Result<(), Error> {
    buf.push(p).map_err(|_| Error::Capacity {
        limit: Limit::TracePoints,
        feature: None,
    })
}

/// Marches along the bisector of holes `a`, `b` from `start` in direction `sign`, appending
/// points. Returns whether it ended at a branch point (rather than closing on itself).
fn march(
    slice: &Slice,
    a: usize,
    b: usize,
    start: Point,
    sign: f32,
    step: f32,
    out: &mut Vec<Point, TRACE_POINTS>,
) -> Result<bool, Error> {
    let half = 0.5 * slice.settings().road_width;
    let mut p = start;
    let mut prev_t: Option<Point> = None;
    for n in 0..TRACE_POINTS {
        let (na, _) = away_from_hole(slice, a, p);
        let (nb, _) = away_from_hole(slice, b, p);
        let mut t = (na - nb).perp().normalized() * sign;
        if let Some(pt) = prev_t {
            if t.dot(pt) < 0.0 {
                t = -t;
            }
        }
        prev_t = Some(t);
        // Predictor along the tangent, corrector back onto d_a = d_b.
        let q = onto_bisector(slice, a, b, p + t * step);
        // Leaving the wall's printable region: a branch point on the wall.
        if slice.wall_clearance(q) < half {
            let e = bisect(p, q, |x| slice.wall_clearance(x) - half);
            push_point(out, e)?;
            return Ok(true);
        }
        // Entering a third cell: a branch point of three cells, where a third hole is as near
        // as the farther of `a` and `b` (measuring only the holes whose box is that near).
        let third = |x: Point| {
            let d = |c: usize| slice.holes()[c].signed_distance(x);
            slice.hole_within(x, d(a).fmax(d(b)), |c| c == a || c == b)
        };
        if third(q) {
            // Positive on `p`'s side, in no third cell.
            let e = bisect(p, q, |x| if third(x) { -1.0 } else { 1.0 });
            push_point(out, e)?;
            return Ok(true);
        }
        if n > 3 && q.dist(start) < 0.5 * step {
            return Ok(false);
        }
        // No progress: the distances have no usable gradient here (the trace sits where the
        // bisector ends in a degenerate point); end the bisector.
        if q.dist(p) < 0.25 * step {
            return Ok(false);
        }
        push_point(out, q)?;
        p = q;
    }
    Err(Error::Capacity {
        limit: Limit::TracePoints,
        feature: None,
    })
}
