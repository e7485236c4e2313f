//! The primitives polygons and polylines share: segments (orientation, meeting, crossing,
//! the closest point) and the bounding box of a point set. Both `polygon` and `polyline` are
//! built on this module, and neither on the other.

use super::Point;

/// The smaller of `a` and `b`, the other where one is NaN: `f32::min`'s answer (the same bits
/// as the `fminf` it calls on the Cortex-M4F, ties to `b`) by comparisons inline. The M4F's
/// FPU has no `VMINNM`, so `f32::min` there is a call to a routine of a dozen instructions;
/// box tests make millions of them.
#[inline(always)]
pub fn fmin(a: f32, b: f32) -> f32 {
    if a < b || b.is_nan() {
        a
    } else {
        b
    }
}

/// The larger of `a` and `b`, the other where one is NaN: `f32::max`'s answer (the same bits
/// as the Cortex-M4F's `fmaxf`, ties to `a`) by comparisons inline; see [`fmin`].
#[inline(always)]
pub fn fmax(a: f32, b: f32) -> f32 {
    if a < b || a.is_nan() {
        b
    } else {
        a
    }
}

/// `x` wrapped into `[0, len)` on a closed curve of length `len` (the keep-out curves, the
/// offset spiral's loops): `fmod` less than zero moved up by `len`. `fmod` is exact, and so
/// are the two shortcuts taken before the (software, bit-by-bit) `fmodf` routine: `x` itself
/// within one length of zero, `x - len` within two lengths (exact by Sterbenz's lemma).
#[inline]
pub fn wrap(x: f32, len: f32) -> f32 {
    let r = if x > -len && x < len {
        x
    } else if x >= len && x < 2.0 * len {
        x - len
    } else {
        libm::fmodf(x, len)
    };
    if r < 0.0 {
        r + len
    } else {
        r
    }
}

/// [`fmin`] and [`fmax`] as methods, for the core's `f32` arithmetic in place of `f32::min`
/// and `f32::max` (calls on the Cortex-M4F; the same answers).
pub trait MinMax {
    /// [`fmin`].
    fn fmin(self, other: Self) -> Self;
    /// [`fmax`].
    fn fmax(self, other: Self) -> Self;
}

impl MinMax for f32 {
    #[inline(always)]
    fn fmin(self, other: f32) -> f32 {
        fmin(self, other)
    }
    #[inline(always)]
    fn fmax(self, other: f32) -> f32 {
        fmax(self, other)
    }
}

/// The closest point of segment `ab` to `p`, and its parameter in [0, 1].
pub fn closest_on_segment(a: Point, b: Point, p: Point) -> (Point, f32) {
    let ab = b - a;
    let l2 = ab.norm2();
    if l2 <= 0.0 {
        return (a, 0.0);
    }
    let t = ((p - a).dot(ab) / l2).clamp(0.0, 1.0);
    (a + ab * t, t)
}

/// Orientation of `c` relative to the line `a -> b`: >0 left, <0 right.
pub fn orient(a: Point, b: Point, c: Point) -> f32 {
    (b - a).cross(c - a)
}

/// Whether the closed segments `ab` and `cd` share a point (crossing or touching).
pub fn segments_meet(a: Point, b: Point, c: Point, d: Point) -> bool {
    let d1 = orient(c, d, a);
    let d2 = orient(c, d, b);
    let d3 = orient(a, b, c);
    let d4 = orient(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |p: Point, q: Point, r: Point, o: f32| {
        o == 0.0
            && r.x >= fmin(p.x, q.x)
            && r.x <= fmax(p.x, q.x)
            && r.y >= fmin(p.y, q.y)
            && r.y <= fmax(p.y, q.y)
    };
    on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4)
}

/// Whether the open segments `ab` and `cd` cross properly (each strictly separates the other's
/// ends).
pub fn segments_cross(a: Point, b: Point, c: Point, d: Point) -> bool {
    let d1 = orient(c, d, a);
    let d2 = orient(c, d, b);
    let d3 = orient(a, b, c);
    let d4 = orient(a, b, d);
    ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
}

