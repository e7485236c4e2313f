//! Closed polygons given as point slices (the closing edge implied).

pub use super::primitives::{bbox, orient, segments_cross, segments_meet};
use super::primitives::{closest_on_segment, fmax, fmin};
use super::Point;

/// Twice the signed area: positive for counter-clockwise.
pub fn double_area(pts: &[Point]) -> f32 {
    let n = pts.len();
    let Some(&o) = pts.first() else {
        return 0.0;
    };
    // Relative to the first vertex: the products of coordinates far from the origin (a
    // small square at (900, 900) mm) would round away the area itself.
    let mut a = 0.0;
    for i in 1..n.saturating_sub(1) {
        a += (pts[i] - o).cross(pts[i + 1] - o);
    }
    a
}

/// Length of the closed boundary.
pub fn perimeter(pts: &[Point]) -> f32 {
    let n = pts.len();
    (0..n).map(|i| pts[i].dist(pts[(i + 1) % n])).sum()
}

/// Where edge `ab` crosses the horizontal line at `y`, if one end lies above it and the other
/// not: the one crossing formula of every even-odd test ([`contains`],
/// `Feature::contains`, `Feature::row_crossings`), so that they agree to the bit.
#[inline]
pub fn row_crossing(a: Point, b: Point, y: f32) -> Option<f32> {
    ((a.y > y) != (b.y > y)).then(|| a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x))
}

/// Even-odd point-in-polygon test.
///
/// ```
/// use hollowpath::geometry::{polygon, Point};
/// let sq = [Point::new(0.0, 0.0), Point::new(1.0, 0.0), Point::new(1.0, 1.0), Point::new(0.0, 1.0)];
/// assert!(polygon::contains(&sq, Point::new(0.5, 0.5)));
/// assert!(!polygon::contains(&sq, Point::new(1.5, 0.5)));
/// ```
pub fn contains(pts: &[Point], p: Point) -> bool {
    let n = pts.len();
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        if let Some(x) = row_crossing(pts[i], pts[j], p.y) {
            if p.x < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// The closest point of the boundary to `p`: (point, distance, edge index).
pub fn closest(pts: &[Point], p: Point) -> (Point, f32, usize) {
    let n = pts.len();
    let mut best = (pts[0], f32::INFINITY, 0);
    let mut best_d2 = f32::INFINITY;
    for i in 0..n {
        let (c, _) = closest_on_segment(pts[i], pts[(i + 1) % n], p);
        let d2 = (c - p).norm2();
        if d2 < best_d2 {
            best_d2 = d2;
            best = (c, 0.0, i);
        }
    }
    best.1 = hollowpath_fpu::sqrtf(best_d2);
    best
}

/// The first pair of non-adjacent edges that meet, if any.
pub fn self_intersection(pts: &[Point]) -> Option<(usize, usize)> {
    let n = pts.len();
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        for j in (i + 1)..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            let (c, d) = (pts[j], pts[(j + 1) % n]);
            if adjacent {
                // Adjacent edges share one vertex; they only intersect if they fold back.
                let shared = if j == i + 1 { b } else { a };
                let (o1, o2) = if j == i + 1 { (a, d) } else { (b, c) };
                if orient(o1, shared, o2) == 0.0 && (o1 - shared).dot(o2 - shared) > 0.0 {
                    return Some((i, j));
                }
                continue;
            }
            if segments_meet(a, b, c, d) {
                return Some((i, j));
            }
        }
    }
    None
}

/// Whether the closed polygon `pts` (no two of its edges meeting but neighbours at their
/// shared vertex) nearly touches itself: two edges that are not neighbours within `tol` of
/// each other, or two neighbours folding back on each other at less than [`PINCH_ANGLE`].
/// Where a boundary comes that close to itself, the edge nearest a point can be a near tie
/// between its two sides (`Feature::nearest` then tells inside from outside by the crossing
/// test alone).
pub fn pinched(pts: &[Point], tol: f32) -> bool {
    let n = pts.len();
    let (sin_min, tol2) = (libm::sinf(PINCH_ANGLE), tol * tol);
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        // The fold at vertex `i + 1` between edge `i` and the next.
        let c = pts[(i + 2) % n];
        let (u, v) = (a - b, c - b);
        if u.dot(v) > 0.0 && libm::fabsf(u.cross(v)) < sin_min * u.norm() * v.norm() {
            return true;
        }
        let (lo, hi) = (
            Point::new(fmin(a.x, b.x) - tol, fmin(a.y, b.y) - tol),
            Point::new(fmax(a.x, b.x) + tol, fmax(a.y, b.y) + tol),
        );
        for j in (i + 2)..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            let (c, d) = (pts[j], pts[(j + 1) % n]);
            if (c.x < lo.x && d.x < lo.x)
                || (c.x > hi.x && d.x > hi.x)
                || (c.y < lo.y && d.y < lo.y)
                || (c.y > hi.y && d.y > hi.y)
            {
                continue;
            }
            // Edges that do not meet are nearest at an end of one of them.
            let near = |p: Point, a: Point, b: Point| (closest_on_segment(a, b, p).0 - p).norm2();
            if near(c, a, b) < tol2
                || near(d, a, b) < tol2
                || near(a, c, d) < tol2
                || near(b, c, d) < tol2
            {
                return true;
            }
        }
    }
    false
}

