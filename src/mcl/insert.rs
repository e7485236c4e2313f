//! Insertion: trace MCL halves from every hollow feature along the field's gradient to the
//! boundary of its cell.
//!
//! Starts are spaced [`mcl_spacing`](crate::Settings::mcl_spacing) along the feature's
//! keep-out curve. Where two neighbouring halves end farther apart than twice the road width
//! (so the roads along them would leave a gap wider than a road), a half is inserted between
//! them, up to [`MAX_REFINE_DEPTH`] times, while the starts stay far enough apart
//! (`MIN_START_GAP_PER_MIN_WIDTH`). In a strong fan (a small feature in a large cell: ends
//! still [`FAN_END_GAP_PER_ROAD`] road widths apart) starts may come nine times as close, and
//! the half is kept only if the field parts it from its neighbours soon (`CROWDED_ROADS`).
//! Streamlines of the harmonic field do not cross; a numerical near-miss that still crosses
//! its neighbour is dropped (and counted), and so is a strong fan's half that crowds.

use heapless::Vec;

use crate::config::{HALF_POINTS, MAX_HALVES, MAX_REFINE_DEPTH, TRACE_POINTS};
use crate::field::Field;
use crate::geometry::primitives::bisect;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, polyline, Point};
use crate::keep_out::{KeepOut, Side};
use crate::mcl::{Half, HalfEnd, Halves};
use crate::slice::{Feature, Nearest};
use crate::stats::PlanStats;
use crate::{Error, FeatureId, Limit, Slice};

/// Largest distance between the far ends of neighbouring halves, in road widths. Halves
/// inserted where ends part more than this crowd at their hole, and their roads overlap there;
/// since crowded pairs turn short of the hole in the zigzag (`toolpath::zigzag::turns`) that
/// costs little: on the random bench's 200 slices (with turns, before a splice's inner pair
/// could turn) 1.9 (before) gave 182 zigzags that meet the bar (coverage 0.9786, overfill
/// 0.0264 on average), 1.7 gave 186 (0.9798, 0.0271), 1.5 gave 187 (0.9806, 0.0281), 1.3 gave
/// 181 (0.9797, 0.0305).
const MAX_END_GAP_PER_ROAD: f32 = 1.5;
// `Half::depth` is a `u8`.
const _: () = assert!(MAX_REFINE_DEPTH <= u8::MAX as u32);
/// The least gap between two neighbouring starts a half is inserted into, in narrowest roads
/// ([`min_width`](crate::Settings::min_width)). Halves from starts much closer than the
/// narrowest road run side by side for a stretch before the field parts them, and roads along
/// them, however narrow, pile onto each other there; a gap left at their far ends the roads
/// fill by widening instead. 0.9: starts a road width apart are refined twice (a quarter road
/// apart) at the default `min_width`, not three times; on the hole reference slices that took
/// the zigzag's over-fill from 0.038-0.042 to 0.018-0.029 for 0.6-1 % of coverage.
const MIN_START_GAP_PER_MIN_WIDTH: f32 = 0.9;
/// Where neighbouring halves end farther apart than this many road widths, a strong fan, a
/// half is inserted between starts down to [`FAN_START_GAP_PER_MIN_WIDTH`] narrowest roads
/// apart, and kept only if it crowds its neighbours for at most [`CROWDED_ROADS`] road widths.
/// Such fans leave the gaps the meanders fill, and a meander covers less than roads along the
/// fan (its turns): on the random bench's 200 slices the zigzag's median coverage rose from
/// 0.9615 to 0.966 and its median overfill from 0.0414 to 0.042, and 34 slices met the bar
/// instead of 24 (with 3 road widths and no crowding test: 0.968, 0.044, 31; with
/// [`MIN_START_GAP_PER_MIN_WIDTH`] halved everywhere: 0.973, 0.050, and 2 of 60 met it).
const FAN_END_GAP_PER_ROAD: f32 = 2.5;
/// The least gap between two starts a strong fan's half is inserted into
/// ([`FAN_END_GAP_PER_ROAD`]), in narrowest roads. A small hole's fan reaches a large cell's
/// far lobes with MCLs many roads apart, and the meanders' strokes across those bands fan in
/// turn (their far ends part, their near ends crowd): more halves from closer starts reach
/// there, and where they crowd at the hole they turn short of it
/// (`toolpath::zigzag::turns`). On the random bench's 200 slices (zigzag, as printed; mean
/// coverage / overfill, slices meeting the bar; with [`CROWDED_ROADS`] 12 unless said, and
/// [`MAX_REFINE_DEPTH`] 3, which stops 0.45 and 0.2 alike, or raised so that the gap binds:
/// four halvings of the default one-road spacing for 0.2, five for 0.1, six for 0.05): 0.45,
/// 0.9803 / 0.0250, 187; 0.3, as 0.45 (its next halving is below it); 0.2, 0.9831 / 0.0256,
/// 189; 0.2 and crowding for 20 roads, 0.9837 / 0.0260, 192 (40 roads: 190, halves running
/// side by side far from a concave hole doubled seed 103's overfill); **0.1 and 20 roads,
/// 0.9852 / 0.0271, 194**; 0.05 and 20 roads, 0.9859 / 0.0281, 192.
const FAN_START_GAP_PER_MIN_WIDTH: f32 = 0.1;
/// How far from its start, in road widths, a strong fan's half may run within a narrowest
/// road of a neighbour: halves from close starts that the field does not part soon (where
/// field lines run side by side, towards a saddle) lay their roads over each other all along,
/// and are dropped. Once the zigzag's arcs stopped laying crescents at crowded ends, overfill
/// had room and coverage did not: on the random bench's 200 slices 5 road widths gave the
/// zigzag a median coverage of 0.9704 and overfill of 0.0343 (97 slices met the bar), 12 gave
/// 0.9729 and 0.0379 (107). On its first 40: 3, 20 met; 5, 22; 6.5, 22; 8, 21; 12, 23; 20,
/// 23 (overfill 0.0007 higher than at 12). With starts down to a tenth of the narrowest road
/// apart ([`FAN_START_GAP_PER_MIN_WIDTH`]) 20 (see there).
const CROWDED_ROADS: f32 = 20.0;
/// The step, in road widths, at which a strong fan's half is sampled from its start for
/// [`CROWDED_ROADS`].
const CROWD_STEP_PER_ROAD: f32 = 0.25;
/// How many starts of a hole's crowded fan halves are remembered, so that a later depth does
/// not trace them again.
const CROWDED_MEMO: usize = 32;

