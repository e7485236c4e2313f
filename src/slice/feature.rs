//! One polygon of a slice: its validation, simplification and distance queries.

use heapless::Vec;

use super::Material;
use crate::config::{self, CHANNELS, MAX_VERTICES, SIMPLIFY_ABOVE_VERTICES};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, polyline, primitives, Point};
use crate::{Error, FeatureId, Limit};

/// The number, in `points` as given, of edge `k` of the polygon with its repeated
/// consecutive points dropped: the last index of the `k`-th run of equal points (the given
/// edge that leaves that vertex). `k` itself where there are fewer runs.
// An error's path: kept out of `Feature::new`'s frame.
#[cold]
#[inline(never)]
fn given_edge(points: &[Point], k: usize) -> u16 {
    let mut run = 0;
    for i in 0..points.len() {
        let last_of_run = points.get(i + 1) != Some(&points[i]);
        if last_of_run {
            if run == k {
                return u16::try_from(i).unwrap_or(u16::MAX);
            }
            run += 1;
        }
    }
    u16::try_from(k).unwrap_or(u16::MAX)
}

/// The number, in `points` as given, of edge `e` of the contour simplified to the points
/// `kept` (their indices in `points`): it starts at its point kept, after that point's
/// repeats. `e` itself where it is not a kept point's.
#[cold]
#[inline(never)]
fn kept_edge(points: &[Point], kept: &[u32], e: u16) -> u16 {
    let Some(&k) = kept.get(e as usize) else {
        return e;
    };
    let mut i = k as usize;
    while i + 1 < points.len() && points[i + 1] == points[i] {
        i += 1;
    }
    u16::try_from(i).unwrap_or(e)
}

/// One polygon of a slice with its material: the wall or a hollow feature.
///
/// ```
/// use hollowpath::{Feature, FeatureId, geometry::Point};
/// let tri = [Point::new(0.0, 0.0), Point::new(0.0, 1.0), Point::new(1.0, 0.0)];
/// let f = Feature::new(FeatureId::Hole(0), &tri, [0.0, 1.0, 0.0, 0.0]).unwrap();
/// // Stored counter-clockwise whatever the input orientation.
/// assert!(hollowpath::geometry::polygon::double_area(f.points()) > 0.0);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Feature {
    pub(super) id: FeatureId,
    pub(super) points: Vec<Point, MAX_VERTICES>,
    pub(super) material: Material,
    pub(super) bbox: (Point, Point),
    /// Bounding boxes of runs of [`CHUNK`] edges, to skip far edges in distance queries.
    pub(super) chunks: Vec<(Point, Point), { MAX_VERTICES / CHUNK }>,
    /// Arc length of the boundary up to each vertex (the keep-out curves' parameter).
    at_vertex: Vec<f32, MAX_VERTICES>,
    /// Whether the boundary nearly touches itself ([`polygon::pinched`]): then the sign of a
    /// distance comes from the crossing test alone ([`Feature::nearest`]).
    pinched: bool,
}

/// Edges per chunk of a feature's distance index.
const CHUNK: usize = 16;
// `n <= MAX_VERTICES` points make at most `MAX_VERTICES / CHUNK` chunks.
const _: () = assert!(MAX_VERTICES % CHUNK == 0);

/// The nearest boundary point of a feature to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Nearest {
    /// The boundary point.
    pub point: Point,
    /// Distance to it, negative inside the polygon.
    pub distance: f32,
    /// The edge it lies on.
    pub edge: usize,
}

impl Nearest {
    /// Unit vector of steepest ascent of the signed distance (away from the feature outside,
    /// towards its boundary inside).
    pub fn gradient(&self, p: Point) -> Point {
        let n = (p - self.point).normalized();
        if self.distance < 0.0 {
            -n
        } else {
            n
        }
    }
}

impl Feature {
    /// A feature of no points, as storage (not valid).
    pub(super) const fn blank() -> Feature {
        Feature {
            id: FeatureId::Wall,
            points: Vec::new(),
            material: [0.0; CHANNELS],
            bbox: (Point::new(0.0, 0.0), Point::new(0.0, 0.0)),
            chunks: Vec::new(),
            at_vertex: Vec::new(),
            pinched: false,
        }
    }

