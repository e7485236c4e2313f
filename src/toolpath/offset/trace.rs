//! Tracing the turns: `D` sampled on a grid (in the lent [`GridMemory`]), each level curve
//! followed by marching squares, its points put onto the level exactly and refined where the
//! grid is coarse for the curve, then simplified into a loop.

use super::{
    capacity, distance, nearest, Loop, OffsetSpiral, OffsetStats, FIRST_TURN_MARGIN,
    MIN_LOOP_ROADS, NONE, OPTIONAL_LOOP_ROADS, REFINE_DEPTH, RUN, SIMPLIFY_TOL,
};
use crate::field::GridMemory;
use crate::geometry::primitives::bisect;
use crate::geometry::primitives::MinMax;
use crate::geometry::Point;
use crate::{Error, Limit, Slice};
use heapless::Vec;

/// No feature: the nearest feature of a point no chord is refined at.
const NONE_FEATURE: usize = usize::MAX;

impl OffsetSpiral {
    /// Samples `D` on a grid over the wall, half a road width apart or coarser.
    pub(super) fn sample(&mut self, slice: &Slice, mem: &mut GridMemory) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let (lo, hi) = slice.wall().bbox();
        // As the field's grid: the spacing from the slice and the road only, the capacity
        // only decides whether it fits.
        self.grid = crate::field::fitted_grid(lo, hi, 0.5 * w, w, true)?;
        mem.clear();
        for k in 0..self.grid.len() {
            let (d, _, _) = distance(slice, self.grid.node(k));
            mem.values.push(d).map_err(|_| capacity(Limit::GridNodes))?;
            mem.tags.push(0).map_err(|_| capacity(Limit::GridNodes))?;
        }
        Ok(())
    }

    /// Traces the loops of every level `w/2 + k w` that some node reaches.
    pub(super) fn trace_all(
        &mut self,
        slice: &Slice,
        mem: &mut GridMemory,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let top = mem.values.iter().fold(0.0f32, |a, &b| a.fmax(b));
        self.points.clear();
        self.run_arc.clear();
        self.runs.clear();
        self.loops.clear();
        let mut k = 0u16;
        loop {
            let level = 0.5 * w + FIRST_TURN_MARGIN + k as f32 * w;
            if level >= top {
                break;
            }
            for m in mem.tags.iter_mut() {
                *m = 0;
            }
            let (nx, ny) = (self.grid.nx, self.grid.ny);
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    for e in 0..4u8 {
                        let c = j * nx + i;
                        if self.is_entry(&mem.values, c, e, level) && mem.tags[c] & (1 << e) == 0 {
                            self.trace(slice, mem, c, e, level, k, stats)?;
                        }
                    }
                }
            }
            k += 1;
        }
        stats.levels = k;
        Ok(())
    }

    /// Values at the corners of cell `c` (lower-left node `c`), counter-clockwise.
    pub(super) fn corners(&self, d: &[f32], c: usize) -> [f32; 4] {
        let nx = self.grid.nx;
        [d[c], d[c + 1], d[c + nx + 1], d[c + nx]]
    }

    /// Whether the level curve enters cell `c` through edge `e` (corner `e` above the level,
    /// corner `e + 1` below: the material above the level stays on the curve's left).
    pub(super) fn is_entry(&self, d: &[f32], c: usize, e: u8, level: f32) -> bool {
        let v = self.corners(d, c);
        v[e as usize] > level && v[(e as usize + 1) % 4] <= level
    }

    /// The edge the curve entering cell `c` through `e` leaves by.
    pub(super) fn exit(&self, d: &[f32], c: usize, e: u8, level: f32) -> u8 {
        let v = self.corners(d, c);
        let above = |k: usize| v[k % 4] > level;
        let saddle = above(0) == above(2) && above(1) == above(3) && above(0) != above(1);
        if saddle {
            let centre = 0.25 * (v[0] + v[1] + v[2] + v[3]);
            return if centre > level {
                (e + 1) % 4
            } else {
                (e + 3) % 4
            };
        }
        (0..4u8)
            .find(|&x| !above(x as usize) && above(x as usize + 1))
            .unwrap_or((e + 1) % 4)
    }

    /// The point where the level crosses edge `e` of cell `c`, put onto the level exactly.
    pub(super) fn crossing(&self, slice: &Slice, d: &[f32], c: usize, e: u8, level: f32) -> Point {
        let nx = self.grid.nx;
        let node = [c, c + 1, c + nx + 1, c + nx];
        let (a, b) = (node[e as usize], node[(e as usize + 1) % 4]);
        let (da, db) = (d[a], d[b]);
        let t = ((level - da) / (db - da)).clamp(0.0, 1.0);
        let (na, nb) = (self.grid.node(a), self.grid.node(b));
        let p0 = na.lerp(nb, t);
        // Where the steps run off (near a ridge or a peak of D), the level is found on the
        // grid edge itself by bisection on the exact distance (the nodes' samples straddle
        // it).
        self.on_level(slice, p0, level).unwrap_or_else(|| {
            let below = distance(slice, na).0 < level;
            // Positive on `na`'s side of the level.
            bisect(na, nb, |x| {
                if (distance(slice, x).0 < level) == below {
                    1.0
                } else {
                    -1.0
                }
            })
        })
    }

    /// The point of the level `level` nearest `p0` by Newton steps along the distance
    /// gradient, or `None` where the steps run off (near a ridge of `D`).
    pub(super) fn on_level(&self, slice: &Slice, p0: Point, level: f32) -> Option<Point> {
        let mut p = p0;
        for _ in 0..4 {
            let (d, g, _) = distance(slice, p);
            let step = level - d;
            p = p + g * step;
            if step.abs() < 1e-6 {
                break;
            }
        }
        (p.dist(p0) <= self.grid.h && p.is_finite()).then_some(p)
    }

    /// Pushes the points of level `level` between the traced points `a` and `b` that keep
    /// the chords within [`SIMPLIFY_TOL`] of the level: where the grid is coarse for the
    /// level's curvature (a road a good fraction of the slice wide, whose grid is coarse too)
    /// the chord between two grid crossings would cut into the turn's clearance, and at a
    /// corner of the level (where it meets another feature's at a ridge) it would cut the
    /// corner off. `a` and `b` come with the features nearest them (`nearest(slice, a).0`,
    /// measured once a point, for both chords it ends).
    pub(super) fn refine(
        &mut self,
        slice: &Slice,
        (a, fa): (Point, usize),
        (b, fb): (Point, usize),
        level: f32,
        depth: u32,
    ) -> Result<(), Error> {
        if depth == 0 {
            return Ok(());
        }
        let mid = a.lerp(b, 0.5);
        // The feature nearest a point put in, where the chords either side of it are refined
        // further (the only use of it).
        let feature_of = |p: Point| {
            if depth > 1 {
                nearest(slice, p).0
            } else {
                NONE_FEATURE
            }
        };
        // Across a ridge the level has a corner: put it in exactly (the chord across a
        // corner of the turn would cut it off, and neither end's steps reach it).
        if fa != fb {
            if let Some((c, fc)) = level_corner(slice, (fa, fb), mid, level, a.dist(b)) {
                if c.dist(a) > 1e-4 && c.dist(b) > 1e-4 {
                    self.refine(slice, (a, fa), (c, fc), level, depth - 1)?;
                    self.points
                        .push(c)
                        .map_err(|_| capacity(Limit::ContourPoints))?;
                    return self.refine(slice, (c, fc), (b, fb), level, depth - 1);
                }
            }
        }
        let Some(m) = self.on_level(slice, mid, level) else {
            return Ok(());
        };
        if m.dist(mid) <= 0.5 * SIMPLIFY_TOL {
            return Ok(());
        }
        let fm = feature_of(m);
        self.refine(slice, (a, fa), (m, fm), level, depth - 1)?;
        self.points
            .push(m)
            .map_err(|_| capacity(Limit::ContourPoints))?;
        self.refine(slice, (m, fm), (b, fb), level, depth - 1)
    }

    /// Traces one loop from cell `c0`, entry edge `e0`, simplifies it and records it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn trace(
        &mut self,
        slice: &Slice,
        mem: &mut GridMemory,
        c0: usize,
        e0: u8,
        level: f32,
        k: u16,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let start = self.points.len();
        let (nx, ny) = (self.grid.nx, self.grid.ny);
        let (mut c, mut e) = (c0, e0);
        // The features nearest the first point and the last one traced.
        let (mut first_f, mut last_f) = (NONE_FEATURE, NONE_FEATURE);
        for _ in 0..4 * self.grid.len() {
            mem.tags[c] |= 1 << e;
            let x = self.exit(&mem.values, c, e, level);
            let p = self.crossing(slice, &mem.values, c, x, level);
            if self.points.last() != Some(&p) {
                let fp = nearest(slice, p).0;
                if let Some(&prev) = self.points[start..].last() {
                    self.refine(slice, (prev, last_f), (p, fp), level, REFINE_DEPTH)?;
                } else {
                    first_f = fp;
                }
                last_f = fp;
                self.points
                    .push(p)
                    .map_err(|_| capacity(Limit::ContourPoints))?;
            }
            let (i, j) = (c % nx, c / nx);
            let next = match x {
                0 if j > 0 => c - nx,
                1 if i + 2 < nx => c + 1,
                2 if j + 2 < ny => c + nx,
                3 if i > 0 => c - 1,
                // The grid has a border of nodes outside the wall, below every level.
                _ => break,
            };
            c = next;
            e = (x + 2) % 4;
            if c == c0 && e == e0 {
                break;
            }
        }
        if let (Some(&first), Some(&last)) = (self.points.get(start), self.points.last()) {
            if self.points.len() > start + 1 {
                self.refine(slice, (last, last_f), (first, first_f), level, REFINE_DEPTH)?;
            }
        }
        let len = simplify_closed(&mut self.points, start, SIMPLIFY_TOL);
        self.points.truncate(start + len);
        stats.loops += 1;
        // Arc lengths (kept at the first point of every run) and box.
        let pts = &self.points[start..];
        let mut s = 0.0;
        let mut bbox = (pts[0], pts[0]);
        for (m, &p) in pts.iter().enumerate() {
            if m > 0 {
                s += pts[m - 1].dist(p);
                if (start + m) % RUN == 0 {
                    let r = (start + m) / RUN;
                    if self.run_arc.len() <= r {
                        self.run_arc
                            .resize(r + 1, 0.0)
                            .map_err(|_| capacity(Limit::ContourPoints))?;
                    }
                    self.run_arc[r] = s;
                }
            }
            bbox = (
                Point::new(bbox.0.x.fmin(p.x), bbox.0.y.fmin(p.y)),
                Point::new(bbox.1.x.fmax(p.x), bbox.1.y.fmax(p.y)),
            );
        }
        let length = s + pts[pts.len() - 1].dist(pts[0]);
        if pts.len() < 3 || length < MIN_LOOP_ROADS * w {
            self.points.truncate(start);
            stats.dropped += 1;
            return Ok(());
        }
        self.loops
            .push(Loop {
                start: start as u16,
                len: len as u16,
                level: k,
                length,
                bbox,
                parent: NONE,
                order: NONE,
                tried: 0,
                seam_tried: 0,
                optional: length < OPTIONAL_LOOP_ROADS * w,
                tight: false,
            })
            .map_err(|_| capacity(Limit::ContourLoops))?;
        self.add_runs(start, len)
    }
}

