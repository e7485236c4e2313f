//! Joins by a bridge out and one back, between loops that run side by side only across a ridge
//! (a sibling of `join`, one more part of [`OffsetSpiral`]'s `impl`): across a seam between
//! two features' turns of one level, tried before relaxed joins; and across a pinch, the last
//! resort before a loop no other join reaches becomes a road of its own.

use super::join::{count_seam_search, tests_plain};
use super::{wrap, OffsetSpiral, Site, PINCH_BRIDGE_ROADS, PINCH_GAP};
use crate::geometry::primitives::{closest_on_segment, segments_meet, MinMax};
use crate::geometry::{polyline, Point};
use crate::toolpath::NARROWING;
use crate::Slice;

/// The gaps a join across a pinch tries, road widths, widest first: a road apart the bridges
/// do not overlap at all, where the pocket has room for both; the last is [`PINCH_GAP`]. A
/// join across a seam tries the first two. On the 48 lattices of channels the wider gaps
/// took the spiral's mean overfill from 0.0331 to 0.0313 (lattice 42's from 0.070 to 0.048),
/// for 0.0001 of coverage.
const PINCH_GAPS: [f32; 3] = [1.0, 0.5, PINCH_GAP];
/// The longest bridge of a join across a seam ([`OffsetSpiral::seam_join`]), road widths:
/// turns of one level either side of a ridge lie less than a road apart, narrowed to it, or
/// up to a road and a half where the gap between them is widened into.
const SEAM_ROADS: f32 = 1.5;
/// How nearly opposite two loops joined across a seam run: the cosine of the angle between
/// one's direction and the other's reversed, at least (within 37 degrees). Without it and
/// [`SEAM_SQUARE`] a loop's tip was joined to the side of another along the ridge, the two
/// bridges running along it (random slice 14: overfill 0.035 to 0.039).
const SEAM_COS: f32 = 0.8;
/// How nearly square to the loops a bridge across a seam runs: the cosine of the angle
/// between the bridge and the first loop's direction, at most (within 11.5 degrees of square).
const SEAM_SQUARE: f32 = 0.2;

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
    /// back, their ends a road, half a road or [`PINCH_GAP`] road widths apart on each loop
    /// (the widest that fits, [`PINCH_GAPS`]), where the channel is there: along the bridge
    /// the distance to the features stays within half a road of the loops' own, and a road
    /// fits there as narrow as a move is laid where it would sag into a keep-out band (along
    /// both bridges where they lie apart). Facing loops of one level run opposite ways: the
    /// walk goes on round the other loop the same way, so the bridges do not cross
    /// ([`Site`]'s `flip`). In a narrow channel the two bridges lie almost on each other: a
    /// road width or so of road laid twice instead of an extrusion start.
    pub(super) fn pinch_join(&mut self, slice: &Slice, w: f32) -> Option<(usize, Site)> {
        self.bridge_join(slice, w, false)
    }

    /// A join across a seam: a loop no join reaches yet, to a reached loop of its own level
    /// that runs within [`SEAM_ROADS`] road widths of it across a ridge (the turns of two
    /// channels of a lattice, side by side between them), by two bridges a road or half a
    /// road apart that cross the ridge square to it. Tried before relaxed joins, which reach
    /// such a loop only through a small loop a level above (the pocket where three or four
    /// channels meet), by two pairs of overlapping bridges.
    pub(super) fn seam_join(&mut self, slice: &Slice, w: f32) -> Option<(usize, Site)> {
        self.bridge_join(slice, w, true)
    }

    /// [`pinch_join`](Self::pinch_join): of the unreached loops' bridges to reached ones, the
    /// shortest; or with `seam` [`seam_join`](Self::seam_join): the shortest of the first
    /// unreached loop that has one.
    ///
    /// As with relaxed joins, sites only ever add to the stretches a site must keep clear of,
    /// so a pair that gave no seam join gives none later: an unreached loop none of whose
    /// pairs gave one is tried next time only against the loops reached since (its
    /// `seam_tried`).
    fn bridge_join(&mut self, slice: &Slice, w: f32, seam: bool) -> Option<(usize, Site)> {
        let n = self.loops.len();
        let reach = if seam { SEAM_ROADS } else { PINCH_BRIDGE_ROADS } * w;
        let step = PINCH_STEP_ROADS * w;
        // (bridge length, loop reached, site)
        let mut best: Option<(f32, usize, Site)> = None;
        for u in 0..n {
            if self.loops[u].visited() || self.loops[u].optional {
                continue;
            }
            let since = if seam { self.loops[u].seam_tried } else { 0 };
            let lu = &self.loops[u];
            // Of its level across a pinch, or the level below round a small loop at a peak of
            // `D` that no relaxed site reaches (the turn below runs more than a road off it).
            let near_level = |l: u16| l == lu.level || (!seam && l + 1 == lu.level);
            for v in 0..n {
                let lv = &self.loops[v];
                if !lv.visited()
                    || lv.order < since
                    || !near_level(lv.level)
                    || !polyline::boxes_overlap(lu.bbox, lv.bbox, reach)
                {
                    continue;
                }
                if seam {
                    count_seam_search();
                }
                // A bridge of length `d` within reach, and shorter than the best so far.
                let better = |d: f32, best: &Option<(f32, usize, Site)>| {
                    d <= reach && best.as_ref().is_none_or(|b| d < b.0)
                };
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
                if let Some(site) = self.pinch_site(slice, (u, su), (v, sv), d, w, seam) {
                    best = Some((d, u, site));
                    continue;
                }
                // Where the nearest point's stretch is taken (a join of the loop below already
                // leaves there, random slice 9107's small loop at a peak of `D`), the nearest
                // of the others whose bridge fits.
                for (su, sv, d) in (0..samples).map(sample) {
                    if better(d, &best) {
                        if let Some(site) = self.pinch_site(slice, (u, su), (v, sv), d, w, seam) {
                            best = Some((d, u, site));
                        }
                    }
                }
            }
            if seam {
                // The first unreached loop that has a seam join takes its shortest one. One
                // that has none was passed over for no other's (the search stops at the
                // first that has one): none of its pairs gave a site.
                if best.is_some() {
                    break;
                }
                if !tests_plain() {
                    self.loops[u].seam_tried = self.visits;
                }
            }
        }
        best.map(|(_, u, site)| (u, site))
    }

    /// The site of a pinch join ([`pinch_join`](Self::pinch_join)), or with `seam` of a join
    /// across a seam ([`seam_join`](Self::seam_join)), from arc length `su` of loop `u` to `sv`
    /// of loop `v`, `d` apart: where the channel is there and both stretches are free, with
    /// the widest gap of [`PINCH_GAPS`] that fits (a seam's: a road or half a road, its loops
    /// running opposite ways and its bridges square to them), `flip` where the two loops run
    /// opposite ways.
    fn pinch_site(
        &self,
        slice: &Slice,
        (u, su): (usize, f32),
        (v, sv): (usize, f32),
        d: f32,
        w: f32,
        seam: bool,
    ) -> Option<Site> {
        let step = PINCH_STEP_ROADS * w;
        let (lu, lv) = (&self.loops[u], &self.loops[v]);
        let (pu, pv) = (self.at(u, su), self.at(v, sv));
        let m = libm::ceilf(d / step).fmax(1.0) as usize;
        // Loops of one level facing each other across a ridge run opposite ways.
        let tangent = |l: usize, s: f32| {
            let len = self.loops[l].length;
            self.at(l, wrap(s + 0.05 * w, len)) - self.at(l, wrap(s - 0.05 * w, len))
        };
        let (tu, tv) = (tangent(u, su).normalized(), tangent(v, sv).normalized());
        let flip = tu.dot(tv) < 0.0;
        // Across a seam: the two run opposite ways, nearly parallel.
        if seam && tu.dot(tv) > -SEAM_COS {
            return None;
        }
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
        if !clear_along(slice, pu, pv, m, |c| {
            rises |= c > high;
            c >= low
        }) {
            return None;
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
        // The widest gap whose bridges fit: a full road apart they do not overlap at all,
        // where the pocket leaves room for both. (Bridges between two features' first turns,
        // which lie on the keep-out curves, blend from one feature's material to the other's
        // only outside both linings: `toolpath::lining`.)
        let gaps = if seam {
            &PINCH_GAPS[..PINCH_GAPS.len() - 1]
        } else {
            &PINCH_GAPS[..]
        };
        gaps.iter().find_map(|&g| {
            let half_gap = 0.5 * g * w;
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
            // Across a seam each bridge crosses it, short and nearly square to the loops.
            let crosses_square = |p: Point, q: Point| {
                let b = q - p;
                b.norm() <= SEAM_ROADS * w && libm::fabsf(b.dot(tu)) <= SEAM_SQUARE * b.norm()
            };
            if seam
                && !(crosses_square(self.at(u, a1), self.at(v, b2))
                    && crosses_square(self.at(u, a2), self.at(v, b1)))
            {
                return None;
            }
            if g > PINCH_GAP {
                let ends_u = [self.at(u, a1), self.at(u, a2)];
                let ends_v = [self.at(v, b1), self.at(v, b2)];
                for &p in &ends_u {
                    for &q in &ends_v {
                        let m = libm::ceilf(p.dist(q) / step).fmax(1.0) as usize;
                        if !clear_along(slice, p, q, m, |c| c >= low) {
                            return None;
                        }
                    }
                }
            }
            Some(Site {
                a: u as u16,
                a1,
                a2,
                b: v as u16,
                b1,
                b2,
                flip,
            })
        })
    }
}

/// Whether `ok` holds for the clearance at each of the `m + 1` points from `p` to `q`, in order
/// (stopping at the first that fails): the channel along a bridge.
fn clear_along(
    slice: &Slice,
    p: Point,
    q: Point,
    m: usize,
    mut ok: impl FnMut(f32) -> bool,
) -> bool {
    (0..=m).all(|i| ok(slice.clearance(p.lerp(q, i as f32 / m as f32))))
}
