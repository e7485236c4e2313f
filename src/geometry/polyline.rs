//! Open polylines given as point slices.

use super::primitives::{bbox, closest_on_segment, fmax, fmin, orient, segments_meet};
use super::Point;

/// Length of an open polyline.
pub fn length(pts: &[Point]) -> f32 {
    pts.windows(2).map(|w| w[0].dist(w[1])).sum()
}

/// The arc length at every point of `pts` from the first, into `cum` (as far as both reach):
/// summed segment by segment, the arithmetic [`point_along`]'s callers share.
pub fn cumulative(pts: &[Point], cum: &mut [f32]) {
    let n = pts.len().min(cum.len());
    if n == 0 {
        return;
    }
    cum[0] = 0.0;
    for j in 1..n {
        cum[j] = cum[j - 1] + pts[j - 1].dist(pts[j]);
    }
}

/// The point at arc length `s` (clamped to the ends).
pub fn point_at(pts: &[Point], s: f32) -> Point {
    let mut acc = 0.0;
    for w in pts.windows(2) {
        let l = w[0].dist(w[1]);
        if acc + l >= s && l > 0.0 {
            return w[0].lerp(w[1], ((s - acc) / l).clamp(0.0, 1.0));
        }
        acc += l;
    }
    *pts.last().unwrap_or(&Point::default())
}

/// [`point_at`] with the arc length at every point known (`cum`, as long as `pts`), found by
/// a binary search, and the direction of the segment it lies on (zero on a polyline of one
/// point).
pub fn point_along(pts: &[Point], cum: &[f32], s: f32) -> (Point, Point) {
    let n = pts.len().min(cum.len());
    if n < 2 {
        return (pts.first().copied().unwrap_or_default(), Point::default());
    }
    // The segment `i .. i + 1` holding `s` (the first or the last beyond the ends).
    let i = cum[..n].partition_point(|&c| c <= s).clamp(1, n - 1) - 1;
    let seg = cum[i + 1] - cum[i];
    let t = if seg > 1e-9 {
        ((s - cum[i]) / seg).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (pts[i].lerp(pts[i + 1], t), pts[i + 1] - pts[i])
}

/// Projection of `p`: (arc length of the closest point, the point, its distance).
pub fn project(pts: &[Point], p: Point) -> (f32, Point, f32) {
    project_points(pts.iter().copied(), p).0
}

/// [`project`] of the polyline whose points `pts` yields (at least one), without a slice of
/// them, and the polyline's [`length`]: the same arithmetic in the same order, so the same
/// bits.
pub fn project_points(mut pts: impl Iterator<Item = Point>, p: Point) -> ((f32, Point, f32), f32) {
    let Some(first) = pts.next() else {
        return ((0.0, p, f32::INFINITY), 0.0);
    };
    let mut best = (0.0, first, f32::INFINITY);
    let (mut acc, mut prev, mut single) = (0.0, first, true);
    for q in pts {
        let (c, t) = closest_on_segment(prev, q, p);
        let d = c.dist(p);
        let l = prev.dist(q);
        if d < best.2 {
            best = (acc + t * l, c, d);
        }
        acc += l;
        prev = q;
        single = false;
    }
    if single {
        best.2 = first.dist(p);
    }
    (best, acc)
}

/// Unit tangent at arc length `s`.
pub fn tangent_at(pts: &[Point], s: f32) -> Point {
    let mut acc = 0.0;
    let n = pts.len();
    for (i, w) in pts.windows(2).enumerate() {
        let l = w[0].dist(w[1]);
        if acc + l >= s || i + 2 == n {
            return (w[1] - w[0]).normalized();
        }
        acc += l;
    }
    Point::default()
}

/// Simplify `pts` into `out` so that no dropped point is farther than `tol` from the kept
/// chord. The ends are always kept. Returns the point that did not fit when `out` fills up.
pub fn simplify<const N: usize>(
    pts: &[Point],
    tol: f32,
    out: &mut heapless::Vec<Point, N>,
) -> Result<(), Point> {
    out.clear();
    if pts.is_empty() {
        return Ok(());
    }
    out.push(pts[0])?;
    let mut anchor = 0;
    let mut k = 2;
    while k < pts.len() {
        let (a, b) = (pts[anchor], pts[k]);
        let too_far = pts[anchor + 1..k]
            .iter()
            .any(|&q| closest_on_segment(a, b, q).0.dist(q) > tol);
        if too_far {
            out.push(pts[k - 1])?;
            anchor = k - 1;
        }
        k += 1;
    }
    if pts.len() > 1 {
        out.push(pts[pts.len() - 1])?;
    }
    Ok(())
}

/// Whether two polylines meet anywhere but at a vertex they share exactly: proper crossings,
/// a vertex of one lying on a segment of the other (a T or a crossing through a vertex) and
/// overlapping collinear segments all count; two segments that only touch at an end point they
/// both have (a matched pair's `p*`) do not.
///
/// ```
/// use hollowpath::geometry::{polyline::polylines_cross, Point};
/// let p = |x, y| Point::new(x, y);
/// assert!(polylines_cross(&[p(0.0, 0.0), p(2.0, 0.0)], &[p(1.0, -1.0), p(1.0, 1.0)]));
/// assert!(polylines_cross(&[p(0.0, 0.0), p(2.0, 0.0)], &[p(1.0, 0.0), p(1.0, 1.0)])); // a T
/// assert!(!polylines_cross(&[p(0.0, 0.0), p(1.0, 0.0)], &[p(1.0, 0.0), p(1.0, 1.0)])); // shared end
/// ```
pub fn polylines_cross(p: &[Point], q: &[Point]) -> bool {
    polylines_cross_boxed(p, bbox(p), q, bbox(q))
}

/// [`polylines_cross`] for a caller that holds both polylines' bounding boxes (`pb` must be
/// `bbox(p)` and `qb` `bbox(q)`): a search testing one polyline against many keeps them
/// instead of measuring each again per pair.
pub fn polylines_cross_boxed(
    p: &[Point],
    pb: (Point, Point),
    q: &[Point],
    qb: (Point, Point),
) -> bool {
    // A segment of `p` clear of `q`'s box meets none of `q`'s segments (each is in that box):
    // one box test instead of one per segment of `q`. Likewise only the run of `q`'s segments
    // from the first to the last that meets `p`'s box can meet a segment of `p`.
    let meets_p = |b: &[Point]| boxes_overlap(bbox(b), pb, 0.0);
    let (Some(first), Some(last)) = (
        q.windows(2).position(meets_p),
        q.windows(2).rposition(meets_p),
    ) else {
        return false;
    };
    // Segments `first ..= last` are points `first ..= last + 1`.
    let q = &q[first..last + 2];
    for a in p.windows(2) {
        let (alo, ahi) = segment_box(a[0], a[1]);
        if !boxes_overlap((alo, ahi), qb, 0.0) {
            continue;
        }
        for b in q.windows(2) {
            // Boxes apart: the segments cannot meet.
            if fmax(b[0].x, b[1].x) < alo.x
                || fmin(b[0].x, b[1].x) > ahi.x
                || fmax(b[0].y, b[1].y) < alo.y
                || fmin(b[0].y, b[1].y) > ahi.y
            {
                continue;
            }
            if segments_meet(a[0], a[1], b[0], b[1]) && !only_shared_end(a[0], a[1], b[0], b[1]) {
                return true;
            }
        }
    }
    false
}

/// The box of each segment of `p`, in order, into `out` (emptied first); `None` if `out`
/// cannot hold them all.
pub fn segment_boxes<'a>(
    p: &[Point],
    out: &'a mut [(Point, Point)],
) -> Option<&'a [(Point, Point)]> {
    let n = p.len().saturating_sub(1);
    let out = out.get_mut(..n)?;
    for (b, w) in out.iter_mut().zip(p.windows(2)) {
        *b = segment_box(w[0], w[1]);
    }
    Some(out)
}

