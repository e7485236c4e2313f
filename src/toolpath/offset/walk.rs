//! Walking the joined loops into the layer: each loop from its entry around to its exit,
//! across the bridges, widening a turn into the gap it leaves before a ridge (or narrowing it
//! where the turn beyond the ridge lies nearer than a road), with the composition of the
//! blended field at every vertex.

use super::{
    capacity, nearest, wrap, Frame, OffsetSpiral, OffsetStats, EDGE_DIRECTIONS, FIRST_TURN_MARGIN,
    LAID_TOL, NONE, RIDGE_MARGIN, RIDGE_STEPS, RIDGE_TOL_PER_ROAD, WIDEN_TRIES, WIDTH_STEP,
};
use crate::config::MAX_LOOPS;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, Point};
use crate::toolpath::composition::BlendedField;
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Limit, Plan, Slice};
use heapless::Vec;

impl OffsetSpiral {
    /// Whether a laid loop of level `level` passes within `tol` of `q`.
    pub(super) fn laid_at(&self, q: Point, level: u16, tol: f32) -> bool {
        self.loops.iter().enumerate().any(|(l, lp)| {
            let (lo, hi) = lp.bbox;
            if !lp.visited()
                || lp.level != level
                || q.x < lo.x - tol
                || q.y < lo.y - tol
                || q.x > hi.x + tol
                || q.y > hi.y + tol
            {
                return false;
            }
            let pts = self.pts(l);
            self.loop_runs(l).any(|(b, ks)| {
                polygon::bbox_distance(b, q) <= tol + polygon::rounding_slack(q, b)
                    && ks.into_iter().any(|k| {
                        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
                        crate::geometry::primitives::closest_on_segment(a, b, q)
                            .0
                            .dist(q)
                            <= tol
                    })
            })
        })
    }

    /// [`widened`] at `p` (whose nearest feature is `near`), against this layer's laid loops.
    pub(super) fn widen(&self, slice: &Slice, p: Point, near: (usize, f32, Point)) -> (Point, f32) {
        widened(slice, p, near, |q, level, tol| self.laid_at(q, level, tol))
    }

    /// The vertex at `p`, with its composition and its road width ([`widened`] at ridges).
    pub(super) fn vertex(
        &self,
        slice: &Slice,
        field: &BlendedField,
        p: Point,
        deposit: bool,
    ) -> Vertex {
        let half = 0.5 * slice.settings().road_width;
        let near = nearest(slice, p);
        let own = slice.material_at(near.0);
        let material = if near.1 < half + 2.0 * FIRST_TURN_MARGIN {
            own
        } else {
            field.at(p).unwrap_or(own)
        };
        let (at, width) = self.widen(slice, p, near);
        Vertex {
            at,
            material,
            width,
            deposit,
        }
    }

    /// The vertex at `p` ending a bridge across between two loops: [`vertex`](Self::vertex)'s,
    /// but never narrowed: a bridge crosses the gap between two turns along the gradient, and
    /// a narrowing measured at its end (for a turn running beside the ridge) would thin the
    /// whole bridge.
    fn bridge_vertex(&self, slice: &Slice, field: &BlendedField, p: Point) -> Vertex {
        let w = slice.settings().road_width;
        let v = self.vertex(slice, field, p, true);
        if v.width < w {
            Vertex {
                at: p,
                width: w,
                ..v
            }
        } else {
            v
        }
    }