/// Traces the halves of every hole into `halves` (cleared first).
// Not inlined: its working set stays in a frame of its own, which the planner's other
// phases then share instead of adding to (`Planner::plan`'s frame).
#[inline(never)]
pub fn insert(
    slice: &Slice,
    field: &Field,
    halves: &mut Halves,
    scratch: &mut Vec<Point, TRACE_POINTS>,
    stats: &mut PlanStats,
) -> Result<(), Error> {
    halves.clear();
    let settings = slice.settings();
    let w = settings.road_width;
    for i in 0..slice.holes().len() {
        let hole = KeepOut::new(&slice.holes()[i], 0.5 * w, Side::Outside);
        let n0 = libm::ceilf(hole.length() / settings.mcl_spacing).fmax(3.0) as usize;
        let ds = hole.length() / n0 as f32;
        for k in 0..n0 {
            trace_half(
                slice,
                field,
                i,
                &hole,
                k as f32 * ds,
                0,
                halves,
                scratch,
                stats,
            )?;
        }
        // Where a strong fan's half was traced and crowded: the start it was traced from
        // (the same neighbours give the same start, and the same half, at the next depth).
        let mut crowded: Vec<f32, CROWDED_MEMO> = Vec::new();
        for depth in 1..=MAX_REFINE_DEPTH {
            let order = sorted_halves(halves, i)?;
            let mut added = false;
            for k in 0..order.len() {
                let (sa, ea) = (
                    halves[order[k] as usize].s,
                    halves.end_point(order[k] as usize),
                );
                let next = order[(k + 1) % order.len()] as usize;
                let (sb, eb) = (halves[next].s, halves.end_point(next));
                let mut gap_s = sb - sa;
                if gap_s <= 0.0 {
                    gap_s += hole.length();
                }
                let end_gap = ea.dist(eb);
                let regular = end_gap > MAX_END_GAP_PER_ROAD * w
                    && gap_s >= MIN_START_GAP_PER_MIN_WIDTH * settings.min_width;
                let fan = end_gap > FAN_END_GAP_PER_ROAD * w
                    && gap_s >= FAN_START_GAP_PER_MIN_WIDTH * settings.min_width;
                let s = (sa + 0.5 * gap_s) % hole.length();
                if regular || (fan && !crowded.contains(&s)) {
                    let traced = trace_half(
                        slice,
                        field,
                        i,
                        &hole,
                        s,
                        depth as u8,
                        halves,
                        scratch,
                        stats,
                    );
                    // A strong fan's half is a refinement the plan can do without: where it
                    // does not fit the buffers (the halves', the pool's, or a trace's: nothing
                    // of it is kept then), it is left out rather than the slice refused.
                    let new = match traced {
                        Err(Error::Capacity { .. }) if !regular => false,
                        other => other?,
                    };
                    // The half just traced is the last one.
                    let last = halves.len().saturating_sub(1);
                    if new
                        && !regular
                        && crowds(
                            halves.points(last),
                            [halves.points(order[k] as usize), halves.points(next)],
                            settings.min_width,
                            w,
                        )
                    {
                        halves.pop_last();
                        stats.dropped_crowded += 1;
                        // Remembered while there is room; past that, a later depth traces
                        // it again and drops it again (the same plan, more work).
                        if !crowded.is_full() {
                            crowded.push(s).map_err(|_| Limit::Halves.error())?;
                        }
                    } else {
                        added |= new;
                    }
                }
            }
            if !added {
                break;
            }
        }
        // Safety net: neighbours must not cross.
        let order = sorted_halves(halves, i)?;
        for k in 0..order.len() {
            let (ia, ib) = (order[k] as usize, order[(k + 1) % order.len()] as usize);
            if ia == ib || !halves[ia].alive || !halves[ib].alive {
                continue;
            }
            if polyline::polylines_cross(halves.points(ia), halves.points(ib)) {
                let drop = if halves[ia].depth >= halves[ib].depth {
                    ia
                } else {
                    ib
                };
                halves[drop].alive = false;
                stats.dropped_crossing += 1;
            }
        }
    }
    // The pool at its fullest: later phases only reshape or drop halves. At most
    // HALF_POOL_POINTS (asserted in `mcl` to fit a u32).
    stats.half_points = halves.pool_len() as u32;
    halves.retain_alive();
    Ok(())
}