    /// Checks one polygon on its own (finite, in range, at least 3 distinct points, some area,
    /// no self-intersection, material fractions) and stores it counter-clockwise. Repeated
    /// consecutive points and a repeated closing point are dropped.
    pub fn new(id: FeatureId, points: &[Point], material: Material) -> Result<Feature, Error> {
        // A repeated closing point (first == last) is dropped before any limit is checked, so
        // a polygon of MAX_VERTICES vertices written closed still fits.
        let mut points = points;
        while let [first, .., last] = points {
            if first != last {
                break;
            }
            points = &points[..points.len() - 1];
        }
        let mut pts: Vec<Point, MAX_VERTICES> = Vec::new();
        for (k, &p) in points.iter().enumerate() {
            check_coordinate(id, k, p)?;
            if pts.last() == Some(&p) {
                continue;
            }
            if pts.push(p).is_err() {
                return Err(Error::TooManyVertices {
                    feature: id,
                    vertices: distinct_consecutive(points),
                    simplified: false,
                });
            }
        }
        while pts.len() > 1 && pts.first() == pts.last() {
            pts.pop();
        }
        let distinct = pts
            .iter()
            .enumerate()
            .filter(|(k, p)| !pts[..*k].contains(p))
            .count();
        if distinct < 3 {
            return Err(Error::TooFewPoints {
                feature: id,
                distinct: distinct as u16,
            });
        }
        // Self-intersection is checked before the net area, so that a bow-tie (whose lobes
        // cancel to no net area) is named for what it is. Only points all on one line (no
        // spread at all) are reported as enclosing no area first, as every such polygon folds
        // back on itself.
        if spread_area(&pts) <= 1e-6 {
            return Err(Error::ZeroArea { feature: id });
        }
        if let Some((a, b)) = polygon::self_intersection(&pts) {
            // Counted in the points as given (repeated points and all): the edge leaves the
            // last of its start's repeats.
            return Err(Error::SelfIntersection {
                feature: id,
                edge_a: given_edge(points, a),
                edge_b: given_edge(points, b),
            });
        }
        let area = polygon::double_area(&pts) * 0.5;
        if area.is_nan() || libm::fabsf(area) <= 1e-6 {
            return Err(Error::ZeroArea { feature: id });
        }
        if area < 0.0 {
            pts.reverse();
        }
        check_material(id, &material)?;
        let bbox = primitives::bbox(&pts);
        let mut chunks = Vec::new();
        let n = pts.len();
        for start in (0..n).step_by(CHUNK) {
            let end = (start + CHUNK).min(n);
            let mut b = primitives::bbox(&pts[start..end]);
            let closing = pts[end % n];
            b.0 = Point::new(b.0.x.fmin(closing.x), b.0.y.fmin(closing.y));
            b.1 = Point::new(b.1.x.fmax(closing.x), b.1.y.fmax(closing.y));
            // Never full: at most MAX_VERTICES / CHUNK chunks (asserted with CHUNK).
            chunks.push(b).map_err(|_| Limit::Vertices.error())?;
        }
        let mut at_vertex = Vec::new();
        let mut acc = 0.0;
        for k in 0..n {
            // Never full: one per vertex, of the same capacity.
            at_vertex.push(acc).map_err(|_| Limit::Vertices.error())?;
            acc += pts[k].dist(pts[(k + 1) % n]);
        }
        // Generously past rounding (`polygon::rounding_slack` is 1e-5 of the coordinates):
        // ten times it.
        let pinched = polygon::pinched(&pts, 10.0 * polygon::rounding_slack(bbox.1, bbox));
        Ok(Feature {
            id,
            points: pts,
            material,
            bbox,
            chunks,
            at_vertex,
            pinched,
        })
    }

