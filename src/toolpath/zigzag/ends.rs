//! The MCLs' ends on the keep-out curves, and how they pair: which curve and where along it
//! each end lies, the arcs pairing consecutive ends, the separate pieces they make (union-find),
//! and the parity fix that leaves MCLs out until at most two curves are odd.

use super::arc::arc_of_direction;
use super::{CURVES, ENDS, NONE};
use crate::config::MAX_MCLS;
use crate::error::Limit;
use crate::geometry::{polyline, Point};
use crate::keep_out::KeepOut;
use crate::{Error, Plan, Slice, Target};
use heapless::Vec;

/// The curves (hole index, or `holes` for the wall) of the two ends of MCL `k`.
pub(super) fn curve_pair(plan: &Plan, k: usize, holes: usize) -> (usize, usize) {
    let m = &plan.mcls[k];
    let b = match m.to {
        Target::Hole(j) => j as usize,
        Target::Wall => holes,
    };
    (m.from as usize, b)
}

/// The ends of all MCLs, on their curves.
pub(super) struct Ends {
    /// The MCLs taking part: end ids `2i`, `2i + 1` are the ends of MCL `mcls[i]`.
    pub(super) mcls: Vec<u16, MAX_MCLS>,
    /// Curve of each end: a hole index, or `holes` for the wall.
    pub(super) curve: [u8; ENDS],
    /// Parameter of each end along its curve.
    pub(super) param: [f32; ENDS],
    /// End ids sorted by (curve, param).
    pub(super) order: Vec<u16, ENDS>,
    /// Where each end stands in `order`, counted from the start of its curve's range.
    pub(super) slot: [u16; ENDS],
    /// For each curve, its range in `order`.
    pub(super) ranges: Vec<(u16, u16), CURVES>,
    /// The arc partner of each end (NONE if unpaired).
    pub(super) arc: [u16; ENDS],
    pub(super) count: usize,
}

pub(super) fn find(parent: &mut [u16], mut x: u16) -> u16 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}

pub(super) fn union(parent: &mut [u16], a: u16, b: u16) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
}

impl Ends {
    /// No ends (12 KiB on a controller: fill it where it stays, [`fill`](Self::fill)).
    pub(super) fn empty() -> Ends {
        Ends {
            mcls: Vec::new(),
            curve: [0; ENDS],
            param: [0.0; ENDS],
            order: Vec::new(),
            ranges: Vec::new(),
            arc: [NONE; ENDS],
            slot: [0; ENDS],
            count: 0,
        }
    }

