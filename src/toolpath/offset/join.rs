//! Joining the loops into one road: the sites where two loops run side by side (where a
//! bridge can be cut), a spanning tree of them from the outermost loop, and the relaxed
//! joins for loops the strict search leaves alone.

use super::{
    capacity, wrap, OffsetSpiral, OffsetStats, Site, BRIDGE_GAPS, NONE, RELAXED_TOL, STRICT_TOL,
    TIGHT_ROUNDS,
};
use crate::config::MAX_SITES;
use crate::geometry::{polygon, polyline};
use crate::{Error, Limit, Slice};
use heapless::Vec;

impl OffsetSpiral {
    /// A place where loop `a` (one level above) runs a road width from loop `b` for long
    /// enough to bridge, clear of the other joins on both. `relaxed` is the second try for a
    /// loop no strict site reaches (small loops at a peak of `D`, where the turns below are
    /// not parallel to it): it checks only the gap, with a looser tolerance.
    pub(super) fn find_site(
        &self,
        slice: &Slice,
        a: usize,
        b: usize,
        relaxed: bool,
    ) -> Option<Site> {
        let w = slice.settings().road_width;
        let len = self.loops[a].length;
        let lenb = self.loops[b].length;
        let steps = libm::floorf(len / (0.25 * w)) as usize;
        let tol = if relaxed { RELAXED_TOL } else { STRICT_TOL };
        for (g, k) in self
            .gaps(a, b)
            .iter()
            .flat_map(|&g| (0..steps).map(move |k| (g, k)))
        {
            let s0 = k as f32 * 0.25 * w;
            let (a1, a2) = (s0, wrap(s0 + g * w, len));
            // Far from `b`, no point of the gap (within `(g + 1/2) w` of `s0` along `a`, so
            // as near in the plane) reaches it a road out (`below` looks a road width along
            // the unit gradient, then `tol` around): the same answer without the searches (a
            // long loop beside a small one is mostly far from it).
            let reach = (g + 0.5) * w + 2.0 * w + (tol + 1e-3) * w;
            if !tests_plain() && polygon::bbox_distance(self.loops[b].bbox, self.at(a, s0)) > reach
            {
                continue;
            }
            if !self.free(a, a1, a2, 0.5 * w) {
                continue;
            }
            // The gap and half a road either side must face `b` a road width away.
            let mut prev: Option<f32> = None;
            let mut ok = true;
            let mut ends = (0.0, 0.0);
            let offsets = if relaxed {
                [f32::NAN, 0.0, 0.5 * g, g, f32::NAN]
            } else {
                [-0.5f32, 0.0, 0.5 * g, g, g + 0.5]
            };
            for (m, off) in offsets.iter().enumerate() {
                if off.is_nan() {
                    continue;
                }
                let p = self.at(a, s0 + off * w);
                match self.below(slice, a, p, tol) {
                    Some((m2, t)) if m2 == b => {
                        if let Some(pt) = prev {
                            let step = wrap(t - pt, lenb);
                            if !(0.1 * w..1.5 * w).contains(&step) {
                                ok = false;
                                break;
                            }
                        }
                        prev = Some(t);
                        if m == 1 {
                            ends.0 = t;
                        } else if m == 3 {
                            ends.1 = t;
                        }
                    }
                    _ => {
                        ok = false;
                        break;
                    }
                }
            }
            if ok && self.free(b, ends.0, ends.1, 0.5 * w) {
                let ends = self.parallel_ends(a, (a1, a2), b, ends, w).unwrap_or(ends);
                return Some(Site {
                    a: a as u16,
                    a1,
                    a2,
                    b: b as u16,
                    b1: ends.0,
                    b2: ends.1,
                    flip: false,
                });
            }
        }
        None
    }

