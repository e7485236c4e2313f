//! The offset spiral: the spiral layer with turns exactly a road width apart everywhere, joined
//! into one closed road.
//!
//! The paper's spiral (section 2.4) lays `S(t) = MCL_v(u)` turn after turn in each Voronoi
//! cell; with the same number of turns on every MCL, turns crowd on short MCLs and part on long
//! ones ([`ControlFunction`](super::spiral::ControlFunction)). Here `f` is chosen so that every
//! turn lies at a fixed *distance* from the features: turn `k` is the level curve
//! `D = w/2 + k w` of the distance `D` to the nearest feature (the hollow features and the
//! wall). Inside the cell of feature `i`, `D` is the distance to feature `i`, so a turn is the
//! cell's MCLs cut at one distance from their feature; at a bisector it meets the neighbouring
//! cell's turn of the same distance (the bisector is where the two distances agree), so the
//! cells' turns join where they touch; near the wall the turns follow the wall.
//!
//! Adjacent turns are exactly a road width apart, so they neither overlap nor leave gaps. The
//! turns are closed loops; two loops a road width apart are joined into one by cutting a
//! half-road gap into each at a place where they run side by side and bridging the gaps
//! (two short roads across, like one step of a zigzag). Joining the loops along a spanning tree
//! of their side-by-side adjacency makes one closed road: the whole layer is one extrusion
//! start. Only loops that touch no other loop (none on the reference slices) are reached by
//! travel, and counted as jumps.
//!
//! The loops are traced by marching squares on a grid of `D` and each point is put exactly on
//! its level by Newton steps along the distance gradient. The composition at every vertex is
//! the plan's blended field ([`BlendedField`]): exactly a feature's material on its keep-out
//! curve.

use super::despike::{finish, Despike};
use core::ops::Range;

use heapless::Vec;

use crate::config::{CONTOUR_POINTS, GRID_NODES, MAX_LOOPS, MAX_SITES};
use crate::digest::Fnv;
use crate::geometry::{polygon, Grid, Point};
use crate::toolpath::composition::BlendedField;
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Limit, Material, Plan, Settings, Slice};

/// How far beyond the keep-out curve the first turn lies, mm: the chords of a turn may cut
/// that far into it without touching a feature's keep-out band.
const FIRST_TURN_MARGIN: f32 = 3e-3;
/// Bisection steps locating a level on a grid edge where Newton steps run off (an edge of
/// 0.1 mm to 6 nm).
const EDGE_BISECTIONS: u32 = 24;
/// How many times a chord between two traced points of a turn is halved, at most, to keep
/// it within [`SIMPLIFY_TOL`] of the turn (a chord 16 times shorter sags 256 times less).
const REFINE_DEPTH: u32 = 4;
/// Largest deviation of a simplified turn from the traced one, mm.
const SIMPLIFY_TOL: f32 = 2e-3;
/// Loops shorter than this many road widths are too small to turn in and are left out.
const MIN_LOOP_ROADS: f32 = 1.0;
/// Loops shorter than this many road widths (small loops at peaks of `D`) are laid only where
/// a join reaches them: a road of their own is not worth an extrusion start.
const OPTIONAL_LOOP_ROADS: f32 = 2.5;
/// How far (road widths) a loop's point, stepped a road width down the distance gradient, may
/// land from the loop below for the two to count as side by side.
const STRICT_TOL: f32 = 0.05;
/// The lengths of the gap a join cuts into each loop, road widths, in the order tried: the
/// two bridges across are this far apart. A full road first: the bridges then neither
/// overlap each other nor leave more bare than the four outer corners a round nozzle rounds
/// off where the road turns onto a bridge. Where a loop has no room for that (a small loop at
/// a peak of `D`), half a road: the bridges overlap by half a road, but the loop is joined
/// rather than left out or reached by travel. On 60 random slices the full-road gap halved
/// the spiral's median overfill (0.036 to 0.020) for 0.5 % coverage.
const BRIDGE_GAPS: [f32; 2] = [1.0, 0.5];
/// The same, for the second try at loops that no strict join reaches.
const RELAXED_TOL: f32 = 0.3;
/// Bisection steps locating a ridge within a road width (`w / 2^14`: 0.02 µm at 0.4 mm).
const RIDGE_STEPS: u32 = 14;
/// How much a feature's own distance along its normal may fall short of growing with the step
/// before the step counts as past one of its own ridges, in road widths. A polygon's every
/// convex-from-inside vertex (the wall's, a round hole's inside) starts a ridge of its own
/// where its two edges are equally near, but the shortfall beyond it grows only as
/// `t (1 - cos a)` for the small turn `a` at the vertex: about 1e-3 t on the reference slices'
/// polygons, well under this. Two parts of a non-convex feature facing each other fall short
/// at a good fraction of `t`.
const RIDGE_TOL_PER_ROAD: f32 = 0.01;
/// Where a turn's road widens, the longest straight piece it is laid in, road widths.
const WIDTH_STEP: f32 = 0.5;
/// How far short of a ridge a widened road stops, mm: the chords of the two sides' roads may
/// cross it by their sagitta.
const RIDGE_MARGIN: f32 = 2e-3;

/// Counters of an offset-spiral layer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OffsetStats {
    /// Distance levels traced (the top one may hold only small loops that were left out).
    pub levels: u16,
    /// Closed loops traced over all levels.
    pub loops: u16,
    /// Loops joined to a neighbour by a bridge (each one saves an extrusion start).
    pub joins: u16,
    /// Loops reached by travel because they touch no loop already in the road.
    pub jumps: u16,
    /// Loops left out: too small to turn in, or small and reached by no join.
    pub dropped: u16,
}

/// One traced loop: a run of `points`, closed.
#[derive(Clone, Copy, Debug)]
struct Loop {
    start: u16,
    len: u16,
    level: u16,
    length: f32,
    bbox: (Point, Point),
    /// The site that joins it to the loop it was reached from (`NONE` for a root).
    parent: u16,
    visited: bool,
    /// Small: laid only if a join reaches it.
    optional: bool,
}

/// A join of two loops `a` and `b` running side by side: the gap `[a1, a2]` (arc length, in
/// `a`'s direction) faces the gap `[b1, b2]` on `b`; bridges `a1-b1` and `a2-b2`.
#[derive(Clone, Copy, Debug)]
struct Site {
    a: u16,
    a1: f32,
    a2: f32,
    b: u16,
    b1: f32,
    b2: f32,
}

/// A loop being walked: where the walk is, which way, how much is left, and the site it was
/// entered by (not to be taken again).
#[derive(Clone, Copy, Debug)]
struct Frame {
    lp: u16,
    pos: f32,
    forward: bool,
    remaining: f32,
    entered_by: u16,
}

const NONE: u16 = u16::MAX;
// A loop's start and length in `points` are `u16`.
const _: () = assert!(CONTOUR_POINTS <= u16::MAX as usize);