/// Bounding box (min, max).
pub fn bbox(pts: &[Point]) -> (Point, Point) {
    let mut lo = Point::new(f32::INFINITY, f32::INFINITY);
    let mut hi = Point::new(f32::NEG_INFINITY, f32::NEG_INFINITY);
    for p in pts {
        lo.x = fmin(lo.x, p.x);
        lo.y = fmin(lo.y, p.y);
        hi.x = fmax(hi.x, p.x);
        hi.y = fmax(hi.y, p.y);
    }
    (lo, hi)
}

/// The box around boxes `a` and `b` (exact: the least and greatest coordinates).
pub fn union(a: (Point, Point), b: (Point, Point)) -> (Point, Point) {
    (
        Point::new(fmin(a.0.x, b.0.x), fmin(a.0.y, b.0.y)),
        Point::new(fmax(a.1.x, b.1.x), fmax(a.1.y, b.1.y)),
    )
}

/// The box around `boxes` (as [`bbox`] of no points where there are none).
pub fn union_all(boxes: &[(Point, Point)]) -> (Point, Point) {
    boxes.iter().fold(bbox(&[]), |acc, &b| union(acc, b))
}

/// Finds where `f` changes sign between `p` (`f(p) > 0`) and `q` (`f(q) <= 0`), by 24
/// halvings of the segment (a 0.1 mm grid edge to 6 nm, finer than an `f32` coordinate of a
/// few mm tells apart): a bisector's or a cell boundary's crossing, a level of the distance.
///
/// Once the interval is narrower than the coordinates can tell apart, a midpoint rounds to a
/// point already measured (the last one found on either side): its side is known and `f` is
/// not called again (it would answer the same for the same bits). The answer is the plain
/// 24 halvings'.
pub(crate) fn bisect(p: Point, q: Point, mut f: impl FnMut(Point) -> f32) -> Point {
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    // The last points measured on the positive side and on the other.
    let (mut above, mut below): (Option<Point>, Option<Point>) = (None, None);
    let same = |a: Option<Point>, x: Point| {
        a.is_some_and(|a| a.x.to_bits() == x.x.to_bits() && a.y.to_bits() == x.y.to_bits())
    };
    for _ in 0..24 {
        let mid = 0.5 * (lo + hi);
        let x = p.lerp(q, mid);
        let known = if same(above, x) {
            Some(true)
        } else if same(below, x) {
            Some(false)
        } else {
            None
        };
        let positive = known.unwrap_or_else(|| f(x) > 0.0);
        if positive {
            lo = mid;
            above = Some(x);
        } else {
            hi = mid;
            below = Some(x);
        }
    }
    p.lerp(q, 0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain 24 halvings, measuring every midpoint.
    fn plain(p: Point, q: Point, f: impl Fn(Point) -> f32) -> Point {
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if f(p.lerp(q, mid)) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        p.lerp(q, 0.5 * (lo + hi))
    }

    #[test]
    fn bisection_answers_as_the_plain_halvings_and_measures_fewer_points_on_a_short_edge() {
        // Short edges far from the origin (a few ulps to a grid step long) and long ones; a
        // circle's distance crossing a level somewhere along each.
        let mut fewer = 0;
        for k in 0..400u32 {
            let x = 50.0 + k as f32 * 0.37;
            let len = [1e-5, 1e-3, 0.1, 2.0][k as usize % 4];
            let (p, q) = (Point::new(x, 1.0), Point::new(x + len, 1.0 + 0.5 * len));
            let level = p.norm() + (k % 7) as f32 / 7.0 * (q.norm() - p.norm());
            let f = |x: Point| level - x.norm();
            let calls = core::cell::Cell::new(0);
            let counted = |x: Point| {
                calls.set(calls.get() + 1);
                f(x)
            };
            let got = bisect(p, q, counted);
            let want = plain(p, q, f);
            assert_eq!(
                (got.x.to_bits(), got.y.to_bits()),
                (want.x.to_bits(), want.y.to_bits())
            );
            assert!(calls.get() <= 24);
            if calls.get() < 24 {
                fewer += 1;
            }
        }
        // Every edge up to 1e-3 mm long at x >= 50 is resolved before the 24th halving.
        assert!(
            fewer >= 200,
            "{fewer} of 400 bisections measured fewer points"
        );
    }
}