/// [`polylines_cross_boxed`] for a caller that tests one polyline `p` against many and holds
/// the box of each of its segments (`p_boxes`, from [`segment_boxes`]): the same answer, with
/// each segment of `q` boxed once and compared with the boxes held, instead of each pair's
/// boxes measured again.
pub fn polylines_cross_segment_boxed(
    p: &[Point],
    p_boxes: &[(Point, Point)],
    pb: (Point, Point),
    q: &[Point],
    qb: (Point, Point),
) -> bool {
    // Only the run of `p`'s segments from the first to the last that meets `q`'s box can meet
    // a segment of `q` (each lies in that box).
    let meets_q = |b: &(Point, Point)| boxes_overlap(*b, qb, 0.0);
    let (Some(first), Some(last)) = (
        p_boxes.iter().position(meets_q),
        p_boxes.iter().rposition(meets_q),
    ) else {
        return false;
    };
    let run = &p_boxes[first..=last];
    for b in q.windows(2) {
        let (blo, bhi) = segment_box(b[0], b[1]);
        if !boxes_overlap((blo, bhi), pb, 0.0) {
            continue;
        }
        for (i, &(alo, ahi)) in (first..).zip(run.iter()) {
            // Boxes apart: the segments cannot meet.
            if bhi.x < alo.x || blo.x > ahi.x || bhi.y < alo.y || blo.y > ahi.y {
                continue;
            }
            let (a0, a1) = (p[i], p[i + 1]);
            if segments_meet(a0, a1, b[0], b[1]) && !only_shared_end(a0, a1, b[0], b[1]) {
                return true;
            }
        }
    }
    false
}

/// The box of segment `ab`: (min, max).
#[inline]
fn segment_box(a: Point, b: Point) -> (Point, Point) {
    (
        Point::new(fmin(a.x, b.x), fmin(a.y, b.y)),
        Point::new(fmax(a.x, b.x), fmax(a.y, b.y)),
    )
}

/// Whether segments `ab` and `cd` (which meet) touch only at an end point both have.
fn only_shared_end(a: Point, b: Point, c: Point, d: Point) -> bool {
    let shared = if a == c || a == d {
        Some((a, b, if a == c { d } else { c }))
    } else if b == c || b == d {
        Some((b, a, if b == c { d } else { c }))
    } else {
        None
    };
    match shared {
        // Touching at the shared end only, unless they run on along the same line.
        Some((s, x, y)) => orient(s, x, y) != 0.0 || (x - s).dot(y - s) <= 0.0,
        None => false,
    }
}

/// Whether two boxes overlap (with a margin).
pub fn boxes_overlap(a: (Point, Point), b: (Point, Point), margin: f32) -> bool {
    a.0.x <= b.1.x + margin
        && b.0.x <= a.1.x + margin
        && a.0.y <= b.1.y + margin
        && b.0.y <= a.1.y + margin
}
