//! Joins across a pinch: the last resort before a loop no other join reaches becomes a road
//! of its own (a sibling of `join`, one more part of [`OffsetSpiral`]'s `impl`).

use super::{wrap, OffsetSpiral, Site, PINCH_BRIDGE_ROADS, PINCH_GAP};
use crate::geometry::primitives::{closest_on_segment, segments_meet, MinMax};
use crate::geometry::{polyline, Point};
use crate::toolpath::NARROWING;
use crate::Slice;

/// How finely a pinch join samples a loop for its nearest point to the other, and the bridge
/// for the channel, in road widths.
const PINCH_STEP_ROADS: f32 = 0.1;

impl OffsetSpiral {
    /// A join across a pinch: a loop no other join reaches (and not a small one, which is
    /// left out rather than joined by a bridge), to a reached loop of the same level across a
    /// channel the distance grid is too coarse to resolve; or to the reached loop a level
    /// below, round a loop at a peak of `D` whose turn below runs more than a road off it
    /// (so no relaxed site faces it), by the same bridge out and back. Either way the last
    /// resort before a loop becomes a road of its own (an extrusion start).
    ///
    /// Where two features come within a couple of road widths of each other, the region a
    /// turn's road fits in narrows to a channel between them; where the channel is narrower
    /// than the grid's spacing, no grid node in it is as far from the features as the turn,
    /// and the traced turn closes on each side of it: the pocket beyond becomes an island loop
    /// that runs beside no other. Here such a loop is joined to the reached loop of its level
    /// nearest it (at most [`PINCH_BRIDGE_ROADS`] road widths away; from the nearest point of
    /// it where both loops' stretches are free of other joins), by a bridge out and one
    /// back, their ends [`PINCH_GAP`] road widths apart on each loop, where the channel is
    /// there: along the bridge the distance to the features stays within half a road of the
    /// loops' own, and a road fits there as narrow as a move is laid where it would sag into
    /// a keep-out band. The two bridges lie almost on each other (they cross: facing loops of
    /// one level run opposite ways, and the walk turns back along the other loop): a road
    /// width or so of road laid twice instead of an extrusion start.
    pub(super) fn pinch_join(&self, slice: &Slice, w: f32) -> Option<(usize, Site)> {
        let n = self.loops.len();
        let reach = PINCH_BRIDGE_ROADS * w;
        let step = PINCH_STEP_ROADS * w;
        // (bridge length, loop reached, site)
        let mut best: Option<(f32, usize, Site)> = None;
        // A bridge of length `d` within reach and shorter than the best so far.
        let better = |d: f32, best: &Option<(f32, usize, Site)>| {
            d <= reach && best.as_ref().is_none_or(|b| d < b.0)
        };
        for u in (0..n).filter(|&u| !self.loops[u].visited() && !self.loops[u].optional) {
            let lu = &self.loops[u];
            // Of its level across a pinch, or the level below round a small loop at a peak of
            // `D` that no relaxed site reaches (the turn below runs more than a road off it).
            let near_level = |l: u16| l == lu.level || l + 1 == lu.level;
            for v in (0..n).filter(|&v| self.loops[v].visited() && near_level(self.loops[v].level))
            {
                let lv = &self.loops[v];
                if !polyline::boxes_overlap(lu.bbox, lv.bbox, reach) {
                    continue;
                }
                // The points of `u` every tenth of a road, each with the nearest point of `v`
                // and the distance to it.
                let samples = libm::ceilf(lu.length / step) as usize;
                let sample = |k: usize| {
                    let su = k as f32 * step;
                    let (sv, d) = self.project(v, self.at(u, su));
                    (su, sv, d)
                };
                // The nearest (the first of equals).
                let nearest = (0..samples)
                    .map(sample)
                    .reduce(|a, b| if b.2 < a.2 { b } else { a });
                let Some((su, sv, d)) = nearest else { continue };
                if !better(d, &best) {
                    continue;
                }
                if let Some(site) = self.pinch_site(slice, (u, su), (v, sv), d, w) {
                    best = Some((d, u, site));
                    continue;
                }
                // Where the nearest point's stretch is taken (a join of the loop below already
                // leaves there, random slice 9107's small loop at a peak of `D`), the nearest
                // of the others whose bridge fits.
                for (su, sv, d) in (0..samples).map(sample) {
                    if better(d, &best) {
                        if let Some(site) = self.pinch_site(slice, (u, su), (v, sv), d, w) {
                            best = Some((d, u, site));
                        }
                    }
                }
            }
        }
        best.map(|(_, u, site)| (u, site))
    }