/// The sharpest fold between neighbouring edges [`pinched`] lets pass, radians (14 degrees):
/// sharper, a point's distances to the two edges can tie within rounding while their sides
/// differ.
pub const PINCH_ANGLE: f32 = 0.25;

/// The first pair of edges (one of each polygon) that meet, if any.
pub fn boundaries_meet(p: &[Point], q: &[Point]) -> Option<(usize, usize)> {
    let (pb, qb) = (bbox(p), bbox(q));
    if pb.0.x > qb.1.x || qb.0.x > pb.1.x || pb.0.y > qb.1.y || qb.0.y > pb.1.y {
        return None;
    }
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        for j in 0..q.len() {
            if segments_meet(a, b, q[j], q[(j + 1) % q.len()]) {
                return Some((i, j));
            }
        }
    }
    None
}

/// Distance from `p` to a box, 0 inside: a lower bound of the distance to what the box holds.
pub fn bbox_distance(b: (Point, Point), p: Point) -> f32 {
    hollowpath_fpu::sqrtf(bbox_distance2(b, p))
}

/// The square of [`bbox_distance`], without its square root (a software routine on the
/// Cortex-M4F's libm, dozens of instructions): for comparing with squared distances.
///
/// It runs for every chunk of every feature on every distance query, so its maxima are plain
/// comparisons (one compare and one select each on the Cortex-M4F), not [`fmax`]'s NaN-aware
/// ones: the square is the same. They differ only where `fmax` would pass over a NaN or pick
/// `-0.0` over `0.0`; a NaN `p` gives both NaN differences, which either maximum passes on and
/// the comparison with zero turns into 0 as `fmax` does, and a signed zero squares to `0.0`.
#[inline]
pub fn bbox_distance2(b: (Point, Point), p: Point) -> f32 {
    let larger = |a: f32, b: f32| if a > b { a } else { b };
    let dx = larger(larger(b.0.x - p.x, p.x - b.1.x), 0.0);
    let dy = larger(larger(b.0.y - p.y, p.y - b.1.y), 0.0);
    dx * dx + dy * dy
}

/// How far rounding may move a distance measured from `p` to a segment in box `(lo, hi)`, or
/// to the box itself, in `f32`: 1e-5 of the largest coordinate involved (plus 1e-5 mm). Each
/// rounding moves a value by at most 6e-8 of it and such a distance is a few roundings deep,
/// so this is generous. A search that skips a box only when it is farther than its best by
/// this much skips nothing that could have won or tied: it answers as the search over all.
pub fn rounding_slack(p: Point, (lo, hi): (Point, Point)) -> f32 {
    let size = |q: Point| fmax(q.x.abs(), q.y.abs());
    1e-5 * (1.0 + size(p) + fmax(size(lo), size(hi)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_area_of_a_small_square_far_from_the_origin_is_its_own() {
        // 0.2 mm square at (900, 900) mm: the products of absolute coordinates (8.1e5, an
        // ulp of 0.06) rounded its area (0.04 mm^2) to nothing, and the slice was refused as
        // enclosing none.
        for (x, y) in [(0.0f32, 0.0f32), (900.0, 900.0), (-950.0, 400.0)] {
            let sq = [
                Point::new(x, y),
                Point::new(x + 0.2, y),
                Point::new(x + 0.2, y + 0.2),
                Point::new(x, y + 0.2),
            ];
            let a = 0.5 * double_area(&sq);
            assert!((a - 0.04).abs() < 4e-4, "at ({x}, {y}): {a}");
            let mut cw = sq;
            cw.reverse();
            assert!((0.5 * double_area(&cw) + 0.04).abs() < 4e-4);
        }
        assert_eq!(double_area(&[]), 0.0);
    }
}
