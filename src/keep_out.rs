//! The keep-out curve of a feature: the curve half a road width off its boundary, on the side
//! of the printable region. A road centred on it puts its edge on the feature, not inside it.
//!
//! The curve is parametrised by arc length `s` along the feature's own polygon (so the
//! parameter of a hole's MCL start is the same on the hole and on its keep-out curve). Normals
//! are interpolated between vertices, so the curve is smooth where the polygon samples a smooth
//! outline; where the feature is concave the point is pulled back to exactly half a road
//! width.

use crate::geometry::{polygon, primitives, Point};
use crate::Feature;

/// Which side of the feature the printable region lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Outside the polygon (a hollow feature).
    Outside,
    /// Inside the polygon (the wall).
    Inside,
}

/// A feature's keep-out curve: a view of the feature (its arc lengths are the feature's,
/// its vertex normals computed where they are used), a few bytes, so a layer may hold one per
/// feature without 3 KiB of tables each (28 KiB of the zigzag's frame on a controller).
pub struct KeepOut<'a> {
    feature: &'a Feature,
    side: Side,
    /// Arc length of the polygon up to each vertex (the feature's).
    at_vertex: &'a [f32],
    length: f32,
    half: f32,
}

impl<'a> KeepOut<'a> {
    /// The curve `half` off `feature`, on `side`.
    pub fn new(feature: &'a Feature, half: f32, side: Side) -> KeepOut<'a> {
        KeepOut {
            feature,
            side,
            at_vertex: feature.arc_lengths(),
            length: polygon::perimeter(feature.points()),
            half,
        }
    }

    /// The unit normal at vertex `k` towards the region: the mean of its two edges' normals.
    fn vertex_normal(&self, k: usize) -> Point {
        let pts = self.feature.points();
        let n = pts.len();
        let sign = match self.side {
            Side::Outside => 1.0,
            Side::Inside => -1.0,
        };
        // Counter-clockwise: the outward normal of edge a->b is (dy, -dx).
        let edge_normal = |k: usize| {
            let d = pts[(k + 1) % n] - pts[k];
            Point::new(d.y, -d.x).normalized() * sign
        };
        (edge_normal((k + n - 1) % n) + edge_normal(k)).normalized()
    }

    /// Length of the parameter domain (the feature's perimeter).
    pub fn length(&self) -> f32 {
        self.length
    }

    /// `s` wrapped into `[0, length)`.
    pub fn wrap(&self, s: f32) -> f32 {
        primitives::wrap(s, self.length)
    }

    /// The feature's boundary point at `s` and the unit normal towards the region there.
    pub fn base(&self, s: f32) -> (Point, Point) {
        let pts = self.feature.points();
        let n = pts.len();
        let s = self.wrap(s);
        // The edge holding s: the last vertex at or before it.
        let k = match self.at_vertex[..n].binary_search_by(|x| x.total_cmp(&s)) {
            Ok(k) => k,
            Err(k) => k.saturating_sub(1),
        };
        let (a, b) = (pts[k], pts[(k + 1) % n]);
        let l = a.dist(b);
        let t = if l > 0.0 {
            ((s - self.at_vertex[k]) / l).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let nrm = self
            .vertex_normal(k)
            .lerp(self.vertex_normal((k + 1) % n), t)
            .normalized();
        (a.lerp(b, t), nrm)
    }

    /// The keep-out curve's point at `s`: offset along the interpolated normal, then pulled
    /// to exactly half a road width on the region's side where another edge is nearer (a
    /// concave stretch of a hole, a sharp corner of the wall).
    pub fn at(&self, s: f32) -> Point {
        let (q, normal) = self.base(s);
        let mut p = q + normal * self.half;
        for _ in 0..8 {
            let (clearance, away, near) = self.clearance(p);
            if clearance >= self.half - 1e-5 {
                return p;
            }
            p = near + away * self.half;
        }
        if self.clearance(p).0 >= self.half - 1e-5 {
            return p;
        }
        // Pulled to and fro between two edges of a sharp corner: go out along the normal
        // instead, as far as it takes for every edge to be half a road width away (the miter
        // point of the corner), found by doubling and bisection.
        let clear = |d: f32| self.clearance(q + normal * d).0 >= self.half - 1e-5;
        let (mut lo, mut hi) = (self.half, 2.0 * self.half);
        while !clear(hi) && hi < 64.0 * self.half {
            lo = hi;
            hi *= 2.0;
        }
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if clear(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        q + normal * hi
    }

    /// Distance from `p` to the feature on the region's side (positive in the region), the
    /// unit vector away from the feature into the region, and the nearest feature point.
    fn clearance(&self, p: Point) -> (f32, Point, Point) {
        let near = self.feature.nearest(p);
        match self.side {
            Side::Outside => (near.distance, near.gradient(p), near.point),
            Side::Inside => (-near.distance, -near.gradient(p), near.point),
        }
    }

    /// The parameter of the feature point nearest to `p`.
    pub fn param_of(&self, p: Point) -> f32 {
        let near = self.feature.nearest(p);
        let k = near.edge;
        self.at_vertex[k] + self.feature.points()[k].dist(near.point)
    }

    /// Calls `f` with the curve's points from `s0` to `s1` (inclusive), going forward
    /// (increasing `s`, counter-clockwise) or backward, through every vertex in between.
    pub fn arc(&self, s0: f32, s1: f32, forward: bool, mut f: impl FnMut(Point, f32)) {
        let n = self.feature.points().len();
        let span = if forward {
            self.wrap(s1 - s0)
        } else {
            self.wrap(s0 - s1)
        };
        f(self.at(s0), s0);
        let s0w = self.wrap(s0);
        // Vertices strictly inside the span, in travel order.
        for step in 0..n {
            let k = if forward {
                // First vertex after s0 going forward.
                let first = self.at_vertex[..n].partition_point(|&x| x <= s0w) % n;
                (first + step) % n
            } else {
                let first = (self.at_vertex[..n].partition_point(|&x| x < s0w) + n - 1) % n;
                (first + n - step) % n
            };
            let sv = self.at_vertex[k];
            let d = if forward {
                self.wrap(sv - s0w)
            } else {
                self.wrap(s0w - sv)
            };
            if d <= 1e-6 {
                continue;
            }
            if d >= span {
                break;
            }
            f(self.at(sv), sv);
        }
        if span > 1e-6 {
            f(self.at(s1), s1);
        }
    }
}