    /// [`Feature::new`] of `points` simplified within `tolerance` (mm) when they have more than
    /// [`SIMPLIFY_ABOVE_VERTICES`] distinct vertices (else, or with `tolerance` 0, exactly
    /// `Feature::new`). Douglas-Peucker on the closed polygon in fixed memory (the kept
    /// vertices' indices only): every input vertex stays within `tolerance` of the result. If
    /// the result would intersect itself or degenerate, the tolerance is halved (more vertices
    /// kept) until it does not.
    ///
    /// ```
    /// # // The host build's capacities take megabytes: run on a large stack.
    /// # std::thread::Builder::new().stack_size(256 << 20).spawn(|| {
    /// use hollowpath::{Feature, FeatureId, geometry::Point};
    /// let circle: Vec<Point> = (0..4096)
    ///     .map(|k| {
    ///         let a = k as f32 / 4096.0 * std::f32::consts::TAU;
    ///         Point::new(5.0 * a.cos(), 5.0 * a.sin())
    ///     })
    ///     .collect();
    /// let f = Feature::simplified(FeatureId::Hole(0), &circle, [0.0, 1.0, 0.0, 0.0], 0.005).unwrap();
    /// assert!(f.points().len() <= 128);
    /// # }).unwrap().join().unwrap();
    /// ```
    // Not inlined: its contour buffers (3 KiB on the MCU) stay in a frame of its own, not in
    // the frame of a caller that lives through every later phase (the bench's validate peak
    // 17 808 -> 17 408 bytes).
    #[inline(never)]
    pub fn simplified(
        id: FeatureId,
        points: &[Point],
        material: Material,
        tolerance: f32,
    ) -> Result<Feature, Error> {
        if tolerance.is_nan()
            || tolerance <= 0.0
            || distinct_consecutive(points) as usize <= SIMPLIFY_ABOVE_VERTICES
        {
            return Feature::new(id, points, material);
        }
        for (k, &p) in points.iter().enumerate() {
            check_coordinate(id, k, p)?;
        }
        let mut n = points.len();
        if n > 1 && points[n - 1] == points[0] {
            n -= 1;
        }
        let mut tol = tolerance;
        loop {
            let Some(kept) = douglas_peucker_closed(&points[..n], tol) else {
                return Err(Error::TooManyVertices {
                    feature: id,
                    vertices: distinct_consecutive(points),
                    simplified: true,
                });
            };
            let mut pts: Vec<Point, MAX_VERTICES> = Vec::new();
            for &k in kept.iter() {
                // Never full: `kept` has the same capacity.
                pts.push(points[k as usize])
                    .map_err(|_| Limit::Vertices.error())?;
            }
            match Feature::new(id, &pts, material) {
                Err(
                    Error::SelfIntersection { .. }
                    | Error::ZeroArea { .. }
                    | Error::TooFewPoints { .. },
                ) if tol > MIN_SIMPLIFY_TOLERANCE => {
                    tol *= 0.5;
                }
                // The edges of the simplified contour, counted in the points as given: each
                // starts at a point kept, after that point's repeats.
                Err(Error::SelfIntersection {
                    feature,
                    edge_a,
                    edge_b,
                }) => {
                    return Err(Error::SelfIntersection {
                        feature,
                        edge_a: kept_edge(&points[..n], &kept, edge_a),
                        edge_b: kept_edge(&points[..n], &kept, edge_b),
                    });
                }
                other => return other,
            }
        }
    }

    /// The arc length of the boundary (counter-clockwise from vertex 0) up to each vertex.
    pub fn arc_lengths(&self) -> &[f32] {
        &self.at_vertex
    }

    /// Which feature this is.
    pub fn id(&self) -> FeatureId {
        self.id
    }
    /// The vertices, counter-clockwise, the closing edge implied.
    pub fn points(&self) -> &[Point] {
        &self.points
    }
    /// The material deposited at this feature.
    pub fn material(&self) -> Material {
        self.material
    }
    /// Bounding box (min, max).
    pub fn bbox(&self) -> (Point, Point) {
        self.bbox
    }
    /// The nearest boundary point to `p`. Of equal distances (a vertex two edges share) the
    /// one whose chunk of edges has the nearer box wins, then the lower-numbered chunk, then
    /// the lower-numbered edge: the order a search from the nearest chunk outwards finds them
    /// in, whatever order the chunks are looked at. The chunk whose box is nearest goes first;
    /// every other chunk whose box is farther than the best so far is skipped.
    pub fn nearest(&self, p: Point) -> Nearest {
        let n = self.points.len();
        // Filled as needed: a large MAX_VERTICES costs no clearing per query.
        let mut bounds: Vec<f32, { MAX_VERTICES / CHUNK }> = Vec::new();
        // One per chunk, and `chunks` has the same capacity: `extend`, which would panic on
        // overflow, cannot.
        bounds.extend(self.chunks.iter().map(|b| polygon::bbox_distance2(*b, p)));
        let first = (1..bounds.len()).fold(0, |m, c| if bounds[c] < bounds[m] { c } else { m });
        // (point, squared distance, edge, chunk)
        let pts = &self.points[..];
        let visit = |c: usize, best: &mut (Point, f32, usize, usize)| {
            let p = Point::new(p.x, p.y);
            let ahead = best.1 == f32::INFINITY || (bounds[c], c) < (bounds[best.3], best.3);
            let mut edge = |k: usize, a: Point, b: Point| {
                let (q, _) = primitives::closest_on_segment(a, b, p);
                let d2 = (q - p).norm2();
                // The integer test first: after the chunk's first edge, `best.3 == c`.
                if d2 < best.1 || (best.3 != c && ahead && d2 == best.1) {
                    *best = (q, d2, k, c);
                }
            };
            let edges = self.chunk_edges(c);
            // Each edge's end is the next one's start; the closing edge (to vertex 0), in the
            // last chunk, on its own.
            let inner = &pts[edges.start..(edges.end + 1).min(n)];
            for (k, w) in (edges.start..).zip(inner.windows(2)) {
                edge(k, w[0], w[1]);
            }
            if edges.end == n {
                edge(n - 1, pts[n - 1], pts[0]);
            }
        };
        let mut best = (self.points[0], f32::INFINITY, 0, first);
        visit(first, &mut best);
        for (c, &lower) in bounds.iter().enumerate() {
            // A box as far as the best may still hold a point as near that wins the tie.
            if c != first && lower <= best.1 {
                visit(c, &mut best);
            }
        }
        let d = hollowpath_fpu::sqrtf(best.1);
        let inside = polygon::bbox_distance2(self.bbox, p) == 0.0 && {
            let near = if self.pinched {
                None
            } else {
                self.inside_near(p, best.2)
            };
            debug_assert!(near.is_none_or(|near| near == self.contains(p)));
            near.unwrap_or_else(|| self.contains(p))
        };
        Nearest {
            point: best.0,
            distance: if inside { -d } else { d },
            edge: best.2,
        }
    }