/// Where the level `level` of features `fa` and `fb` meet (the corner of the turn at the
/// ridge between them), by Newton steps on both distances from `p0`, if the steps converge
/// within `reach` of `p0` onto a point no other feature is nearer to; with it, the feature
/// nearest it.
fn level_corner(
    slice: &Slice,
    (fa, fb): (usize, usize),
    p0: Point,
    level: f32,
    reach: f32,
) -> Option<(Point, usize)> {
    let mut p = p0;
    for _ in 0..8 {
        let (da, ga) = slice.clearance_gradient_to(fa, p);
        let (db, gb) = slice.clearance_gradient_to(fb, p);
        let (ra, rb) = (level - da, level - db);
        if ra.abs() < 1e-6 && rb.abs() < 1e-6 {
            break;
        }
        // Solve [ga; gb] x = [ra; rb].
        let det = ga.x * gb.y - ga.y * gb.x;
        if det.abs() < 1e-3 {
            return None;
        }
        p = p + Point::new((ra * gb.y - rb * ga.y) / det, (ga.x * rb - gb.x * ra) / det);
        if !p.is_finite() || p.dist(p0) > reach {
            return None;
        }
    }
    let (f, d, _) = nearest(slice, p);
    ((f == fa || f == fb) && (d - level).abs() < 1e-5).then_some((p, f))
}

/// Simplifies the closed polyline `pts[start..]` in place, keeping every point whose removal
/// would move the curve more than `tol`; returns how many points remain.
fn simplify_closed<const N: usize>(pts: &mut Vec<Point, N>, start: usize, tol: f32) -> usize {
    let n = pts.len() - start;
    if n < 4 {
        return n;
    }
    let mut out = start + 1;
    let mut anchor = start;
    let mut k = start + 1;
    while k < pts.len() {
        // Extend the chord from the anchor as far as every skipped point stays within `tol`.
        let mut end = k;
        while end + 1 < pts.len() && end + 1 - anchor <= 64 {
            let (a, b) = (pts[anchor], pts[end + 1]);
            let fits = (anchor + 1..=end).all(|m| {
                let (q, _) = crate::geometry::primitives::closest_on_segment(a, b, pts[m]);
                q.dist(pts[m]) <= tol
            });
            if !fits {
                break;
            }
            end += 1;
        }
        pts[out] = pts[end];
        out += 1;
        anchor = end;
        k = end + 1;
    }
    out - start
}
