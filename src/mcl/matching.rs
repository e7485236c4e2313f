//! Matching MCLs across the bisectors: the paper's Algorithm I (section 2.1).
//!
//! For every bisector piece `B_k` between the cells of holes `a` and `b`, the halves of both
//! cells that end on it are candidates. Each has the objective (2.1)
//!
//! `f(p, q) = <N(p), N(q)>^w_n / |p - q|^w_d`
//!
//! with `p` its end on the bisector, `N(p)` the bisector's normal there (pointing away from its
//! own hole), `q` its start on the hole and `N(q)` the hole's outward normal. Greedily, the
//! unmatched half with the largest `f` takes the nearest unmatched half of the other cell along
//! the bisector, if that lies within `delta`; both are rebuilt to meet at the weighted point
//! `p* = B_k(u*)`, `u* = (u_i f_i + u_j f_j) / (f_i + f_j)` of (2.3). With no feasible
//! candidate the half is deleted, and halves left unmatched are removed: no MCL ends dangling
//! on a bisector.
//!
//! Beyond the paper, a candidate is feasible only if the match keeps the order of the matches
//! already made along the bisector (on both sides and at `p*`) and crosses no finished MCL, so
//! the rebuilt MCLs cannot cross each other.

use heapless::Vec;

use crate::cells::{away_from_hole, onto_bisector, Cells};
use crate::config::{HALF_POINTS, MAX_HALVES, MCL_POINTS};
use crate::error::{Error, Limit};
use crate::geometry::primitives::MinMax;
use crate::geometry::{polyline, primitives, Point};
use crate::mcl::{reshape_end, Half, HalfEnd, Halves};
use crate::stats::PlanStats;
use crate::Slice;

/// How far (mm) a half's end may lie from the traced bisector and still count as on it.
const ON_BISECTOR_TOL: f32 = 0.02;

/// The matching objective (2.1) of a half whose end lies on a bisector with normal
/// `bisector_normal` (pointing away from the half's hole).
///
/// ```
/// use hollowpath::geometry::Point;
/// use hollowpath::mcl::matching::objective;
/// // Perfectly aligned normals, 2 mm apart, w_n = w_d = 1.
/// let f = objective(Point::new(1.0, 0.0), Point::new(1.0, 0.0), 2.0, 1.0, 1.0);
/// assert_eq!(f, 0.5);
/// ```
pub fn objective(bisector_normal: Point, hole_normal: Point, dist: f32, w_n: f32, w_d: f32) -> f32 {
    let dot = bisector_normal.dot(hole_normal).fmax(0.0);
    libm::powf(dot, w_n) / libm::powf(dist.fmax(1e-3), w_d)
}

#[derive(Clone, Copy)]
struct Candidate {
    half: u16,
    side_a: bool,
    u: f32,
    f: f32,
    done: bool,
}

#[derive(Clone, Copy)]
struct Match {
    ua: f32,
    ub: f32,
    ustar: f32,
}