    /// Whether `p` is inside, told from the boundary where it is nearest to `p`, on edge `k`;
    /// `None` where rounding could make that answer differ from [`contains`](Self::contains)'s.
    /// Only for a feature that is not [`pinched`](polygon::pinched): where the boundary comes
    /// within rounding of itself (a gap thinner than that, a sharp spike), the edge found
    /// nearest can be the far side of the gap, a near tie with the right one, and this would
    /// answer for that side.
    ///
    /// The disc around `p` through its nearest boundary point `q` holds no boundary, so `p`
    /// lies on the side of the boundary that the ray from `q` towards `p` leaves into: left of
    /// the edge (the inside: a feature's points run counter-clockwise) where `q` is inside the
    /// edge; where `q` is a vertex, inside the wedge between its two edges (left of both at a
    /// convex vertex, left of either at a reflex one). Each side is a cross product, used only
    /// where it is larger than its rounding can be ([`polygon::rounding_slack`] times the
    /// vectors' sizes: every rounding in it is at most 6e-8 of a coordinate or of the
    /// product), so the answer is the crossing test's wherever it is given; a point almost on
    /// an edge's line, or a vertex almost straight, is left to the crossing test. One edge or
    /// two in place of a crossing test over a whole run of edges.
    fn inside_near(&self, p: Point, k: usize) -> Option<bool> {
        let pts = &self.points[..];
        let n = pts.len();
        let next = |i: usize| if i + 1 < n { i + 1 } else { 0 };
        let (a, b) = (pts[k], pts[next(k)]);
        let slack = polygon::rounding_slack(p, self.bbox);
        let size = |v: Point| libm::fabsf(v.x) + libm::fabsf(v.y);
        // The sign of `cross(e, u)`, where it is certain.
        let side = |e: Point, u: Point| {
            let c = e.cross(u);
            (libm::fabsf(c) > slack * (size(e) + size(u))).then_some(c > 0.0)
        };
        let (_, t) = primitives::closest_on_segment(a, b, p);
        let (v, e_in, e_out) = if t <= 0.0 {
            (a, a - pts[(k + n - 1) % n], b - a)
        } else if t >= 1.0 {
            (b, b - a, pts[next(next(k))] - b)
        } else {
            return side(b - a, p - (a + (b - a) * t));
        };
        let u = p - v;
        let (left_in, left_out) = (side(e_in, u)?, side(e_out, u)?);
        if left_in == left_out {
            Some(left_in)
        } else {
            // Inside the wedge only at a reflex vertex (turning right).
            side(e_in, e_out).map(|convex| !convex)
        }
    }

    /// Whether the feature's box lies within `d` of `p`, with room for rounding
    /// ([`polygon::rounding_slack`]): where it does not, the feature is farther than `d` (its
    /// distance is at least its box's).
    pub(crate) fn box_within(&self, p: Point, d: f32) -> bool {
        let reach = d + polygon::rounding_slack(p, self.bbox);
        polygon::bbox_distance2(self.bbox, p) <= reach * reach
    }

