//! The keep-out curve of a feature: the curve half a road width off its boundary, on the side
//! of the printable region. A road centred on it puts its edge on the feature, not inside it.
//!
//! The curve is parametrised by arc length `s` along the feature's own polygon (so the
//! parameter of a hole's MCL start is the same on the hole and on its keep-out curve). Normals
//! are interpolated between vertices, so the curve is smooth where the polygon samples a smooth
//! outline; where the feature is concave the point is pulled back to exactly half a road
//! width.

use heapless::Vec;

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
        self.at_from(self.base(s)).0
    }

    /// [`at`](Self::at) where the curve's point at `s` is reached from the feature's point
    /// there without crossing the feature; `None` on the side of a notch narrower than a
    /// road, where the point half a road off every edge along the normal lies beyond the
    /// notch's other side (past a neighbouring spike of a star, or inside it). The curve has
    /// no point of its own there: it crosses the notch's mouth.
    pub fn reachable(&self, s: f32) -> Option<Point> {
        let (q, normal) = self.base(s);
        let (p, offset) = self.at_from((q, normal));
        // From just off the feature's point (a segment from the point itself meets its own
        // edges). The plain offset needs no test: an edge it crossed would lie nearer its end
        // than the half road it is from `q`.
        let from = q + normal * (1e-3 * self.half);
        (offset || !self.feature.segment_meets(from, p)).then_some(p)
    }

    /// [`at`](Self::at) for the feature's point `q` and the normal `normal` there, and whether
    /// it is the plain offset `q + half normal` (every edge at least half a road from it).
    fn at_from(&self, (q, normal): (Point, Point)) -> (Point, bool) {
        let mut p = q + normal * self.half;
        for k in 0..8 {
            let (clearance, away, near) = self.clearance(p);
            if clearance >= self.half - 1e-5 {
                return (p, k == 0);
            }
            p = near + away * self.half;
        }
        if self.clearance(p).0 >= self.half - 1e-5 {
            return (p, false);
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
        (q + normal * hi, false)
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
    /// (increasing `s`, counter-clockwise) or backward, through every vertex in between whose
    /// point is [`reachable`](Self::reachable) (across the mouth of a notch narrower than a
    /// road, whose sides have none).
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
            if let Some(p) = self.reachable(sv) {
                f(p, sv);
            }
        }
        if span > 1e-6 {
            f(self.at(s1), s1);
        }
    }
}

/// How near, in road widths, an arc comes back to where it was, on average over the stretch in
/// between, for that stretch to be a fold ([`skip_folds`]). On 15 random slices that miss the
/// bar, the zigzag's overfill fell by 0.0023 on average at half a road, 0.0029 at one, 0.0027
/// at one and a half, coverage by less than 0.0001 (measured before a chord had to fit, which
/// only keeps some folds).
pub const FOLD_GAP: f32 = 1.0;