    /// The ends of the MCLs `mcls`, in place (built in a frame of its own and returned by
    /// value, they took a second 12 KiB).
    pub(super) fn fill(
        &mut self,
        slice: &Slice,
        plan: &Plan,
        curves: &[KeepOut<'_>],
        mcls: &Vec<u16, MAX_MCLS>,
    ) -> Result<(), Error> {
        let holes = slice.holes().len();
        let e = self;
        e.mcls.clone_from(mcls);
        e.count = 2 * mcls.len();
        e.order.clear();
        e.ranges.clear();
        e.arc = [NONE; ENDS];
        for (k, &mk) in mcls.iter().enumerate() {
            let m = &plan.mcls[mk as usize];
            e.curve[2 * k] = m.from;
            e.param[2 * k] = plan.halves[m.first as usize].s;
            match (m.to, m.second) {
                (Target::Hole(j), Some(second)) => {
                    e.curve[2 * k + 1] = j;
                    e.param[2 * k + 1] = plan.halves[second as usize].s;
                }
                _ => {
                    let last = plan.halves.end_point(m.first as usize);
                    e.curve[2 * k + 1] = holes as u8;
                    e.param[2 * k + 1] = curves[holes].param_of(last);
                }
            }
        }
        for id in 0..e.count as u16 {
            // Never full: two ends per MCL, at most ENDS.
            e.order.push(id).map_err(|_| Limit::Mcls.error())?;
        }
        let (curve, param) = (&e.curve, &e.param);
        e.order.sort_unstable_by(|&a, &b| {
            curve[a as usize]
                .cmp(&curve[b as usize])
                .then(param[a as usize].total_cmp(&param[b as usize]))
                .then(a.cmp(&b))
        });
        let mut start = 0;
        for c in 0..=holes {
            let mut end = start;
            while end < e.count && e.curve[e.order[end] as usize] as usize == c {
                end += 1;
            }
            for k in start..end {
                e.slot[e.order[k] as usize] = (k - start) as u16;
            }
            // Never full: one range per curve, at most CURVES.
            e.ranges
                .push((start as u16, end as u16))
                .map_err(|_| Limit::Holes.error())?;
            start = end;
        }
        Ok(())
    }

    /// Pairs consecutive ends of curve `c` starting at position `offset` of its range; with an
    /// odd count the end at `offset - 1` stays unpaired.
    pub(super) fn pair_curve(&mut self, c: usize, offset: usize) {
        let (a, b) = self.ranges[c];
        let (a, b) = (a as usize, b as usize);
        let n = b - a;
        for k in a..b {
            self.arc[self.order[k] as usize] = NONE;
        }
        for i in 0..n / 2 {
            let x = self.order[a + (offset + 2 * i) % n];
            let y = self.order[a + (offset + 2 * i + 1) % n];
            self.arc[x as usize] = y;
            self.arc[y as usize] = x;
        }
    }

    /// The end `steps` places from end `id` along its curve (increasing arc length; back for
    /// a negative count), round the curve's ends.
    pub(super) fn beside(&self, id: u16, steps: isize) -> u16 {
        let (lo, hi) = self.ranges[self.curve[id as usize] as usize];
        let n = (hi - lo) as isize;
        let k = self.slot[id as usize] as isize;
        self.order[lo as usize + (k + steps).rem_euclid(n) as usize]
    }

    /// Joins ends `b` and `c` by an arc, their former mates to each other: arcs `(a, b)` and
    /// `(c, d)` become `(a, d)` and `(b, c)` (a splice); where one of them was free, the
    /// other's former mate is left free instead.
    pub(super) fn rejoin(&mut self, b: u16, c: u16) {
        let (a, d) = (self.arc[b as usize], self.arc[c as usize]);
        if a != NONE {
            self.arc[a as usize] = d;
        }
        if d != NONE {
            self.arc[d as usize] = a;
        }
        self.arc[b as usize] = c;
        self.arc[c as usize] = b;
    }

    /// Number of separate pieces (paths and loops) of MCLs and arcs.
    pub(super) fn pieces(&self, parent: &mut [u16; ENDS]) -> u16 {
        for (i, p) in parent.iter_mut().enumerate().take(self.count) {
            *p = i as u16;
        }
        for k in 0..self.count / 2 {
            union(parent, 2 * k as u16, 2 * k as u16 + 1);
        }
        for i in 0..self.count {
            if self.arc[i] != NONE {
                union(parent, i as u16, self.arc[i]);
            }
        }
        (0..self.count)
            .filter(|&i| find(parent, i as u16) == i as u16)
            .count() as u16
    }
}

/// Which stretches of the keep-out curves the arcs lay, once the pairings and splices are
/// chosen: stretch `k` of a curve runs from its `k`-th end (in [`Ends::order`]) to the next,
/// and is laid where an arc passes over it. Elsewhere the strip along the curve (a road wide,
/// kept for arcs) is nobody's: the strokes of the meanders beside it may run into it
/// ([`bare`](Self::bare)).
pub(super) struct Arcs {
    laid: [bool; ENDS],
}

impl Arcs {
    /// The stretches `ends`' arcs pass over.
    pub(super) fn new(ends: &Ends, curves: &[KeepOut<'_>]) -> Arcs {
        let mut laid = [false; ENDS];
        for id in 0..ends.count as u16 {
            let mate = ends.arc[id as usize];
            if mate == NONE || mate < id {
                continue;
            }
            let c = ends.curve[id as usize] as usize;
            let (lo, hi) = ends.ranges[c];
            let (lo, n) = (lo as usize, (hi - lo) as usize);
            let (forward, (count, _)) = arc_of_direction(ends, &curves[c], c, id, mate);
            let from = ends.slot[id as usize] as usize;
            // The stretches from `id`'s slot to `mate`'s, the way the arc runs.
            for k in 0..=count {
                let stretch = if forward {
                    (from + k) % n
                } else {
                    (from + n - 1 - k % n) % n
                };
                laid[lo + stretch] = true;
            }
        }
        Arcs { laid }
    }

    /// The stretch of curve beside end `id` that no arc lays, where the arc from `id` runs
    /// the other way: which way it runs from `id` (forward: increasing arc length) and half
    /// its length (the MCL at `id` owns the half next to it, the MCL at the stretch's other
    /// end the rest). `None` where both stretches beside `id` are laid, or both bare (a path's
    /// free end).
    pub(super) fn bare_beside(
        &self,
        ends: &Ends,
        curves: &[KeepOut<'_>],
        id: u16,
    ) -> Option<(bool, f32)> {
        let c = ends.curve[id as usize] as usize;
        let (lo, hi) = *ends.ranges.get(c)?;
        let (lo, n) = (lo as usize, (hi - lo) as usize);
        if n < 2 {
            return None;
        }
        let slot = ends.slot[id as usize] as usize;
        let param = |k: usize| ends.param[ends.order[lo + k % n] as usize];
        let curve = curves.get(c)?;
        let (ahead, behind) = (!self.laid[lo + slot], !self.laid[lo + (slot + n - 1) % n]);
        match (ahead, behind) {
            (true, false) => Some((true, 0.5 * curve.wrap(param(slot + 1) - param(slot)))),
            (false, true) => Some((false, 0.5 * curve.wrap(param(slot) - param(slot + n - 1)))),
            _ => None,
        }
    }

    /// Whether the keep-out strip nearest to `p` lies on a stretch no arc lays, at least
    /// `margin` (arc length) from either end of it: a curve without MCL ends is bare all round.
    pub(super) fn bare(
        &self,
        slice: &Slice,
        ends: &Ends,
        curves: &[KeepOut<'_>],
        p: Point,
        margin: f32,
    ) -> bool {
        let (c, _, _) = slice.nearest_feature(p);
        let (Some(&(lo, hi)), Some(curve)) = (ends.ranges.get(c), curves.get(c)) else {
            return false;
        };
        let (lo, n) = (lo as usize, (hi - lo) as usize);
        if n == 0 {
            return true;
        }
        let param = |k: usize| ends.param[ends.order[lo + k] as usize];
        let s = curve.param_of(p);
        // The stretch holding `s`: after the last end at or before it, or after the last end
        // of all where `s` comes before the first (the curve's ends are sorted by param).
        let at_or_before =
            ends.order[lo..lo + n].partition_point(|&id| ends.param[id as usize] <= s);
        let after = at_or_before.checked_sub(1).unwrap_or(n - 1);
        !self.laid[lo + after]
            && curve.wrap(s - param(after)) >= margin
            && curve.wrap(param((after + 1) % n) - s) >= margin
    }
}

/// MCL ends per curve (a hole index, or `holes` for the wall) among the `active` MCLs.
pub(super) fn end_counts(plan: &Plan, holes: usize, active: &[u16]) -> [u16; CURVES] {
    let mut count = [0u16; CURVES];
    for &k in active {
        let (a, b) = curve_pair(plan, k as usize, holes);
        count[a] += 1;
        count[b] += 1;
    }
    count
}

/// How many separate groups the curves holding MCL ends form, joined by the `active` MCLs.
pub(super) fn curve_groups(plan: &Plan, holes: usize, active: &[u16]) -> usize {
    let mut parent = [0u16; CURVES];
    for (i, p) in parent.iter_mut().enumerate() {
        *p = i as u16;
    }
    for &k in active {
        let (a, b) = curve_pair(plan, k as usize, holes);
        union(&mut parent, a as u16, b as u16);
    }
    let count = end_counts(plan, holes, active);
    (0..=holes)
        .filter(|&c| count[c] > 0 && find(&mut parent, c as u16) == c as u16)
        .count()
}

/// Leaves MCLs out of `active` until at most two curves hold an odd number of MCL ends (a
/// T-join: every odd curve is a free end, and each pair of free ends a separate path).
///
/// Each step takes the shortest chain of MCLs (by length, Dijkstra over the curves) from one
/// odd curve to another and leaves the whole chain out: its two end curves turn even, and
/// every curve it passes through loses two ends and keeps its parity. A chain is taken only
/// if every curve it touches keeps at least one MCL end (each feature's strip is still laid)
/// and the curves stay as connected as they were (the pieces can still be spliced into one
/// road). The neighbours' bands reach over the ground of the MCLs left out
/// (`meander::band::band_at` measures to the MCLs laid). Where no chain qualifies, the odd curves
/// that remain stay odd, and the layer needs a start per pair of them.
pub(super) fn even_out(plan: &Plan, holes: usize, active: &mut Vec<u16, MAX_MCLS>) {
    let curves = holes + 1;
    let mut length = [0.0f32; MAX_MCLS];
    for &k in active.iter() {
        length[k as usize] = polyline::length(&plan.points(&plan.mcls[k as usize]));
    }
    // Chains found to split the curves or empty one: not tried again.
    let mut refused: Vec<(u8, u8), { 4 * CURVES }> = Vec::new();
    loop {
        let count = end_counts(plan, holes, active);
        let odd = |c: usize| count[c] % 2 == 1;
        if (0..curves).filter(|&c| odd(c)).count() <= 2 {
            return;
        }
        let groups = curve_groups(plan, holes, active);
        // The shortest MCL joining each pair of curves.
        let mut edge = [[(f32::INFINITY, NONE); CURVES]; CURVES];
        for &k in active.iter() {
            let (a, b) = curve_pair(plan, k as usize, holes);
            if a != b && length[k as usize] < edge[a][b].0 {
                edge[a][b] = (length[k as usize], k);
                edge[b][a] = (length[k as usize], k);
            }
        }
        // The shortest chain from each odd curve to the nearest other odd curve.
        let mut best: Option<(f32, u8, u8, [u16; CURVES])> = None;
        for src in (0..curves).filter(|&c| odd(c)) {
            let mut dist = [f32::INFINITY; CURVES];
            // The MCL by which each curve was reached (NONE for the source).
            let mut via = [NONE; CURVES];
            let mut done = [false; CURVES];
            dist[src] = 0.0;
            while let Some(c) = (0..curves)
                .filter(|&c| !done[c] && dist[c].is_finite())
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))
            {
                done[c] = true;
                if c != src && odd(c) && !refused.contains(&(src as u8, c as u8)) {
                    if best.is_none_or(|b| dist[c] < b.0) {
                        best = Some((dist[c], src as u8, c as u8, via));
                    }
                    break;
                }
                for other in 0..curves {
                    let (len, k) = edge[c][other];
                    let d = dist[c] + len;
                    if !done[other] && d < dist[other] {
                        dist[other] = d;
                        via[other] = k;
                    }
                }
            }
        }
        let Some((_, src, dst, via)) = best else {
            return;
        };
        // Walk the chain back from `dst` and leave it out, unless that empties a curve or
        // splits the curves.
        let before: Vec<u16, MAX_MCLS> = active.clone();
        let mut c = dst as usize;
        while c != src as usize {
            let k = via[c];
            let (a, b) = curve_pair(plan, k as usize, holes);
            if let Some(i) = active.iter().position(|&m| m == k) {
                active.remove(i);
            }
            c = if a == c { b } else { a };
        }
        let after = end_counts(plan, holes, active);
        let emptied = (0..curves).any(|c| count[c] > 0 && after[c] == 0);
        if emptied || curve_groups(plan, holes, active) > groups {
            *active = before;
            if refused.push((src, dst)).is_err() {
                return;
            }
        }
    }
}

/// For every piece (by its union-find root), whether it has a free end: a path, not a loop.
pub(super) fn open_pieces(ends: &Ends, parent: &mut [u16; ENDS]) -> [bool; ENDS] {
    let mut open = [false; ENDS];
    for i in 0..ends.count {
        if ends.arc[i] == NONE {
            open[find(parent, i as u16) as usize] = true;
        }
    }
    open
}

/// The point of end `id`: its MCL's first point or last ([`Plan::mcl_ends`]).
pub(super) fn end_point(plan: &Plan, ends: &Ends, id: u16) -> Point {
    let (first, last) = plan.mcl_ends(&plan.mcls[ends.mcls[(id / 2) as usize] as usize]);
    if id % 2 == 0 {
        first
    } else {
        last
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::keep_out::Side;
    use crate::Settings;

    fn square(lo: f32, hi: f32) -> [Point; 4] {
        [
            Point::new(lo, lo),
            Point::new(hi, lo),
            Point::new(hi, hi),
            Point::new(lo, hi),
        ]
    }

    #[test]
    fn the_stretches_an_arc_passes_are_laid_and_the_others_bare() {
        // A 20 mm square wall (arc length 0 at (0, 0), counter-clockwise), one hole.
        let hole = square(9.0, 11.0);
        let holes = [(&hole[..], [0.0, 1.0, 0.0, 0.0])];
        let slice = Slice::from_contours(
            &square(0.0, 20.0),
            [1.0, 0.0, 0.0, 0.0],
            &holes,
            Settings::default(),
        )
        .unwrap();
        let half = 0.5 * slice.settings().road_width;
        let curves = [
            KeepOut::new(&slice.holes()[0], half, Side::Outside),
            KeepOut::new(slice.wall(), half, Side::Inside),
        ];
        // Four ends on the wall's curve, at 2, 4 (the bottom side), 22 and 24 mm (the right
        // side: y = 2 and 4); none on the hole's.
        let mut ends = Ends::empty();
        ends.count = 4;
        for (id, s) in [2.0f32, 4.0, 22.0, 24.0].into_iter().enumerate() {
            ends.curve[id] = 1;
            ends.param[id] = s;
            ends.order.push(id as u16).unwrap();
            ends.slot[id] = id as u16;
        }
        ends.ranges.push((0, 0)).unwrap();
        ends.ranges.push((0, 4)).unwrap();
        // Arcs 2 -> 4 and 22 -> 24: the stretches between 4 and 22, and from 24 round to 2,
        // are nobody's.
        for (a, b) in [(0u16, 1u16), (2, 3)] {
            ends.arc[a as usize] = b;
            ends.arc[b as usize] = a;
        }
        let arcs = Arcs::new(&ends, &curves);
        let w = slice.settings().road_width;
        let bare = |p: Point, margin: f32| arcs.bare(&slice, &ends, &curves, p, margin);
        // Beside the arcs: laid.
        assert!(!bare(Point::new(3.0, 0.3), 0.0));
        assert!(!bare(Point::new(19.7, 3.0), 0.0));
        // Between them, along the bottom and the right side, and round the far corner.
        assert!(bare(Point::new(10.0, 0.3), w));
        assert!(bare(Point::new(19.7, 1.0), w));
        assert!(bare(Point::new(10.0, 19.7), w));
        // Too near an arc's end for the margin asked.
        assert!(!bare(Point::new(4.2, 0.3), w));
        assert!(bare(Point::new(4.2, 0.3), 0.1));
        // Nearer the hole than the wall: its curve holds no ends, so it is bare all round.
        assert!(bare(Point::new(8.5, 10.0), w));
        // Beside each end, the stretch its arc does not lay: from 4 on to 22 (half of its 18
        // mm to each end), and from 2 back round to 24 (half of 58).
        let beside = |id: u16| arcs.bare_beside(&ends, &curves, id);
        assert_eq!(beside(1), Some((true, 9.0)));
        assert_eq!(beside(2), Some((false, 9.0)));
        assert_eq!(beside(0), Some((false, 29.0)));
        assert_eq!(beside(3), Some((true, 29.0)));
        // A path's free end has a bare stretch either side: neither is its own.
        ends.arc[3] = NONE;
        ends.arc[2] = NONE;
        let arcs = Arcs::new(&ends, &curves);
        assert_eq!(arcs.bare_beside(&ends, &curves, 3), None);
        assert_eq!(arcs.bare_beside(&ends, &curves, 1), Some((true, 9.0)));
        // Paired the other way, 24 -> 2 (round the corner at 0, the way that passes over no
        // end) and 4 -> 22: the stretches laid and bare swap.
        for (a, b) in [(0u16, 3u16), (1, 2)] {
            ends.arc[a as usize] = b;
            ends.arc[b as usize] = a;
        }
        let arcs = Arcs::new(&ends, &curves);
        let bare = |p: (f32, f32)| arcs.bare(&slice, &ends, &curves, Point::new(p.0, p.1), 0.0);
        for p in [(10.0, 0.3), (19.7, 1.0), (10.0, 19.7), (0.3, 10.0)] {
            assert!(!bare(p), "{p:?}");
        }
        for p in [(3.0, 0.3), (19.7, 3.0)] {
            assert!(bare(p), "{p:?}");
        }
    }
}
