//! The validated slice: the wall, the hollow features, their materials and the settings.
//!
//! A [`Slice`] can only be built through [`Slice::new`], which refuses every invalid input with
//! an [`Error`] naming the feature and the reason, so everything downstream may assume a valid
//! slice: simple polygons, counter-clockwise, holes strictly inside the wall and disjoint.

mod feature;
mod settings;

use feature::{distinct_consecutive, MIN_SIMPLIFY_TOLERANCE};
pub use feature::{Feature, Nearest};
pub use settings::Settings;

use heapless::Vec;

use crate::config::{CHANNELS, MAX_HOLES, SIMPLIFY_ABOVE_VERTICES};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, polyline, primitives, Point};
use crate::{Error, FeatureId, Limit};

/// A composition: one fraction per material channel, summing to 1.
pub type Material = [f32; CHANNELS];

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
        slice
            .fill_from_contours(wall, wall_material, holes, settings)
            .map_err(|e| slice.numbered_as_given(e, wall, holes))?;
        Ok(slice)
    }

    /// [`from_contours`](Self::from_contours) into this slice's own storage, with no
    /// slice-sized temporary (a controller's [`SliceStore`]). On error the slice holds
    /// whatever was built so far: not a valid slice, but the features the error's numbers
    /// count in ([`from_contours`](Self::from_contours) renumbers them as given,
    /// [`numbered_as_given`](Self::numbered_as_given); in here, or in the controller's
    /// [`SliceStore::build_from_contours`], that call grew the caller's frame by a feature,
    /// 3.4 KiB on the MCU, in every phase of the bench).
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

    /// `e` with its vertex and edge numbers counted in the contours as given rather than as
    /// stored (counter-clockwise, repeated points dropped, perhaps simplified), so that a
    /// message points at the file's own vertex: a stored vertex is the first given point at
    /// its place; a stored edge is the given edge that starts at its first end in the given
    /// contour's own direction. A number not found stays as stored.
    // Cold and not inlined: an error's path, kept out of the frame of the slice's callers.
    #[cold]
    #[inline(never)]
    fn numbered_as_given(&self, e: Error, wall: &[Point], holes: &[(&[Point], Material)]) -> Error {
        // Where feature `f`'s stored vertex `v` is in `given` (at most MAX_VERTICES stored,
        // and a given contour that long or longer is numbered within u16 by the capacity
        // check it passed).
        let vertex = |f: &Feature, given: &[Point], v: u16| -> u16 {
            f.points
                .get(v as usize)
                .and_then(|p| given.iter().position(|q| q == p))
                .and_then(|i| u16::try_from(i).ok())
                .unwrap_or(v)
        };
        // Stored edges run counter-clockwise; a clockwise contour was given the other way.
        let edge = |f: &Feature, given: &[Point], k: u16| -> u16 {
            let n = f.points.len();
            if polygon::double_area(given) < 0.0 && n > 0 {
                vertex(f, given, ((k as usize + 1) % n) as u16)
            } else {
                vertex(f, given, k)
            }
        };
        let hole = |h: u8| {
            (
                self.holes.get(h as usize),
                holes.get(h as usize).map(|g| g.0),
            )
        };
        match e {
            Error::HoleOutsideWall { hole: h, vertex: v } => match hole(h) {
                (Some(f), Some(given)) => Error::HoleOutsideWall {
                    hole: h,
                    vertex: vertex(f, given, v),
                },
                _ => e,
            },
            Error::HoleCrossesWall {
                hole: h,
                edge: k,
                wall_edge,
            } => match hole(h) {
                (Some(f), Some(given)) => Error::HoleCrossesWall {
                    hole: h,
                    edge: edge(f, given, k),
                    wall_edge: edge(&self.wall, wall, wall_edge),
                },
                _ => e,
            },
            other => other,
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

    /// Whether a hole other than those `skip` names lies within `d` of `p` (its signed distance
    /// at most `d`), measuring only the holes whose box lies within `d` (plus
    /// [`polygon::rounding_slack`]: a hole's distance is at least its box's, so one skipped
    /// is farther). With `d` negative, `p` would lie inside such a hole: every hole is
    /// measured.
    pub fn hole_within(&self, p: Point, d: f32, skip: impl Fn(usize) -> bool) -> bool {
        self.holes.iter().enumerate().any(|(c, h)| {
            if skip(c) {
                return false;
            }
            (d < 0.0 || h.box_within(p, d)) && h.signed_distance(p) <= d
        })
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
    /// [`Slice::from_contours`] does; on error the store holds no slice. An error's vertex and
    /// edge numbers count in the contours as stored (counter-clockwise, repeats dropped): the
    /// host, which validated them with [`Slice::from_contours`] first, names them as given.
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