    /// The gap on loop `b` below the gap `(a1, a2)` of loop `a` (a strict or relaxed join's),
    /// moved so that its chord is as long as `a`'s (about its middle): the two bridges then
    /// run parallel, a road apart, where the points straight below `a`'s gap ends (`ends`)
    /// draw them together on a small loop round a hole (they overlap by a wedge there) or
    /// apart on the wall's turns (a bare wedge). `None` where that gap is not free, would take
    /// half the loop or more, or is degenerate. On a loop too small for the chord it is left
    /// as long as two steps make it; on a [`tight`](super::Loop) loop it may take some of the
    /// room the half-road gaps leave (the joins are then made again, as for any loop left
    /// unjoined).
    fn parallel_ends(
        &self,
        a: usize,
        (a1, a2): (f32, f32),
        b: usize,
        ends: (f32, f32),
        w: f32,
    ) -> Option<(f32, f32)> {
        let lenb = self.loops[b].length;
        let chord_a = self.at(a, a1).dist(self.at(a, a2));
        let gap = wrap(ends.1 - ends.0, lenb);
        let chord_b = self.at(b, ends.0).dist(self.at(b, ends.1));
        if chord_b < 1e-6 || gap <= 0.0 {
            return None;
        }
        let mid = ends.0 + 0.5 * gap;
        // The arc whose chord is `chord_a`: two steps scaling the arc by the chord's shortfall.
        let mut half = 0.5 * gap * chord_a / chord_b;
        for _ in 0..2 {
            let c = self
                .at(b, wrap(mid - half, lenb))
                .dist(self.at(b, wrap(mid + half, lenb)));
            if c < 1e-6 {
                return None;
            }
            half *= chord_a / c;
        }
        if !(half > 0.0 && 2.0 * half < 0.5 * lenb) {
            return None;
        }
        let moved = (wrap(mid - half, lenb), wrap(mid + half, lenb));
        self.free(b, moved.0, moved.1, 0.5 * w).then_some(moved)
    }

    /// Joins the loops along a spanning tree of their side-by-side adjacency, breadth first
    /// from the wall's first turn.
    ///
    /// Full-road gaps take more room on a loop than half-road ones, whose two bridges overlap
    /// by half a road: where full gaps leave a loop no room for its join (another extrusion
    /// start), the loops around each loop left unjoined are marked [`tight`](super::Loop) and
    /// the joins made again, their sites there with half-road gaps only, the rest still with
    /// the wider ones ([`BRIDGE_GAPS`]), for up to [`TIGHT_ROUNDS`] rounds while starts remain.
    /// The way with the fewest roads is kept, of those with half-road gaps on fewer loops: the
    /// wider gaps, the marked loops, or half-road gaps everywhere (the last resort).
    pub(super) fn join(&mut self, slice: &Slice, stats: &mut OffsetStats) -> Result<(), Error> {
        let before = *stats;
        self.gaps_from = 0;
        self.clear_tight();
        let full = self.join_with(slice, stats)?;
        if full <= 1 {
            return Ok(());
        }
        let mut marked = full;
        for _ in 0..TIGHT_ROUNDS {
            if marked <= 1 || !self.mark_tight(slice) {
                break;
            }
            *stats = before;
            marked = self.join_with(slice, stats)?;
        }
        if marked <= 1 {
            return Ok(());
        }
        *stats = before;
        self.gaps_from = (BRIDGE_GAPS.len() - 1) as u8;
        let half = self.join_with(slice, stats)?;
        if half < marked.min(full) {
            return Ok(());
        }
        // Half-road gaps everywhere gave no fewer roads: back to the better of the others.
        *stats = before;
        self.gaps_from = 0;
        if full <= marked {
            self.clear_tight();
        }
        self.join_with(slice, stats)?;
        Ok(())
    }

    /// No loop [`tight`](super::Loop).
    fn clear_tight(&mut self) {
        for l in self.loops.iter_mut() {
            l.tight = false;
        }
    }

    /// Marks [`tight`](super::Loop) every loop that a road other than the first starts on
    /// (no join reached it) and every loop that could join it (a level apart or on its level,
    /// its box within two road widths: a strict, relaxed or pinch site's reach). Whether any
    /// loop was newly marked.
    fn mark_tight(&mut self, slice: &Slice) -> bool {
        let w = slice.settings().road_width;
        let n = self.loops.len();
        let first = (0..n)
            .filter(|&l| self.loops[l].visited() && self.loops[l].parent == NONE)
            .min_by_key(|&l| self.loops[l].order);
        let mut any = false;
        for u in 0..n {
            let lu = self.loops[u];
            if !lu.visited() || lu.parent != NONE || Some(u) == first {
                continue;
            }
            for v in 0..n {
                let lv = &mut self.loops[v];
                let near = v == u
                    || (lv.level.abs_diff(lu.level) <= 1
                        && polyline::boxes_overlap(lu.bbox, lv.bbox, 2.0 * w));
                if near && !lv.tight {
                    lv.tight = true;
                    any = true;
                }
            }
        }
        any
    }