/// Whether the half along `pts` runs within `gap` of one of its neighbours' halves for more
/// than [`CROWDED_ROADS`] road widths `w` from its start (sampled every
/// [`CROWD_STEP_PER_ROAD`]); only as far as it stays that close, so a half the field parts
/// from them soon costs a few samples.
fn crowds(pts: &[Point], neighbours: [&[Point]; 2], gap: f32, w: f32) -> bool {
    let step = CROWD_STEP_PER_ROAD * w;
    let length = polyline::length(pts);
    let mut s = 0.0;
    while s <= CROWDED_ROADS * w {
        if s > length {
            // Crowded to its end, which is no longer than allowed.
            return false;
        }
        let p = polyline::point_at(pts, s);
        if neighbours.iter().all(|n| polyline::project(n, p).2 >= gap) {
            return false;
        }
        s += step;
    }
    true
}

/// Indices of the halves of hole `i`, sorted by their start parameter.
pub fn sorted_halves(halves: &[Half], i: usize) -> Result<Vec<u16, MAX_HALVES>, Error> {
    let mut order: Vec<u16, MAX_HALVES> = Vec::new();
    for (k, h) in halves.iter().enumerate() {
        if h.hole as usize == i && h.alive {
            // Never full: at most one per half, and `halves` has the same capacity.
            order.push(k as u16).map_err(|_| Limit::Halves.error())?;
        }
    }
    order.sort_unstable_by(|&a, &b| {
        halves[a as usize]
            .s
            .total_cmp(&halves[b as usize].s)
            .then(a.cmp(&b))
    });
    Ok(order)
}

/// Indices of all halves, sorted by hole and start parameter.
pub(crate) fn sorted_all(halves: &[Half]) -> Vec<u16, MAX_HALVES> {
    let mut order: Vec<u16, MAX_HALVES> = (0..halves.len() as u16).collect();
    order.sort_unstable_by(|&a, &b| {
        let (x, y) = (&halves[a as usize], &halves[b as usize]);
        x.hole
            .cmp(&y.hole)
            .then(x.s.total_cmp(&y.s))
            .then(a.cmp(&b))
    });
    order
}