    /// Walks loop `l` from arc length `s` for `dist` in the given direction, emitting the
    /// loop's points on the way and the end point.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn walk(
        &self,
        slice: &Slice,
        field: &BlendedField,
        sink: &mut impl PathSink,
        l: usize,
        s: f32,
        dist: f32,
        forward: bool,
    ) -> Result<(), Error> {
        let pts = self.pts(l);
        let len = self.loops[l].length;
        let n = pts.len();
        let s = wrap(s, len);
        let mut k = if forward {
            self.arc_partition(l, |a| a <= s).0 % n
        } else {
            (self.arc_partition(l, |a| a < s).0 + n - 1) % n
        };
        let mut prev = self.at(l, s);
        for _ in 0..n {
            let arc_k = self.arc_of(l, k);
            let along = if forward {
                wrap(arc_k - s, len)
            } else {
                wrap(s - arc_k, len)
            };
            if along >= dist - 1e-5 {
                break;
            }
            if along > 1e-5 {
                self.emit_span(slice, field, sink, prev, pts[k])?;
                prev = pts[k];
            }
            k = if forward {
                (k + 1) % n
            } else {
                (k + n - 1) % n
            };
        }
        let end = if forward { s + dist } else { s - dist };
        self.emit_span(slice, field, sink, prev, self.at(l, end))
    }

    /// Emits the turn's straight piece from `from` (already emitted) to `to`. A piece longer
    /// than [`WIDTH_STEP`] road widths along which some road widens ([`widened`]) is emitted
    /// in steps that long, so a width applies where it was found rather than tapering over
    /// the whole piece.
    pub(super) fn emit_span(
        &self,
        slice: &Slice,
        field: &BlendedField,
        sink: &mut impl PathSink,
        from: Point,
        to: Point,
    ) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let steps = libm::ceilf(from.dist(to) / (WIDTH_STEP * w)).fmax(1.0) as usize;
        let at = |k: usize| from.lerp(to, k as f32 / steps as f32);
        let end = self.vertex(slice, field, to, true);
        let width_at = |q: Point| self.widen(slice, q, nearest(slice, q)).1;
        let start = sink.last_vertex().map_or(w, |v| v.width);
        let varies =
            steps > 1 && (start != w || end.width != w || (1..steps).any(|k| width_at(at(k)) != w));
        if varies {
            for k in 1..steps {
                emit_move(slice, sink, self.vertex(slice, field, at(k), true))?;
            }
        }
        emit_move(slice, sink, end)
    }

    /// The ends of `site` on loop `l`: `(own gap start, own gap end, other loop, other's gap
    /// start, other's gap end)`.
    pub(super) fn site_on(&self, site: usize, l: usize) -> (f32, f32, usize, f32, f32) {
        let st = &self.sites[site];
        if st.a as usize == l {
            (st.a1, st.a2, st.b as usize, st.b1, st.b2)
        } else {
            (st.b1, st.b2, st.a as usize, st.a1, st.a2)
        }
    }

    /// Walks the loops as one road per tree of joins.
    pub(super) fn walk_all(
        &mut self,
        slice: &Slice,
        plan: &Plan,
        sink: &mut impl PathSink,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        let field = BlendedField::new(slice, plan);
        // Small loops no join reached are left out.
        stats.dropped += self.loops.iter().filter(|l| !l.visited()).count() as u16;
        let roots: Vec<u16, MAX_LOOPS> = (0..self.loops.len())
            .filter(|&l| self.loops[l].visited() && self.loops[l].parent == NONE)
            .map(|l| l as u16)
            .collect();
        for (r, &root) in roots.iter().enumerate() {
            let root = root as usize;
            if r > 0 {
                stats.jumps += 1;
            }
            // Start the root where no join is.
            let len = self.loops[root].length;
            let mut s0 = 0.0;
            while s0 < len && !self.free(root, s0, s0, 0.0) {
                s0 += 0.1 * slice.settings().road_width;
            }
            emit_move(
                slice,
                sink,
                self.vertex(slice, &field, self.at(root, s0), false),
            )?;
            self.stack.clear();
            // Cannot fail: the stack was just emptied.
            self.stack
                .push(Frame {
                    lp: root as u16,
                    pos: s0,
                    forward: true,
                    remaining: len,
                    entered_by: NONE,
                })
                .map_err(|_| Limit::ContourLoops.error())?;
            while let Some(top) = self.stack.last().copied() {
                let l = top.lp as usize;
                let len = self.loops[l].length;
                // The nearest join ahead on this loop, other than the one it was entered by.
                let mut next: Option<(f32, usize)> = None;
                for (si, st) in self.sites.iter().enumerate() {
                    if si == top.entered_by as usize || (st.a != top.lp && st.b != top.lp) {
                        continue;
                    }
                    let (x1, x2, _, _, _) = self.site_on(si, l);
                    let ahead = if top.forward {
                        wrap(x1 - top.pos, len)
                    } else {
                        wrap(top.pos - x2, len)
                    };
                    if ahead < top.remaining && next.is_none_or(|n| ahead < n.0) {
                        next = Some((ahead, si));
                    }
                }
                match next {
                    Some((ahead, si)) => {
                        self.walk(slice, &field, sink, l, top.pos, ahead, top.forward)?;
                        let (x1, x2, child, y1, y2) = self.site_on(si, l);
                        let gap = wrap(x2 - x1, len);
                        let child_gap = wrap(y2 - y1, self.loops[child].length);
                        let (resume, enter) = if top.forward { (x2, y1) } else { (x1, y2) };
                        if let Some(f) = self.stack.last_mut() {
                            f.pos = resume;
                            f.remaining -= ahead + gap;
                        }
                        // The bridge across.
                        emit_move(
                            slice,
                            sink,
                            self.bridge_vertex(slice, &field, self.at(child, enter)),
                        )?;
                        self.stack
                            .push(Frame {
                                lp: child as u16,
                                pos: enter,
                                forward: !top.forward,
                                remaining: self.loops[child].length - child_gap,
                                entered_by: si as u16,
                            })
                            .map_err(|_| capacity(Limit::ContourLoops))?;
                    }
                    None => {
                        self.walk(slice, &field, sink, l, top.pos, top.remaining, top.forward)?;
                        self.stack.pop();
                        // The bridge back.
                        if let Some(f) = self.stack.last() {
                            let p = self.at(f.lp as usize, f.pos);
                            emit_move(slice, sink, self.bridge_vertex(slice, &field, p))?;
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// Whether feature `f` (not the nearest to the ray's start, which lies in the material at
/// distance `d` from the features) is at least `d + t` from the ray's point `q` at `t` by the
/// boxes of its chunks alone, so that [`widened`]'s gap there cannot fall below zero. Where
/// the ray enters the feature it crosses its boundary within `t` of `q`, so a point of the ray
/// inside the feature has a chunk's box nearer than `d + t`; elsewhere the boxes hold every
/// edge. A lower bound with the rounding slack: it skips only features the exact test skips,
/// without their exact distance (the nearest edge and, for the wall, the inside test).
fn clear_beyond(slice: &Slice, f: usize, d: f32, q: Point, t: f32) -> bool {
    let feature = slice.holes().get(f).unwrap_or(slice.wall());
    let need = d + t + polygon::rounding_slack(q, feature.bbox());
    d >= 0.0 && feature.nearest_box2(q) >= need * need
}

/// A turn's point `p` widened into the gap it leaves before a ridge, and the road width there;
/// `own`, `d` and `n` are its nearest feature, the distance to it and the gradient
/// ([`nearest`]).
///
/// Turns lie at fixed distances from the features, so where two features' turns meet at the
/// ridge between them (the bisector, where the distances agree) the last turn on each side
/// leaves a sliver narrower than a road. Along the distance gradient `n` from `p` (a straight
/// line inside the feature's cell), the ridge lies where another feature's distance `D_j(p + t
/// n)` drops to `D(p) + t` (or the feature's own distance falls behind `D(p) + t`, at a ridge
/// between two parts of one non-convex feature); the function `D_j(p + t n) - D(p) - t` only
/// falls (`D_j` is 1-Lipschitz), so bisection finds it. If it lies closer than a road width `w`
/// there is no next turn beyond `p`: the road widens by the sliver `g` (the ridge's distance
/// beyond the
/// road's outer edge, `t - w/2`) and its centre moves `g/2` outward, so its inner edge stays
/// where it was and its outer edge reaches the ridge, where the other side's last turn, widened
/// the same way, meets it. Where the next turn does cross the ray but was left out (a small
/// loop no join reached, `laid(q, level)` false at its crossing `q`), the road widens the same
/// way as far as [`Settings::max_width`] allows. The road is never wider than
/// [`Settings::max_width`], and half its width never exceeds its clearance (`D` grows by `g/2`,
/// and every other feature is at least that far: it is farther than the ridge). Where the
/// ridge lies nearer than half a road, the road narrows instead ([`narrowed`]).
///
/// [`Settings::max_width`]: crate::Settings::max_width
fn widened(
    slice: &Slice,
    p: Point,
    (own, d, n): (usize, f32, Point),
    laid: impl Fn(Point, u16, f32) -> bool,
) -> (Point, f32) {
    let w = slice.settings().road_width;
    let holes = slice.holes().len();
    let len = n.norm();
    if len < 1e-6 {
        return (p, w);
    }
    let n = n * (1.0 / len);
    // The nearest ridge along `n` within reach of the widest road's outer edge.
    let gap = |f: usize, t: f32| slice.clearance_to(f, p + n * t) - d - t;
    // The ridge is looked for as far as a turn can be missing: beyond a road width out the
    // next turn crosses the ray, and the road widens only where that turn was left out (or
    // never traced: a sliver of a level too thin for the grid near a saddle of `D`). The
    // widening itself stops at `max_width`, short of a far ridge: a partial fill of a gap
    // wider than the widest road still covers most of it.
    let reach = (slice.settings().max_width - 0.5 * w).fmax(2.0 * w) + RIDGE_MARGIN;
    let mut ridge = reach;
    for f in 0..=holes {
        // The feature's own ridges count too (a non-convex feature's parts face each other):
        // along its own normal its distance grows exactly with `t` until one, to rounding.
        let tol = if f == own {
            RIDGE_TOL_PER_ROAD * w
        } else {
            0.0
        };
        // A hole whose box is at least `d + 2 reach` away is farther than `d + t` from every
        // point of the ray within reach (its distance falls by at most `t`).
        let far = slice
            .holes()
            .get(f)
            .is_some_and(|h| f != own && polygon::bbox_distance(h.bbox(), p) >= d + 2.0 * reach);
        if far || (f != own && clear_beyond(slice, f, d, p + n * ridge, ridge)) {
            continue;
        }
        let at_ridge = gap(f, ridge);
        if at_ridge >= -tol {
            continue;
        }
        // The gap falls by at most 2 a unit of `t` (`D_f` is 1-Lipschitz along the ray, and
        // `t` rises by 1): from a bound of it at `lo` (below) or `hi` (above), a step whose
        // answer those bounds already give, with room for the rounding of both values the
        // bound rests on, is taken without measuring: the same steps as measuring each, so
        // the same ridge to the bit. (`below` is unknown at 0 until a step measures.)
        let sure = 2.0 * polygon::rounding_slack(p, slice.wall().bbox()) + 1e-5 * w;
        let (mut lo, mut hi) = (0.0f32, ridge);
        let (mut below, mut above) = (f32::NEG_INFINITY, at_ridge);
        for _ in 0..RIDGE_STEPS {
            let mid = 0.5 * (lo + hi);
            let (low, high) = (below - 2.0 * (mid - lo), above + 2.0 * (hi - mid));
            let (holds, at) = if low >= sure - tol {
                (true, low)
            } else if high < -tol - sure {
                (false, high)
            } else {
                let g = gap(f, mid);
                (g >= -tol, g)
            };
            debug_assert!(
                (gap(f, mid) >= -tol) == holds,
                "the ridge search's bound at {mid} disagrees with the gap measured there"
            );
            if holds {
                lo = mid;
                below = at;
            } else {
                hi = mid;
                above = at;
                // The ridge found will lie below `hi`, and the features after this one only
                // lower it: nearer than [`NARROW_FLOOR`] the road keeps its width, whatever
                // the rest of the search finds ([`narrowed`]).
                if hi < NARROW_FLOOR * w {
                    return (p, w);
                }
            }
        }
        ridge = lo;
    }
    let g = (ridge - 0.5 * w - RIDGE_MARGIN).fmin(slice.settings().max_width - w);
    if g < 0.0 {
        return narrowed(slice, p, (d, n), ridge, laid);
    }
    if g == 0.0 {
        return (p, w);
    }
    // The next turn crosses the ray a road width out: widen only if it was left out, and
    // only as far as the widened road keeps off every laid piece of that turn (near a corner
    // of the next turn, where it meets another feature's turn at the ridge, the traced turn
    // cuts the corner and passes the ray's point at a distance).
    let next = if ridge >= w {
        let level = turn_level(d, w) + 1;
        if laid(p + n * w, level, LAID_TOL * w) {
            return (p, w);
        }
        Some(level)
    } else {
        None
    };
    // Where the ridge bends toward the road (near a corner where two features' turns meet),
    // the widened road's round edge would cross it sideways onto the other side's road:
    // widen less, or not at all.
    // The same across the feature's own ridges ([`OWN_SIDE`]).
    // No feature is nearer `q` than its own (of equal distances, either counts).
    let in_cell = |q: Point| {
        let (nearest, d, near) = slice.nearest_feature(q);
        if nearest == own {
            // On this side of the feature's own ridges: its distance grows away from the
            // same part of it (beyond a ridge between two parts facing each other, the
            // gradient turns toward the road).
            let grad = slice.clearance_gradient(own, &near, q);
            grad.dot(n) >= OWN_SIDE * grad.norm()
        } else {
            d >= slice.clearance_to(own, q)
        }
    };
    let mut g = g;
    for _ in 0..WIDEN_TRIES {
        let (c, r) = (p + n * (0.5 * g), 0.5 * (w + g));
        if next.is_none_or(|level| !laid(c, level, r + 0.5 * w))
            && EDGE_DIRECTIONS
                .iter()
                .all(|&(x, y)| in_cell(c + Point::new(x, y) * r))
        {
            return (c, w + g);
        }
        g *= 0.5;
    }
    (p, w)
}

/// The level of the turn at distance `d` from its feature (`w/2 + k w`, less the first turn's
/// margin, rounded). A float-to-int `as` saturates: a level beyond `u16::MAX` (a slice 650 m
/// deep at the finest road) would only be clipped, never wrapped.
fn turn_level(d: f32, w: f32) -> u16 {
    libm::roundf((d - 0.5 * w - FIRST_TURN_MARGIN) / w).fmax(0.0) as u16
}

/// How nearly a widened road's edge must lie on its own side of its feature's own ridges
/// ([`widened`]): the cosine of the largest angle between the feature's distance gradient
/// there and at the road. Beyond a ridge between two parts of a feature that face each other
/// (a star's notch), the gradient points back toward the road: more than a right angle off.
/// On 200 random slices (with the first turns narrowed too, since undone) a right angle took
/// the spiral's median overfill from 0.018 to 0.017 and let 199 meet the bar; 60 degrees
/// (0.5) took it to 0.015 but cost coverage (one slice at 0.969) and left 198.
const OWN_SIDE: f32 = 0.0;

/// How nearly the other turn must face a narrowed road's ([`narrowed`]): the cosine of the
/// largest angle between the two gradients' opposites.
const FACING: f32 = 0.9;
/// The nearest ridge, road widths out, at which a road narrows ([`narrowed`]). Nearer, the two
/// turns are less than half a road apart: the tip of a lens where they converge on a corner
/// of the ridge, or the two sides of a small loop round a peak of `D`, whose round ends (not
/// the other turn) cover the ground beyond the ridge there, and narrowed they left it bare.
/// On 200 random slices narrowing down to the ridge itself (0; the first turns and the
/// bridges narrowed too) lowered the spiral's overfill by 0.0028 on average but its coverage
/// by 0.0012 (one slice fell below 0.97); see the README's random slices for this floor's
/// figures.
const NARROW_FLOOR: f32 = 0.25;

/// A turn's point `p` (at distance `d` from its nearest feature, `n` the unit gradient) whose
/// ridge lies `ridge` out, nearer than half a road: the same level's turn beyond the ridge (the
/// other feature's, or another part of the same one) lies less than a road away, and two roads
/// a road wide would lay the ground between them twice. Where that turn is laid, the road
/// narrows to the ridge: its inner edge stays where it was (on the turn below's outer edge)
/// and its outer edge stops [`RIDGE_MARGIN`] short of the ridge, where the other turn,
/// narrowed the same way, meets it; never narrower than
/// [`min_width`](crate::Settings::min_width); not where the ridge is nearer than
/// [`NARROW_FLOOR`], and not on the first turn (on the keep-out curve, in its feature's own
/// material).
fn narrowed(
    slice: &Slice,
    p: Point,
    (d, n): (f32, Point),
    ridge: f32,
    laid: impl Fn(Point, u16, f32) -> bool,
) -> (Point, f32) {
    let settings = slice.settings();
    let w = settings.road_width;
    let g = (ridge - 0.5 * w - RIDGE_MARGIN).fmax(settings.min_width - w);
    if g >= 0.0 || ridge < NARROW_FLOOR * w {
        return (p, w);
    }
    let level = turn_level(d, w);
    // The first turn runs on the keep-out curve in its feature's own material: narrowed, its
    // centre would move inside the curve, and a move from a blended vertex onto it would
    // cross the curve in a blend.
    if level == 0 {
        return (p, w);
    }
    // The other turn crosses the ray about twice the ridge's distance out, facing back along
    // it (near a corner where the turns meet at the ridge at an angle, the ground beyond the
    // ridge is not the other turn's: narrowing there would leave it bare).
    let q = p + n * (2.0 * ridge);
    let (_, _, back) = nearest(slice, q);
    let len = back.norm();
    if len < 1e-6 || back.dot(n) > -FACING * len || !laid(q, level, LAID_TOL * w) {
        return (p, w);
    }
    (p + n * (0.5 * g), w + g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Settings;

    /// A 10 mm square wall with a rectangular hole whose left side is at `x`, from y = 2 to 8:
    /// between x = 0 and `x` the wall's turns and the hole's face each other across the ridge
    /// at `x / 2`.
    fn facing(x: f32) -> Slice {
        let p = Point::new;
        let wall = [p(0.0, 0.0), p(10.0, 0.0), p(10.0, 10.0), p(0.0, 10.0)];
        let hole = [p(x, 2.0), p(x + 2.0, 2.0), p(x + 2.0, 8.0), p(x, 8.0)];
        let holes = [(&hole[..], [0.0, 1.0, 0.0, 0.0])];
        Slice::from_contours(&wall, [1.0, 0.0, 0.0, 0.0], &holes, Settings::default()).unwrap()
    }

    /// The wall's turn of level 4 (`w/2 + 4 w` from it) at y = 5.
    fn turn_point(slice: &Slice) -> Point {
        let w = slice.settings().road_width;
        Point::new(0.5 * w + 4.0 * w + FIRST_TURN_MARGIN, 5.0)
    }

    #[test]
    fn a_turn_narrows_to_the_ridge_where_the_turn_beyond_it_lies_nearer_than_a_road() {
        // Ridge at x = 1.95: the wall's level-4 turn (x = 1.803) and the hole's (x = 2.097)
        // lie 0.294 apart, 0.106 less than a road.
        let slice = facing(3.9);
        let w = slice.settings().road_width;
        let p = turn_point(&slice);
        let ridge = 1.95 - p.x;
        let (at, width) = widened(&slice, p, nearest(&slice, p), |_, _, _| true);
        // The inner edge stays; the outer one stops RIDGE_MARGIN short of the ridge.
        assert!(
            (at.x - 0.5 * width - (p.x - 0.5 * w)).abs() < 1e-4,
            "{at:?} {width}"
        );
        assert!(
            (at.x + 0.5 * width - (1.95 - RIDGE_MARGIN)).abs() < 1e-4,
            "{at:?} {width}"
        );
        assert!((width - (0.5 * w + ridge - RIDGE_MARGIN)).abs() < 1e-4);
        assert!(width < w && width >= slice.settings().min_width);
        // Where the turn beyond the ridge was left out, the road keeps its width.
        assert_eq!(
            widened(&slice, p, nearest(&slice, p), |_, _, _| false),
            (p, w)
        );
        // And where the ridge is nearer than NARROW_FLOOR (the turns less than half a road
        // apart).
        let slice = facing(2.0 * (p.x + 0.8 * NARROW_FLOOR * w));
        assert_eq!(
            widened(&slice, p, nearest(&slice, p), |_, _, _| true),
            (p, w)
        );
        let slice = facing(2.0 * (p.x + 1.2 * NARROW_FLOOR * w));
        assert!(widened(&slice, p, nearest(&slice, p), |_, _, _| true).1 < w);
        // The first turn, on the keep-out curve, never narrows.
        let first = Point::new(0.5 * w + FIRST_TURN_MARGIN, 5.0);
        let slice = facing(2.0 * (first.x + 1.5 * NARROW_FLOOR * w));
        assert_eq!(
            widened(&slice, first, nearest(&slice, first), |_, _, _| true),
            (first, w)
        );
    }

    #[test]
    fn a_road_widening_into_a_notch_keeps_to_its_side_of_the_notch_ridge() {
        // A hole with a V notch from above, its arms from (3, 6) down to (5, 2) and back up to
        // (7, 6): the material in the notch has the feature's own ridge at x = 5.
        let q = Point::new;
        let wall = [q(-5.0, -5.0), q(15.0, -5.0), q(15.0, 15.0), q(-5.0, 15.0)];
        let hole = [
            q(0.0, 0.0),
            q(10.0, 0.0),
            q(10.0, 6.0),
            q(7.0, 6.0),
            q(5.0, 2.0),
            q(3.0, 6.0),
            q(0.0, 6.0),
        ];
        let holes = [(&hole[..], [0.0, 1.0, 0.0, 0.0])];
        let slice =
            Slice::from_contours(&wall, [1.0, 0.0, 0.0, 0.0], &holes, Settings::default()).unwrap();
        let w = slice.settings().road_width;
        // The first turn beside the left arm, 0.35 mm (along its normal) short of the ridge:
        // it widens into the sliver, with no next turn to keep off.
        let n = Point::new(2.0, 1.0) * (1.0 / libm::sqrtf(5.0));
        let d = 0.5 * w + FIRST_TURN_MARGIN;
        let p = q(5.0 - 0.35 * n.x, 3.0);
        let p = q(p.x, 6.0 - 2.0 * (p.x - d * n.x - 3.0) + d * n.y);
        let near = nearest(&slice, p);
        assert!((near.1 - d).abs() < 1e-4, "{near:?}");
        let (at, width) = widened(&slice, p, near, |_, _, _| false);
        assert!(width > w, "{width}");
        // Its round edge stays left of the ridge all round (measured at its widest, along `n`,
        // it would stop short of it; sideways, toward the notch's opening, it used to cross).
        for k in 0..72 {
            let a = k as f32 * core::f32::consts::PI / 36.0;
            let e = at + Point::new(libm::cosf(a), libm::sinf(a)) * (0.5 * width);
            assert!(e.x <= 5.0 + 1e-4, "edge {e:?} of {at:?} {width}");
        }
    }

    #[test]
    fn a_turn_widens_into_a_sliver_before_the_ridge_and_keeps_its_width_a_road_from_it() {
        let w = Settings::default().road_width;
        // Ridge at x = 2.2, 0.397 beyond the turn: the sliver between the two sides' turns
        // (0.394 apart edge to edge, less than a road) is shared, each side widening to it.
        let slice = facing(4.4);
        let p = turn_point(&slice);
        let (at, width) = widened(&slice, p, nearest(&slice, p), |_, _, _| false);
        assert!(
            (at.x + 0.5 * width - (2.2 - RIDGE_MARGIN)).abs() < 1e-4,
            "{at:?} {width}"
        );
        assert!(width > w);
        // Ridge exactly half a road beyond the turn (plus the margin): neither.
        let slice = facing(2.0 * (p.x + 0.5 * w + RIDGE_MARGIN));
        let (at, width) = widened(&slice, p, nearest(&slice, p), |_, _, _| true);
        assert!(
            (width - w).abs() < 1e-4 && at.dist(p) < 1e-4,
            "{at:?} {width}"
        );
    }
}
