//! The zigzag's roads along its MCLs ([`super::zigzag`]): the band each MCL's road owns
//! between its neighbouring MCLs, the road's width and place in it, and the meander that fills
//! a band wider than the widest road.

use core::cell::RefCell;

use heapless::Vec;

use crate::config::MAX_MCLS;
use crate::error::Limit;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, primitives, Point};
use crate::toolpath::composition::along;
use crate::toolpath::zigzag::EDGE_MARGIN;
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Plan, Slice};

/// A road meanders only where its band is wider than the widest road by this many road
/// widths: a narrower excess costs less left as slivers either side than paid for with the
/// turns of a meander of one or two strokes (which lap back over the wide road around them).
const MEANDER_MARGIN: f32 = 0.5;

/// The band a road along an MCL owns at a point ([`band_at`]): the unit normal to the left of
/// the MCL, and the distances to the neighbouring MCL on the left and on the right.
pub(super) type Band = (Point, f32, f32);

/// Whether a band is wider than the widest road
/// ([`max_width`](crate::Settings::max_width)) by [`MEANDER_MARGIN`]: there the road meanders
/// ([`meander`]).
pub(super) fn too_wide(slice: &Slice, band: Option<Band>) -> bool {
    let settings = slice.settings();
    band.is_some_and(|(_, l, r)| {
        0.5 * (l + r) > settings.max_width + MEANDER_MARGIN * settings.road_width
    })
}

/// The MCLs a zigzag lays, which the band of each road is measured against ([`band_at`]),
/// and the boxes around them (to skip those too far to matter).
#[derive(Clone, Copy)]
pub(super) struct Fan<'a> {
    /// The plan index of the MCL the road runs along.
    pub me: u16,
    /// Its place in `laid`: the MCLs next to it there (its neighbours around the feature) are
    /// measured first, so the nearest bound the search early.
    pub at: u16,
    /// Plan indices of the MCLs laid.
    pub laid: &'a [u16],
    /// The box around each MCL laid, in the order of `laid`.
    pub boxes: &'a [(Point, Point)],
    /// The box around each run of [`CHUNK`] MCLs in `laid` (neighbours around a feature, so
    /// one box rules out several far ones at once).
    pub chunks: &'a [(Point, Point)],
    /// The MCL segments near the last query ([`Near`]), for the next.
    pub near: &'a RefCell<Near>,
}

impl Fan<'_> {
    /// [`Slice::clearance`] at `q`, from the edges [`Near`] holds where they answer it.
    fn clearance(&self, slice: &Slice, q: Point) -> f32 {
        self.near
            .try_borrow_mut()
            .ok()
            .and_then(|mut near| near.clearance(slice, q))
            .unwrap_or_else(|| slice.clearance(q))
    }
}

/// How many MCLs laid in a row share one of [`Fan::chunks`]' boxes.
const CHUNK: usize = 8;

/// [`Fan::boxes`]' buffer.
pub(super) type FanBoxes = Vec<(Point, Point), MAX_MCLS>;
/// [`Fan::chunks`]' buffer.
pub(super) type FanChunks = Vec<(Point, Point), { MAX_MCLS.div_ceil(CHUNK) }>;

/// Fills [`Fan::boxes`] and [`Fan::chunks`] for the MCLs `laid` (plan indices).
pub(super) fn fan_boxes(
    plan: &Plan,
    laid: &[u16],
    boxes: &mut FanBoxes,
    chunks: &mut FanChunks,
) -> Result<(), Error> {
    boxes.clear();
    chunks.clear();
    for &k in laid {
        boxes
            .push(primitives::bbox(&plan.points(&plan.mcls[k as usize])))
            .map_err(|_| Limit::Mcls.error())?;
    }
    for run in boxes.chunks(CHUNK) {
        let (mut lo, mut hi) = run[0];
        for &(a, b) in run {
            lo = Point::new(lo.x.fmin(a.x), lo.y.fmin(a.y));
            hi = Point::new(hi.x.fmax(b.x), hi.y.fmax(b.y));
        }
        chunks.push((lo, hi)).map_err(|_| Limit::Mcls.error())?;
    }
    Ok(())
}

/// The `step`-th of `0..n` outward from `at`: `at`, `at + 1`, `at - 1`, `at + 2`, ... (mod `n`,
/// each once over `step` in `0..n`).
fn outward(at: usize, step: usize, n: usize) -> usize {
    let half = step.div_ceil(2);
    if step % 2 == 1 {
        let i = at + half;
        if i >= n {
            i - n
        } else {
            i
        }
    } else if half > at {
        at + n - half
    } else {
        at - half
    }
}