/// Drops the folds of a stretch of keep-out curve, given as its points and their arc lengths
/// from the first (the curve's parameter: along the feature's boundary), both ends kept:
/// stretches where the curve runs into a notch of its feature and back out along itself (a
/// star's notches, a slit), so that a road laid along it would cover the same ground twice (the
/// zigzag's arcs, `toolpath::zigzag::emit`: on some random slices a star hole's whole strip;
/// the detours round features, `toolpath::detour`, walk the curve without it). A stretch from point `i` to point `j` is a fold
/// where `j` comes back within [`FOLD_GAP`] road widths of `i`, the stretch is longer than a
/// road, and twice the area it encloses (with the chord back) over its length is under
/// [`FOLD_GAP`] road widths too: the way in and the way out lie that close on average. The
/// printable ground inside such a notch is at most a road across, between the way in and the
/// way out; the chord across the mouth leaves it to the roads beside the mouth, which costs
/// less than laying the notch twice. A loop round a whole feature encloses the feature and
/// stays, and so does a stretch whose chord does not `fit` (it would cut a spike of the feature).
/// From each point kept, the longest such stretch goes.
pub fn skip_folds<const N: usize>(
    points: &mut Vec<(Point, f32), N>,
    w: f32,
    fits: impl Fn(Point, Point) -> bool,
) {
    let n = points.len();
    if n < 4 {
        return;
    }
    let gap = FOLD_GAP * w;
    let mut kept = 0;
    let mut i = 0;
    while i < n {
        points[kept] = points[i];
        kept += 1;
        let (p, s) = points[i];
        // Twice the area between the points from `i` to `j` and the chord back to `i`,
        // summed as `j` moves on.
        let mut twice_area = 0.0f32;
        let mut next = i + 1;
        for j in i + 2..n {
            twice_area += (points[j - 1].0 - p).cross(points[j].0 - p);
            let (q, t) = points[j];
            let length = t - s;
            if length > w
                && q.dist(p) <= gap
                && libm::fabsf(twice_area) <= gap * length
                && fits(p, q)
            {
                next = j;
            }
        }
        i = next;
    }
    points.truncate(kept);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Arc points at `pts`, arc lengths summed along them.
    fn arc(pts: &[(f32, f32)]) -> Vec<(Point, f32), 64> {
        let mut out: Vec<(Point, f32), 64> = Vec::new();
        let mut s = 0.0;
        for (k, &(x, y)) in pts.iter().enumerate() {
            let p = Point::new(x, y);
            if k > 0 {
                s += out[k - 1].0.dist(p);
            }
            out.push((p, s)).unwrap();
        }
        out
    }

    #[test]
    fn a_fold_into_a_notch_is_skipped_and_a_loop_round_a_feature_kept() {
        let w = 0.4;
        // Along, into a notch 0.1 mm wide and 2 mm deep, back out, and on.
        let mut folded = arc(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 1.0),
            (1.0, 2.0),
            (1.1, 2.0),
            (1.1, 1.0),
            (1.1, 0.0),
            (2.0, 0.0),
        ]);
        skip_folds(&mut folded, w, |_, _| true);
        let kept: std::vec::Vec<_> = folded.iter().map(|&(p, _)| (p.x, p.y)).collect();
        assert_eq!(kept, [(0.0, 0.0), (1.0, 0.0), (1.1, 0.0), (2.0, 0.0)]);
        // Round a square of 2 mm, back to within 0.1 mm of the start: it encloses the square.
        let pts = [
            (0.0, 0.0),
            (0.0, -1.0),
            (2.0, -1.0),
            (2.0, 1.0),
            (0.0, 1.0),
            (0.0, 0.1),
            (-1.0, 0.1),
        ];
        let mut round = arc(&pts);
        skip_folds(&mut round, w, |_, _| true);
        assert_eq!(round.len(), pts.len());
        // A notch two roads wide stays: the arc fills it.
        let mut wide = arc(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 2.0),
            (1.8, 2.0),
            (1.8, 0.0),
            (3.0, 0.0),
        ]);
        skip_folds(&mut wide, w, |_, _| true);
        assert_eq!(wide.len(), 6);
        // A fold whose chord does not fit (it would cut a spike of the feature) stays.
        let mut kept = arc(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 2.0),
            (1.1, 2.0),
            (1.1, 0.0),
            (2.0, 0.0),
        ]);
        skip_folds(&mut kept, w, |_, _| false);
        assert_eq!(kept.len(), 6);
    }

    #[test]
    fn a_notch_narrower_than_a_road_has_no_curve_points_on_its_sides() {
        use crate::FeatureId;
        // A 4 mm square hole with a slit 0.2 mm wide and 2 mm deep from its top; roads 0.4 mm.
        let pts = [
            (0.0, 0.0),
            (4.0, 0.0),
            (4.0, 4.0),
            (2.1, 4.0),
            (2.1, 2.0),
            (1.9, 2.0),
            (1.9, 4.0),
            (0.0, 4.0),
        ]
        .map(|(x, y)| Point::new(x, y));
        let hole = Feature::new(FeatureId::Hole(0), &pts, [0.0, 1.0, 0.0, 0.0]).unwrap();
        let curve = KeepOut::new(&hole, 0.2, Side::Outside);
        let s_of = |k: usize| hole.arc_lengths()[k];
        // The slit's bottom corners' normals point across it, into the hole beyond: no point
        // of the curve is reached from them. The mouth's corners have theirs.
        assert!(curve.reachable(s_of(4)).is_none());
        assert!(curve.reachable(s_of(5)).is_none());
        assert!(curve.reachable(s_of(3)).is_some() && curve.reachable(s_of(6)).is_some());
        // Along the top, across the slit: every point given is half a road off the hole and
        // above the slit, and no chord between two crosses the hole.
        let (s0, s1) = (s_of(2) + 0.5, s_of(6) + 0.5);
        let mut got: std::vec::Vec<Point> = std::vec::Vec::new();
        curve.arc(s0, s1, true, |p, _| got.push(p));
        assert!(got.len() >= 4, "{got:?}");
        assert!(got.iter().all(|p| p.y >= 4.0 - 1e-3), "{got:?}");
        assert!(
            got.iter()
                .all(|&p| (hole.signed_distance(p) - 0.2).abs() < 1e-3),
            "{got:?}"
        );
        assert!(
            got.windows(2).all(|w| !hole.segment_meets(w[0], w[1])),
            "{got:?}"
        );
        // Counter-clockwise along the top is right to left, and so is every step but a
        // hair's across the cusp over the slit's mouth (its corners' points, each pulled half a
        // road off the other corner): the bottom corners' points along their normals lay 2 mm
        // either side, beyond the hole's top.
        assert!(got.windows(2).all(|w| w[1].x < w[0].x + 0.05), "{got:?}");
    }
}
