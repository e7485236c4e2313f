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
//! turns are closed loops; two loops a road width apart are joined into one by cutting a gap
//! a road long (half a road where a small loop has no room) into each at a place where they
//! run side by side and bridging the gaps
//! (two short roads across, like one step of a zigzag). Joining the loops along a spanning tree
//! of their side-by-side adjacency makes one closed road: the whole layer is one extrusion
//! start. A join's two bridges run parallel: the gap on the loop below is as long, chord for
//! chord, as the gap above, so that bridges into a small turn round a hole do not converge
//! onto each other; and each is laid as wide as the two lie apart (narrowing to that from
//! the loop it leaves), so that they fill the gap between the loops without lying on each
//! other. Where two features' turns of one level run side by side across the ridge
//! between them (the channels of a lattice), the loops are joined across that seam, square to
//! it, before any loop is reached through a small loop a level above them (`seam_join`): the
//! pocket where three or four channels meet is otherwise the only way from one channel to the
//! next, two overlapping pairs of bridges a pocket. Where two features come within about one
//! and a half road widths, the channel a turn passes through between them can be thinner than
//! the grid resolves: the traced turn closes on both sides of it, and the pocket beyond is an
//! island loop beside no other. Such a loop is joined across the pinch to the nearest reached
//! loop of its level, by a bridge out and one back through the channel (`pinch_join`), a road
//! apart where the pocket leaves room for both. Only loops that no join reaches are reached by
//! travel, and counted as jumps (none on the reference slices, none on 200 random slices, none
//! on the 48 lattices of channels of `host_sim::random_slice::lattices`).
//!
//! A turn whose road would leave a sliver narrower than a road before a ridge widens into it
//! (`ridge`): up to the ridge, a little past it where the other side's road stops short
//! of a corner where three or four cells meet, and never much over a laid turn beyond.
//!
//! The loops are traced by marching squares on a grid of `D` and each point is put exactly on
//! its level by Newton steps along the distance gradient. The composition at every vertex is
//! the plan's blended field ([`BlendedField`]): exactly a feature's material on its keep-out
//! curve.

mod join;
mod loops;
mod pinch;
mod ridge;
mod trace;
mod walk;

use super::despike::{finish, Despike};
use super::lining::Lining;

use heapless::Vec;

use crate::config::{CONTOUR_POINTS, MAX_LOOPS, MAX_SITES};
use crate::digest::Fnv;
use crate::field::GridMemory;
use crate::geometry::primitives::wrap;
use crate::geometry::{Grid, Point};
use crate::toolpath::PathSink;
use crate::{Error, Limit, Material, Plan, Settings, Slice};

/// How far beyond the keep-out curve the first turn lies, mm: the chords of a turn may cut
/// that far into it without touching a feature's keep-out band.
const FIRST_TURN_MARGIN: f32 = 3e-3;
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
/// the spiral's median overfill (0.036 to 0.020) for 0.5 % coverage. Where full gaps leave a
/// loop unjoined, the loops around it are made [`tight`](Loop::tight) (half-road gaps only)
/// rather than every join of the slice: on 4 of 200 random slices that lowered the overfill
/// from 0.029-0.044 to 0.018-0.026. Three quarters of a road between the two: the small loop
/// in a pocket where four channels of a square lattice meet is a diamond whose sides are
/// shorter than a road, and a road-long gap round its corner reaches past the side's middle,
/// which lies over another channel's turn (on the 48 lattices mean overfill 0.0234 -> 0.0211,
/// the worst 0.092 -> 0.073; the random bench's 0.0159 -> 0.0156, coverage unchanged).
const BRIDGE_GAPS: [f32; 3] = [1.0, 0.75, 0.5];
/// Over how much of its own width a bridge narrows from the loop it leaves to its width
/// between the loops, and widens again to the loop it enters ([`OffsetSpiral::emit_bridge`]),
/// at most a quarter of the bridge's length. Hardly a choice: 0.25, 0.5 and 1.0 gave the same
/// offset-spiral means to the fourth decimal on the 48 lattices (coverage 0.9805, overfill
/// 0.0125) and on the random bench's seed 1 (0.9893, 0.0088).
const BRIDGE_TAPER: f32 = 0.5;
/// Rounds of marking crowded loops [`tight`](Loop::tight) before half-road gaps everywhere
/// are tried ([`OffsetSpiral::join`]): each round marks the loops around the roads still
/// started apart, so a slice needs as many as the crowding spreads.
const TIGHT_ROUNDS: usize = 4;
/// The same, for the second try at loops that no strict join reaches.
const RELAXED_TOL: f32 = 0.3;
/// The longest bridge across a pinch ([`OffsetSpiral::pinch_join`]), road widths: the channel a
/// turn passes through between two features is lost in the distance grid over at most a grid
/// cell or two (the grid's spacing is at most 1.5 road widths).
const PINCH_BRIDGE_ROADS: f32 = 3.0;
/// The narrowest gap a join across a pinch cuts into each loop, road widths, where the wider
/// ones do not fit (`pinch::PINCH_GAPS`): the bridge out and the bridge back lie this far
/// apart, almost on each other, in a channel that may have room for one road only.
const PINCH_GAP: f32 = 0.1;
/// Bisection steps locating a ridge within a road width (`w / 2^14`: 0.02 µm at 0.4 mm).
const RIDGE_STEPS: u32 = 14;
/// How much a feature's own distance along its normal may fall short of growing with the step
/// before the step counts as past one of its own ridges, in road widths. A polygon's every
/// convex-from-inside vertex (the wall's, a round hole's inside) starts a ridge of its own
/// where its two edges are equally near, but the shortfall beyond it grows only as
/// `t (1 - cos a)` for the small turn `a` at the vertex: about 1e-3 t on the reference slices'
/// polygons, well under this, but 0.012-0.019 t on a circle of 32-40 vertices, past it within a
/// road: such a ridge is told apart by how fast it falls beyond (`ridge::SPOKE_FALL`). Two parts
/// of a non-convex feature facing each other fall short at a good fraction of `t`.
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
    /// When it was reached: how many loops were reached before it (`visits`); `NONE`
    /// while unreached ([`visited`](Loop::visited)).
    order: u16,
    /// Unreached: every loop reached before this many (by `order`) was tried for a relaxed
    /// join to it and gave none ([`relaxed_join`](OffsetSpiral::relaxed_join)).
    tried: u16,
    /// Unreached: the same for a join across a seam ([`seam_join`](OffsetSpiral::seam_join)).
    seam_tried: u16,
    /// Small: laid only if a join reaches it.
    optional: bool,
    /// Crowded: its joins cut half-road gaps only ([`BRIDGE_GAPS`]' last), so that they all
    /// find room on it ([`join`](OffsetSpiral::join)).
    tight: bool,
}