/// Traces one half from arc length `s` of `hole`; returns whether a half was added.
///
/// No half starts on the side of a notch narrower than a road (a star's notch, a slit):
/// the keep-out curve has no point of its own there ([`KeepOut::reachable`]), and the point
/// it is pulled to lies at the notch's mouth or round a neighbouring spike's tip, where the
/// zigzag's arcs to the ends beside it then lay the same strip twice (a whole road along a
/// star's spike). On the random bench's 200 slices the zigzag's median overfill fell from
/// 0.0392 to 0.0385 and its median coverage rose from 0.9692 to 0.9702: 74 met the bar
/// instead of 63. The reference slices' plans are unchanged (their holes have no such notch).
#[allow(clippy::too_many_arguments)]
fn trace_half(
    slice: &Slice,
    field: &Field,
    i: usize,
    hole: &KeepOut<'_>,
    s: f32,
    depth: u8,
    halves: &mut Halves,
    scratch: &mut Vec<Point, TRACE_POINTS>,
    stats: &mut PlanStats,
) -> Result<bool, Error> {
    let (_, normal) = hole.base(s);
    let Some(start) = hole.reachable(s) else {
        stats.failed_traces += 1;
        return Ok(false);
    };
    if !slice.is_printable(start, 1e-4) || slice.nearest_holes(start).0 != i {
        stats.failed_traces += 1;
        return Ok(false);
    }
    let Some(end) = trace(slice, field, i, start, normal, scratch) else {
        if scratch.len() >= TRACE_POINTS - 1 {
            return Err(Error::Capacity {
                limit: Limit::TracePoints,
                feature: Some(FeatureId::Hole(i as u8)),
            });
        }
        stats.failed_traces += 1;
        return Ok(false);
    };
    let mut points: Vec<Point, HALF_POINTS> = Vec::new();
    // Simplify within 0.5 % of a road width, coarser only up to 10 %: past that the half
    // would no longer follow its streamline, and the buffer is too small.
    let w = slice.settings().road_width;
    let mut tol = 0.005 * w;
    while polyline::simplify(scratch, tol, &mut points).is_err() {
        tol *= 2.0;
        if tol > 0.1 * w {
            return Err(Error::Capacity {
                limit: Limit::HalfPoints,
                feature: Some(FeatureId::Hole(i as u8)),
            });
        }
    }
    let new = Half {
        hole: i as u8,
        s,
        start_normal: normal,
        end,
        partner: None,
        on_bisector: None,
        depth,
        alive: true,
        at: 0,
        len: 0,
    };
    halves.push(new, &points)?;
    stats.traced += 1;
    Ok(true)
}

/// The turns, as (cosine, sine), a climbing step tries away from the direction that came
/// within half a road of the hole: 15 to 75 degrees either side, nearest first, so that of
/// directions equally far from the hole the least turned is taken.
const CLIMB_TURNS: [(f32, f32); 10] = [
    (0.965_925_8, 0.258_819_04),
    (0.965_925_8, -0.258_819_04),
    (0.866_025_4, 0.5),
    (0.866_025_4, -0.5),
    (0.707_106_77, 0.707_106_77),
    (0.707_106_77, -0.707_106_77),
    (0.5, 0.866_025_4),
    (0.5, -0.866_025_4),
    (0.258_819_04, 0.965_925_8),
    (0.258_819_04, -0.965_925_8),
];
/// How far, in road widths, a line may climb (out of a notch) before it is given up: in a
/// slot deeper than that, whose sides its steps would cross to and fro, climbing between
/// steps that do not, it traces no half, as before climbing.
const MAX_CLIMB_ROADS: f32 = 4.0;