/// Matches across every bisector of `cells`; removes the unmatched bisector halves.
// Not inlined: its working set stays in a frame of its own, which the planner's other
// phases then share instead of adding to (`Planner::plan`'s frame).
#[inline(never)]
pub fn match_all(
    slice: &Slice,
    cells: &Cells,
    halves: &mut Halves,
    stats: &mut PlanStats,
) -> Result<(), Error> {
    let settings = *slice.settings();
    // Every half's box, kept as halves are joined: each join is checked against the finished
    // halves, and measuring every one of them again for each was most of the check's work.
    let mut boxes: Vec<(Point, Point), MAX_HALVES> = Vec::new();
    halves.boxes(&mut boxes)?;
    // Put every bisector end on its bisector piece.
    for x in 0..halves.len() {
        let e = halves.end_point(x);
        let h = &mut halves[x];
        h.partner = None;
        h.on_bisector = None;
        if let HalfEnd::Bisector(j) = h.end {
            let best = cells
                .between(h.hole as usize, j as usize)
                .map(|(k, b)| {
                    let (u, _, d) = polyline::project(&b.points, e);
                    (k, u, d)
                })
                .fold(None, |acc: Option<(usize, f32, f32)>, x| match acc {
                    Some(a) if a.2 <= x.2 => Some(a),
                    _ => Some(x),
                });
            match best {
                Some((k, u, d)) if d < ON_BISECTOR_TOL => h.on_bisector = Some((k as u8, u)),
                _ => {
                    h.alive = false;
                    stats.off_bisector += 1;
                }
            }
        }
    }
    for (k, bis) in cells.bisectors.iter().enumerate() {
        let mut cands: Vec<Candidate, MAX_HALVES> = Vec::new();
        for (idx, h) in halves.iter().enumerate() {
            let Some((bk, u)) = h.on_bisector else {
                continue;
            };
            if bk as usize != k || !h.alive {
                continue;
            }
            let p = halves.end_point(idx);
            let (na, _) = away_from_hole(slice, bis.a as usize, p);
            let (nb, _) = away_from_hole(slice, bis.b as usize, p);
            let side_a = h.hole == bis.a;
            let normal = if side_a { na - nb } else { nb - na }.normalized();
            let f = objective(
                normal,
                h.start_normal,
                p.dist(halves.start(idx)),
                settings.w_n,
                settings.w_d,
            );
            // Cannot fail: at most one candidate per half, and `halves` has the same capacity.
            cands
                .push(Candidate {
                    half: idx as u16,
                    side_a,
                    u,
                    f,
                    done: false,
                })
                .map_err(|_| Limit::Halves.error())?;
        }
        let mut matches: Vec<Match, MAX_HALVES> = Vec::new();
        loop {
            // The unmatched half with the largest objective (first on ties).
            let mut best: Option<usize> = None;
            for (c, cand) in cands.iter().enumerate() {
                if !cand.done && best.is_none_or(|b| cand.f > cands[b].f) {
                    best = Some(c);
                }
            }
            let Some(bi) = best else { break };
            cands[bi].done = true;
            let me = cands[bi];
            // Candidates of the other cell, nearest first along the bisector.
            let mut chosen = None;
            let mut tried: Vec<bool, MAX_HALVES> = Vec::new();
            // Never full: `cands` has the same capacity.
            tried
                .resize(cands.len(), false)
                .map_err(|_| Limit::Halves.error())?;
            loop {
                let mut near: Option<usize> = None;
                for (c, o) in cands.iter().enumerate() {
                    if o.done || tried[c] || o.side_a == me.side_a {
                        continue;
                    }
                    let d = libm::fabsf(o.u - me.u);
                    if d < settings.delta && near.is_none_or(|n| d < libm::fabsf(cands[n].u - me.u))
                    {
                        near = Some(c);
                    }
                }
                let Some(c) = near else { break };
                tried[c] = true;
                let other = cands[c];
                let (ua, ub, fa, fb) = if me.side_a {
                    (me.u, other.u, me.f, other.f)
                } else {
                    (other.u, me.u, other.f, me.f)
                };
                let ustar = if fa + fb > 0.0 {
                    (ua * fa + ub * fb) / (fa + fb)
                } else {
                    0.5 * (ua + ub)
                };
                let keeps_order = matches.iter().all(|m| {
                    let s = (ua - m.ua).signum();
                    s != 0.0 && (ub - m.ub).signum() == s && (ustar - m.ustar).signum() == s
                });
                if !keeps_order {
                    continue;
                }
                let pstar = onto_bisector(
                    slice,
                    bis.a as usize,
                    bis.b as usize,
                    polyline::point_at(&bis.points, ustar),
                );
                if try_join(
                    halves,
                    &mut boxes,
                    me.half as usize,
                    other.half as usize,
                    pstar,
                ) {
                    chosen = Some(c);
                    // Never full: a match uses up two candidates (of the same capacity).
                    matches
                        .push(Match { ua, ub, ustar })
                        .map_err(|_| Limit::Halves.error())?;
                    let (x, y) = (me.half as usize, other.half as usize);
                    halves[x].on_bisector = Some((k as u8, ustar));
                    halves[y].on_bisector = Some((k as u8, ustar));
                    break;
                }
            }
            match chosen {
                Some(c) => {
                    cands[c].done = true;
                    stats.matched_pairs += 1;
                }
                None => {
                    halves[me.half as usize].alive = false;
                    stats.removed_unmatched += 1;
                }
            }
        }
    }
    // Halves ending on a bisector without a partner are removed.
    for h in halves.iter_mut() {
        if h.alive && h.end != HalfEnd::Wall && h.partner.is_none() {
            h.alive = false;
            stats.removed_unmatched += 1;
        }
    }
    Ok(())
}

/// Rebuilds halves `x` and `y` to meet at `pstar`, unless that makes them cross a finished
/// MCL (a wall half or a matched half); on success they become partners.
/// `boxes` holds every half's box and is kept so.
fn try_join(
    halves: &mut Halves,
    boxes: &mut [(Point, Point)],
    x: usize,
    y: usize,
    pstar: Point,
) -> bool {
    let mut px = halves.points_copy(x);
    let mut py = halves.points_copy(y);
    reshape_end(&mut px, pstar);
    reshape_end(&mut py, pstar);
    let holes = [halves[x].hole, halves[y].hole];
    let held = |k: usize, _: &Half| boxes[k];
    if crosses_finished_boxed(halves, held, &px, &[x, y], &holes)
        || crosses_finished_boxed(halves, held, &py, &[x, y], &holes)
    {
        return false;
    }
    halves[x].partner = Some(y as u16);
    halves[y].partner = Some(x as u16);
    boxes[x] = primitives::bbox(&px);
    boxes[y] = primitives::bbox(&py);
    halves.set_points(x, &px);
    halves.set_points(y, &py);
    true
}

