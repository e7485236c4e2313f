//! The geometry of the zigzag's band queries ([`reach`](super::band::reach)): how far a ray
//! runs before it comes near a segment ([`within`], over every feature: [`features_within`])
//! and how far a ball grows along it before it touches one ([`ball`]), each behind a cheap
//! test of the segment's ends ([`products`], [`meet_with`], [`touch_with`]) that rules most
//! segments out.

use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, primitives, Point};
use crate::Slice;

/// How far a ball may grow from `p` along the unit normal `n` before it touches segment
/// `a`-`b` less `off`: the least `t >= 0` at which `p + t n` is no nearer `p` than the
/// segment's `off`-neighbourhood (`dist(p + t n, ab) <= t + off`), infinite if never. The
/// distance from a point moving along a line to a segment is convex in `t`, so the first
/// such `t` is the least root among the segment's pieces (its two ends and its interior).
pub(super) fn ball(p: Point, n: Point, a: Point, b: Point, off: f32) -> f32 {
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
pub(super) fn within(p: Point, n: Point, a: Point, b: Point, off: f32) -> f32 {
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

/// The features' edges a ray from `p` may meet, each with the least `t` at
/// which the ray comes within `off` of it ([`within`]): the least over all features.
pub(super) fn features_within(slice: &Slice, p: Point, n: Point, off: f32) -> f32 {
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
pub(super) fn meet(p: Point, n: Point, seg: [Point; 2], off: f32, best: &mut f32) {
    let (h, g) = products(p, n, seg);
    meet_with(p, n, seg, off, (h, g), best);
}

/// Where the ends of `seg` lie from `p` across and along the unit vector `n`: `(h, g)`, each
/// a pair (the first end's, the second's). Along `-n` they are the same negated, to the bit
/// (up to the sign of a zero, which no comparison sees).
#[inline(always)]
pub(super) fn products(p: Point, n: Point, seg: [Point; 2]) -> ((f32, f32), (f32, f32)) {
    let (da, db) = (seg[0] - p, seg[1] - p);
    ((n.cross(da), n.cross(db)), (n.dot(da), n.dot(db)))
}

/// [`meet`] with the ends' [`products`] given.
#[inline(always)]
pub(super) fn meet_with(
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
pub(super) fn box_clear_of_strip(
    p: Point,
    n: Point,
    (lo, hi): (Point, Point),
    off: f32,
    best: f32,
) -> bool {
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

/// One segment of [`reach`](super::band::reach)'s search: lowers `best` to the radius of the
/// first ball along `p + t n` that touches segment `seg` of an MCL laid (`own`: of the MCL the
/// road runs along, whose segments next to `p` do not count).
#[inline(always)]
pub(super) fn touch(p: Point, n: Point, seg: [Point; 2], own: bool, w: f32, best: &mut f32) {
    let (h, g) = products(p, n, seg);
    touch_with(p, n, seg, own, w, (h, g), best);
}

/// [`touch`] with the ends' [`products`] given.
#[inline(always)]
pub(super) fn touch_with(
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
pub(super) fn negated(((ha, hb), (ga, gb)): ((f32, f32), (f32, f32))) -> ((f32, f32), (f32, f32)) {
    ((-ha, -hb), (-ga, -gb))
}