/// Points of a loop whose segments share one box of [`OffsetSpiral`]'s `runs`.
const RUN: usize = 16;
/// Runs of all the loops' points.
const RUNS: usize = CONTOUR_POINTS.div_ceil(RUN);

/// The offset spiral's working memory (about 200 KiB: the distance grid and the loops), meant
/// to live in a `static` on the MCU like the [`Planner`](crate::Planner).
///
/// ```
/// # // The host build's capacities take megabytes: run on a large stack.
/// # std::thread::Builder::new().stack_size(256 << 20).spawn(|| {
/// use hollowpath::geometry::Point;
/// use hollowpath::toolpath::offset::OffsetSpiral;
/// use hollowpath::toolpath::Vertex;
/// use hollowpath::{Feature, FeatureId, Planner, Settings, Slice};
/// let circle = |c: Point, r: f32, n: usize| -> Vec<Point> {
///     (0..n).map(|k| {
///         let a = k as f32 / n as f32 * std::f32::consts::TAU;
///         Point::new(c.x + r * a.cos(), c.y + r * a.sin())
///     }).collect()
/// };
/// let wall = Feature::new(FeatureId::Wall, &circle(Point::new(0.0, 0.0), 8.0, 64), [1.0, 0.0, 0.0, 0.0]).unwrap();
/// let hole = Feature::new(FeatureId::Hole(0), &circle(Point::new(0.5, 0.0), 4.0, 48), [0.0, 1.0, 0.0, 0.0]).unwrap();
/// let slice = Slice::new(wall, &[hole], Settings::default()).unwrap();
/// let plan = Box::new(Planner::new()).plan(&slice).unwrap().clone();
/// let mut work = Box::new(OffsetSpiral::new());
/// let mut path = Box::new(hollowpath::heapless::Vec::<Vertex, 65_536>::new());
/// let stats = work.build(&slice, &plan, &mut *path).unwrap();
/// // One road: the first vertex is reached by travel, every later move deposits.
/// assert!(path[1..].iter().all(|v| v.deposit));
/// assert_eq!(stats.jumps, 0);
/// # }).unwrap().join().unwrap();
/// ```
pub struct OffsetSpiral {
    grid: Grid,
    d: Vec<f32, GRID_NODES>,
    marks: Vec<u8, GRID_NODES>,
    points: Vec<Point, CONTOUR_POINTS>,
    arc: Vec<f32, CONTOUR_POINTS>,
    /// The box around the segments starting at points `RUN r .. RUN (r + 1)` of `points`
    /// (each segment's end included; a run two loops share holds both loops' segments): a
    /// search along a loop skips the runs whose box is too far.
    runs: Vec<(Point, Point), RUNS>,
    loops: Vec<Loop, MAX_LOOPS>,
    sites: Vec<Site, MAX_SITES>,
    stack: Vec<Frame, MAX_LOOPS>,
    queue: Vec<u16, MAX_LOOPS>,
    /// The bridge gaps [`find_site`](Self::find_site) tries: [`BRIDGE_GAPS`] from this index
    /// on. An index, not a slice: a pointer would make the initial value non-zero, and the
    /// firmware's static (200 KiB) would be stored in flash as `.data` instead of zeroed `.bss`.
    gaps_from: u8,
    /// The slice the loops and joins above were prepared for (its [`Prepared`] key) and
    /// the figures of that preparation: [`build`](Self::build) on the same slice again
    /// only walks them.
    prepared: Option<(Prepared, OffsetStats)>,
}

/// What the preparation of a slice's loops and joins depends on: its contours (as IEEE
/// bits) and its settings.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Prepared {
    digest: u64,
    settings: Settings,
}

impl Prepared {
    fn of(slice: &Slice) -> Prepared {
        let mut h = Fnv::new();
        for f in core::iter::once(slice.wall()).chain(slice.holes().iter()) {
            // At most MAX_VERTICES points a contour (asserted in `config`).
            h.word(f.points().len() as u32);
            for &p in f.points() {
                h.point(p);
            }
        }
        Prepared {
            digest: h.finish(),
            settings: *slice.settings(),
        }
    }
}

impl Default for OffsetSpiral {
    fn default() -> Self {
        Self::new()
    }
}

/// The feature nearest to `p` (a hole index, or `holes` for the wall), the distance `D` to it
/// (positive in the material) and its gradient.
fn nearest(slice: &Slice, p: Point) -> (usize, f32, Point) {
    let nw = slice.wall().nearest(p);
    let mut best = (slice.holes().len(), -nw.distance, -nw.gradient(p));
    for (k, h) in slice.holes().iter().enumerate() {
        if polygon::bbox_distance(h.bbox(), p) >= best.1 {
            continue;
        }
        let n = h.nearest(p);
        if n.distance < best.1 {
            best = (k, n.distance, n.gradient(p));
        }
    }
    best
}

/// The material of feature `f` (a hole index, or `holes` for the wall).
fn material_of(slice: &Slice, f: usize) -> Material {
    slice
        .holes()
        .get(f)
        .map_or(slice.wall().material(), |h| h.material())
}

/// The distance `D` from `p` to the nearest feature (positive in the material), its gradient,
/// and the material of that feature.
fn distance(slice: &Slice, p: Point) -> (f32, Point, Material) {
    let (f, d, g) = nearest(slice, p);
    (d, g, material_of(slice, f))
}

/// The distance from `p` to feature `f` (as [`feature_distance`]) and its gradient.
fn feature_distance_gradient(slice: &Slice, f: usize, p: Point) -> (f32, Point) {
    match slice.holes().get(f) {
        Some(h) => {
            let n = h.nearest(p);
            (n.distance, n.gradient(p))
        }
        None => {
            let n = slice.wall().nearest(p);
            (-n.distance, -n.gradient(p))
        }
    }
}

/// Where the level `level` of features `fa` and `fb` meet (the corner of the turn at the
/// ridge between them), by Newton steps on both distances from `p0`, if the steps converge
/// within `reach` of `p0` onto a point no other feature is nearer to.
fn level_corner(
    slice: &Slice,
    (fa, fb): (usize, usize),
    p0: Point,
    level: f32,
    reach: f32,
) -> Option<Point> {
    let mut p = p0;
    for _ in 0..8 {
        let (da, ga) = feature_distance_gradient(slice, fa, p);
        let (db, gb) = feature_distance_gradient(slice, fb, p);
        let (ra, rb) = (level - da, level - db);
        if ra.abs() < 1e-6 && rb.abs() < 1e-6 {
            break;
        }
        // Solve [ga; gb] x = [ra; rb].
        let det = ga.x * gb.y - ga.y * gb.x;
        if det.abs() < 1e-3 {
            return None;
        }
        p = p + Point::new((ra * gb.y - rb * ga.y) / det, (ga.x * rb - gb.x * ra) / det);
        if !p.is_finite() || p.dist(p0) > reach {
            return None;
        }
    }
    let (f, d, _) = nearest(slice, p);
    ((f == fa || f == fb) && (d - level).abs() < 1e-5).then_some(p)
}