/// Whether `pts` crosses any finished, alive half other than those in `skip`, each half's
/// bounding box from `box_of` (the half's index and the half; exactly `bbox` of its points:
/// a caller that checks many moves keeps the boxes instead of measuring every half again for
/// each).
///
/// Only halves of the holes in `holes` are looked at: a half stays in its own cell, so it can
/// only meet halves of its own hole or of the hole across the bisector it ends on.
pub(crate) fn crosses_finished_boxed(
    halves: &Halves,
    box_of: impl Fn(usize, &Half) -> (Point, Point),
    pts: &[Point],
    skip: &[usize],
    holes: &[u8],
) -> bool {
    let bb = primitives::bbox(pts);
    halves
        .iter()
        .enumerate()
        .any(|(k, h)| crosses_half(halves, k, h, || box_of(k, h), pts, bb, skip, holes))
}

/// Every half's bounding box, and the box around each run of `run` halves' boxes.
#[derive(Clone, Copy)]
pub(crate) struct HalfBoxes<'a> {
    /// One box per half.
    pub boxes: &'a [(Point, Point)],
    /// One box per run of `run` halves.
    pub runs: &'a [(Point, Point)],
    /// Halves per run.
    pub run: usize,
}

/// [`crosses_finished_boxed`] with the halves' boxes and their runs' in `index`: a run whose
/// box is clear of `pts`' holds no half whose box meets it, and is passed over whole (the
/// same answer).
pub(crate) fn crosses_finished_chunked(
    halves: &Halves,
    index: HalfBoxes<'_>,
    pts: &[Point],
    skip: &[usize],
    holes: &[u8],
) -> bool {
    let bb = primitives::bbox(pts);
    // `pts` is one half's points (at most `HALF_POINTS`), its segments boxed once for all
    // the halves it is tested against.
    let mut room = [(Point::default(), Point::default()); HALF_POINTS];
    let Some(seg) = polyline::segment_boxes(pts, &mut room) else {
        return crosses_finished_boxed(halves, |k, _| index.boxes[k], pts, skip, holes);
    };
    let n = index.run;
    index.runs.iter().enumerate().any(|(c, &run)| {
        polyline::boxes_overlap(bb, run, 1e-4)
            && (c * n..((c + 1) * n).min(halves.len())).any(|k| {
                counts(&halves[k], k, skip, holes) && {
                    let hb = index.boxes[k];
                    polyline::boxes_overlap(bb, hb, 1e-4)
                        && polyline::polylines_cross_segment_boxed(
                            pts,
                            seg,
                            bb,
                            halves.points_of(&halves[k]),
                            hb,
                        )
                }
            })
    })
}

/// Whether finished half `k` (`h`) is one [`crosses_finished_boxed`] tests: alive, of one of
/// `holes`, not in `skip`, and finished (at the wall, or matched).
fn counts(h: &Half, k: usize, skip: &[usize], holes: &[u8]) -> bool {
    h.alive
        && holes.contains(&h.hole)
        && !skip.contains(&k)
        && (h.end == HalfEnd::Wall || h.partner.is_some())
}

/// Whether finished half `k` (`h`, its box from `hb`) counts for [`crosses_finished_boxed`] and
/// crosses `pts` (whose box is `bb`).
#[allow(clippy::too_many_arguments)]
fn crosses_half(
    halves: &Halves,
    k: usize,
    h: &Half,
    hb: impl FnOnce() -> (Point, Point),
    pts: &[Point],
    bb: (Point, Point),
    skip: &[usize],
    holes: &[u8],
) -> bool {
    if !counts(h, k, skip, holes) {
        return false;
    }
    let hb = hb();
    polyline::boxes_overlap(bb, hb, 1e-4)
        && polyline::polylines_cross_boxed(pts, bb, halves.points_of(h), hb)
}

/// Points of a finished MCL made of halves `first` and (optionally) `second`.
pub(crate) fn joined_points(
    halves: &Halves,
    first: usize,
    second: Option<usize>,
) -> Vec<Point, MCL_POINTS> {
    // Two halves of at most HALF_POINTS points, less the shared joint, always fit (so
    // `extend`, which would panic on overflow, cannot).
    const _: () = assert!(2 * HALF_POINTS - 1 <= MCL_POINTS);
    let mut out: Vec<Point, MCL_POINTS> = Vec::new();
    out.extend(halves.points(first).iter().copied());
    if let Some(s) = second {
        out.extend(halves.points(s).iter().rev().skip(1).copied());
    }
    out
}