    /// The site of a pinch join ([`pinch_join`](Self::pinch_join)) from arc length `su` of loop
    /// `u` to `sv` of loop `v`, `d` apart: where the channel is there and both stretches are
    /// free.
    fn pinch_site(
        &self,
        slice: &Slice,
        (u, su): (usize, f32),
        (v, sv): (usize, f32),
        d: f32,
        w: f32,
    ) -> Option<Site> {
        let step = PINCH_STEP_ROADS * w;
        let (lu, lv) = (&self.loops[u], &self.loops[v]);
        let (pu, pv) = (self.at(u, su), self.at(v, sv));
        let m = libm::ceilf(d / step).fmax(1.0) as usize;
        // The channel is there: along the bridge the distance to the features stays between
        // the two loops' own, less and plus half a road (clear of the roads of the turns below
        // and above), and a road fits, as narrow as a move is laid where no bend keeps it out
        // of a keep-out band. Where no loop a level above lies within a road of the bridge,
        // there is no road above to keep clear of: two features' turns that meet at a ridge
        // they never cross (a hole at the centre of a round wall, whose ridge is a circle
        // between their last turns, each family of turns a road of its own) are joined
        // across it, however high the distance rises between them.
        let (cu, cv) = (slice.clearance(pu), slice.clearance(pv));
        let low = (0.5 * (1.0 - NARROWING) * w).fmax(cu.fmin(cv) - 0.5 * w) - 1e-4;
        let high = cu.fmax(cv) + 0.5 * w + 1e-4;
        let mut rises = false;
        for i in 0..=m {
            let c = slice.clearance(pu.lerp(pv, i as f32 / m as f32));
            if c < low {
                return None;
            }
            rises |= c > high;
        }
        // Where the distance rises past the upper bound, a turn a level above must not run
        // near the bridge itself (not only its box: a turn that runs round the whole slice,
        // along the wall of a lattice of channels, has a box over every bridge). Asked only
        // then: the test walks the turns' points.
        if rises {
            let above = lu.level.max(lv.level) + 1;
            let span = (
                Point::new(pu.x.fmin(pv.x), pu.y.fmin(pv.y)),
                Point::new(pu.x.fmax(pv.x), pu.y.fmax(pv.y)),
            );
            let near_bridge = |i: usize| {
                let pts = self.pts(i);
                let close = |p: Point| closest_on_segment(pu, pv, p).0.dist(p) <= w;
                let crosses = |k: usize| segments_meet(pts[k], pts[(k + 1) % pts.len()], pu, pv);
                pts.iter().any(|&p| close(p)) || (0..pts.len()).any(crosses)
            };
            let above_near = self.loops.iter().enumerate().any(|(i, l)| {
                l.level == above && polyline::boxes_overlap(l.bbox, span, w) && near_bridge(i)
            });
            if above_near {
                return None;
            }
        }
        let half_gap = 0.5 * PINCH_GAP * w;
        let (a1, a2) = (
            wrap(su - half_gap, lu.length),
            wrap(su + half_gap, lu.length),
        );
        let (b1, b2) = (
            wrap(sv - half_gap, lv.length),
            wrap(sv + half_gap, lv.length),
        );
        if !self.free(u, a1, a2, 0.5 * w) || !self.free(v, b1, b2, 0.5 * w) {
            return None;
        }
        Some(Site {
            a: u as u16,
            a1,
            a2,
            b: v as u16,
            b1,
            b2,
        })
    }
}