    /// [`join`](Self::join) with the gaps in `self.gaps`; returns how many roads (trees of
    /// joins) the loops make.
    pub(super) fn join_with(
        &mut self,
        slice: &Slice,
        stats: &mut OffsetStats,
    ) -> Result<usize, Error> {
        let w = slice.settings().road_width;
        let mut roads = 0;
        self.sites.clear();
        let n = self.loops.len();
        // Adjacency by sampling each loop and looking one level down.
        let mut pairs: Vec<(u16, u16, u16), MAX_SITES> = Vec::new();
        for a in 0..n {
            let len = self.loops[a].length;
            let steps = libm::ceilf(len / (0.5 * w)) as usize;
            for k in 0..steps {
                let p = self.at(a, k as f32 * 0.5 * w);
                if let Some((b, _)) = self.below(slice, a, p, STRICT_TOL) {
                    if let Some(e) = pairs
                        .iter_mut()
                        .find(|e| e.0 as usize == a && e.1 as usize == b)
                    {
                        e.2 += 1;
                    } else {
                        pairs
                            .push((a as u16, b as u16, 1))
                            .map_err(|_| capacity(Limit::ContourSites))?;
                    }
                }
            }
        }
        // Longest contact first: those have the most room for a site.
        pairs.sort_unstable_by(|x, y| y.2.cmp(&x.2).then(x.0.cmp(&y.0)).then(x.1.cmp(&y.1)));
        for l in self.loops.iter_mut() {
            l.parent = NONE;
            l.order = NONE;
            l.tried = 0;
            l.seam_tried = 0;
        }
        self.visits = 0;
        // Roots: the longest loop of level 0 first (the wall's first turn), then any loop
        // left unreached. After each tree, loops no strict join reached get a relaxed join to
        // any reached loop a level away before a new road is started.
        loop {
            let root = (0..n)
                .filter(|&l| !self.loops[l].visited() && !self.loops[l].optional)
                .min_by(|&x, &y| {
                    let (lx, ly) = (&self.loops[x], &self.loops[y]);
                    lx.level
                        .cmp(&ly.level)
                        .then(ly.length.total_cmp(&lx.length))
                        .then(x.cmp(&y))
                });
            let Some(root) = root else { break };
            roads += 1;
            self.visit(root);
            self.bfs(slice, &pairs, root, stats)?;
            while let Some((other, site)) = self
                .seam_join(slice, w)
                .or_else(|| self.relaxed_join(slice, w))
                .or_else(|| self.pinch_join(slice, w))
            {
                self.attach(other, site, stats)?;
                self.bfs(slice, &pairs, other, stats)?;
            }
        }
        Ok(roads)
    }

    /// Records `site` as the join that reaches loop `other`.
    pub(super) fn attach(
        &mut self,
        other: usize,
        site: Site,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        self.sites
            .push(site)
            .map_err(|_| capacity(Limit::ContourSites))?;
        self.visit(other);
        self.loops[other].parent = (self.sites.len() - 1) as u16;
        stats.joins += 1;
        Ok(())
    }

    /// Marks loop `l` reached, the `visits`-th.
    fn visit(&mut self, l: usize) {
        let lo = &mut self.loops[l];
        lo.order = self.visits;
        // At most one visit per loop, and `MAX_LOOPS < NONE`.
        self.visits += 1;
    }

    /// Joins every loop reachable from `start` (already reached) by strict sites, breadth first.
    pub(super) fn bfs(
        &mut self,
        slice: &Slice,
        pairs: &[(u16, u16, u16)],
        start: usize,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        self.queue.clear();
        // Never full: the queue was just emptied.
        self.queue
            .push(start as u16)
            .map_err(|_| Limit::ContourLoops.error())?;
        let mut head = 0;
        while head < self.queue.len() {
            let l = self.queue[head] as usize;
            head += 1;
            for &(a, b, _) in pairs.iter() {
                let (a, b) = (a as usize, b as usize);
                let other = if a == l {
                    b
                } else if b == l {
                    a
                } else {
                    continue;
                };
                if self.loops[other].visited() {
                    continue;
                }
                if let Some(site) = self.find_site(slice, a, b, false) {
                    self.attach(other, site, stats)?;
                    self.queue
                        .push(other as u16)
                        .map_err(|_| capacity(Limit::ContourLoops))?;
                }
            }
        }
        Ok(())
    }

