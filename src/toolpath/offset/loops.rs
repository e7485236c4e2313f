//! The traced loops as closed curves: their points and arc lengths, the boxes around runs of
//! their segments, a point at an arc length, the projection onto a loop, the loop below a
//! point, and whether a stretch of a loop is free for a bridge.

use super::{capacity, distance, wrap, OffsetSpiral, RUN};
use crate::geometry::{polygon, Point};
use crate::{Error, Limit, Slice};
use core::ops::Range;

impl OffsetSpiral {
    pub(super) fn pts(&self, l: usize) -> &[Point] {
        let lp = &self.loops[l];
        &self.points[lp.start as usize..(lp.start + lp.len) as usize]
    }

    pub(super) fn arcs(&self, l: usize) -> &[f32] {
        let lp = &self.loops[l];
        &self.arc[lp.start as usize..(lp.start + lp.len) as usize]
    }

    /// The point of loop `l` at arc length `s`.
    pub(super) fn at(&self, l: usize, s: f32) -> Point {
        let (pts, arc) = (self.pts(l), self.arcs(l));
        let len = self.loops[l].length;
        let s = wrap(s, len);
        let k = arc.partition_point(|&a| a <= s).max(1) - 1;
        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
        let (sa, sb) = (arc[k], if k + 1 < arc.len() { arc[k + 1] } else { len });
        let t = if sb > sa { (s - sa) / (sb - sa) } else { 0.0 };
        a.lerp(b, t.clamp(0.0, 1.0))
    }

    /// Adds the segments of loop `start .. start + n` of `points` to the boxes of their runs.
    pub(super) fn add_runs(&mut self, start: usize, n: usize) -> Result<(), Error> {
        const EMPTY: (Point, Point) = (
            Point::new(f32::INFINITY, f32::INFINITY),
            Point::new(f32::NEG_INFINITY, f32::NEG_INFINITY),
        );
        for k in 0..n {
            let r = (start + k) / RUN;
            while self.runs.len() <= r {
                self.runs
                    .push(EMPTY)
                    .map_err(|_| capacity(Limit::ContourPoints))?;
            }
            let b = &mut self.runs[r];
            for q in [self.points[start + k], self.points[start + (k + 1) % n]] {
                b.0 = Point::new(b.0.x.min(q.x), b.0.y.min(q.y));
                b.1 = Point::new(b.1.x.max(q.x), b.1.y.max(q.y));
            }
        }
        Ok(())
    }

    /// The runs of loop `l`'s segments: (the run's box, the range of segment indices of the
    /// loop in it), in the loop's order.
    pub(super) fn loop_runs(
        &self,
        l: usize,
    ) -> impl Iterator<Item = ((Point, Point), Range<usize>)> + '_ {
        let (start, n) = (self.loops[l].start as usize, self.loops[l].len as usize);
        (start / RUN..(start + n).div_ceil(RUN)).map(move |r| {
            let (a, b) = ((r * RUN).max(start), ((r + 1) * RUN).min(start + n));
            (self.runs[r], a - start..b - start)
        })
    }

    /// The arc length of the point of loop `l` nearest `p`, and the distance: of equal
    /// distances, the first along the loop. The run of segments whose box is nearest is
    /// measured first, then the runs whose box is no farther than the best so far.
    pub(super) fn project(&self, l: usize, p: Point) -> (f32, f32) {
        let (pts, arc) = (self.pts(l), self.arcs(l));
        let len = self.loops[l].length;
        let n = pts.len();
        // (arc length, distance, segment)
        let visit = |ks: Range<usize>, best: &mut (f32, f32, usize)| {
            for k in ks {
                let (a, b) = (pts[k], pts[(k + 1) % n]);
                let (q, t) = crate::geometry::primitives::closest_on_segment(a, b, p);
                let d = q.dist(p);
                if d < best.1 || (d == best.1 && k < best.2) {
                    let sb = if k + 1 < n { arc[k + 1] } else { len };
                    *best = (arc[k] + t * (sb - arc[k]), d, k);
                }
            }
        };
        let nearest_run = self
            .loop_runs(l)
            .map(|(b, ks)| (polygon::bbox_distance2(b, p), ks))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let Some((_, first)) = nearest_run else {
            return (0.0, f32::INFINITY);
        };
        let mut best = (0.0, f32::INFINITY, usize::MAX);
        visit(first.clone(), &mut best);
        for (b, ks) in self.loop_runs(l) {
            if ks != first && polygon::bbox_distance(b, p) <= best.1 + polygon::rounding_slack(p, b)
            {
                visit(ks, &mut best);
            }
        }
        (best.0, best.1)
    }

    /// The loop one level below `l` that the point `p` of `l` faces a road width away, with
    /// the arc length there.
    /// `tol` is how far (in road widths) from the lower loop the back-projection may land.
    pub(super) fn below(
        &self,
        slice: &Slice,
        l: usize,
        p: Point,
        tol: f32,
    ) -> Option<(usize, f32)> {
        let w = slice.settings().road_width;
        let level = self.loops[l].level;
        if level == 0 {
            return None;
        }
        let (_, g, _) = distance(slice, p);
        let q = p - g * w;
        let tol = tol * w;
        let mut best: Option<(usize, f32, f32)> = None;
        for (m, lp) in self.loops.iter().enumerate() {
            if lp.level + 1 != level || polygon::bbox_distance(lp.bbox, q) > tol {
                continue;
            }
            let (s, d) = self.project(m, q);
            if d < tol && best.is_none_or(|b| d < b.2) {
                best = Some((m, s, d));
            }
        }
        best.map(|(m, s, _)| (m, s))
    }

    /// Whether `[s1, s2]` (forward, on loop `l`) keeps `margin` clear of every site on `l`.
    pub(super) fn free(&self, l: usize, s1: f32, s2: f32, margin: f32) -> bool {
        let len = self.loops[l].length;
        let span = wrap(s2 - s1, len) + 2.0 * margin;
        if span >= len {
            return false;
        }
        let lo = s1 - margin;
        self.sites.iter().all(|st| {
            let (t1, t2) = if st.a as usize == l {
                (st.a1, st.a2)
            } else if st.b as usize == l {
                (st.b1, st.b2)
            } else {
                return true;
            };
            // Two arcs of the loop overlap if either starts inside the other.
            let other = wrap(t2 - t1, len);
            wrap(t1 - lo, len) > span && wrap(lo - t1, len) > other
        })
    }
}