/// How far a ball may grow from `p` along the unit normal `n` before it touches segment
/// `a`-`b` less `off`: the least `t >= 0` at which `p + t n` is no nearer `p` than the
/// segment's `off`-neighbourhood (`dist(p + t n, ab) <= t + off`), infinite if never. The
/// distance from a point moving along a line to a segment is convex in `t`, so the first
/// such `t` is the least root among the segment's pieces (its two ends and its interior).
fn ball(p: Point, n: Point, a: Point, b: Point, off: f32) -> f32 {
    let mut best = f32::INFINITY;
    // The ends: |c - p - t n| = t + off.
    for c in [a, b] {
        let d = c - p;
        let den = 2.0 * (n.dot(d) + off);
        if den > 1e-12 {
            let t = (d.dot(d) - off * off) / den;
            best = best.fmin(t.fmax(0.0));
        }
    }
    // The interior: the signed distance to the segment's line, h(t) = h0 + t (n . m), is
    // +-(t + off) with its foot inside the segment.
    let e = b - a;
    let len = e.norm();
    if len > 1e-9 {
        let m = Point::new(-e.y / len, e.x / len);
        let h0 = (p - a).dot(m);
        let nm = n.dot(m);
        let s0 = (p - a).dot(e) / (len * len);
        if h0.abs() <= off && (0.0..=1.0).contains(&s0) {
            // `p` lies within `off` of the segment already.
            return 0.0;
        }
        for (num, den) in [(h0 - off, 1.0 - nm), (-h0 - off, 1.0 + nm)] {
            if den > 1e-9 && num >= 0.0 {
                let t = num / den;
                let s = (p + n * t - a).dot(e) / (len * len);
                if (0.0..=1.0).contains(&s) && t < best {
                    best = t;
                }
            }
        }
    }
    best
}

