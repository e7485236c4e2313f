//! The validated slice: the wall, the hollow features, their materials and the settings.
//!
//! A [`Slice`] can only be built through [`Slice::new`], which refuses every invalid input with
//! an [`Error`] naming the feature and the reason, so everything downstream may assume a valid
//! slice: simple polygons, counter-clockwise, holes strictly inside the wall and disjoint.

use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::config::{self, defaults, CHANNELS, MAX_HOLES, MAX_VERTICES, SIMPLIFY_ABOVE_VERTICES};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, polyline, primitives, Point};
use crate::{Error, FeatureId, Limit, SettingId};

/// A composition: one fraction per material channel, summing to 1.
pub type Material = [f32; CHANNELS];

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
    id: FeatureId,
    points: Vec<Point, MAX_VERTICES>,
    material: Material,
    bbox: (Point, Point),
    /// Bounding boxes of runs of [`CHUNK`] edges, to skip far edges in distance queries.
    chunks: Vec<(Point, Point), { MAX_VERTICES / CHUNK }>,
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
    const fn blank() -> Feature {
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
            return Err(Error::SelfIntersection {
                feature: id,
                edge_a: a as u16,
                edge_b: b as u16,
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
                if (a.y > p.y) != (b.y > p.y) {
                    let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
                    if p.x < x {
                        inside = !inside;
                    }
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
    fn chunks_near(
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
const MIN_SIMPLIFY_TOLERANCE: f32 = 1e-6;

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
fn distinct_consecutive(points: &[Point]) -> u32 {
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

/// The planner's knobs. Every field has a documented default ([`Settings::default`]); a slice
/// file may set any of them by its key.
///
/// ```
/// let s = hollowpath::Settings::for_road_width(0.5);
/// assert_eq!(s.road_width, 0.5);
/// assert_eq!(s.delta, 1.0); // 2 road widths
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// `road_width`: deposited road width, mm (default 0.4; 0.01 to 10).
    pub road_width: f32,
    /// `layer_height`: layer height, mm (default 0.3).
    pub layer_height: f32,
    /// `w_n`: weight of the normal term of the matching objective (2.1) (default 1).
    pub w_n: f32,
    /// `w_d`: weight of the distance term of the matching objective (2.1) (default 1).
    pub w_d: f32,
    /// `delta`: proximity bound of Algorithm I along the bisector, mm (default 2 road widths).
    pub delta: f32,
    /// `mcl_spacing`: spacing of MCLs along a feature, mm (default 1 road width); denser where
    /// they diverge, so that neighbouring roads leave no gap wider than a road.
    pub mcl_spacing: f32,
    /// `relax_iterations`: relaxation sweeps near branch points (default 8, at most 64); 0
    /// skips the smoothing, the final spacing guarantee still holds.
    pub relax_iterations: u8,
    /// `relax_spacing`: the least distance between MCL ends on the cell boundary after
    /// relaxation, mm (default 1 road width).
    pub relax_spacing: f32,
    /// `min_width`: the narrowest road a layer may deposit, mm (default 0.5 road widths; at
    /// most the road width). Where neighbouring roads converge, a road narrows to their
    /// spacing down to this, rather than piling onto them.
    pub min_width: f32,
    /// `max_width`: the widest road a layer may deposit, mm (default 1.6 road widths; from the
    /// road width to 3 road widths). Where neighbouring roads diverge, a road widens to their
    /// spacing up to this, rather than leaving a gap.
    pub max_width: f32,
    /// `simplify_tolerance`: contours of more than
    /// [`SIMPLIFY_ABOVE_VERTICES`] vertices are
    /// simplified within this, mm, before planning ([`Slice::from_contours`]; default 0.005,
    /// at most a tenth of the road width; 0 keeps every vertex).
    pub simplify_tolerance: f32,
}

impl Settings {
    /// The defaults for a given road width (spacing-like settings scale with it).
    pub fn for_road_width(road_width: f32) -> Settings {
        Settings {
            road_width,
            layer_height: defaults::LAYER_HEIGHT,
            w_n: defaults::W_N,
            w_d: defaults::W_D,
            delta: defaults::DELTA_PER_ROAD * road_width,
            mcl_spacing: defaults::MCL_SPACING_PER_ROAD * road_width,
            relax_iterations: defaults::RELAX_ITERATIONS,
            relax_spacing: road_width,
            min_width: defaults::MIN_WIDTH_PER_ROAD * road_width,
            max_width: defaults::MAX_WIDTH_PER_ROAD * road_width,
            simplify_tolerance: defaults::SIMPLIFY_TOLERANCE.fmin(0.1 * road_width),
        }
    }

    fn validate(&self) -> Result<(), Error> {
        let checks = [
            (
                SettingId::RoadWidth,
                self.road_width,
                self.road_width >= config::MIN_ROAD_WIDTH_MM
                    && self.road_width <= config::MAX_ROAD_WIDTH_MM,
            ),
            (
                SettingId::LayerHeight,
                self.layer_height,
                self.layer_height > 0.0 && self.layer_height <= config::MAX_ROAD_WIDTH_MM,
            ),
            (
                SettingId::WeightNormal,
                self.w_n,
                self.w_n >= 0.0 && self.w_n <= 16.0,
            ),
            (
                SettingId::WeightDistance,
                self.w_d,
                self.w_d >= 0.0 && self.w_d <= 16.0,
            ),
            (
                SettingId::Delta,
                self.delta,
                self.delta > 0.0 && self.delta.is_finite(),
            ),
            (
                SettingId::MclSpacing,
                self.mcl_spacing,
                self.mcl_spacing >= 0.25 * self.road_width
                    && self.mcl_spacing <= 4.0 * self.road_width,
            ),
            (
                SettingId::RelaxSpacing,
                self.relax_spacing,
                self.relax_spacing > 0.0 && self.relax_spacing <= 4.0 * self.road_width,
            ),
            (
                SettingId::MinWidth,
                self.min_width,
                self.min_width > 0.0 && self.min_width <= self.road_width,
            ),
            (
                SettingId::MaxWidth,
                self.max_width,
                self.max_width >= self.road_width && self.max_width <= 3.0 * self.road_width,
            ),
            (
                SettingId::SimplifyTolerance,
                self.simplify_tolerance,
                self.simplify_tolerance >= 0.0 && self.simplify_tolerance <= 0.1 * self.road_width,
            ),
        ];
        if self.relax_iterations > config::MAX_RELAX_ITERATIONS {
            return Err(Error::InvalidSetting {
                setting: SettingId::RelaxIterations,
                value: self.relax_iterations as f32,
            });
        }
        for (setting, value, ok) in checks {
            // `ok` is false for NaN as every comparison is.
            if !ok {
                return Err(Error::InvalidSetting { setting, value });
            }
        }
        Ok(())
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings::for_road_width(defaults::ROAD_WIDTH)
    }
}

/// A validated slice.
///
/// ```
/// # // The host build's capacities take megabytes: run on a large stack.
/// # std::thread::Builder::new().stack_size(256 << 20).spawn(|| {
/// use hollowpath::{Feature, FeatureId, Settings, Slice, geometry::Point};
/// let circle = |cx: f32, r: f32, n: usize| -> Vec<Point> {
///     (0..n).map(|k| {
///         let a = k as f32 / n as f32 * std::f32::consts::TAU;
///         Point::new(cx + r * a.cos(), r * a.sin())
///     }).collect()
/// };
/// let wall = Feature::new(FeatureId::Wall, &circle(0.0, 10.0, 64), [1.0, 0.0, 0.0, 0.0]).unwrap();
/// let hole = Feature::new(FeatureId::Hole(0), &circle(0.0, 3.0, 32), [0.0, 1.0, 0.0, 0.0]).unwrap();
/// let slice = Slice::new(wall, &[hole], Settings::default()).unwrap();
/// assert_eq!(slice.holes().len(), 1);
/// # }).unwrap().join().unwrap();
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Slice {
    wall: Feature,
    holes: Vec<Feature, MAX_HOLES>,
    settings: Settings,
}

impl Slice {
    /// Validates the slice as a whole: settings in range, every hole strictly inside the
    /// wall, holes pairwise disjoint and not nested. A slice without holes (a model's cap or
    /// bottom layer) is valid: it plans to no MCLs and is laid by the offset spiral alone, from
    /// the wall inwards; the MCL layers (zigzag, MCL spiral) refuse it with
    /// [`Error::NoHoles`].
    pub fn new(wall: Feature, holes: &[Feature], settings: Settings) -> Result<Slice, Error> {
        settings.validate()?;
        if holes.len() > MAX_HOLES {
            return Err(Error::TooManyHoles {
                holes: holes.len().min(u32::MAX as usize) as u32,
            });
        }
        let mut slice = Slice {
            wall,
            holes: Vec::new(),
            settings,
        };
        for h in holes {
            // Never full: `holes.len() <= MAX_HOLES` was checked.
            slice
                .holes
                .push(h.clone())
                .map_err(|_| Limit::Holes.error())?;
        }
        slice.check()?;
        Ok(slice)
    }

    /// A slice of no contours, as storage to build one in ([`SliceStore`]); not valid.
    const fn blank() -> Slice {
        Slice {
            wall: Feature::blank(),
            holes: Vec::new(),
            settings: Settings {
                road_width: 0.0,
                layer_height: 0.0,
                w_n: 0.0,
                w_d: 0.0,
                delta: 0.0,
                mcl_spacing: 0.0,
                relax_iterations: 0,
                relax_spacing: 0.0,
                min_width: 0.0,
                max_width: 0.0,
                simplify_tolerance: 0.0,
            },
        }
    }

    /// Numbers the features (the wall, holes from 0 in order) and validates the slice as a
    /// whole, in place: every hole strictly inside the wall, holes pairwise disjoint and not
    /// nested (the first fault in hole order).
    fn check(&mut self) -> Result<(), Error> {
        self.wall.id = FeatureId::Wall;
        let wall = &self.wall;
        for i in 0..self.holes.len() {
            let (stored, rest) = self.holes.split_at_mut(i);
            let h = &mut rest[0];
            // At most MAX_HOLES (<= 64) holes: fits the `u8`.
            h.id = FeatureId::Hole(i as u8);
            let hole = i as u8;
            for (v, &p) in h.points.iter().enumerate() {
                if wall.signed_distance(p) >= 0.0 {
                    return Err(Error::HoleOutsideWall {
                        hole,
                        vertex: v as u16,
                    });
                }
            }
            if let Some((e, we)) = polygon::boundaries_meet(&h.points, &wall.points) {
                return Err(Error::HoleCrossesWall {
                    hole,
                    edge: e as u16,
                    wall_edge: we as u16,
                });
            }
            for (j, other) in stored.iter().enumerate() {
                let j = j as u8;
                if polygon::boundaries_meet(&other.points, &h.points).is_some() {
                    return Err(Error::HolesOverlap { a: j, b: hole });
                }
                if polygon::contains(&other.points, h.points[0]) {
                    return Err(Error::HolesNested {
                        outer: j,
                        inner: hole,
                    });
                }
                if polygon::contains(&h.points, other.points[0]) {
                    return Err(Error::HolesNested {
                        outer: hole,
                        inner: j,
                    });
                }
            }
        }
        Ok(())
    }

    /// Builds and validates a slice from raw contours (a wall and `(points, material)` per
    /// hole), simplifying each contour within `settings.simplify_tolerance` as
    /// [`Feature::simplified`] does. Where a simplified contour would meet or leave another
    /// (the wall, a hole), the contours concerned are simplified again with half the
    /// tolerance, keeping more vertices, until they do not.
    pub fn from_contours(
        wall: &[Point],
        wall_material: Material,
        holes: &[(&[Point], Material)],
        settings: Settings,
    ) -> Result<Slice, Error> {
        let mut slice = Slice::blank();
        slice.fill_from_contours(wall, wall_material, holes, settings)?;
        Ok(slice)
    }

    /// [`from_contours`](Self::from_contours) into this slice's own storage, with no
    /// slice-sized temporary (a controller's [`SliceStore`]). On error the slice holds
    /// whatever was built so far: not a valid slice.
    fn fill_from_contours(
        &mut self,
        wall: &[Point],
        wall_material: Material,
        holes: &[(&[Point], Material)],
        settings: Settings,
    ) -> Result<(), Error> {
        settings.validate()?;
        if holes.len() > MAX_HOLES {
            return Err(Error::TooManyHoles {
                holes: holes.len().min(u32::MAX as usize) as u32,
            });
        }
        self.settings = settings;
        const WALL: usize = MAX_HOLES;
        let mut tols = [settings.simplify_tolerance; MAX_HOLES + 1];
        loop {
            self.wall = Feature::simplified(FeatureId::Wall, wall, wall_material, tols[WALL])?;
            self.holes.clear();
            for (i, &(pts, m)) in holes.iter().enumerate() {
                let f = Feature::simplified(FeatureId::Hole(i as u8), pts, m, tols[i])?;
                // Never full: `holes.len() <= MAX_HOLES` was checked.
                self.holes.push(f).map_err(|_| Limit::Holes.error())?;
            }
            let e = match self.check() {
                Ok(()) => return Ok(()),
                Err(e) => e,
            };
            let named = match e {
                Error::HoleOutsideWall { hole, .. } | Error::HoleCrossesWall { hole, .. } => {
                    [hole as usize, WALL]
                }
                Error::HolesOverlap { a, b } => [a as usize, b as usize],
                Error::HolesNested { outer, inner } => [outer as usize, inner as usize],
                _ => return Err(e),
            };
            let mut refined = false;
            for k in named {
                let pts = if k == WALL { wall } else { holes[k].0 };
                if tols[k] > MIN_SIMPLIFY_TOLERANCE
                    && distinct_consecutive(pts) as usize > SIMPLIFY_ABOVE_VERTICES
                {
                    tols[k] *= 0.5;
                    refined = true;
                }
            }
            if !refined {
                return Err(e);
            }
        }
    }

    /// Feature `k` in the layers' numbering of the features: hole `k`, and the wall after
    /// the holes (`k == holes().len()`, or any larger `k`).
    pub fn feature_at(&self, k: usize) -> &Feature {
        self.holes.get(k).unwrap_or(&self.wall)
    }

    /// The material of feature `k` ([`feature_at`](Self::feature_at)'s numbering).
    pub fn material_at(&self, k: usize) -> Material {
        self.feature_at(k).material()
    }

    /// The distance from `p` to feature `k` ([`feature_at`](Self::feature_at)'s numbering),
    /// positive on the printable side of it (outside a hole, inside the wall).
    pub fn clearance_to(&self, k: usize, p: Point) -> f32 {
        self.nearest_of(k, p).0
    }

    /// [`clearance_to`](Self::clearance_to) feature `k` (the wall for `holes().len()`) and its
    /// nearest boundary point, as [`Feature::nearest`] gives it.
    fn nearest_of(&self, k: usize, p: Point) -> (f32, Nearest) {
        match self.holes.get(k) {
            Some(h) => {
                let n = h.nearest(p);
                (n.distance, n)
            }
            None => {
                let n = self.wall.nearest(p);
                (-n.distance, n)
            }
        }
    }

    /// [`clearance_to`](Self::clearance_to) and its gradient (the unit vector away from
    /// the feature on its printable side).
    pub fn clearance_gradient_to(&self, k: usize, p: Point) -> (f32, Point) {
        let (d, n) = self.nearest_of(k, p);
        (d, self.clearance_gradient(k, &n, p))
    }

    /// The gradient of the clearance to feature `k` at `p` (the unit vector away from it on
    /// its printable side), from its nearest boundary point `n` as [`Feature::nearest`] or
    /// [`nearest_feature`](Self::nearest_feature) gives it: the wall's signed distance grows
    /// out of the material, so its gradient is turned round.
    pub fn clearance_gradient(&self, k: usize, n: &Nearest, p: Point) -> Point {
        let g = n.gradient(p);
        if k < self.holes.len() {
            g
        } else {
            -g
        }
    }

    /// The outer wall.
    pub fn wall(&self) -> &Feature {
        &self.wall
    }
    /// The hollow features, in the order of the slice file.
    pub fn holes(&self) -> &[Feature] {
        &self.holes
    }
    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Distance from `p` to the wall, positive inside.
    pub fn wall_clearance(&self, p: Point) -> f32 {
        -self.wall.signed_distance(p)
    }

    /// The nearest and second-nearest hole to `p` with their signed distances
    /// (`(i, d_i, j, d_j)`; `j == i` and `d_j` infinite with a single hole). Of equal
    /// distances the lower-numbered hole comes first.
    ///
    /// The two holes whose boxes are nearest are measured first, then every other hole whose
    /// box lies within the second distance so far plus [`polygon::rounding_slack`] (a hole
    /// skipped can neither come nearer nor tie): the answer is the two least `(d, k)` pairs,
    /// whatever the order the holes are measured in.
    pub fn nearest_holes(&self, p: Point) -> (usize, f32, usize, f32) {
        let mut best = (0, f32::INFINITY, 0, f32::INFINITY);
        let offer = |k: usize, d: f32, best: &mut (usize, f32, usize, f32)| {
            if d < best.1 || (d == best.1 && k < best.0) {
                *best = (k, d, best.0, best.1);
            } else if d < best.3 || (d == best.3 && k < best.2) {
                best.2 = k;
                best.3 = d;
            }
        };
        // The two nearest boxes (of equal box distances the lower-numbered hole); with two
        // holes or fewer, every hole is measured anyway.
        let (first, second) = if self.holes.len() <= 2 {
            (0, 1)
        } else {
            let mut two = [(usize::MAX, f32::INFINITY); 2];
            for (k, h) in self.holes.iter().enumerate() {
                let b = polygon::bbox_distance2(h.bbox, p);
                if b < two[0].1 || two[0].0 == usize::MAX {
                    two = [(k, b), two[0]];
                } else if b < two[1].1 || two[1].0 == usize::MAX {
                    two[1] = (k, b);
                }
            }
            (two[0].0, two[1].0)
        };
        for k in [first, second] {
            if let Some(h) = self.holes.get(k) {
                offer(k, h.signed_distance(p), &mut best);
            }
        }
        for (k, h) in self.holes.iter().enumerate() {
            if k == first || k == second {
                continue;
            }
            // (A box farther than a non-positive limit: `p` lies inside two holes, which
            // validation refuses, and no third can be nearer.)
            let limit = best.3 + polygon::rounding_slack(p, h.bbox);
            if limit <= 0.0 || polygon::bbox_distance2(h.bbox, p) >= limit * limit {
                continue;
            }
            offer(k, h.signed_distance(p), &mut best);
        }
        if best.3 == f32::INFINITY {
            best.2 = best.0;
        }
        best
    }

    /// Whether `p` is in the printable region: inside the wall and outside every hole, half a
    /// road width from each (with a tolerance `tol`).
    pub fn is_printable(&self, p: Point, tol: f32) -> bool {
        self.fits(p, self.settings.road_width, tol)
    }

    /// The distance from `p` to the nearest feature (a hole or the wall), positive in the
    /// material.
    pub fn clearance(&self, p: Point) -> f32 {
        self.nearest_feature(p).1
    }

    /// The feature nearest to `p` ([`feature_at`](Self::feature_at)'s numbering: the wall is
    /// `holes().len()`), the distance to it (positive in the material) and its nearest
    /// boundary point (as [`Feature::nearest`] gives it, whose gradient points into the
    /// material for a hole and out of it for the wall). Of equal distances the wall, then the
    /// lower-numbered hole.
    ///
    /// The feature with the nearest box goes first (the wall's boxes are its chunks'), then
    /// every other one whose box is within the best distance so far plus
    /// [`polygon::rounding_slack`], so a feature skipped could neither win nor tie. A point
    /// outside the wall is never nearer a hole than the wall (the holes lie inside it), so
    /// the wall's chunk boxes bound its distance there too.
    pub fn nearest_feature(&self, p: Point) -> (usize, f32, Nearest) {
        let wall_id = self.holes.len();
        // The wall's bound last, after the holes': one per feature, within the capacity.
        let mut bounds: Vec<f32, { MAX_HOLES + 1 }> = Vec::new();
        bounds.extend(
            self.holes
                .iter()
                .map(|h| polygon::bbox_distance(h.bbox, p))
                .chain(core::iter::once(hollowpath_fpu::sqrtf(
                    self.wall.nearest_box2(p),
                ))),
        );
        // The wall ranks before every hole among equal distances.
        let rank = |k: usize| if k == wall_id { 0 } else { k + 1 };
        let first = (0..wall_id).fold(wall_id, |m, k| if bounds[k] < bounds[m] { k } else { m });
        let (d, n) = self.nearest_of(first, p);
        let mut best = (first, d, n);
        let slack = polygon::rounding_slack(p, self.wall.bbox);
        for k in (0..=wall_id).filter(|&k| k != first) {
            if bounds[k] > best.1 + slack {
                continue;
            }
            let (d, n) = self.nearest_of(k, p);
            if d < best.1 || (d == best.1 && rank(k) < rank(best.0)) {
                best = (k, d, n);
            }
        }
        best
    }

    /// Whether a road `width` wide centred at `p` stays in the material: inside the wall and
    /// outside every hole, half `width` from each (with a tolerance `tol`). For the road width
    /// this is [`Slice::is_printable`]; a narrower road may pass nearer a feature.
    pub fn fits(&self, p: Point, width: f32, tol: f32) -> bool {
        self.clearance(p) >= width * 0.5 - tol
    }

    /// Whether segment `ab` crosses or touches the boundary of a hole or of the wall.
    pub fn segment_crosses_feature(&self, a: Point, b: Point) -> bool {
        self.features_crossed(a, b).next().is_some()
    }

    /// The features (holes first, then the wall) whose boundary segment `ab` crosses or
    /// touches.
    pub fn features_crossed(&self, a: Point, b: Point) -> impl Iterator<Item = &Feature> {
        self.holes
            .iter()
            .chain(core::iter::once(&self.wall))
            .filter(move |f| f.segment_meets(a, b))
    }

    /// The point of segment `ab` nearest to a feature where that is closer than `clearance`,
    /// with its parameter along the segment; `None` if the whole segment keeps `clearance` from
    /// every feature. For a segment that crosses no feature boundary the nearest approach is
    /// at a feature's vertex (two segments are nearest at an end of one of them), so only
    /// vertices are looked at: exact, and cheap.
    pub fn segment_dip(&self, a: Point, b: Point, clearance: f32) -> Option<(f32, Point)> {
        let mut best: Option<(f32, f32, Point)> = None;
        self.vertices_near(a, b, clearance, |q| {
            let (c, t) = primitives::closest_on_segment(a, b, q);
            let d = c.dist(q);
            if d < clearance && best.is_none_or(|x| d < x.0) {
                best = Some((d, t, c));
            }
        });
        best.map(|(_, t, c)| (t, c))
    }

    /// Calls `f` with every feature vertex in the box of segment `ab` grown by `r`.
    fn vertices_near(&self, a: Point, b: Point, r: f32, mut f: impl FnMut(Point)) {
        let lo = Point::new(a.x.fmin(b.x) - r, a.y.fmin(b.y) - r);
        let hi = Point::new(a.x.fmax(b.x) + r, a.y.fmax(b.y) + r);
        // Only the chunks whose box meets the query's can hold such a vertex; the rest are
        // skipped, and the vertices come in the same order as over the whole polygon.
        let mut consider = |feature: &Feature| {
            for edges in feature.chunks_near((lo, hi)) {
                for (q, _) in edges {
                    if q.x >= lo.x && q.x <= hi.x && q.y >= lo.y && q.y <= hi.y {
                        f(q);
                    }
                }
            }
        };
        for h in self.holes.iter() {
            if polyline::boxes_overlap(h.bbox, (lo, hi), 0.0) {
                consider(h);
            }
        }
        consider(&self.wall);
    }

    /// [`Slice::segment_dip`] for a road whose half-width tapers linearly from `ra` at `a` to
    /// `rb` at `b`: the point of segment `ab` that comes nearest a feature relative to the
    /// half-width there (deepest into the road), with its parameter; `None` if every feature
    /// keeps clear of the road. For a feature vertex `q`, `|s(t) - q| - r(t)` is convex in `t`
    /// and least where its derivative vanishes, at the plain projection of `q` shifted by
    /// `k h / sqrt(1 - k^2)` along the segment (`k` the taper's slope, `h` the distance of `q`
    /// off the line), so each vertex is checked at one point.
    pub fn tapered_dip(&self, a: Point, b: Point, ra: f32, rb: f32) -> Option<(f32, Point)> {
        let ab = b - a;
        let len = ab.norm();
        let k = if len > 0.0 { (rb - ra) / len } else { 0.0 };
        let mut best: Option<(f32, f32, Point)> = None;
        self.vertices_near(a, b, ra.fmax(rb), |q| {
            let t = if len <= 0.0 {
                0.0
            } else if k.abs() >= 1.0 {
                // One end's disc holds the other's.
                if rb > ra {
                    1.0
                } else {
                    0.0
                }
            } else {
                let u = (q - a).dot(ab) / len;
                let h = libm::fabsf((q - a).cross(ab)) / len;
                ((u + k * h / hollowpath_fpu::sqrtf(1.0 - k * k)) / len).clamp(0.0, 1.0)
            };
            let c = a + ab * t;
            let depth = ra + (rb - ra) * t - c.dist(q);
            if depth > 0.0 && best.is_none_or(|x| depth > x.0) {
                best = Some((depth, t, c));
            }
        });
        best.map(|(_, t, c)| (t, c))
    }

    /// Whether every segment of the polyline `pts` is printable
    /// ([`segment_is_printable`](Self::segment_is_printable)), each point measured once. A
    /// polyline of one point has no segment, and passes.
    pub fn polyline_is_printable(&self, pts: &[Point], tol: f32) -> bool {
        let half = 0.5 * self.settings.road_width;
        (pts.len() < 2 || pts.iter().all(|&p| self.is_printable(p, tol)))
            && pts.windows(2).all(|w| {
                !self.segment_crosses_feature(w[0], w[1])
                    && self.segment_dip(w[0], w[1], half - tol).is_none()
            })
    }

    /// Whether the whole segment `ab` lies in the printable region (within `tol`): both ends
    /// printable, no feature boundary crossed, no feature nearer than half a road width.
    pub fn segment_is_printable(&self, a: Point, b: Point, tol: f32) -> bool {
        self.polyline_is_printable(&[a, b], tol)
    }
}

/// Storage for one slice, built in place: on a controller a [`Slice`] is 21 KiB (2.3 MiB in
/// the `large` build), and building one by value (returned through `Result`s and closures)
/// took a copy in every frame on the way; the application keeps one of these in its static
/// and the link's assembler builds the arriving slice straight into it.
///
/// ```
/// # std::thread::Builder::new().stack_size(256 << 20).spawn(|| {
/// use hollowpath::{geometry::Point, slice::SliceStore, Settings};
/// let square = |c: f32, r: f32| [Point::new(c - r, -r), Point::new(c + r, -r), Point::new(c + r, r), Point::new(c - r, r)];
/// let mut store = Box::new(SliceStore::new());
/// assert!(store.get().is_none());
/// let holes = [(&square(0.0, 2.0)[..], [0.0, 1.0, 0.0, 0.0])];
/// store.build_from_contours(&square(0.0, 8.0), [1.0, 0.0, 0.0, 0.0], &holes, Settings::default()).unwrap();
/// assert_eq!(store.get().unwrap().holes().len(), 1);
/// // A refused slice leaves nothing behind.
/// let outside = [(&square(20.0, 2.0)[..], [0.0, 1.0, 0.0, 0.0])];
/// assert!(store.build_from_contours(&square(0.0, 8.0), [1.0, 0.0, 0.0, 0.0], &outside, Settings::default()).is_err());
/// assert!(store.get().is_none());
/// # }).unwrap().join().unwrap();
/// ```
pub struct SliceStore {
    slice: Slice,
    valid: bool,
}

impl SliceStore {
    /// Empty storage (holding no slice).
    pub const fn new() -> SliceStore {
        SliceStore {
            slice: Slice::blank(),
            valid: false,
        }
    }

    /// The slice built last, unless the build failed or the store was cleared since.
    pub fn get(&self) -> Option<&Slice> {
        self.valid.then_some(&self.slice)
    }

    /// Forgets the slice.
    pub fn clear(&mut self) {
        self.valid = false;
    }

    /// Builds and validates a slice from raw contours into this storage, exactly as
    /// [`Slice::from_contours`] does; on error the store holds no slice.
    pub fn build_from_contours(
        &mut self,
        wall: &[Point],
        wall_material: Material,
        holes: &[(&[Point], Material)],
        settings: Settings,
    ) -> Result<&Slice, Error> {
        self.valid = false;
        self.slice
            .fill_from_contours(wall, wall_material, holes, settings)?;
        self.valid = true;
        Ok(&self.slice)
    }
}

impl Default for SliceStore {
    fn default() -> Self {
        Self::new()
    }
}