/// A climbing step from `p` (see [`trace`]): of the directions [`CLIMB_TURNS`] away from
/// `dir` that keep going on along `heading` (the direction the line came in), the one whose
/// step of `step` ends farthest from `hole`, if that is at least `half` (less rounding).
/// Where a normal from one side of a notch points at the other, the farthest step runs out
/// along the notch's middle. No single step turns back on the line's heading; a line that
/// climbs step after step could still turn round, which [`MAX_CLIMB_ROADS`] bounds.
fn climb(
    hole: &Feature,
    p: Point,
    dir: Point,
    heading: Point,
    step: f32,
    half: f32,
) -> Option<Point> {
    let mut best: Option<(f32, Point)> = None;
    for (c, s) in CLIMB_TURNS {
        let d = Point::new(dir.x * c - dir.y * s, dir.x * s + dir.y * c);
        if d.dot(heading) <= CLIMB_HEADING_COS * heading.norm() {
            continue;
        }
        let q = p + d * step;
        let dq = hole.nearest(q).distance;
        if best.is_none_or(|(b, _)| dq > b) {
            best = Some((dq, q));
        }
    }
    best.filter(|&(dq, _)| dq >= half - 1e-3).map(|(_, q)| q)
}

/// How far off the line's heading a climbing step may turn: at most about 84 degrees
/// (cosine 0.1), never back.
const CLIMB_HEADING_COS: f32 = 0.1;