    /// A relaxed site between a loop not yet reached and a reached loop one level away
    /// (within two road widths of it), with the loop it reaches: the first such pair, unreached
    /// loops in order, then reached ones.
    ///
    /// Sites only ever add to the stretches a site must keep clear of ([`free`](Self::free)),
    /// so a pair that gave none gives none later: each unreached loop is tried against the
    /// loops reached since its last try only (each loop's `tried`). The answer is the search
    /// over every pair's, and a slice of many small loops (a wall of spikes: every spike's
    /// tip is an island of turns) no longer searches every pair again after every join.
    pub(super) fn relaxed_join(&mut self, slice: &Slice, w: f32) -> Option<(usize, Site)> {
        let n = self.loops.len();
        for u in 0..n {
            if self.loops[u].visited() {
                continue;
            }
            let since = if tests_plain() {
                0
            } else {
                self.loops[u].tried
            };
            for v in (0..n).filter(|&v| self.loops[v].visited() && self.loops[v].order >= since) {
                let (lu, lv) = (&self.loops[u], &self.loops[v]);
                if !polyline::boxes_overlap(lu.bbox, lv.bbox, 2.0 * w) {
                    continue;
                }
                count_relaxed_search();
                let site = if lu.level == lv.level + 1 {
                    self.find_site(slice, u, v, true)
                } else if lv.level == lu.level + 1 {
                    self.find_site(slice, v, u, true)
                } else {
                    None
                };
                if let Some(site) = site {
                    return Some((u, site));
                }
            }
            self.loops[u].tried = self.visits;
        }
        None
    }
}