/// How far the ray from `p` along the unit vector `n` runs before it comes within `off` of
/// segment `a`-`b`: the least `t >= 0` with `dist(p + t n, ab) <= off`, infinite if never (the
/// distance is convex in `t`: the least root among the segment's ends and interior).
fn within(p: Point, n: Point, a: Point, b: Point, off: f32) -> f32 {
    let e = b - a;
    let len2 = e.dot(e);
    let s0 = if len2 > 1e-18 {
        ((p - a).dot(e) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    if (a + e * s0).dist(p) <= off {
        return 0.0;
    }
    let mut best = f32::INFINITY;
    // The ends: |c - p - t n| = off.
    for c in [a, b] {
        let d = c - p;
        let k = n.dot(d);
        let disc = k * k - d.dot(d) + off * off;
        if disc >= 0.0 {
            let t = k - hollowpath_fpu::sqrtf(disc);
            if t >= 0.0 {
                best = best.fmin(t);
            }
        }
    }
    // The interior: the signed distance to the line, h0 + t (n . m), is +-off with its foot
    // inside the segment.
    if len2 > 1e-18 {
        let len = hollowpath_fpu::sqrtf(len2);
        let m = Point::new(-e.y / len, e.x / len);
        let h0 = (p - a).dot(m);
        let nm = n.dot(m);
        if nm.abs() > 1e-9 {
            for target in [off, -off] {
                let t = (target - h0) / nm;
                if t >= 0.0 && t < best {
                    let s = (p + n * t - a).dot(e) / len2;
                    if (0.0..=1.0).contains(&s) {
                        best = t;
                    }
                }
            }
        }
    }
    best
}

/// The features' edges a ray from `p` may meet within `limit`, each with the least `t` at
/// which the ray comes within `off` of it ([`within`]): the least over all features.
fn features_within(slice: &Slice, p: Point, n: Point, off: f32) -> f32 {
    let mut best = f32::INFINITY;
    for f in slice.holes().iter().chain(core::iter::once(slice.wall())) {
        if polygon::bbox_distance(f.bbox(), p) >= best + off {
            continue;
        }
        let pts = f.points();
        for (run_box, edges) in f.edge_runs() {
            // A run whose box lies wholly on one side of the strip (all four corners beyond
            // it by more than rounding) holds no edge the test below would keep.
            if box_clear_of_strip(p, n, run_box, off, best) {
                continue;
            }
            for i in edges {
                meet(p, n, [pts[i], pts[(i + 1) % pts.len()]], off, &mut best);
            }
        }
    }
    best
}

/// One edge of [`features_within`]'s search: lowers `best` to the least `t` at which the ray
/// from `p` along `n` comes within `off` of edge `a`-`b`.
fn meet(p: Point, n: Point, seg: [Point; 2], off: f32, best: &mut f32) {
    let (h, g) = products(p, n, seg);
    meet_with(p, n, seg, off, (h, g), best);
}

/// Where the ends of `seg` lie from `p` across and along the unit vector `n`: `(h, g)`, each
/// a pair (the first end's, the second's). Along `-n` they are the same negated, to the bit
/// (up to the sign of a zero, which no comparison sees).
#[inline(always)]
fn products(p: Point, n: Point, seg: [Point; 2]) -> ((f32, f32), (f32, f32)) {
    let (da, db) = (seg[0] - p, seg[1] - p);
    ((n.cross(da), n.cross(db)), (n.dot(da), n.dot(db)))
}

/// [`meet`] with the ends' [`products`] given.
#[inline(always)]
fn meet_with(
    p: Point,
    n: Point,
    [a, b]: [Point; 2],
    off: f32,
    ((ha, hb), (ga, gb)): ((f32, f32), (f32, f32)),
    best: &mut f32,
) {
    // Only a segment that reaches the strip `off` either side of the ray, ahead of `p` and
    // nearer than the best so far, can be nearer (a segment lies between its ends): most are
    // ruled out by four products.
    if (ha > off && hb > off)
        || (ha < -off && hb < -off)
        || (ga < -off && gb < -off)
        || (ga > *best + off && gb > *best + off)
    {
        return;
    }
    *best = best.fmin(within(p, n, a, b, off));
}

/// Whether box `(lo, hi)` lies wholly beyond one side of the strip of [`features_within`]'s
/// ray from `p` along `n` (more than `off` to either side, more than `off` behind `p`, or
/// more than `best + off` ahead), by more than rounding: then so does every segment in it.
fn box_clear_of_strip(p: Point, n: Point, (lo, hi): (Point, Point), off: f32, best: f32) -> bool {
    let corners = [lo, Point::new(hi.x, lo.y), hi, Point::new(lo.x, hi.y)];
    let slack = polygon::rounding_slack(p, (lo, hi));
    let (mut h, mut g) = (
        (f32::INFINITY, f32::NEG_INFINITY),
        (f32::INFINITY, f32::NEG_INFINITY),
    );
    for c in corners {
        let d = c - p;
        let (hc, gc) = (n.cross(d), n.dot(d));
        h = (h.0.fmin(hc), h.1.fmax(hc));
        g = (g.0.fmin(gc), g.1.fmax(gc));
    }
    h.0 > off + slack || h.1 < -off - slack || g.1 < -off - slack || g.0 > best + off + slack
}

/// How far the ground across the MCL at `p` reaches along the unit normal `n` before it is
/// another road's, as the gap to a neighbour (the road owns half of it): twice the radius of
/// the largest ball centred on the normal that touches the MCL at `p` and no other MCL laid,
/// so each road fills up to the medial line between it and the next, from whatever side that
/// comes, and neighbouring roads' strokes meet without overlap however the MCLs fan, curve or
/// end; or, where the normal meets a feature first, twice the room up to its keep-out strip
/// (a road wide, where the arcs run). The MCL the road runs along counts too, away from `p`
/// (a curved MCL may face itself). Both sides at once: along `n` and along `-n`.
fn reach(slice: &Slice, plan: &Plan, p: Point, n: Point, fan: &Fan<'_>) -> [f32; 2] {
    // The segments and edges held near `p` answer most queries (those whose balls stay
    // inside their disk); the rest search every feature and every MCL laid.
    let near = match fan.near.try_borrow_mut() {
        Ok(mut near) => near.reach_both(slice, plan, p, n, fan),
        Err(_) => [None, None],
    };
    let back = n * -1.0;
    [(near[0], n), (near[1], back)]
        .map(|(near, n)| near.map_or_else(|| search(slice, plan, p, n, fan), |best| 2.0 * best))
}

/// [`reach`] along `n` alone, searching every feature and every MCL laid.
fn search(slice: &Slice, plan: &Plan, p: Point, n: Point, fan: &Fan<'_>) -> f32 {
    let w = slice.settings().road_width;
    let strip = w + 2.0 * EDGE_MARGIN;
    // Cannot stay infinite: the wall stops every ray from inside it.
    let hit = features_within(slice, p, n, 0.0);
    let mut best = if hit.is_finite() {
        (hit - strip).fmax(0.0)
    } else {
        0.0
    };
    // From the MCL's own place in `laid` outward: its neighbours first.
    let count = fan.laid.len();
    let runs = fan.chunks.len();
    let at = (fan.at as usize).min(count.saturating_sub(1)) / CHUNK;
    for step in 0..runs {
        let c = outward(at, step, runs);
        // A ball of radius t from p reaches no point farther than 2 t from p.
        if polygon::bbox_distance2(fan.chunks[c], p) >= 4.0 * best * best {
            continue;
        }
        for i in c * CHUNK..((c + 1) * CHUNK).min(count) {
            reach_mcl(plan, p, n, fan, i, w, &mut best);
        }
    }
    2.0 * best
}

/// [`reach`]'s search over the `i`-th MCL of `fan.laid`: lowers `best` to the radius of the
/// first ball along `p + t n` that touches it.
fn reach_mcl(plan: &Plan, p: Point, n: Point, fan: &Fan<'_>, i: usize, w: f32, out: &mut f32) {
    let mut best = *out;
    let (m, bbox) = (fan.laid[i], fan.boxes[i]);
    if polygon::bbox_distance2(bbox, p) >= 4.0 * best * best {
        return;
    }
    {
        let mut pts = plan.points_iter(&plan.mcls[m as usize]);
        let Some(mut prev) = pts.next() else {
            return;
        };
        for q in pts {
            touch(p, n, [prev, q], m == fan.me, w, &mut best);
            prev = q;
        }
    }
    *out = best;
}

/// One segment of [`reach`]'s search: lowers `best` to the radius of the first ball along
/// `p + t n` that touches segment `seg` of an MCL laid (`own`: of the MCL the road runs along,
/// whose segments next to `p` do not count).
#[inline(always)]
fn touch(p: Point, n: Point, seg: [Point; 2], own: bool, w: f32, best: &mut f32) {
    let (h, g) = products(p, n, seg);
    touch_with(p, n, seg, own, w, (h, g), best);
}

/// [`touch`] with the ends' [`products`] given.
#[inline(always)]
fn touch_with(
    p: Point,
    n: Point,
    seg: [Point; 2],
    own: bool,
    w: f32,
    ((ha, hb), (ga, gb)): ((f32, f32), (f32, f32)),
    best: &mut f32,
) {
    // The balls still in question lie ahead of `p` within `2 best` along `n` and within
    // `best` across it: a segment wholly outside that box cannot touch them.
    let b = *best;
    if (ga < 0.0 && gb < 0.0)
        || (ga > 2.0 * b && gb > 2.0 * b)
        || (ha > b && hb > b)
        || (ha < -b && hb < -b)
    {
        return;
    }
    // Its own segments next to `p` are where the ball touches.
    if own
        && (seg[0].dist(p) < 2.0 * w
            || seg[1].dist(p) < 2.0 * w
            || primitives::closest_on_segment(seg[0], seg[1], p).0.dist(p) < 1e-3)
    {
        return;
    }
    *best = b.fmin(ball(p, n, seg[0], seg[1], 0.0));
}

/// The [`products`] of the other side: along `-n`.
#[inline(always)]
fn negated(((ha, hb), (ga, gb)): ((f32, f32), (f32, f32))) -> ((f32, f32), (f32, f32)) {
    ((-ha, -hb), (-ga, -gb))
}

/// How many MCL segments [`Near`] holds. A disk of [`NEAR_ROADS`] road widths held at most 96 on
/// the reference slices and 147 on 193 random ones; a disk with more is not held (its queries
/// search everything, with the same answers).
const NEAR_SEGMENTS: usize = 160;
/// How many feature edges [`Near`] holds (at most 12 on the reference slices, 78 on the random
/// ones, whose contours keep a vertex every few hundredths of a millimetre).
const NEAR_EDGES: usize = 96;
/// The radius of [`Near`]'s disk, in road widths. It changes no answer, only how many queries
/// it answers and how many segments each measures: a query is answered where its balls stay
/// in the disk (at worst `2 t` within half the radius, as the disk is filled again once the
/// road walks farther from its centre), most bands are one to two roads wide, and a wider
/// disk holds more segments. 2.5 to 3 took the fewest instructions on four_holes (2 to 6
/// measured), answering 95 % of the queries.
const NEAR_ROADS: f32 = 3.0;
/// [`Near::segs`]' MCL indices are `u16` (plan indices).
const _: () = assert!(crate::config::MAX_MCLS <= u16::MAX as usize);

/// The segments of the MCLs laid within a disk, for the [`reach`] queries that follow one
/// another along a road: a query whose balls stay inside the disk needs no other segment (a
/// ball of radius `t` from `p` reaches no point farther than `2 t` from `p`), so it measures
/// only these instead of searching every MCL laid, and finds the same least ball. The disk
/// moves (is filled again around the query) once a query lies more than half its radius from
/// its centre.
pub(super) struct Near {
    centre: Point,
    radius: f32,
    /// Whether `segs` holds every segment within the disk (false before the first fill, and
    /// after a fill that found more than [`NEAR_SEGMENTS`]).
    held: bool,
    /// Each segment's ends and the plan index of its MCL.
    segs: Vec<([Point; 2], u16), NEAR_SEGMENTS>,
    /// The features' edges within the disk.
    edges: Vec<[Point; 2], NEAR_EDGES>,
    /// Whether the centre lies in the material (clear of every feature), once asked.
    material: Option<bool>,
}

impl Near {
    /// No disk held.
    pub(super) const fn new() -> Near {
        Near {
            centre: Point::new(0.0, 0.0),
            radius: 0.0,
            held: false,
            segs: Vec::new(),
            edges: Vec::new(),
            material: None,
        }
    }

    /// Holds the segments of `fan`'s MCLs laid and the features' edges that come within
    /// `radius` of `centre` (by their boxes: one left out lies wholly farther), or nothing, if
    /// they are too many.
    fn fill(&mut self, slice: &Slice, plan: &Plan, fan: &Fan<'_>, centre: Point, radius: f32) {
        self.segs.clear();
        self.edges.clear();
        self.material = None;
        self.centre = centre;
        self.radius = radius;
        self.held = false;
        let r2 = radius * radius;
        for f in slice.holes().iter().chain(core::iter::once(slice.wall())) {
            if polygon::bbox_distance2(f.bbox(), centre) > r2 {
                continue;
            }
            let pts = f.points();
            for (run_box, edges) in f.edge_runs() {
                if polygon::bbox_distance2(run_box, centre) > r2 {
                    continue;
                }
                for i in edges {
                    let edge = [pts[i], pts[(i + 1) % pts.len()]];
                    if !segment_box_within(edge, centre, r2) {
                        continue;
                    }
                    if self.edges.push(edge).is_err() {
                        // Too many to hold: every query searches everything until the next
                        // fill.
                        self.edges.clear();
                        return;
                    }
                }
            }
        }
        let count = fan.laid.len();
        for (c, &chunk) in fan.chunks.iter().enumerate() {
            if polygon::bbox_distance2(chunk, centre) > r2 {
                continue;
            }
            for i in c * CHUNK..((c + 1) * CHUNK).min(count) {
                let m = fan.laid[i];
                if polygon::bbox_distance2(fan.boxes[i], centre) > r2 {
                    continue;
                }
                let mut pts = plan.points_iter(&plan.mcls[m as usize]);
                let Some(mut prev) = pts.next() else {
                    continue;
                };
                for q in pts {
                    let seg = [prev, q];
                    prev = q;
                    if !segment_box_within(seg, centre, r2) {
                        continue;
                    }
                    if self.segs.push((seg, m)).is_err() {
                        self.segs.clear();
                        self.edges.clear();
                        return;
                    }
                }
            }
        }
        self.held = true;
    }

    /// [`reach`]'s least ball radius at `p` along `n` and along `-n`, each if the disk answers
    /// it (after filling it around `p` if `p` lies more than half its radius from its
    /// centre); `None` where something not held could be nearer.
    fn reach_both(
        &mut self,
        slice: &Slice,
        plan: &Plan,
        p: Point,
        n: Point,
        fan: &Fan<'_>,
    ) -> [Option<f32>; 2] {
        let radius = NEAR_ROADS * slice.settings().road_width;
        let mut fresh = false;
        if !self.held || p.dist(self.centre) >= 0.6 * radius {
            self.fill(slice, plan, fan, p, radius);
            fresh = true;
        }
        let mut got = self.answer(slice, p, n, fan);
        if !fresh && got.iter().any(Option::is_none) {
            self.fill(slice, plan, fan, p, radius);
            got = self.answer(slice, p, n, fan);
        }
        got
    }

    /// [`reach_both`](Self::reach_both) from the disk as it is. The ends' products are
    /// measured once for both sides.
    ///
    /// Everything not held lies farther than the radius from the centre, so farther than
    /// `room` from `p`: the ray meets no edge not held before `room`, and no ball within
    /// `2 t < room` of `p` touches a segment not held. So an edge met before `room` is the
    /// feature the full search finds; where none is, the features lie at least `room` away,
    /// and a ball smaller than their strip there is the answer.
    fn answer(&self, slice: &Slice, p: Point, n: Point, fan: &Fan<'_>) -> [Option<f32>; 2] {
        if !self.held {
            return [None, None];
        }
        let w = slice.settings().road_width;
        // A thousandth of the radius and the coordinates' rounding spare.
        let slack = 1e-3 * self.radius + polygon::rounding_slack(p, (self.centre, self.centre));
        let room = self.radius - p.dist(self.centre) - slack;
        if room <= 0.0 {
            return [None, None];
        }
        let strip = w + 2.0 * EDGE_MARGIN;
        let back = n * -1.0;
        let mut hit = [f32::INFINITY; 2];
        for &edge in self.edges.iter() {
            let hg = products(p, n, edge);
            meet_with(p, n, edge, 0.0, hg, &mut hit[0]);
            meet_with(p, back, edge, 0.0, negated(hg), &mut hit[1]);
        }
        // As the full search starts, where the feature met is held; else from no bound.
        let mut best = hit.map(|hit| {
            if hit < room {
                (hit - strip).fmax(0.0)
            } else {
                f32::INFINITY
            }
        });
        for &(seg, m) in self.segs.iter() {
            let hg = products(p, n, seg);
            let own = m == fan.me;
            touch_with(p, n, seg, own, w, hg, &mut best[0]);
            touch_with(p, back, seg, own, w, negated(hg), &mut best[1]);
        }
        [0, 1].map(|k| {
            (2.0 * best[k] < room && (hit[k] < room || best[k] < room - strip)).then_some(best[k])
        })
    }
}

impl Near {
    /// [`Slice::clearance`] at `q`, if the disk answers it: where `q` lies in the material and
    /// its nearest edge held is nearer than anything not held can be. `q` is in the material
    /// if the centre is (asked of the slice once per disk) and the segment from the centre to
    /// `q`, which lies in the disk, meets no edge held (so none at all). Its clearance is then
    /// the least distance to an edge, measured as [`Feature::nearest`] measures it (the same
    /// closest point, the square root of the least squared distance), so the same bits.
    ///
    /// [`Feature::nearest`]: crate::Feature::nearest
    fn clearance(&mut self, slice: &Slice, q: Point) -> Option<f32> {
        if !self.held {
            return None;
        }
        let slack = 1e-3 * self.radius + polygon::rounding_slack(q, (self.centre, self.centre));
        let room = self.radius - q.dist(self.centre) - slack;
        let c = self.centre;
        if room <= 0.0
            || self
                .edges
                .iter()
                .any(|&[a, b]| primitives::segments_meet(c, q, a, b))
            || !*self
                .material
                .get_or_insert_with(|| slice.clearance(c) > 0.0)
        {
            return None;
        }
        let d2 = self.edges.iter().fold(f32::INFINITY, |m, &[a, b]| {
            let d2 = (primitives::closest_on_segment(a, b, q).0 - q).norm2();
            if d2 < m {
                d2
            } else {
                m
            }
        });
        let d = hollowpath_fpu::sqrtf(d2);
        (d < room).then_some(d)
    }
}

/// Whether the box around segment `seg` comes within `sqrt(r2)` of `c` (a segment whose box
/// does not lies wholly farther).
#[inline(always)]
fn segment_box_within([a, b]: [Point; 2], c: Point, r2: f32) -> bool {
    let (lo, hi) = (
        Point::new(a.x.fmin(b.x), a.y.fmin(b.y)),
        Point::new(a.x.fmax(b.x), a.y.fmax(b.y)),
    );
    polygon::bbox_distance2((lo, hi), c) <= r2
}

/// The band the road along an MCL owns at `p` (direction `dir`): the unit normal to the left of
/// the MCL and how far the ground reaches across it on the left and on the right before the
/// next road ([`reach`]: the first MCL laid that the normal meets, or a feature's keep-out
/// strip); the road owns half of each gap. `None` where `dir` is degenerate.
pub(super) fn band_at(
    slice: &Slice,
    plan: &Plan,
    p: Point,
    dir: Point,
    fan: &Fan<'_>,
) -> Option<Band> {
    let len = dir.norm();
    if len < 1e-6 {
        return None;
    }
    // Unit normal to the left of the MCL.
    let left_n = Point::new(-dir.y / len, dir.x / len);
    let [left, right] = reach(slice, plan, p, left_n, fan);
    Some((left_n, left, right))
}

/// Where the band an MCL's road owns ([`band_at`]) is wider than the widest road
/// ([`max_width`](crate::Settings::max_width)), as it is where MCLs fan apart toward the wall,
/// in large cells and around long channels, the road fills it with a meander: strokes across
/// the band, from its right edge to its left edge and back, a road apart, advancing along the
/// MCL. The strokes stand on one grid over the whole MCL (a road apart, evenly), not per move:
/// an MCL's vertices are mostly nearer each other than a road, and a move shorter than a road
/// holds one stroke or none. Emits the strokes along the MCL's move from `a` to `b` (arc
/// lengths `sa`, `sb` of `len` from the `from` end, materials `ma`, `mb` at its ends),
/// `state` the meander so far along the MCL.
#[allow(clippy::too_many_arguments)]
pub(super) fn meander(
    slice: &Slice,
    plan: &Plan,
    (a, b): (Point, Point),
    (sa, sb, len): (f32, f32, f32),
    (ma, mb): (&crate::Material, &crate::Material),
    fan: &Fan<'_>,
    state: &mut Strokes,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    if len < 1e-6 || (sb - sa).abs() < 1e-9 {
        return Ok(());
    }
    // Strokes stand a road apart (a little less, evenly) over the whole MCL, at arc lengths
    // `(k + 1/2) spacing` from its `from` end, whatever the spacing of its vertices: a move
    // shorter than a road holds one stroke or none, a long one several.
    let count = libm::ceilf(len / w).fmax(1.0);
    let spacing = len / count;
    let dir = b - a;
    // The strokes on this move, in walking order: from `sa` (included) toward `sb`.
    let first = if sb > sa {
        libm::ceilf(sa / spacing - 0.5)
    } else {
        libm::floorf(sa / spacing - 0.5)
    };
    let step = if sb > sa { 1.0 } else { -1.0 };
    let mut k = first;
    loop {
        let s = (k + 0.5) * spacing;
        let inside = if sb > sa { s < sb } else { s > sb };
        if !inside || k < 0.0 || k >= count {
            break;
        }
        let t = ((s - sa) / (sb - sa)).clamp(0.0, 1.0);
        let material = along(ma, mb, s, len);
        state.in_meander = stroke(
            slice,
            plan,
            a.lerp(b, t),
            dir,
            spacing,
            material,
            fan,
            state,
            sink,
        )?;
        k += step;
    }
    Ok(())
}

/// Where a meander along one MCL stands.
#[derive(Clone, Copy, Debug)]
pub(super) struct Strokes {
    /// The side the next stroke starts on.
    pub right_first: bool,
    /// Whether the last sample along the MCL was a stroke.
    pub in_meander: bool,
    /// The ends (right, left) of the last stroke, while the strokes run on.
    tips: Option<[Point; 2]>,
}

impl Strokes {
    /// Before the first stroke of an MCL.
    pub(super) fn new() -> Strokes {
        Strokes {
            right_first: true,
            in_meander: false,
            tips: None,
        }
    }
}

/// One stroke of a [`meander`] across the band at `q` (the MCL's direction `dir`), `spacing`
/// from the last, if the band there is wider than the widest road: from the side
/// `state.right_first` names to the other, which the next stroke then starts from. Returns
/// whether the band is that wide (whether `q` belongs to a meander).
///
/// The strokes stand a road apart along the MCL; where they fan apart across a wide band (the
/// MCL curves away from that side), each end is as wide as the gap to the last stroke's end
/// on its side, up to [`max_width`](crate::Settings::max_width) and a road off the strip, and
/// the stroke tapers from it to `spacing` at the MCL, so the fan leaves no wedges bare.
#[allow(clippy::too_many_arguments)]
fn stroke(
    slice: &Slice,
    plan: &Plan,
    q: Point,
    dir: Point,
    spacing: f32,
    material: crate::Material,
    fan: &Fan<'_>,
    state: &mut Strokes,
    sink: &mut impl PathSink,
) -> Result<bool, Error> {
    let settings = slice.settings();
    let band = band_at(slice, plan, q, dir, fan);
    let Some((left_n, left, right)) = band.filter(|_| too_wide(slice, band)) else {
        state.tips = None;
        return Ok(false);
    };
    let ws = spacing.fmax(settings.min_width);
    // Room for the stroke off every keep-out curve's strip (each feature's own material's
    // place, where an arc may run): its edge a road off the feature.
    let room = settings.road_width + 0.5 * ws + 2.0 * EDGE_MARGIN;
    let side = |reach: f32, sign: f32| {
        // As far out as the band reaches, short of the strip along the stroke's line (a stroke
        // beside a wall or a hole runs on beside it): the line up to where it first comes
        // within `room` of a feature's edge keeps `room` from every feature, and crosses
        // none (it would meet the edge first). None where `q` itself is within `room`.
        let free = features_within(slice, q, left_n * sign, room);
        q + left_n * (sign * reach.fmin(free))
    };
    let tips = [
        side((0.5 * right - 0.5 * ws).fmax(0.0), -1.0),
        side((0.5 * left - 0.5 * ws).fmax(0.0), 1.0),
    ];
    // Each end as wide as the gap to the last stroke's end on its side, where the strokes fan
    // apart (across the MCL's direction), within reach of the strip; the wider end stops
    // short by its extra half width, so its round end keeps to the band.
    let along_mcl = dir * (1.0 / dir.norm());
    let tip_width = |k: usize| {
        let gap = state
            .tips
            .map_or(ws, |last| (last[k] - tips[k]).dot(along_mcl).abs());
        let cap = 2.0 * (fan.clearance(slice, tips[k]) - settings.road_width - 2.0 * EDGE_MARGIN);
        gap.fmin(settings.max_width).fmin(cap).fmax(ws)
    };
    let widths = [tip_width(0), tip_width(1)];
    let tips = [0, 1].map(|k| {
        let out = tips[k].dist(q);
        let back = (0.5 * (widths[k] - ws)).fmin(out);
        if out > 1e-6 {
            tips[k] + (q - tips[k]) * (back / out)
        } else {
            tips[k]
        }
    });
    let order = if state.right_first { [0, 1] } else { [1, 0] };
    let at = |k: usize| Vertex {
        at: tips[k],
        material,
        width: widths[k],
        deposit: true,
    };
    emit_move(slice, sink, at(order[0]))?;
    if tips[0].dist(q) > ws && tips[1].dist(q) > ws {
        // The MCL's point between the two tapers.
        emit_move(
            slice,
            sink,
            Vertex {
                at: q,
                material,
                width: ws,
                deposit: true,
            },
        )?;
    }
    emit_move(slice, sink, at(order[1]))?;
    state.right_first = !state.right_first;
    state.tips = Some(tips);
    Ok(true)
}

/// Where the road along MCL polyline `pts` passes vertex `j`, and its width there.
///
/// The road covers its share of the gaps to the nearest neighbouring road on either side
/// (distances `l` and `r` of its band): from half-way to the left one to half-way to
/// the right one. So it is `(l + r) / 2` wide and its centre lies `(r - l) / 4` toward the
/// wider gap; two neighbours then meet half-way between their MCLs where MCLs fan out or crowd
/// in, without gap or overlap. The width stays within the slice's
/// [`min_width`](crate::Settings::min_width) .. [`max_width`](crate::Settings::max_width) and
/// at most twice the point's clearance from the features, less [`EDGE_MARGIN`] each side (the
/// shift is left out where it would come nearer a feature than half the narrowest road); the
/// MCL's end vertices (`end`: on keep-out curves, where the arcs to the next MCL leave) stay
/// where they are and are at most a road width wide, so nothing spills. `band` is the band
/// the road owns at `p` ([`band_at`]).
pub(super) fn road_at(
    slice: &Slice,
    fan: &Fan<'_>,
    p: Point,
    end: bool,
    band: Option<Band>,
) -> (Point, f32) {
    let settings = slice.settings();
    let w = settings.road_width;
    let Some((left_n, left, right)) = band else {
        return (p, w);
    };
    let width = (0.5 * (left + right)).clamp(settings.min_width, settings.max_width);
    let cap = |q: Point| 2.0 * (fan.clearance(slice, q) - EDGE_MARGIN);
    if end {
        return (p, width.fmin(w - 2.0 * EDGE_MARGIN));
    }
    let shifted = p - left_n * (0.25 * (right - left)).clamp(-0.25 * width, 0.25 * width);
    // The shift toward the wider gap may bring the road nearer a feature than half the
    // narrowest road: then it stays on its MCL.
    let shifted_cap = cap(shifted);
    if shifted_cap >= settings.min_width {
        (shifted, width.fmin(shifted_cap))
    } else {
        (p, width.fmin(cap(p)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Feature, FeatureId, Planner, Settings};
    use std::boxed::Box;
    use std::vec::Vec as StdVec;

    /// A xorshift generator: the same slices on every run.
    struct Rng(u64);

    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.unit()
        }
    }

    /// A wobbly closed curve around `c`: radius `r (1 + a cos(k t + phase))`, stretched by `s`.
    fn blob(
        c: Point,
        r: f32,
        s: (f32, f32),
        a: f32,
        k: f32,
        phase: f32,
        n: usize,
    ) -> StdVec<Point> {
        (0..n)
            .map(|i| {
                let t = i as f32 / n as f32 * core::f32::consts::TAU;
                let rr = r * (1.0 + a * libm::cosf(k * t + phase));
                Point::new(
                    c.x + s.0 * rr * libm::cosf(t),
                    c.y + s.1 * rr * libm::sinf(t),
                )
            })
            .collect()
    }

    /// A random slice: an oval wall 10-16 mm across each way and up to 6 blob holes that keep
    /// a millimetre from the wall and from each other, roads 0.3-0.6 mm.
    fn random_slice(rng: &mut Rng) -> Option<Slice> {
        let (rx, ry) = (rng.range(10.0, 16.0), rng.range(10.0, 16.0));
        let wall = blob(
            Point::new(0.0, 0.0),
            1.0,
            (rx, ry),
            rng.range(0.0, 0.15),
            3.0,
            0.4,
            128,
        );
        let wall = Feature::new(FeatureId::Wall, &wall, [1.0, 0.0, 0.0, 0.0]).ok()?;
        let mut holes: StdVec<Feature> = StdVec::new();
        for k in 0..6 {
            let c = Point::new(rng.range(-0.7, 0.7) * rx, rng.range(-0.7, 0.7) * ry);
            let pts = blob(
                c,
                rng.range(1.0, 3.0),
                (1.0, 1.0),
                rng.range(0.0, 0.3),
                5.0,
                rng.unit() * 6.0,
                48,
            );
            let clear = pts.iter().all(|&p| wall.signed_distance(p) < -1.0)
                && holes
                    .iter()
                    .all(|o| pts.iter().all(|&p| o.signed_distance(p) > 1.0));
            if clear {
                let mut m = [0.0; 4];
                m[1 + k % 3] = 1.0;
                holes.push(Feature::new(FeatureId::Hole(holes.len() as u8), &pts, m).ok()?);
            }
        }
        if holes.is_empty() {
            return None;
        }
        Slice::new(wall, &holes, Settings::for_road_width(rng.range(0.3, 0.6))).ok()
    }

    /// Wherever the near disk answers a band query, it answers as the search over every
    /// feature and every MCL, to the bit, and a clearance as the slice does; and it answers
    /// most of them. Queries along every MCL (at its points and between them, both normals,
    /// clearances up to two roads across), in walking order as the zigzag asks.
    #[test]
    fn the_near_disk_answers_as_the_full_search() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let (mut slices, mut asked, mut answered) = (0, 0usize, 0usize);
        let mut cleared = (0usize, 0usize);
        let mut planner = Box::new(Planner::new());
        let (mut boxes, mut chunks) = (Box::new(FanBoxes::new()), Box::new(FanChunks::new()));
        while slices < 6 {
            let Some(slice) = random_slice(&mut rng) else {
                continue;
            };
            let Ok(plan) = planner.plan(&slice) else {
                continue;
            };
            slices += 1;
            let laid: StdVec<u16> = (0..plan.mcls.len() as u16).collect();
            fan_boxes(plan, &laid, &mut boxes, &mut chunks).unwrap();
            let near = RefCell::new(Near::new());
            let w = slice.settings().road_width;
            for (at, &k) in laid.iter().enumerate() {
                let fan = Fan {
                    me: k,
                    at: at as u16,
                    laid: &laid,
                    boxes: &boxes,
                    chunks: &chunks,
                    near: &near,
                };
                let pts = plan.points(&plan.mcls[k as usize]);
                for seg in pts.windows(2) {
                    let dir = seg[1] - seg[0];
                    let len = dir.norm();
                    if len < 1e-6 {
                        continue;
                    }
                    let left = Point::new(-dir.y / len, dir.x / len);
                    for p in [seg[0], seg[0].lerp(seg[1], 0.5)] {
                        let got = near.borrow_mut().reach_both(&slice, plan, p, left, &fan);
                        // The clearance across the MCL, where the road and its strokes ask.
                        for k in [-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0] {
                            let q = p + left * (k * w);
                            cleared.0 += 1;
                            if let Some(d) = near.borrow_mut().clearance(&slice, q) {
                                cleared.1 += 1;
                                assert_eq!(
                                    d.to_bits(),
                                    slice.clearance(q).to_bits(),
                                    "slice {slices}: clearance at {q:?}"
                                );
                            }
                        }
                        for (got, n) in got.into_iter().zip([left, left * -1.0]) {
                            let full = search(&slice, plan, p, n, &fan);
                            asked += 1;
                            if let Some(best) = got {
                                answered += 1;
                                assert_eq!(
                                    (2.0 * best).to_bits(),
                                    full.to_bits(),
                                    "slice {slices}, MCL {k} at {p:?} toward {n:?}: {} != {full}",
                                    2.0 * best
                                );
                            }
                        }
                    }
                }
            }
        }
        assert!(
            answered * 4 >= asked * 3,
            "the disk answered {answered} of {asked} queries"
        );
        assert!(
            cleared.1 * 5 >= cleared.0,
            "the disk answered {} of {} clearances",
            cleared.1,
            cleared.0
        );
    }
}