/// The distance from `p` to feature `f` (a hole index, or `holes` for the wall), positive in
/// the material.
fn feature_distance(slice: &Slice, f: usize, p: Point) -> f32 {
    match slice.holes().get(f) {
        Some(h) => h.nearest(p).distance,
        None => -slice.wall().nearest(p).distance,
    }
}

/// A turn's point `p` widened into the gap it leaves before a ridge, and the road width there;
/// `own`, `d` and `n` are its nearest feature, the distance to it and the gradient
/// ([`nearest`]).
///
/// Turns lie at fixed distances from the features, so where two features' turns meet at the
/// ridge between them (the bisector, where the distances agree) the last turn on each side
/// leaves a sliver narrower than a road. Along the distance gradient `n` from `p` (a straight
/// line inside the feature's cell), the ridge lies where another feature's distance `D_j(p + t
/// n)` drops to `D(p) + t` (or the feature's own distance falls behind `D(p) + t`, at a ridge
/// between two parts of one non-convex feature); the function `D_j(p + t n) - D(p) - t` only
/// falls (`D_j` is 1-Lipschitz), so bisection finds it. If it lies closer than a road width `w`
/// there is no next turn beyond `p`: the road widens by the sliver `g` (the ridge's distance
/// beyond the
/// road's outer edge, `t - w/2`) and its centre moves `g/2` outward, so its inner edge stays
/// where it was and its outer edge reaches the ridge, where the other side's last turn, widened
/// the same way, meets it. Where the next turn does cross the ray but was left out (a small
/// loop no join reached, `laid(q, level)` false at its crossing `q`), the road widens the same
/// way as far as [`Settings::max_width`] allows. The road is never wider than
/// [`Settings::max_width`], and half its width never exceeds its clearance (`D` grows by `g/2`,
/// and every other feature is at least that far: it is farther than the ridge).
///
/// [`Settings::max_width`]: crate::Settings::max_width
fn widened(
    slice: &Slice,
    p: Point,
    (own, d, n): (usize, f32, Point),
    laid: impl Fn(Point, u16, f32) -> bool,
) -> (Point, f32) {
    let w = slice.settings().road_width;
    let holes = slice.holes().len();
    let len = n.norm();
    if len < 1e-6 {
        return (p, w);
    }
    let n = n * (1.0 / len);
    // The nearest ridge along `n` within reach of the widest road's outer edge.
    let gap = |f: usize, t: f32| feature_distance(slice, f, p + n * t) - d - t;
    // The ridge is looked for as far as a turn can be missing: beyond a road width out the
    // next turn crosses the ray, and the road widens only where that turn was left out (or
    // never traced: a sliver of a level too thin for the grid near a saddle of `D`). The
    // widening itself stops at `max_width`, short of a far ridge: a partial fill of a gap
    // wider than the widest road still covers most of it.
    let reach = (slice.settings().max_width - 0.5 * w).max(2.0 * w) + RIDGE_MARGIN;
    let mut ridge = reach;
    for f in 0..=holes {
        // The feature's own ridges count too (a non-convex feature's parts face each other):
        // along its own normal its distance grows exactly with `t` until one, to rounding.
        let tol = if f == own {
            RIDGE_TOL_PER_ROAD * w
        } else {
            0.0
        };
        // A hole whose box is at least `d + 2 reach` away is farther than `d + t` from every
        // point of the ray within reach (its distance falls by at most `t`).
        let far = slice
            .holes()
            .get(f)
            .is_some_and(|h| f != own && polygon::bbox_distance(h.bbox(), p) >= d + 2.0 * reach);
        if far || gap(f, ridge) >= -tol {
            continue;
        }
        let (mut lo, mut hi) = (0.0f32, ridge);
        for _ in 0..RIDGE_STEPS {
            let mid = 0.5 * (lo + hi);
            if gap(f, mid) >= -tol {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        ridge = lo;
    }
    let g = (ridge - 0.5 * w - RIDGE_MARGIN).min(slice.settings().max_width - w);
    if g <= 0.0 {
        return (p, w);
    }
    // The next turn crosses the ray a road width out: widen only if it was left out, and
    // only as far as the widened road keeps off every laid piece of that turn (near a corner
    // of the next turn, where it meets another feature's turn at the ridge, the traced turn
    // cuts the corner and passes the ray's point at a distance).
    let next = if ridge >= w {
        // A float-to-int `as` saturates: a level beyond `u16::MAX` (a slice 650 m deep at the
        // finest road) would only be clipped, never wrapped.
        let level = libm::roundf((d - 0.5 * w - FIRST_TURN_MARGIN) / w).max(0.0) as u16 + 1;
        if laid(p + n * w, level, LAID_TOL * w) {
            return (p, w);
        }
        Some(level)
    } else {
        None
    };
    // Where the ridge bends toward the road (near a corner where two features' turns meet),
    // the widened road's round edge would cross it sideways onto the other side's road:
    // widen less, or not at all.
    let in_cell = |q: Point| {
        let mine = feature_distance(slice, own, q);
        (0..=holes).all(|f| f == own || feature_distance(slice, f, q) >= mine)
    };
    let mut g = g;
    for _ in 0..WIDEN_TRIES {
        let (c, r) = (p + n * (0.5 * g), 0.5 * (w + g));
        if next.is_none_or(|level| !laid(c, level, r + 0.5 * w))
            && EDGE_DIRECTIONS
                .iter()
                .all(|&(x, y)| in_cell(c + Point::new(x, y) * r))
        {
            return (c, w + g);
        }
        g *= 0.5;
    }
    (p, w)
}

/// Directions (unit vectors, every 30 degrees) in which a widened road's edge must stay in
/// its feature's cell.
const EDGE_DIRECTIONS: [(f32, f32); 12] = [
    (1.0, 0.0),
    (0.866_025_4, 0.5),
    (0.5, 0.866_025_4),
    (0.0, 1.0),
    (-0.5, 0.866_025_4),
    (-0.866_025_4, 0.5),
    (-1.0, 0.0),
    (-0.866_025_4, -0.5),
    (-0.5, -0.866_025_4),
    (0.0, -1.0),
    (0.5, -0.866_025_4),
    (0.866_025_4, -0.5),
];
/// How near (road widths) a laid turn must pass the point a road width out along the distance
/// gradient for the next turn to count as laid there.
const LAID_TOL: f32 = 0.1;
/// How many times a widening that crosses the ridge sideways is halved before it is given up.
const WIDEN_TRIES: u32 = 3;

/// `x` wrapped into `[0, len)`.
fn wrap(x: f32, len: f32) -> f32 {
    let r = libm::fmodf(x, len);
    if r < 0.0 {
        r + len
    } else {
        r
    }
}

fn capacity(limit: Limit) -> Error {
    Error::Capacity {
        limit,
        feature: None,
    }
}

impl OffsetSpiral {
    /// Empty working memory (no allocation: the buffers are inline).
    pub const fn new() -> OffsetSpiral {
        OffsetSpiral {
            grid: Grid {
                origin: Point::new(0.0, 0.0),
                h: 0.0,
                nx: 0,
                ny: 0,
            },
            d: Vec::new(),
            marks: Vec::new(),
            points: Vec::new(),
            arc: Vec::new(),
            runs: Vec::new(),
            loops: Vec::new(),
            sites: Vec::new(),
            stack: Vec::new(),
            queue: Vec::new(),
            gaps_from: 0,
            prepared: None,
        }
    }

    /// The bridge gaps [`find_site`](Self::find_site) tries now.
    fn gaps(&self) -> &'static [f32] {
        &BRIDGE_GAPS[(self.gaps_from as usize).min(BRIDGE_GAPS.len())..]
    }

    /// Writes the offset-spiral layer of `slice` into `sink`, with the composition of
    /// `plan`'s blended field. The loops and joins are [`prepare`](Self::prepare)d first,
    /// unless they already were for this slice (every odd layer of a job walks the same
    /// ones): then the first vertex comes without that work.
    pub fn build(
        &mut self,
        slice: &Slice,
        plan: &Plan,
        sink: &mut impl PathSink,
    ) -> Result<OffsetStats, Error> {
        let mut stats = self.prepare(slice)?;
        let mut despiked = Despike::new(sink, slice.settings().road_width);
        self.walk_all(slice, plan, &mut despiked, &mut stats)?;
        finish(&mut despiked)?;
        Ok(stats)
    }

    /// Samples the distance field, traces its loops and joins them (all the layer's work
    /// before its first vertex), unless that was done for this very slice already; the
    /// figures of the preparation. A controller calls it after planning, so that the
    /// spiral layers start at once.
    pub fn prepare(&mut self, slice: &Slice) -> Result<OffsetStats, Error> {
        let key = Prepared::of(slice);
        if let Some((k, stats)) = self.prepared {
            if k == key {
                return Ok(stats);
            }
        }
        self.prepared = None;
        let mut stats = OffsetStats::default();
        self.sample(slice)?;
        self.trace_all(slice, &mut stats)?;
        self.join(slice, &mut stats)?;
        self.prepared = Some((key, stats));
        Ok(stats)
    }

    /// Samples `D` on a grid over the wall, half a road width apart or coarser.
    fn sample(&mut self, slice: &Slice) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let (lo, hi) = slice.wall().bbox();
        // As the field's grid: the spacing from the slice and the road only, the capacity
        // only decides whether it fits.
        self.grid = crate::field::fitted_grid(lo, hi, 0.5 * w, w, true)?;
        self.d.clear();
        self.marks.clear();
        for k in 0..self.grid.len() {
            let (d, _, _) = distance(slice, self.grid.node(k));
            self.d.push(d).map_err(|_| capacity(Limit::GridNodes))?;
            self.marks.push(0).map_err(|_| capacity(Limit::GridNodes))?;
        }
        Ok(())
    }

    /// Traces the loops of every level `w/2 + k w` that some node reaches.
    fn trace_all(&mut self, slice: &Slice, stats: &mut OffsetStats) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let top = self.d.iter().fold(0.0f32, |a, &b| a.max(b));
        self.points.clear();
        self.arc.clear();
        self.runs.clear();
        self.loops.clear();
        let mut k = 0u16;
        loop {
            let level = 0.5 * w + FIRST_TURN_MARGIN + k as f32 * w;
            if level >= top {
                break;
            }
            for m in self.marks.iter_mut() {
                *m = 0;
            }
            let (nx, ny) = (self.grid.nx, self.grid.ny);
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    for e in 0..4u8 {
                        let c = j * nx + i;
                        if self.is_entry(c, e, level) && self.marks[c] & (1 << e) == 0 {
                            self.trace(slice, c, e, level, k, stats)?;
                        }
                    }
                }
            }
            k += 1;
        }
        stats.levels = k;
        Ok(())
    }

    /// Values at the corners of cell `c` (lower-left node `c`), counter-clockwise.
    fn corners(&self, c: usize) -> [f32; 4] {
        let nx = self.grid.nx;
        [self.d[c], self.d[c + 1], self.d[c + nx + 1], self.d[c + nx]]
    }

    /// Whether the level curve enters cell `c` through edge `e` (corner `e` above the level,
    /// corner `e + 1` below: the material above the level stays on the curve's left).
    fn is_entry(&self, c: usize, e: u8, level: f32) -> bool {
        let v = self.corners(c);
        v[e as usize] > level && v[(e as usize + 1) % 4] <= level
    }

    /// The edge the curve entering cell `c` through `e` leaves by.
    fn exit(&self, c: usize, e: u8, level: f32) -> u8 {
        let v = self.corners(c);
        let above = |k: usize| v[k % 4] > level;
        let saddle = above(0) == above(2) && above(1) == above(3) && above(0) != above(1);
        if saddle {
            let centre = 0.25 * (v[0] + v[1] + v[2] + v[3]);
            return if centre > level {
                (e + 1) % 4
            } else {
                (e + 3) % 4
            };
        }
        (0..4u8)
            .find(|&x| !above(x as usize) && above(x as usize + 1))
            .unwrap_or((e + 1) % 4)
    }

    /// The point where the level crosses edge `e` of cell `c`, put onto the level exactly.
    fn crossing(&self, slice: &Slice, c: usize, e: u8, level: f32) -> Point {
        let nx = self.grid.nx;
        let node = [c, c + 1, c + nx + 1, c + nx];
        let (a, b) = (node[e as usize], node[(e as usize + 1) % 4]);
        let (da, db) = (self.d[a], self.d[b]);
        let t = ((level - da) / (db - da)).clamp(0.0, 1.0);
        let (na, nb) = (self.grid.node(a), self.grid.node(b));
        let p0 = na.lerp(nb, t);
        // Where the steps run off (near a ridge or a peak of D), the level is found on the
        // grid edge itself by bisection on the exact distance (the nodes' samples straddle
        // it).
        self.on_level(slice, p0, level).unwrap_or_else(|| {
            let below = distance(slice, na).0 < level;
            let (mut lo, mut hi) = (0.0f32, 1.0f32);
            for _ in 0..EDGE_BISECTIONS {
                let mid = 0.5 * (lo + hi);
                if (distance(slice, na.lerp(nb, mid)).0 < level) == below {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            na.lerp(nb, 0.5 * (lo + hi))
        })
    }

    /// The point of the level `level` nearest `p0` by Newton steps along the distance
    /// gradient, or `None` where the steps run off (near a ridge of `D`).
    fn on_level(&self, slice: &Slice, p0: Point, level: f32) -> Option<Point> {
        let mut p = p0;
        for _ in 0..4 {
            let (d, g, _) = distance(slice, p);
            let step = level - d;
            p = p + g * step;
            if step.abs() < 1e-6 {
                break;
            }
        }
        (p.dist(p0) <= self.grid.h && p.is_finite()).then_some(p)
    }

    /// Pushes the points of level `level` between the traced points `a` and `b` that keep
    /// the chords within [`SIMPLIFY_TOL`] of the level: where the grid is coarse for the
    /// level's curvature (a road a good fraction of the slice wide, whose grid is coarse too)
    /// the chord between two grid crossings would cut into the turn's clearance, and at a
    /// corner of the level (where it meets another feature's at a ridge) it would cut the
    /// corner off.
    fn refine(
        &mut self,
        slice: &Slice,
        a: Point,
        b: Point,
        level: f32,
        depth: u32,
    ) -> Result<(), Error> {
        if depth == 0 {
            return Ok(());
        }
        let mid = a.lerp(b, 0.5);
        // Across a ridge the level has a corner: put it in exactly (the chord across a
        // corner of the turn would cut it off, and neither end's steps reach it).
        let (fa, fb) = (nearest(slice, a).0, nearest(slice, b).0);
        if fa != fb {
            if let Some(c) = level_corner(slice, (fa, fb), mid, level, a.dist(b)) {
                if c.dist(a) > 1e-4 && c.dist(b) > 1e-4 {
                    self.refine(slice, a, c, level, depth - 1)?;
                    self.points
                        .push(c)
                        .map_err(|_| capacity(Limit::ContourPoints))?;
                    return self.refine(slice, c, b, level, depth - 1);
                }
            }
        }
        let Some(m) = self.on_level(slice, mid, level) else {
            return Ok(());
        };
        if m.dist(mid) <= 0.5 * SIMPLIFY_TOL {
            return Ok(());
        }
        self.refine(slice, a, m, level, depth - 1)?;
        self.points
            .push(m)
            .map_err(|_| capacity(Limit::ContourPoints))?;
        self.refine(slice, m, b, level, depth - 1)
    }

    /// Traces one loop from cell `c0`, entry edge `e0`, simplifies it and records it.
    fn trace(
        &mut self,
        slice: &Slice,
        c0: usize,
        e0: u8,
        level: f32,
        k: u16,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let start = self.points.len();
        let (nx, ny) = (self.grid.nx, self.grid.ny);
        let (mut c, mut e) = (c0, e0);
        for _ in 0..4 * self.grid.len() {
            self.marks[c] |= 1 << e;
            let x = self.exit(c, e, level);
            let p = self.crossing(slice, c, x, level);
            if self.points.last() != Some(&p) {
                if let Some(&prev) = self.points[start..].last() {
                    self.refine(slice, prev, p, level, REFINE_DEPTH)?;
                }
                self.points
                    .push(p)
                    .map_err(|_| capacity(Limit::ContourPoints))?;
            }
            let (i, j) = (c % nx, c / nx);
            let next = match x {
                0 if j > 0 => c - nx,
                1 if i + 2 < nx => c + 1,
                2 if j + 2 < ny => c + nx,
                3 if i > 0 => c - 1,
                // The grid has a border of nodes outside the wall, below every level.
                _ => break,
            };
            c = next;
            e = (x + 2) % 4;
            if c == c0 && e == e0 {
                break;
            }
        }
        if let (Some(&first), Some(&last)) = (self.points.get(start), self.points.last()) {
            if self.points.len() > start + 1 {
                self.refine(slice, last, first, level, REFINE_DEPTH)?;
            }
        }
        let len = simplify_closed(&mut self.points, start, SIMPLIFY_TOL);
        self.points.truncate(start + len);
        stats.loops += 1;
        // Arc lengths and box.
        let pts = &self.points[start..];
        let mut s = 0.0;
        let mut bbox = (pts[0], pts[0]);
        self.arc.truncate(start);
        for (m, &p) in pts.iter().enumerate() {
            if m > 0 {
                s += pts[m - 1].dist(p);
            }
            bbox = (
                Point::new(bbox.0.x.min(p.x), bbox.0.y.min(p.y)),
                Point::new(bbox.1.x.max(p.x), bbox.1.y.max(p.y)),
            );
            self.arc
                .push(s)
                .map_err(|_| capacity(Limit::ContourPoints))?;
        }
        let length = s + pts[pts.len() - 1].dist(pts[0]);
        if pts.len() < 3 || length < MIN_LOOP_ROADS * w {
            self.points.truncate(start);
            self.arc.truncate(start);
            stats.dropped += 1;
            return Ok(());
        }
        self.loops
            .push(Loop {
                start: start as u16,
                len: len as u16,
                level: k,
                length,
                bbox,
                parent: NONE,
                visited: false,
                optional: length < OPTIONAL_LOOP_ROADS * w,
            })
            .map_err(|_| capacity(Limit::ContourLoops))?;
        self.add_runs(start, len)
    }

    fn pts(&self, l: usize) -> &[Point] {
        let lp = &self.loops[l];
        &self.points[lp.start as usize..(lp.start + lp.len) as usize]
    }

    fn arcs(&self, l: usize) -> &[f32] {
        let lp = &self.loops[l];
        &self.arc[lp.start as usize..(lp.start + lp.len) as usize]
    }

    /// The point of loop `l` at arc length `s`.
    fn at(&self, l: usize, s: f32) -> Point {
        let (pts, arc) = (self.pts(l), self.arcs(l));
        let len = self.loops[l].length;
        let s = wrap(s, len);
        let k = arc.partition_point(|&a| a <= s).max(1) - 1;
        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
        let (sa, sb) = (arc[k], if k + 1 < arc.len() { arc[k + 1] } else { len });
        let t = if sb > sa { (s - sa) / (sb - sa) } else { 0.0 };
        a.lerp(b, t.clamp(0.0, 1.0))
    }

    /// Adds the segments of loop `start .. start + n` of `points` to the boxes of their runs.
    fn add_runs(&mut self, start: usize, n: usize) -> Result<(), Error> {
        const EMPTY: (Point, Point) = (
            Point::new(f32::INFINITY, f32::INFINITY),
            Point::new(f32::NEG_INFINITY, f32::NEG_INFINITY),
        );
        for k in 0..n {
            let r = (start + k) / RUN;
            while self.runs.len() <= r {
                self.runs
                    .push(EMPTY)
                    .map_err(|_| capacity(Limit::ContourPoints))?;
            }
            let b = &mut self.runs[r];
            for q in [self.points[start + k], self.points[start + (k + 1) % n]] {
                b.0 = Point::new(b.0.x.min(q.x), b.0.y.min(q.y));
                b.1 = Point::new(b.1.x.max(q.x), b.1.y.max(q.y));
            }
        }
        Ok(())
    }

    /// The runs of loop `l`'s segments: (the run's box, the range of segment indices of the
    /// loop in it), in the loop's order.
    fn loop_runs(&self, l: usize) -> impl Iterator<Item = ((Point, Point), Range<usize>)> + '_ {
        let (start, n) = (self.loops[l].start as usize, self.loops[l].len as usize);
        (start / RUN..(start + n).div_ceil(RUN)).map(move |r| {
            let (a, b) = ((r * RUN).max(start), ((r + 1) * RUN).min(start + n));
            (self.runs[r], a - start..b - start)
        })
    }

    /// The arc length of the point of loop `l` nearest `p`, and the distance: of equal
    /// distances, the first along the loop. The run of segments whose box is nearest is
    /// measured first, then the runs whose box is no farther than the best so far.
    fn project(&self, l: usize, p: Point) -> (f32, f32) {
        let (pts, arc) = (self.pts(l), self.arcs(l));
        let len = self.loops[l].length;
        let n = pts.len();
        // (arc length, distance, segment)
        let visit = |ks: Range<usize>, best: &mut (f32, f32, usize)| {
            for k in ks {
                let (a, b) = (pts[k], pts[(k + 1) % n]);
                let (q, t) = crate::geometry::polyline::closest_on_segment(a, b, p);
                let d = q.dist(p);
                if d < best.1 || (d == best.1 && k < best.2) {
                    let sb = if k + 1 < n { arc[k + 1] } else { len };
                    *best = (arc[k] + t * (sb - arc[k]), d, k);
                }
            }
        };
        let nearest_run = self
            .loop_runs(l)
            .map(|(b, ks)| (polygon::bbox_distance2(b, p), ks))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let Some((_, first)) = nearest_run else {
            return (0.0, f32::INFINITY);
        };
        let mut best = (0.0, f32::INFINITY, usize::MAX);
        visit(first.clone(), &mut best);
        for (b, ks) in self.loop_runs(l) {
            if ks != first && polygon::bbox_distance(b, p) <= best.1 + polygon::rounding_slack(p, b)
            {
                visit(ks, &mut best);
            }
        }
        (best.0, best.1)
    }

    /// The loop one level below `l` that the point `p` of `l` faces a road width away, with
    /// the arc length there.
    /// `tol` is how far (in road widths) from the lower loop the back-projection may land.
    fn below(&self, slice: &Slice, l: usize, p: Point, tol: f32) -> Option<(usize, f32)> {
        let w = slice.settings().road_width;
        let level = self.loops[l].level;
        if level == 0 {
            return None;
        }
        let (_, g, _) = distance(slice, p);
        let q = p - g * w;
        let tol = tol * w;
        let mut best: Option<(usize, f32, f32)> = None;
        for (m, lp) in self.loops.iter().enumerate() {
            if lp.level + 1 != level || polygon::bbox_distance(lp.bbox, q) > tol {
                continue;
            }
            let (s, d) = self.project(m, q);
            if d < tol && best.is_none_or(|b| d < b.2) {
                best = Some((m, s, d));
            }
        }
        best.map(|(m, s, _)| (m, s))
    }

    /// Whether `[s1, s2]` (forward, on loop `l`) keeps `margin` clear of every site on `l`.
    fn free(&self, l: usize, s1: f32, s2: f32, margin: f32) -> bool {
        let len = self.loops[l].length;
        let span = wrap(s2 - s1, len) + 2.0 * margin;
        if span >= len {
            return false;
        }
        let lo = s1 - margin;
        self.sites.iter().all(|st| {
            let (t1, t2) = if st.a as usize == l {
                (st.a1, st.a2)
            } else if st.b as usize == l {
                (st.b1, st.b2)
            } else {
                return true;
            };
            // Two arcs of the loop overlap if either starts inside the other.
            let other = wrap(t2 - t1, len);
            wrap(t1 - lo, len) > span && wrap(lo - t1, len) > other
        })
    }

    /// A place where loop `a` (one level above) runs a road width from loop `b` for long
    /// enough to bridge, clear of the other joins on both. `relaxed` is the second try for a
    /// loop no strict site reaches (small loops at a peak of `D`, where the turns below are
    /// not parallel to it): it checks only the gap, with a looser tolerance.
    fn find_site(&self, slice: &Slice, a: usize, b: usize, relaxed: bool) -> Option<Site> {
        let w = slice.settings().road_width;
        let len = self.loops[a].length;
        let lenb = self.loops[b].length;
        let steps = libm::floorf(len / (0.25 * w)) as usize;
        for (g, k) in self
            .gaps()
            .iter()
            .flat_map(|&g| (0..steps).map(move |k| (g, k)))
        {
            let s0 = k as f32 * 0.25 * w;
            let (a1, a2) = (s0, wrap(s0 + g * w, len));
            if !self.free(a, a1, a2, 0.5 * w) {
                continue;
            }
            // The gap and half a road either side must face `b` a road width away.
            let mut prev: Option<f32> = None;
            let mut ok = true;
            let mut ends = (0.0, 0.0);
            let (offsets, tol) = if relaxed {
                ([f32::NAN, 0.0, 0.5 * g, g, f32::NAN], RELAXED_TOL)
            } else {
                ([-0.5f32, 0.0, 0.5 * g, g, g + 0.5], STRICT_TOL)
            };
            for (m, off) in offsets.iter().enumerate() {
                if off.is_nan() {
                    continue;
                }
                let p = self.at(a, s0 + off * w);
                match self.below(slice, a, p, tol) {
                    Some((m2, t)) if m2 == b => {
                        if let Some(pt) = prev {
                            let step = wrap(t - pt, lenb);
                            if !(0.1 * w..1.5 * w).contains(&step) {
                                ok = false;
                                break;
                            }
                        }
                        prev = Some(t);
                        if m == 1 {
                            ends.0 = t;
                        } else if m == 3 {
                            ends.1 = t;
                        }
                    }
                    _ => {
                        ok = false;
                        break;
                    }
                }
            }
            if ok && self.free(b, ends.0, ends.1, 0.5 * w) {
                return Some(Site {
                    a: a as u16,
                    a1,
                    a2,
                    b: b as u16,
                    b1: ends.0,
                    b2: ends.1,
                });
            }
        }
        None
    }

    /// Joins the loops along a spanning tree of their side-by-side adjacency, breadth first
    /// from the wall's first turn.
    fn join(&mut self, slice: &Slice, stats: &mut OffsetStats) -> Result<(), Error> {
        // Full-road gaps take more room on a loop than half-road ones: where they leave a
        // loop no room for its join (another extrusion start), the joins are made again with
        // half-road gaps only, and the way with fewer roads is kept.
        let before = *stats;
        self.gaps_from = 0;
        let roads = self.join_with(slice, stats)?;
        if roads > 1 {
            *stats = before;
            self.gaps_from = 1;
            if self.join_with(slice, stats)? >= roads {
                *stats = before;
                self.gaps_from = 0;
                self.join_with(slice, stats)?;
            }
        }
        Ok(())
    }

    /// [`join`](Self::join) with the gaps in `self.gaps`; returns how many roads (trees of
    /// joins) the loops make.
    fn join_with(&mut self, slice: &Slice, stats: &mut OffsetStats) -> Result<usize, Error> {
        let w = slice.settings().road_width;
        let mut roads = 0;
        self.sites.clear();
        let n = self.loops.len();
        // Adjacency by sampling each loop and looking one level down.
        let mut pairs: Vec<(u16, u16, u16), MAX_SITES> = Vec::new();
        for a in 0..n {
            let len = self.loops[a].length;
            let steps = libm::ceilf(len / (0.5 * w)) as usize;
            for k in 0..steps {
                let p = self.at(a, k as f32 * 0.5 * w);
                if let Some((b, _)) = self.below(slice, a, p, STRICT_TOL) {
                    if let Some(e) = pairs
                        .iter_mut()
                        .find(|e| e.0 as usize == a && e.1 as usize == b)
                    {
                        e.2 += 1;
                    } else {
                        pairs
                            .push((a as u16, b as u16, 1))
                            .map_err(|_| capacity(Limit::ContourSites))?;
                    }
                }
            }
        }
        // Longest contact first: those have the most room for a site.
        pairs.sort_unstable_by(|x, y| y.2.cmp(&x.2).then(x.0.cmp(&y.0)).then(x.1.cmp(&y.1)));
        for l in self.loops.iter_mut() {
            l.visited = false;
            l.parent = NONE;
        }
        // Roots: the longest loop of level 0 first (the wall's first turn), then any loop
        // left unreached. After each tree, loops no strict join reached get a relaxed join to
        // any reached loop a level away before a new road is started.
        loop {
            let root = (0..n)
                .filter(|&l| !self.loops[l].visited && !self.loops[l].optional)
                .min_by(|&x, &y| {
                    let (lx, ly) = (&self.loops[x], &self.loops[y]);
                    lx.level
                        .cmp(&ly.level)
                        .then(ly.length.total_cmp(&lx.length))
                        .then(x.cmp(&y))
                });
            let Some(root) = root else { break };
            roads += 1;
            self.loops[root].visited = true;
            self.bfs(slice, &pairs, root, stats)?;
            while let Some((other, site)) = self.relaxed_join(slice, w) {
                self.attach(other, site, stats)?;
                self.bfs(slice, &pairs, other, stats)?;
            }
        }
        Ok(roads)
    }

    /// Records `site` as the join that reaches loop `other`.
    fn attach(&mut self, other: usize, site: Site, stats: &mut OffsetStats) -> Result<(), Error> {
        self.sites
            .push(site)
            .map_err(|_| capacity(Limit::ContourSites))?;
        let lo = &mut self.loops[other];
        lo.visited = true;
        lo.parent = (self.sites.len() - 1) as u16;
        stats.joins += 1;
        Ok(())
    }

    /// Joins every loop reachable from `start` (already reached) by strict sites, breadth first.
    fn bfs(
        &mut self,
        slice: &Slice,
        pairs: &[(u16, u16, u16)],
        start: usize,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        self.queue.clear();
        // Never full: the queue was just emptied.
        self.queue
            .push(start as u16)
            .map_err(|_| Limit::ContourLoops.error())?;
        let mut head = 0;
        while head < self.queue.len() {
            let l = self.queue[head] as usize;
            head += 1;
            for &(a, b, _) in pairs.iter() {
                let (a, b) = (a as usize, b as usize);
                let other = if a == l {
                    b
                } else if b == l {
                    a
                } else {
                    continue;
                };
                if self.loops[other].visited {
                    continue;
                }
                if let Some(site) = self.find_site(slice, a, b, false) {
                    self.attach(other, site, stats)?;
                    self.queue
                        .push(other as u16)
                        .map_err(|_| capacity(Limit::ContourLoops))?;
                }
            }
        }
        Ok(())
    }

    /// A relaxed site between a loop not yet reached and a reached loop one level away
    /// (within two road widths of it), with the loop it reaches.
    fn relaxed_join(&self, slice: &Slice, w: f32) -> Option<(usize, Site)> {
        let n = self.loops.len();
        for u in (0..n).filter(|&u| !self.loops[u].visited) {
            for v in (0..n).filter(|&v| self.loops[v].visited) {
                let (lu, lv) = (&self.loops[u], &self.loops[v]);
                let gap_x = (lu.bbox.0.x - lv.bbox.1.x).max(lv.bbox.0.x - lu.bbox.1.x);
                let gap_y = (lu.bbox.0.y - lv.bbox.1.y).max(lv.bbox.0.y - lu.bbox.1.y);
                if gap_x.max(gap_y) > 2.0 * w {
                    continue;
                }
                let site = if lu.level == lv.level + 1 {
                    self.find_site(slice, u, v, true)
                } else if lv.level == lu.level + 1 {
                    self.find_site(slice, v, u, true)
                } else {
                    None
                };
                if let Some(site) = site {
                    return Some((u, site));
                }
            }
        }
        None
    }

    /// Whether a laid loop of level `level` passes within `tol` of `q`.
    fn laid_at(&self, q: Point, level: u16, tol: f32) -> bool {
        self.loops.iter().enumerate().any(|(l, lp)| {
            let (lo, hi) = lp.bbox;
            if !lp.visited
                || lp.level != level
                || q.x < lo.x - tol
                || q.y < lo.y - tol
                || q.x > hi.x + tol
                || q.y > hi.y + tol
            {
                return false;
            }
            let pts = self.pts(l);
            self.loop_runs(l).any(|(b, ks)| {
                polygon::bbox_distance(b, q) <= tol + polygon::rounding_slack(q, b)
                    && ks.into_iter().any(|k| {
                        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
                        crate::geometry::polyline::closest_on_segment(a, b, q)
                            .0
                            .dist(q)
                            <= tol
                    })
            })
        })
    }

    /// [`widened`] at `p` (whose nearest feature is `near`), against this layer's laid loops.
    fn widen(&self, slice: &Slice, p: Point, near: (usize, f32, Point)) -> (Point, f32) {
        widened(slice, p, near, |q, level, tol| self.laid_at(q, level, tol))
    }

    /// The vertex at `p`, with its composition and its road width ([`widened`] at ridges).
    fn vertex(&self, slice: &Slice, field: &BlendedField, p: Point, deposit: bool) -> Vertex {
        let half = 0.5 * slice.settings().road_width;
        let near = nearest(slice, p);
        let own = material_of(slice, near.0);
        let material = if near.1 < half + 2.0 * FIRST_TURN_MARGIN {
            own
        } else {
            field.at(p).unwrap_or(own)
        };
        let (at, width) = self.widen(slice, p, near);
        Vertex {
            at,
            material,
            width,
            deposit,
        }
    }

    /// Walks loop `l` from arc length `s` for `dist` in the given direction, emitting the
    /// loop's points on the way and the end point.
    #[allow(clippy::too_many_arguments)]
    fn walk(
        &self,
        slice: &Slice,
        field: &BlendedField,
        sink: &mut impl PathSink,
        l: usize,
        s: f32,
        dist: f32,
        forward: bool,
    ) -> Result<(), Error> {
        let (pts, arc) = (self.pts(l), self.arcs(l));
        let len = self.loops[l].length;
        let n = pts.len();
        let s = wrap(s, len);
        let mut k = if forward {
            arc.partition_point(|&a| a <= s) % n
        } else {
            (arc.partition_point(|&a| a < s) + n - 1) % n
        };
        let mut prev = self.at(l, s);
        for _ in 0..n {
            let along = if forward {
                wrap(arc[k] - s, len)
            } else {
                wrap(s - arc[k], len)
            };
            if along >= dist - 1e-5 {
                break;
            }
            if along > 1e-5 {
                self.emit_span(slice, field, sink, prev, pts[k])?;
                prev = pts[k];
            }
            k = if forward {
                (k + 1) % n
            } else {
                (k + n - 1) % n
            };
        }
        let end = if forward { s + dist } else { s - dist };
        self.emit_span(slice, field, sink, prev, self.at(l, end))
    }

    /// Emits the turn's straight piece from `from` (already emitted) to `to`. A piece longer
    /// than [`WIDTH_STEP`] road widths along which some road widens ([`widened`]) is emitted
    /// in steps that long, so a width applies where it was found rather than tapering over
    /// the whole piece.
    fn emit_span(
        &self,
        slice: &Slice,
        field: &BlendedField,
        sink: &mut impl PathSink,
        from: Point,
        to: Point,
    ) -> Result<(), Error> {
        let w = slice.settings().road_width;
        let steps = libm::ceilf(from.dist(to) / (WIDTH_STEP * w)).max(1.0) as usize;
        let at = |k: usize| from.lerp(to, k as f32 / steps as f32);
        let end = self.vertex(slice, field, to, true);
        let width_at = |q: Point| self.widen(slice, q, nearest(slice, q)).1;
        let start = sink.last_vertex().map_or(w, |v| v.width);
        let varies =
            steps > 1 && (start != w || end.width != w || (1..steps).any(|k| width_at(at(k)) != w));
        if varies {
            for k in 1..steps {
                emit_move(slice, sink, self.vertex(slice, field, at(k), true))?;
            }
        }
        emit_move(slice, sink, end)
    }

    /// The ends of `site` on loop `l`: `(own gap start, own gap end, other loop, other's gap
    /// start, other's gap end)`.
    fn site_on(&self, site: usize, l: usize) -> (f32, f32, usize, f32, f32) {
        let st = &self.sites[site];
        if st.a as usize == l {
            (st.a1, st.a2, st.b as usize, st.b1, st.b2)
        } else {
            (st.b1, st.b2, st.a as usize, st.a1, st.a2)
        }
    }

    /// Walks the loops as one road per tree of joins.
    fn walk_all(
        &mut self,
        slice: &Slice,
        plan: &Plan,
        sink: &mut impl PathSink,
        stats: &mut OffsetStats,
    ) -> Result<(), Error> {
        let field = BlendedField::new(slice, plan);
        // Small loops no join reached are left out.
        stats.dropped += self.loops.iter().filter(|l| !l.visited).count() as u16;
        let roots: Vec<u16, MAX_LOOPS> = (0..self.loops.len())
            .filter(|&l| self.loops[l].visited && self.loops[l].parent == NONE)
            .map(|l| l as u16)
            .collect();
        for (r, &root) in roots.iter().enumerate() {
            let root = root as usize;
            if r > 0 {
                stats.jumps += 1;
            }
            // Start the root where no join is.
            let len = self.loops[root].length;
            let mut s0 = 0.0;
            while s0 < len && !self.free(root, s0, s0, 0.0) {
                s0 += 0.1 * slice.settings().road_width;
            }
            emit_move(
                slice,
                sink,
                self.vertex(slice, &field, self.at(root, s0), false),
            )?;
            self.stack.clear();
            // Cannot fail: the stack was just emptied.
            self.stack
                .push(Frame {
                    lp: root as u16,
                    pos: s0,
                    forward: true,
                    remaining: len,
                    entered_by: NONE,
                })
                .map_err(|_| Limit::ContourLoops.error())?;
            while let Some(top) = self.stack.last().copied() {
                let l = top.lp as usize;
                let len = self.loops[l].length;
                // The nearest join ahead on this loop, other than the one it was entered by.
                let mut next: Option<(f32, usize)> = None;
                for (si, st) in self.sites.iter().enumerate() {
                    if si == top.entered_by as usize || (st.a != top.lp && st.b != top.lp) {
                        continue;
                    }
                    let (x1, x2, _, _, _) = self.site_on(si, l);
                    let ahead = if top.forward {
                        wrap(x1 - top.pos, len)
                    } else {
                        wrap(top.pos - x2, len)
                    };
                    if ahead < top.remaining && next.is_none_or(|n| ahead < n.0) {
                        next = Some((ahead, si));
                    }
                }
                match next {
                    Some((ahead, si)) => {
                        self.walk(slice, &field, sink, l, top.pos, ahead, top.forward)?;
                        let (x1, x2, child, y1, y2) = self.site_on(si, l);
                        let gap = wrap(x2 - x1, len);
                        let child_gap = wrap(y2 - y1, self.loops[child].length);
                        let (resume, enter) = if top.forward { (x2, y1) } else { (x1, y2) };
                        if let Some(f) = self.stack.last_mut() {
                            f.pos = resume;
                            f.remaining -= ahead + gap;
                        }
                        // The bridge across.
                        emit_move(
                            slice,
                            sink,
                            self.vertex(slice, &field, self.at(child, enter), true),
                        )?;
                        self.stack
                            .push(Frame {
                                lp: child as u16,
                                pos: enter,
                                forward: !top.forward,
                                remaining: self.loops[child].length - child_gap,
                                entered_by: si as u16,
                            })
                            .map_err(|_| capacity(Limit::ContourLoops))?;
                    }
                    None => {
                        self.walk(slice, &field, sink, l, top.pos, top.remaining, top.forward)?;
                        self.stack.pop();
                        // The bridge back.
                        if let Some(f) = self.stack.last() {
                            let p = self.at(f.lp as usize, f.pos);
                            emit_move(slice, sink, self.vertex(slice, &field, p, true))?;
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// Simplifies the closed polyline `pts[start..]` in place, keeping every point whose removal
/// would move the curve more than `tol`; returns how many points remain.
fn simplify_closed<const N: usize>(pts: &mut Vec<Point, N>, start: usize, tol: f32) -> usize {
    let n = pts.len() - start;
    if n < 4 {
        return n;
    }
    let mut out = start + 1;
    let mut anchor = start;
    let mut k = start + 1;
    while k < pts.len() {
        // Extend the chord from the anchor as far as every skipped point stays within `tol`.
        let mut end = k;
        while end + 1 < pts.len() && end + 1 - anchor <= 64 {
            let (a, b) = (pts[anchor], pts[end + 1]);
            let fits = (anchor + 1..=end).all(|m| {
                let (q, _) = crate::geometry::polyline::closest_on_segment(a, b, pts[m]);
                q.dist(pts[m]) <= tol
            });
            if !fits {
                break;
            }
            end += 1;
        }
        pts[out] = pts[end];
        out += 1;
        anchor = end;
        k = end + 1;
    }
    out - start
}