/// Follows the field from `start` (where hole `i`'s keep-out curve has the outward normal
/// `normal`) in the cell of hole `i` until the cell boundary, into `out`. `None` if the line
/// does not reach the boundary.
///
/// Within a grid step of the hole the line follows the hole's own normal (the field's grid is
/// too coarse there). In a notch a little wider than a road (a star's, between two spikes)
/// the keep-out curve's point lies where the notch is a road wide, half a road from both
/// sides, where that normal, taken from one side, steps towards the other: such a step
/// *climbs* instead, along the direction of [`CLIMB_TURNS`] that keeps farthest from the
/// hole, out along the notch's middle (see there).
fn trace(
    slice: &Slice,
    field: &Field,
    i: usize,
    start: Point,
    normal: Point,
    out: &mut Vec<Point, TRACE_POINTS>,
) -> Option<HalfEnd> {
    let w = slice.settings().road_width;
    let half = 0.5 * w;
    let h = field.grid().h;
    let step = 0.5 * h.fmin(w);
    // Far enough from hole `i` (by a lower bound `lo` of its distance) for its normal to be
    // weighted by nothing in the direction: a grid step beyond half a road.
    let far = |lo: f32| lo >= half + h * (1.0 + 1e-3);
    // The direction at `x`: the field's gradient blended with hole `i`'s normal there (from
    // its nearest point `near`, measured if not given) by the distance. Where `lo` keeps the
    // hole far, the normal's weight is 0 and the hole is not measured (`n * 0 + g` is `g`;
    // the zero added settles a zero coordinate's sign as the blend's would).
    let direction = |x: Point, lo: f32, near: Option<Nearest>| {
        let g = field.gradient(x, i).filter(|g| g.norm2() > 1e-12);
        if let (true, Some(g)) = (far(lo), g) {
            return (Point::new(0.0, 0.0) + g.normalized()).normalized();
        }
        let near = near.unwrap_or_else(|| slice.holes()[i].nearest(x));
        let (n, d) = (near.gradient(x), near.distance);
        let weight = ((d - half) / h).clamp(0.0, 1.0);
        match g {
            Some(g) => (n * (1.0 - weight) + g.normalized() * weight).normalized(),
            None => n,
        }
    };
    let own = |x: Point| slice.holes()[i].signed_distance(x);
    let others = |x: Point| {
        (0..slice.holes().len())
            .filter(|&c| c != i)
            .map(|c| (c, slice.holes()[c].signed_distance(x)))
            .fold((i, f32::INFINITY), |a, b| if b.1 < a.1 { b } else { a })
    };
    // Whether another hole is as near `x` as `d` (`others(x).1 <= d`), measuring only the
    // holes whose box is within `d`.
    let other_within = |x: Point, d: f32| slice.hole_within(x, d, |c| c == i);
    // Whether another hole's box lies within `d` of `x`: where none does, no other hole is
    // as near `x` as `d` (`other_within` would measure none).
    let other_box_within = |x: Point, d: f32| {
        (slice.holes().iter().enumerate()).any(|(c, f)| c != i && f.box_within(x, d))
    };
    let hole_box = slice.holes()[i].bbox();
    out.clear();
    out.push(start).ok()?;
    let mut p = start;
    // Hole `i`'s nearest point to `p`, where measured (once for the step that ends at `p` and
    // the one that starts there), and bounds of its distance: the distance changes by no more
    // than a step's length over a step, so where the field alone steers, no other hole is
    // near and the lower bound keeps the hole beyond half a road, `q` is not measured and the
    // bounds widen by the step (and rounding) instead.
    let first = slice.holes()[i].nearest(p);
    let mut near_p = Some(first);
    let (mut lo_p, mut hi_p) = (first.distance, first.distance);
    // A lower bound of the wall's clearance at `p`: the distance to the wall changes by no
    // more than a step's length over a step, so the wall is measured again only where the
    // bound, less rounding, no longer keeps it farther than half a road. Each step takes a
    // millionth off the bound besides, more than the subtraction can round, so a bound
    // carried over many steps stays below the clearance.
    let mut wall_p = slice.wall_clearance(p);
    // The direction the line last moved in (not normalised: the curve's normal at the start,
    // then the last step), and how many steps have climbed.
    let (mut heading, mut climbs) = (normal, 0u32);
    let most_climbs = libm::ceilf(MAX_CLIMB_ROADS * w / step) as u32;
    while out.len() < TRACE_POINTS - 1 {
        let d1 = direction(p, lo_p, near_p);
        let mid = p + d1 * (0.5 * step);
        let lo_mid = lo_p - mid.dist(p) - polygon::rounding_slack(mid, hole_box);
        let d2 = direction(mid, lo_mid, None);
        let mut q = p + d2 * step;
        let mut climbed = false;
        // Once, or twice where the step came within half a road of the hole and climbs.
        let (wall_q, near_q, lo_q, hi_q) = loop {
            let bound = wall_p - q.dist(p) - 1e-6 * (1.0 + wall_p.abs());
            let wall_q = if bound > half + polygon::rounding_slack(q, slice.wall().bbox()) {
                bound
            } else {
                slice.wall_clearance(q)
            };
            if wall_q < half {
                let e = bisect(p, q, |x| slice.wall_clearance(x) - half);
                out.push(e).ok()?;
                return Some(HalfEnd::Wall);
            }
            let moved = q.dist(p) + polygon::rounding_slack(q, hole_box);
            let (lo_q, hi_q) = (lo_p - moved, hi_p + moved);
            let near_q = if far(lo_q) && !other_box_within(q, hi_q) {
                None
            } else {
                Some(slice.holes()[i].nearest(q))
            };
            let (lo_q, hi_q) = match near_q {
                Some(near) => {
                    let dq = near.distance;
                    if other_within(q, dq) {
                        // Which side of the bisector `x` lies on (`others(x).1 - own(x)`'s
                        // sign), measuring only the holes whose box is near enough to decide.
                        let side = |x: Point| {
                            let nearer = other_within(x, own(x));
                            debug_assert_eq!(!nearer, others(x).1 - own(x) > 0.0, "side at {x:?}");
                            if nearer {
                                -1.0
                            } else {
                                1.0
                            }
                        };
                        let e = bisect(p, q, side);
                        let (j, _) = others(e);
                        out.push(e).ok()?;
                        return Some(HalfEnd::Bisector(j as u8));
                    }
                    if dq < half - 1e-3 {
                        if climbed || climbs >= most_climbs {
                            return None;
                        }
                        q = climb(&slice.holes()[i], p, d2, heading, step, half)?;
                        climbed = true;
                        continue;
                    }
                    (dq, dq)
                }
                None => (lo_q, hi_q),
            };
            break (wall_q, near_q, lo_q, hi_q);
        };
        climbs += u32::from(climbed);
        heading = q - p;
        out.push(q).ok()?;
        p = q;
        near_p = near_q;
        (lo_p, hi_p) = (lo_q, hi_q);
        wall_p = wall_q;
    }
    None
}

#[cfg(test)]
mod tests {
    use std::boxed::Box;
    use std::vec::Vec as StdVec;

    use super::*;
    use crate::plan::Planner;
    use crate::{FeatureId, Settings};

    /// A 30 mm square wall round the hole `hole`, roads `w` wide.
    fn in_square_wall(hole: &[Point], w: f32) -> Slice {
        let wall = [(-15.0, -15.0), (15.0, -15.0), (15.0, 15.0), (-15.0, 15.0)]
            .map(|(x, y)| Point::new(x, y));
        let wall = Feature::new(FeatureId::Wall, &wall, [1.0, 0.0, 0.0, 0.0]).unwrap();
        let hole = Feature::new(FeatureId::Hole(0), hole, [0.0, 1.0, 0.0, 0.0]).unwrap();
        Slice::new(wall, &[hole], Settings::for_road_width(w)).unwrap()
    }