    /// The squared distance from `p` to the nearest box of the feature's chunks of edges: a
    /// lower bound of the squared distance to its boundary.
    pub fn nearest_box2(&self, p: Point) -> f32 {
        self.chunks
            .iter()
            .map(|b| polygon::bbox_distance2(*b, p))
            // A plain comparison, not `fmin`: a box distance is never NaN, and this runs for
            // every field node and every nearest-feature query (`fmin`'s NaN test cost the
            // plan 0.1 % and verify 0.7-1 % on QEMU).
            .fold(f32::INFINITY, |m, d| if d < m { d } else { m })
    }

    /// Where the boundary crosses the horizontal line at `y`: the `x` of every edge with one
    /// end above `y` and the other not, computed as [`contains`](Self::contains) computes it,
    /// into `out` (emptied first), in increasing order. A point `p` with `p.y == y` is inside
    /// exactly where an odd number of them lie right of it ([`inside_by_crossings`]): the
    /// answer of `contains` for a whole row of points from one pass over the edges.
    pub fn row_crossings(&self, y: f32, out: &mut Vec<f32, MAX_VERTICES>) {
        out.clear();
        let n = self.points.len();
        for k in 0..n {
            if let Some(x) = polygon::row_crossing(self.points[(k + 1) % n], self.points[k], y) {
                // One crossing an edge at most, and `out` holds one per vertex: never full.
                if out.push(x).is_err() {
                    break;
                }
            }
        }
        out.sort_unstable_by(f32::total_cmp);
    }

    /// Whether a point at `x` on the line whose crossings are `crossings` (increasing,
    /// [`row_crossings`](Self::row_crossings)) is inside: an odd number of them lie right of
    /// it (`x < c`), as [`contains`](Self::contains) counts them.
    pub fn inside_by_crossings(crossings: &[f32], x: f32) -> bool {
        let right = crossings.len() - crossings.partition_point(|&c| c <= x);
        right % 2 == 1
    }

    /// Whether `p` is inside the polygon: [`polygon::contains`]'s even-odd crossing test,
    /// with the same answer, on the edges of the chunks whose box straddles `p`'s horizontal
    /// line right of `p` only. An edge flips the count only if one end is above `p.y` and the
    /// other is not, and where it crosses that line lies within its ends' x range (to within
    /// [`polygon::rounding_slack`]), so every chunk skipped would have flipped nothing.
    pub fn contains(&self, p: Point) -> bool {
        let n = self.points.len();
        let mut inside = false;
        for (b, edges) in self.edge_runs() {
            if b.1.y <= p.y || b.0.y > p.y || b.1.x + polygon::rounding_slack(p, b) < p.x {
                continue;
            }
            for k in edges {
                let (a, b) = (self.points[(k + 1) % n], self.points[k]);
                if polygon::row_crossing(a, b, p.y).is_some_and(|x| p.x < x) {
                    inside = !inside;
                }
            }
        }
        inside
    }

    /// The feature's edges in runs of consecutive edges, each run with the box around it (edge
    /// `k` runs from vertex `k` to vertex `k + 1`, the last one back to vertex 0): a search may
    /// rule out a whole run by its box.
    pub fn edge_runs(
        &self,
    ) -> impl Iterator<Item = ((Point, Point), core::ops::Range<usize>)> + '_ {
        self.chunks
            .iter()
            .enumerate()
            .map(move |(c, b)| (*b, self.chunk_edges(c)))
    }

    /// The edges of chunk `c`.
    fn chunk_edges(&self, c: usize) -> core::ops::Range<usize> {
        c * CHUNK..((c + 1) * CHUNK).min(self.points.len())
    }

    /// Whether segment `ab` crosses or touches the feature's boundary.
    pub(crate) fn segment_meets(&self, a: Point, b: Point) -> bool {
        let (lo, hi) = (
            Point::new(a.x.fmin(b.x), a.y.fmin(b.y)),
            Point::new(a.x.fmax(b.x), a.y.fmax(b.y)),
        );
        polyline::boxes_overlap(self.bbox, (lo, hi), 0.0)
            && self.chunks_near((lo, hi)).any(|edges| {
                edges
                    .into_iter()
                    .any(|(p, q)| primitives::segments_meet(a, b, p, q))
            })
    }

    /// The edges (start, end) of every chunk whose box meets box `b`, chunk by chunk in the
    /// polygon's order: what a search for edges or vertices within `b` need look at. Each
    /// edge's start is one vertex, so the starts of all chunks are every vertex once.
    pub(super) fn chunks_near(
        &self,
        b: (Point, Point),
    ) -> impl Iterator<Item = impl Iterator<Item = (Point, Point)> + '_> + '_ {
        let (pts, n) = (&self.points, self.points.len());
        self.edge_runs()
            .filter(move |(cb, _)| polyline::boxes_overlap(*cb, b, 0.0))
            .map(move |(_, edges)| edges.map(move |k| (pts[k], pts[(k + 1) % n])))
    }

    /// Distance from `p` to the boundary, negative inside the polygon.
    pub fn signed_distance(&self, p: Point) -> f32 {
        self.nearest(p).distance
    }
}