impl Loop {
    /// Whether a join (or a root) has reached it.
    fn visited(&self) -> bool {
        self.order != NONE
    }
}

/// A join of two loops `a` and `b` running side by side: the gap `[a1, a2]` (arc length, in
/// `a`'s direction) faces the gap `[b1, b2]` on `b`; bridges `a1-b1` and `a2-b2`, or where
/// the two run opposite ways (`flip`: loops of one level facing each other across a ridge)
/// `a1-b2` and `a2-b1`, so that the bridges do not cross.
#[derive(Clone, Copy, Debug)]
struct Site {
    a: u16,
    a1: f32,
    a2: f32,
    b: u16,
    b1: f32,
    b2: f32,
    flip: bool,
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

/// The offset spiral's working memory (97 KiB on a controller: the loops and their joins;
/// the distance grid is a lent [`GridMemory`]), meant
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
/// let mut planner = Box::new(Planner::new());
/// planner.plan(&slice).unwrap();
/// // The plan, and the field's node memory lent for the spiral's distance grid.
/// let (plan, grid) = planner.plan_and_grid();
/// let mut work = Box::new(OffsetSpiral::new());
/// let mut path = Box::new(hollowpath::heapless::Vec::<Vertex, 65_536>::new());
/// let stats = work.build(&slice, plan, grid, &mut *path).unwrap();
/// // One road: the first vertex is reached by travel, every later move deposits.
/// assert!(path[1..].iter().all(|v| v.deposit));
/// assert_eq!(stats.jumps, 0);
/// # }).unwrap().join().unwrap();
/// ```
pub struct OffsetSpiral {
    /// The distance grid; its nodes' `D` and marks live in a [`GridMemory`] lent to
    /// [`prepare`](Self::prepare) (the planner's field's, on a controller).
    grid: Grid,
    points: Vec<Point, CONTOUR_POINTS>,
    /// The arc length along its loop of the point `RUN r` (the first of run `r`), for the runs
    /// whose first point is not the first of its loop: a point's arc length is this plus the
    /// segments after it, summed in the same order as when the loop was traced
    /// ([`arc_of`](Self::arc_of)), so a run's lengths cost 4 bytes, not 64.
    run_arc: Vec<f32, RUNS>,
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
    /// firmware's static (97 KiB) would be stored in flash as `.data` instead of zeroed `.bss`.
    gaps_from: u8,
    /// Loops reached so far by the joins being made (each loop's `order`).
    visits: u16,
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
/// (positive in the material) and its gradient (into the material).
fn nearest(slice: &Slice, p: Point) -> (usize, f32, Point) {
    let (k, d, n) = slice.nearest_feature(p);
    (k, d, slice.clearance_gradient(k, &n, p))
}

/// The distance `D` from `p` to the nearest feature (positive in the material), its gradient,
/// and the material of that feature.
fn distance(slice: &Slice, p: Point) -> (f32, Point, Material) {
    let (f, d, g) = nearest(slice, p);
    (d, g, slice.material_at(f))
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
/// How many bisection steps find the widest widening whose edge does not cross the ridge
/// sideways, where the whole sliver's does (to an eighth of it).
const WIDEN_TRIES: u32 = 3;
/// How far a widened road's round edge may reach past the ridge into another feature's cell,
/// as the amount by which that feature is nearer than its own there, in road widths (where
/// the two face each other, the edge lies at most half that past the ridge). Where three or
/// four cells meet, each side's widened road is held off the corner by the other ridges, and
/// the pocket between them stayed bare, a star with arms along the seams; a little past the
/// ridge, the roads reach into the other sides' bare arms. On the 48 lattices of channels,
/// with [`NEXT_TURN_OVERLAP`] and against the bridges' change alone
/// ([`OffsetSpiral::bridge_width`]), mean coverage 0.9772 -> 0.9805 (6 lattices below 0.97 -> none)
/// and overfill 0.0185 -> 0.0125 (every lattice's spiral meets the bar); on the random
/// bench's seeds 1 and 5000 coverage 0.9889 -> 0.9893 and 0.9893 -> 0.9896, overfill
/// 0.0149 -> 0.0088 and 0.0146 -> 0.0086. Without [`NEXT_TURN_OVERLAP`], 0.05 took the
/// lattices to 0.9814 / 0.0217, four of them over the overfill bar.
const SEAM_CROSS: f32 = 0.1;
/// How much of its widening a road whose ridge lies nearer than a road may lay over a laid
/// turn of the next level across the ridge ([`widened`](ridge::widened)): before, it widened
/// to the ridge over the arms of a pocket's small loop, a lens laid twice beside each arm
/// (lattice 41: overfill 0.067). None at all (0) left the arms' tips bare (lattice 41's
/// coverage 0.969 -> 0.955, overfill 0.021); half the widening, with [`SEAM_CROSS`], 0.971
/// at overfill 0.029.
const NEXT_TURN_OVERLAP: f32 = 0.5;

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
            points: Vec::new(),
            run_arc: Vec::new(),
            runs: Vec::new(),
            loops: Vec::new(),
            sites: Vec::new(),
            stack: Vec::new(),
            queue: Vec::new(),
            gaps_from: 0,
            visits: 0,
            prepared: None,
        }
    }