#[cfg(test)]
std::thread_local! {
    /// Test builds only: whether this thread's joins search as before their shortcuts (relaxed
    /// joins try every pair again, sites are sought along all of a loop however far from the
    /// other), and how many pairs relaxed joins and joins across a seam have tried.
    static PLAIN: core::cell::Cell<bool> = const { core::cell::Cell::new(false) };
    static RELAXED_SEARCHES: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
    static SEAM_SEARCHES: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

/// Whether relaxed joins and joins across a seam try every pair again: never, outside tests.
#[cfg(not(test))]
pub(super) const fn tests_plain() -> bool {
    false
}

#[cfg(test)]
pub(super) fn tests_plain() -> bool {
    PLAIN.with(|p| p.get())
}

#[cfg(not(test))]
fn count_relaxed_search() {}

#[cfg(test)]
fn count_relaxed_search() {
    RELAXED_SEARCHES.with(|n| n.set(n.get() + 1));
}

#[cfg(not(test))]
pub(super) fn count_seam_search() {}

#[cfg(test)]
pub(super) fn count_seam_search() {
    SEAM_SEARCHES.with(|n| n.set(n.get() + 1));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::GridMemory;
    use crate::geometry::Point;
    use crate::Settings;
    use std::boxed::Box;
    use std::vec::Vec as StdVec;

    /// A round hole of 24 vertices.
    fn circle(cx: f32, cy: f32, r: f32) -> StdVec<Point> {
        (0..24)
            .map(|k| {
                let a = k as f32 * core::f32::consts::TAU / 24.0;
                Point::new(cx + r * libm::cosf(a), cy + r * libm::sinf(a))
            })
            .collect()
    }

    /// Runs `f` on a thread with a large stack (a spiral's working set is on it).
    fn on_large_stack(f: impl FnOnce() + Send + 'static) {
        std::thread::Builder::new()
            .stack_size(64 << 20)
            .spawn(f)
            .unwrap()
            .join()
            .unwrap();
    }

    /// A wall of `spikes` spikes, `r0` to `r0 + depth` from the centre (a fixed generator),
    /// round a small hole, at `road` mm roads: the turns close round the spikes' tips into
    /// islands that run beside no turn, which only relaxed joins reach.
    fn spiky(spikes: usize, depth: f32, r0: f32, road: f32) -> Slice {
        let mut seed = 0x2545_f491_u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let wall: StdVec<Point> = (0..spikes)
            .map(|k| {
                let a = k as f32 * core::f32::consts::TAU / spikes as f32;
                let r = r0 + depth * next();
                Point::new(r * libm::cosf(a), r * libm::sinf(a))
            })
            .collect();
        let hole = circle(0.0, 0.0, 1.5);
        let holes = [(&hole[..], [0.0, 1.0, 0.0, 0.0])];
        let settings = Settings {
            road_width: road,
            ..Settings::default()
        };
        Slice::from_contours(&wall, [1.0, 0.0, 0.0, 0.0], &holes, settings).unwrap()
    }

    /// The joins of the spiral's loops, as bits.
    fn joins(spiral: &OffsetSpiral) -> StdVec<[u32; 7]> {
        let bits = |s: &Site| {
            [
                s.a as u32,
                s.a1.to_bits(),
                s.a2.to_bits(),
                s.b as u32,
                s.b1.to_bits(),
                s.b2.to_bits(),
                s.flip as u32,
            ]
        };
        spiral.sites.iter().map(bits).collect()
    }

    /// Prepares `slice`'s spiral as the search over every pair after every join would, then
    /// with the shortcuts; asserts the joins are the same bits, and returns them with the
    /// pairs relaxed joins and joins across a seam tried, each way (`[plain, shortcut]`).
    fn searches(slice: &Slice) -> (StdVec<[u32; 7]>, OffsetStats, [usize; 2], [usize; 2]) {
        let mut grid = Box::new(GridMemory::new());
        let mut relaxed = [0usize; 2];
        let mut seams = [0usize; 2];
        let mut built: [(StdVec<[u32; 7]>, OffsetStats); 2] = Default::default();
        for (k, plain) in [true, false].into_iter().enumerate() {
            PLAIN.with(|p| p.set(plain));
            RELAXED_SEARCHES.with(|n| n.set(0));
            SEAM_SEARCHES.with(|n| n.set(0));
            let mut spiral = Box::new(OffsetSpiral::new());
            let stats = spiral.prepare(slice, &mut grid).unwrap();
            relaxed[k] = RELAXED_SEARCHES.with(|n| n.get());
            seams[k] = SEAM_SEARCHES.with(|n| n.get());
            built[k] = (joins(&spiral), stats);
        }
        PLAIN.with(|p| p.set(false));
        assert_eq!(built[0], built[1]);
        let [_, (joins, stats)] = built;
        (joins, stats, relaxed, seams)
    }

    /// Relaxed joins try each unreached loop only against the loops reached since its last
    /// try, and sites are sought only where the loops come near: the loops are joined exactly
    /// as the search over every pair after every join, along all of each loop, joined them,
    /// with a fraction of its relaxed searches.
    #[test]
    fn relaxed_joins_try_each_pair_once_and_join_as_the_full_search() {
        on_large_stack(|| {
            // 240 spikes 7-11 mm out, 0.25 mm roads (within every build's capacities but the
            // board's): 77 loops, 43 joins.
            let (_, stats, relaxed, _) = searches(&spiky(240, 4.0, 7.0, 0.25));
            // The slice needs relaxed joins, many of them.
            assert!(stats.joins > 30, "{stats:?}");
            assert!(relaxed[0] > 3000, "{relaxed:?}");
            // 8 times fewer until joins across seams (tried first) reached some of the loops
            // relaxed joins had reached: 3 640 and 552 searches since.
            assert!(5 * relaxed[1] < relaxed[0], "{relaxed:?}");
        });
    }

    /// The same joins for joins across a seam, on a lattice of channels (6 x 6 round channels
    /// of radius 0.25 mm, 2 mm apart, at 0.4 mm roads: every channel's second turn meets its
    /// neighbours' across a seam); and those joins are what reach the channels.
    #[test]
    // 36 holes: past the default build's capacity, within `large`'s (the workspace's tests
    // build the core with it).
    #[cfg_attr(
        not(feature = "large"),
        ignore = "36 holes need the `large` capacities"
    )]
    fn seam_joins_try_each_pair_once_and_join_as_the_full_search() {
        on_large_stack(|| {
            let holes: StdVec<StdVec<Point>> = (0..36)
                .map(|k| circle(2.0 * (k % 6) as f32, 2.0 * (k / 6) as f32, 0.25))
                .collect();
            let holes: StdVec<(&[Point], [f32; 4])> = holes
                .iter()
                .map(|h| (&h[..], [0.0, 1.0, 0.0, 0.0]))
                .collect();
            let wall = [
                Point::new(-2.0, -2.0),
                Point::new(12.0, -2.0),
                Point::new(12.0, 12.0),
                Point::new(-2.0, 12.0),
            ];
            let settings = Settings {
                road_width: 0.4,
                ..Settings::default()
            };
            let slice =
                Slice::from_contours(&wall, [1.0, 0.0, 0.0, 0.0], &holes, settings).unwrap();
            let (joins, stats, _, seams) = searches(&slice);
            assert!(stats.joins > 100, "{stats:?}");
            // Joins across a seam (loops running opposite ways) reach channels.
            assert!(joins.iter().filter(|j| j[6] == 1).count() > 20, "{stats:?}");
            // The same joins with a fraction of the searches: 812 against 182 (while first
            // turns took no seam joins, from `aad6ecc` until the offset spiral was lined, the
            // first unreached loop searched had one each time, and the counts were equal).
            assert!(seams[0] > 500, "{seams:?}");
            assert!(4 * seams[1] < seams[0], "{seams:?}");
        });
    }
}