    /// A star of `spikes` rounded spikes (`r(a) = mean + depth * cos(spikes * a)`, 64
    /// vertices) in a 30 mm square wall, roads `w` wide.
    fn star_slice(spikes: usize, mean: f32, depth: f32, w: f32) -> Slice {
        let star: StdVec<Point> = (0..64)
            .map(|k| {
                let a = core::f32::consts::TAU * k as f32 / 64.0;
                let r = mean + depth * libm::cosf(spikes as f32 * a);
                Point::new(r * libm::cosf(a), r * libm::sinf(a))
            })
            .collect();
        in_square_wall(&star, w)
    }

    /// Plans `slice` and asserts that no MCL comes within half a road (less rounding) of its
    /// one hole.
    fn plan_clear_of_the_hole(slice: &Slice, planner: &mut Planner) {
        let w = slice.settings().road_width;
        let plan = planner.plan(slice).unwrap();
        for m in &plan.mcls {
            for p in plan.points(m).iter() {
                let d = slice.holes()[0].nearest(*p).distance;
                assert!(d >= 0.5 * w - 2e-3, "{p:?} {d}");
            }
        }
    }

    /// The angles, round the origin, at which the plan's MCLs start.
    fn start_angles(plan: &crate::Plan) -> StdVec<f32> {
        (plan.mcls.iter())
            .map(|m| {
                let p = plan.points(m)[0];
                libm::atan2f(p.y, p.x)
            })
            .collect()
    }

    /// A star whose notches are a road wide somewhat less than half a road out (random slice
    /// 5029's small star, 2.3 mm across at 0.58 mm roads): its keep-out curve's points there
    /// lie where the notch is a road wide, half a road from both sides, and the hole's normal,
    /// taken from one side, steps towards the other. Lines climb out of every notch, so MCLs
    /// leave every one of them; no line comes within half a road of the star. Without
    /// climbing the lines from the notches failed: 8 MCLs left the star (104 with), most
    /// notches had none, and the ground beyond them was left to the meanders.
    #[test]
    fn lines_climb_out_of_a_star_s_notches() {
        let slice = star_slice(8, 0.91, 0.245, 0.58);
        let mut planner = Box::new(Planner::new());
        plan_clear_of_the_hole(&slice, &mut planner);
        let angles = start_angles(planner.last_plan());
        for k in 0..8 {
            let notch = core::f32::consts::PI * (2 * k + 1) as f32 / 8.0;
            let off = |a: f32| {
                let d = (a - notch).rem_euclid(core::f32::consts::TAU);
                d.min(core::f32::consts::TAU - d)
            };
            assert!(
                angles
                    .iter()
                    .any(|&a| off(a) < core::f32::consts::PI / 16.0),
                "no MCL leaves notch {k}"
            );
        }
    }

    /// A square hole with a slot a road and a half wide and 10 roads deep. Climbing without a
    /// bound, a line from the slot's bottom crossed it to and fro until the trace's buffer was
    /// full, which refused the slice; with [`MAX_CLIMB_ROADS`] the slice plans (as it did
    /// before lines climbed, when they were given up at once), and every line laid keeps half
    /// a road from the hole.
    #[test]
    fn a_line_in_a_deep_slot_climbs_a_bounded_way() {
        let w = 0.4;
        // A 6 mm square, the slot cut into its top edge.
        let (a, d) = (0.75 * w, 10.0 * w);
        let hole = [
            (-3.0, -3.0),
            (3.0, -3.0),
            (3.0, 3.0),
            (a, 3.0),
            (a, 3.0 - d),
            (-a, 3.0 - d),
            (-a, 3.0),
            (-3.0, 3.0),
        ]
        .map(|(x, y)| Point::new(x, y));
        let slice = in_square_wall(&hole, w);
        let mut planner = Box::new(Planner::new());
        plan_clear_of_the_hole(&slice, &mut planner);
        assert!(planner.last_plan().mcls.len() > 16);
    }
}