    /// The bridge gaps [`find_site`](Self::find_site) tries now between loops `a` and `b`:
    /// the half-road gap only where either is [`tight`](Loop::tight) (or every loop is, the
    /// last resort of [`join`](Self::join)).
    fn gaps(&self, a: usize, b: usize) -> &'static [f32] {
        let from = if self.loops[a].tight || self.loops[b].tight {
            BRIDGE_GAPS.len() - 1
        } else {
            self.gaps_from as usize
        };
        &BRIDGE_GAPS[from.min(BRIDGE_GAPS.len())..]
    }

    /// Writes the offset-spiral layer of `slice` into `sink`, with the composition of
    /// `plan`'s blended field. The loops and joins are [`prepare`](Self::prepare)d first,
    /// unless they already were for this slice (every odd layer of a job walks the same
    /// ones): then the first vertex comes without that work.
    // Not inlined, so that its frame and the zigzag's share the stack in a caller that
    // builds either (`app::job::layer_path`).
    #[inline(never)]
    pub fn build(
        &mut self,
        slice: &Slice,
        plan: &Plan,
        grid: &mut GridMemory,
        sink: &mut impl PathSink,
    ) -> Result<OffsetStats, Error> {
        let mut stats = self.prepare(slice, grid)?;
        // Each feature's lining in its own material, as the zigzag's: where two features
        // are about a road apart their first turns run side by side through the pinch, and
        // a bridge between them blended all the way across, a piece of it ending on one's
        // keep-out curve in a mix of both (random slice 215 drawn with features a road
        // apart: 0.4 off the hole's material).
        let mut lined = Lining::new(sink, slice);
        let mut despiked = Despike::new(&mut lined, slice);
        self.walk_all(slice, plan, &mut despiked, &mut stats)?;
        finish(&mut despiked)?;
        Ok(stats)
    }

    /// Samples the distance field, traces its loops and joins them (all the layer's work
    /// before its first vertex), unless that was done for this very slice already; the
    /// figures of the preparation. A controller calls it after planning, so that the
    /// spiral layers start at once.
    pub fn prepare(&mut self, slice: &Slice, grid: &mut GridMemory) -> Result<OffsetStats, Error> {
        let key = Prepared::of(slice);
        if let Some((k, stats)) = self.prepared {
            if k == key {
                return Ok(stats);
            }
        }
        self.prepared = None;
        let mut stats = OffsetStats::default();
        self.sample(slice, grid)?;
        self.trace_all(slice, grid, &mut stats)?;
        // Nothing to lay (the holes' own refusals come from the planner first).
        if self.loops.is_empty() {
            return Err(Error::WallNoRoom);
        }
        self.join(slice, &mut stats)?;
        self.prepared = Some((key, stats));
        Ok(stats)
    }
}
