//! The traced loops as closed curves: their points and arc lengths, the boxes around runs of
//! their segments, a point at an arc length, the projection onto a loop, the loop below a
//! point, and whether a stretch of a loop is free for a bridge.

use super::{capacity, distance, wrap, OffsetSpiral, RUN};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, Point};
use crate::{Error, Limit, Slice};
use core::ops::Range;

impl OffsetSpiral {
    pub(super) fn pts(&self, l: usize) -> &[Point] {
        let lp = &self.loops[l];
        &self.points[lp.start as usize..(lp.start + lp.len) as usize]
    }

    /// The arc length along loop `l` of its point `k`: from the first point of `k`'s run (or
    /// of the loop) on, the segments summed in the order the trace summed them, so the same
    /// bits as a table of every point's arc length would hold.
    pub(super) fn arc_of(&self, l: usize, k: usize) -> f32 {
        let g = self.loops[l].start as usize + k;
        let (from, mut s) = self.run_head(l, g / RUN);
        for m in from + 1..=g {
            s += self.points[m - 1].dist(self.points[m]);
        }
        s
    }

    /// The first point of run `r` in loop `l` (an index into `points`: the loop's own first
    /// point for the run it starts in) and its arc length along the loop (0 for the loop's
    /// first point).
    fn run_head(&self, l: usize, r: usize) -> (usize, f32) {
        let start = self.loops[l].start as usize;
        let first = (r * RUN).max(start);
        (first, if first == start { 0.0 } else { self.run_arc[r] })
    }

    /// The number of leading points of loop `l` whose arc length satisfies `pred` (true up to
    /// some point, false after: `partition_point` over the arc lengths), and the arc length
    /// of the last of them (0 if none): the runs' first points, searched by halves, narrow it
    /// to one run, which is walked.
    pub(super) fn arc_partition(&self, l: usize, pred: impl Fn(f32) -> bool) -> (usize, f32) {
        let (start, n) = (self.loops[l].start as usize, self.loops[l].len as usize);
        // The runs whose first point satisfies `pred` are a prefix (`pred` is monotone and the
        // arc lengths grow): find its end.
        let (mut lo, mut hi) = (start / RUN, (start + n).div_ceil(RUN));
        let first = lo;
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if pred(self.run_head(l, mid).1) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        if lo == first {
            return (0, 0.0);
        }
        let r = lo - 1;
        let to = ((r + 1) * RUN).min(start + n);
        let (mut k, mut s) = self.run_head(l, r);
        while k + 1 < to {
            let next = s + self.points[k].dist(self.points[k + 1]);
            if !pred(next) {
                break;
            }
            s = next;
            k += 1;
        }
        (k + 1 - start, s)
    }

    /// The point of loop `l` at arc length `s`.
    pub(super) fn at(&self, l: usize, s: f32) -> Point {
        let pts = self.pts(l);
        let len = self.loops[l].length;
        let s = wrap(s, len);
        // The last point at or before `s` (the first, if none is: `s` is never below 0 here).
        let (count, sa) = self.arc_partition(l, |a| a <= s);
        let k = count.max(1) - 1;
        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
        let sb = if k + 1 < pts.len() {
            sa + a.dist(b)
        } else {
            len
        };
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
                b.0 = Point::new(b.0.x.fmin(q.x), b.0.y.fmin(q.y));
                b.1 = Point::new(b.1.x.fmax(q.x), b.1.y.fmax(q.y));
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
        let pts = self.pts(l);
        let len = self.loops[l].length;
        let n = pts.len();
        // (parameter along the segment, distance, segment): the arc length is measured once,
        // for the segment that wins.
        let visit = |ks: Range<usize>, best: &mut (f32, f32, usize)| {
            for k in ks {
                let (a, b) = (pts[k], pts[(k + 1) % n]);
                let (q, t) = crate::geometry::primitives::closest_on_segment(a, b, p);
                let d = q.dist(p);
                if d < best.1 || (d == best.1 && k < best.2) {
                    *best = (t, d, k);
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
        let (t, d, k) = best;
        if k == usize::MAX {
            return (0.0, d);
        }
        let sa = self.arc_of(l, k);
        let sb = if k + 1 < n {
            sa + pts[k].dist(pts[k + 1])
        } else {
            len
        };
        (sa + t * (sb - sa), d)
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
