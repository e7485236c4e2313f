//! Walking the joined loops into the layer: each loop from its entry around to its exit,
//! across the bridges, with each vertex's road as wide as the ridge there allows
//! ([`ridge`](super::ridge)) and the composition of the blended field at every vertex.

use super::ridge::widened;
use super::{
    capacity, nearest, wrap, Frame, OffsetSpiral, OffsetStats, BRIDGE_TAPER, FIRST_TURN_MARGIN,
    NONE, WIDTH_STEP,
};
use crate::config::MAX_LOOPS;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, Point};
use crate::slice::Material;
use crate::toolpath::composition::BlendedField;
use crate::toolpath::moves::WIDTH_TOLERANCE;
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Limit, Plan, Slice};
use heapless::Vec;

/// The composition at `p` (whose nearest feature is `near`, at distance `d`): the plan's
/// blended field, but exactly the feature's own material on its first turn.
fn material(slice: &Slice, field: &BlendedField, p: Point, near: usize, d: f32) -> Material {
    let half = 0.5 * slice.settings().road_width;
    let own = slice.material_at(near);
    if d < half + 2.0 * FIRST_TURN_MARGIN {
        own
    } else {
        field.at(p).unwrap_or(own)
    }
}

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
        let near = nearest(slice, p);
        let (at, width) = self.widen(slice, p, near);
        Vertex {
            at,
            material: material(slice, field, p, near.0, near.1),
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

    /// Emits a bridge of join `site` to `p`: [`bridge_vertex`](Self::bridge_vertex)'s road,
    /// laid [`bridge_width`](Self::bridge_width) wide between its ends. Each end keeps the
    /// width of the loop it leaves or enters, and the road narrows to the bridge's width over
    /// the first and widens back over the last [`BRIDGE_TAPER`] of it: the loops' round ends
    /// still cover the corners beside the gap, and the two bridges of a join do not lie on
    /// each other between them.
    fn emit_bridge(
        &self,
        slice: &Slice,
        field: &BlendedField,
        sink: &mut impl PathSink,
        site: usize,
        p: Point,
    ) -> Result<(), Error> {
        let end = self.bridge_vertex(slice, field, p);
        let width = self.bridge_width(slice, site);
        if let Some(from) = sink.last_vertex().filter(|v| v.deposit) {
            let len = from.at.dist(end.at);
            let taper = (BRIDGE_TAPER * width).fmin(0.25 * len);
            let inner = |q: Point| {
                let (f, d, _) = slice.nearest_feature(q);
                Vertex {
                    at: q,
                    material: material(slice, field, q, f, d),
                    width,
                    deposit: true,
                }
            };
            // A width within a printer's tolerance of the bridge's is laid as it is.
            let wider = |v: f32| taper > 0.0 && v > width * (1.0 + WIDTH_TOLERANCE);
            if wider(from.width) {
                emit_move(slice, sink, inner(from.at.lerp(end.at, taper / len)))?;
            }
            if wider(end.width) {
                emit_move(slice, sink, inner(end.at.lerp(from.at, taper / len)))?;
            }
        }
        emit_move(slice, sink, end)
    }

    /// How wide the two bridges of join `site` are laid between their ends: as wide as they
    /// lie apart (the chord of its gaps), so that together they fill the gap between the two
    /// loops side by side without laying any of it twice; where they lie less than half a road
    /// apart (a join across a pinch), so wide that the two together span a road. Never
    /// narrower than [`min_width`](crate::Settings::min_width). A bridge laid at the width of
    /// a widened turn (a turn beside a ridge, a seam between two features' turns) or a full
    /// road where the gap is tighter lies that much over its twin.
    fn bridge_width(&self, slice: &Slice, site: usize) -> f32 {
        let st = &self.sites[site];
        let (a, b) = (st.a as usize, st.b as usize);
        let chord = |l: usize, s1: f32, s2: f32| self.at(l, s1).dist(self.at(l, s2));
        let apart = chord(a, st.a1, st.a2).fmin(chord(b, st.b1, st.b2));
        let w = slice.settings().road_width;
        apart.fmax(w - apart).fmax(slice.settings().min_width)
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
                        // Enter the child at its gap's end facing the one this walk reaches
                        // (`y1`, or `y2` where the two loops run opposite ways: `flip`) and walk
                        // it away from its gap: the other way round, or with `flip` the same.
                        let flip = self.sites[si].flip;
                        let (resume, enter) = match (top.forward, flip) {
                            (true, false) => (x2, y1),
                            (false, false) => (x1, y2),
                            (true, true) => (x2, y2),
                            (false, true) => (x1, y1),
                        };
                        if let Some(f) = self.stack.last_mut() {
                            f.pos = resume;
                            f.remaining -= ahead + gap;
                        }
                        // The bridge across.
                        self.emit_bridge(slice, &field, sink, si, self.at(child, enter))?;
                        self.stack
                            .push(Frame {
                                lp: child as u16,
                                pos: enter,
                                forward: top.forward == flip,
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
                            self.emit_bridge(slice, &field, sink, top.entered_by as usize, p)?;
                        }
                    }
                }
            }
        }
        Ok(())
    }
}