/// The area of the fan of triangles from the first vertex, each counted positive: zero (or NaN)
/// exactly when all the points lie on one line.
fn spread_area(pts: &[Point]) -> f32 {
    let o = pts[0];
    let twice: f32 = pts
        .windows(2)
        .map(|w| libm::fabsf((w[0] - o).cross(w[1] - o)))
        .sum();
    if twice.is_nan() {
        0.0
    } else {
        0.5 * twice
    }
}

/// Below this tolerance (mm) simplification stops refining: the input itself is at fault.
pub(super) const MIN_SIMPLIFY_TOLERANCE: f32 = 1e-6;

/// Douglas-Peucker on the closed polygon `points`: the indices (ascending) of the vertices
/// kept, every other vertex within `tol` of the polygon they make; `None` if more than
/// [`MAX_VERTICES`] are needed. Starts from vertex 0 and the vertex farthest from it, and
/// splits each gap at its farthest vertex while that is farther than `tol`, depth first.
fn douglas_peucker_closed(points: &[Point], tol: f32) -> Option<Vec<u32, MAX_VERTICES>> {
    let n = points.len();
    let mut kept: Vec<u32, MAX_VERTICES> = Vec::new();
    kept.push(0).ok()?;
    let far = (1..n).fold((0, 0.0f32), |best, k| {
        let d = points[k].dist(points[0]);
        if d > best.1 {
            (k, d)
        } else {
            best
        }
    });
    if far.0 == 0 {
        return Some(kept);
    }
    kept.push(far.0 as u32).ok()?;
    let mut p = 0;
    while p < kept.len() {
        let i = kept[p] as usize;
        // The gap after the last kept vertex closes the polygon through vertex 0.
        let j = if p + 1 < kept.len() {
            kept[p + 1] as usize
        } else {
            n
        };
        let (a, b) = (points[i], points[j % n]);
        let mut best = (0.0f32, 0usize);
        for (k, &q) in points.iter().enumerate().take(j).skip(i + 1) {
            let (c, _) = primitives::closest_on_segment(a, b, q);
            let d = c.dist(q);
            if d > best.0 {
                best = (d, k);
            }
        }
        if best.0 > tol {
            kept.insert(p + 1, best.1 as u32).ok()?;
        } else {
            p += 1;
        }
    }
    Some(kept)
}

/// Points of `points` that differ from the one before them (the closing repeat not counted).
pub(super) fn distinct_consecutive(points: &[Point]) -> u32 {
    let n = points.len();
    let kept = (0..n)
        .filter(|&k| k == 0 || points[k] != points[k - 1])
        .count();
    let closing = n > 1 && points[n - 1] == points[0];
    (kept - usize::from(closing)).min(u32::MAX as usize) as u32
}

/// A vertex's coordinates: finite, and within [`config::MAX_COORD_MM`].
fn check_coordinate(feature: FeatureId, k: usize, p: Point) -> Result<(), Error> {
    let vertex = k.min(u16::MAX as usize) as u16;
    if !p.is_finite() {
        return Err(Error::NonFinite { feature, vertex });
    }
    if libm::fabsf(p.x) > config::MAX_COORD_MM || libm::fabsf(p.y) > config::MAX_COORD_MM {
        return Err(Error::OutOfRange { feature, vertex });
    }
    Ok(())
}

fn check_material(feature: FeatureId, m: &Material) -> Result<(), Error> {
    for (c, &x) in m.iter().enumerate() {
        if x.is_nan() || x < 0.0 || !x.is_finite() {
            return Err(Error::MaterialNegative {
                feature,
                channel: c as u8,
            });
        }
    }
    let sum: f32 = m.iter().sum();
    if libm::fabsf(sum - 1.0) > 1e-3 {
        return Err(Error::MaterialSum { feature, sum });
    }
    Ok(())
}
