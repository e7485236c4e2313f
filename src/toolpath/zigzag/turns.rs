//! Short turns: where MCLs crowd at a hole, two that an arc joins there turn out in the field.
//!
//! Round a small hole in a large cell the MCLs fan out: to keep their roads within the widest
//! road far out, halves start as little as a thirty-second of a road apart at the hole
//! (`mcl::insert`'s strong fans split gaps down to a tenth of the narrowest road),
//! where every road, however narrow, lies over its neighbours until the field parts them, a
//! needle of doubled ground a hole's radius long beside each. Two MCLs whose ends an arc joins
//! at the hole need not reach it: the road runs in along one only until it has room beside
//! it, turns across to the other and runs out along that one, and the two roads either side
//! of the pair widen into the ground the pair left (their bands reach each other there,
//! [`laid_segments`](crate::toolpath::meander::band)). The pieces and pairings do not change: a
//! short turn lays the same road as the arc it replaces, only nearer the wall.
//!
//! Walking out from the hole along both MCLs of a pair a quarter road at a time, the pair turns
//! at the last step where one of the four gaps around it (between the MCL beside it and each of
//! its MCLs, and between its two) is still narrower than the narrowest road
//! ([`min_width`](crate::Settings::min_width)) and the two MCLs beside it are at most three
//! quarters of the widest road apart ([`max_width`](crate::Settings::max_width),
//! [`SPAN_PER_MAX_WIDTH`]; a whole widest road within three roads of the hole,
//! [`SPAN_NEAR_PER_MAX_WIDTH`]), so their roads fill what the pair leaves; the walk starts half
//! a road out ([`MIN_TURN_ROADS`]). A splice's inner pair may turn short too: the outer arc
//! then runs alone along the curve beneath it.
//!
//! The pairs are taken in two passes. In the first, the MCLs beside a pair must reach the hole:
//! of two neighbouring pairs only one turns short, each measured against MCLs laid whole. In
//! the second, the pairs beside one that turned short are walked again, measured as every pair
//! is against what the MCLs lay (`Fan::cut`): where a neighbour was cut back, the gap beside
//! the pair reaches the next MCL laid, so the MCLs left beside both pairs must still lie
//! within three quarters of the widest road wherever the second turns. A strong fan's halves
//! may crowd in a bundle for a dozen roads out from a small hole, more MCLs than one pair
//! thins (random slice 105: three MCLs of 0.6 mm roads within 0.05 mm of each other 4 mm out).
//! A single pass over every pair turned more pairs short, but a pair that turned first kept
//! its neighbour from turning farther out (on the random bench's 200 slices, one slice's
//! overfill rose by 0.006); the second pass keeps every turn of the first, and 197 zigzags met
//! the bar instead of 194 (overfill 0.0271 -> 0.0259 on average, coverage 0.0001 lower, no
//! slice's overfill higher).

use heapless::Vec;

use super::arc::{arc_of, Arc};
use super::ends::Ends;
use super::NONE;
use crate::config::MAX_MCLS;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polyline, Point};
use crate::keep_out::KeepOut;
use crate::toolpath::meander::band::{band_at, Fan};
use crate::toolpath::meander::near::Near;
use crate::{Error, Limit, Plan, Slice};

/// The stretch of each MCL laid that its road lays, by arc length from its `from` end
/// ([`Fan::cut`]), in the order of the MCLs laid.
pub(super) type Cuts = Vec<(f32, f32), MAX_MCLS>;

/// The step, in road widths, at which a pair's MCLs are walked out from the hole.
const STEP_PER_ROAD: f32 = 0.25;
/// How far out from the hole, in road widths, a pair may turn: beyond, its MCLs lay their
/// crowded stretch (a fan that parts them so slowly leaves a wedge wider than a road between
/// the MCLs beside it long before).
const MAX_TURN_ROADS: f32 = 12.0;
/// How far out from the hole, in road widths, a pair's walk starts: the nearest it turns
/// short (a turn nearer lays about what the arc would). On the random bench's first 40 slices,
/// before the other changes that came with the turns, half a road, one and two roads met the
/// bar on 35, 34 and 35 (coverage within 0.0002, overfill 0.0263 / 0.0263 / 0.0272 on
/// average). With every later change in, half a road rather than one: on seed 1's 200 mean
/// coverage 0.9865 -> 0.9862 and overfill 0.0256 -> 0.0250 (no slice's overfill up by more
/// than 0.0015), 794 -> 795 of seeds 1, 5000, 9000 and 20000 meeting the bar; on the 48
/// lattices, whose small channels crowd 16 to 20 MCL ends on their curves, overfill 0.0377 ->
/// 0.0351 (none higher), 29 -> 31. (It was a bound on where the walk, which started half a
/// road out, ended; at half a road that bound held always, so the walk starts there instead.)
const MIN_TURN_ROADS: f32 = 0.5;
/// How far apart, in widest roads, the MCLs beside a pair may be where it turns short. Their
/// roads each fill their half of it, each as wide as its band up to the widest road, but
/// their bands are measured along normals that cross the ground beneath the turn aslant, and
/// at the whole widest road a wedge of it was left bare below each turn (random slice 37).
/// On the random bench's 200 slices (with the rest of this change): 0.75 gave 187 zigzags
/// that meet the bar (coverage 0.9803, overfill 0.0251 on average), 0.9 gave 182 (0.9793,
/// 0.0225); a rule that asked whether each road's band, with the gap beyond it, reaches its
/// half (up to the widest road each side) turned more pairs short and bared more (on the first
/// 40 slices coverage 0.9773, overfill 0.0217, 33 met the bar, 37 with 0.75).
const SPAN_PER_MAX_WIDTH: f32 = 0.75;
/// How far apart, in widest roads, the MCLs beside a pair may be where it turns within
/// [`NEAR_ROADS`] of the hole: there the ground the pair leaves is a short wedge, which the
/// roads beside it fill at a whole widest road apart; the aslant normals of
/// [`SPAN_PER_MAX_WIDTH`] bare ground only along a longer stretch. Round a small channel in a
/// large cell (a lattice's) the strong fan's halves start a thirty-second of its curve apart,
/// closer than the narrowest road, and the span at the hole is already past three quarters of
/// the widest road, so no pair turned short and every road there lay at the narrowest width
/// over its neighbours. On the 48 lattices 31 -> 38 zigzags meet the bar (mean overfill 0.0351
/// -> 0.0297, coverage 0.9827 -> 0.9782: nine at 0.4 mm roads in, two at 0.25 mm out on
/// coverage); on seeds 1, 5000, 9000 and 20000 795 as before (14 in, 20156 out at coverage
/// 0.9693), on 40000 and 50000 398 -> 399 (40021 in); on seed 1 mean overfill 0.0250 ->
/// 0.0220, coverage 0.9862 -> 0.9840. The whole widest road at every distance: lattices 38,
/// but 793 of the 800 (a pair turning far out left a patch 1.5 mm across bare between a wall
/// and a bisector on slice 9085); 0.9 of it at every distance: 37, and seeds 1, 9000 and 20000
/// 200, 198 and 198; within two roads: 37, and seeds 1 and 20000 as within three.
const SPAN_NEAR_PER_MAX_WIDTH: f32 = 1.0;
/// How far out from the hole, in road widths, [`SPAN_NEAR_PER_MAX_WIDTH`] holds.
const NEAR_ROADS: f32 = 3.0;

/// Whether end `id` (of the `id / 2`-th MCL laid) is cut back.
pub(super) fn is_cut(cuts: &[(f32, f32)], id: u16) -> bool {
    cuts.get((id / 2) as usize).is_some_and(|&(lo, hi)| {
        if id % 2 == 0 {
            lo > 0.0
        } else {
            hi < f32::INFINITY
        }
    })
}

/// Cuts back the ends of the pairs of MCLs that turn short at the holes (into `cuts`, one
/// entry per MCL laid); `fan` the MCLs laid, whose disk of near segments is emptied after each
/// cut. Returns how many pairs turn short.
pub(super) fn cut_turns(
    slice: &Slice,
    plan: &Plan,
    ends: &Ends,
    curves: &[KeepOut<'_>],
    fan: &Fan<'_>,
    cuts: &mut Cuts,
) -> Result<u16, Error> {
    cuts.clear();
    for _ in 0..ends.mcls.len() {
        // Never full: one entry per MCL laid, of the same capacity.
        cuts.push((0.0, f32::INFINITY))
            .map_err(|_| Limit::Mcls.error())?;
    }
    let holes = slice.holes().len();
    let mut turns = 0u16;
    // The holes' curves (the wall's, last, has no fan to turn short of), twice: the second
    // time (`beside_cut`) for the pairs beside one that turned short.
    for (beside_cut, (c, curve)) in [false, true]
        .into_iter()
        .flat_map(|p| curves.iter().enumerate().take(holes).map(move |c| (p, c)))
    {
        let (lo, hi) = ends.ranges[c];
        let n = (hi - lo) as usize;
        if n < 4 {
            continue;
        }
        for k in 0..n {
            let b = ends.order[lo as usize + k];
            let e = ends.arc[b as usize];
            if e == NONE || ends.beside(b, 1) != e {
                continue;
            }
            // The pair (b, e), neighbours along the curve; a before it, d after it.
            let (a, d) = (ends.beside(b, -1), ends.beside(e, 1));
            // The first pass takes the pairs whose neighbours reach the hole; the second only
            // those beside a pair that turned short (the others' gaps are as the first found).
            let beside = is_cut(cuts, a) || is_cut(cuts, d);
            if beside != beside_cut || is_cut(cuts, b) || is_cut(cuts, e) {
                continue;
            }
            // An arc between neighbours that runs the long way round, over the others (a
            // splice's outer arc), is no pair's turn.
            if matches!(arc_of(ends, curve, c, b, e).1, Arc::Outer(..)) {
                continue;
            }
            if let Some(s) = turn(slice, plan, ends, fan, cuts, b, e) {
                // Both MCLs are cut the same arc length from the hole.
                for id in [b, e] {
                    let i = (id / 2) as usize;
                    let len = polyline::length(&plan.points(&plan.mcls[ends.mcls[i] as usize]));
                    if id % 2 == 0 {
                        cuts[i].0 = s;
                    } else {
                        cuts[i].1 = len - s;
                    }
                }
                // The disk holds the segments cut off.
                *fan.near.borrow_mut() = Near::new();
                turns += 1;
            }
        }
    }
    Ok(turns)
}

/// Where the pair of ends `b`, `e` turns short: the arc length from those ends along both
/// MCLs, or `None` where the pair does not crowd at the hole or turning short would leave the
/// MCLs beside it too far apart.
fn turn(
    slice: &Slice,
    plan: &Plan,
    ends: &Ends,
    fan: &Fan<'_>,
    cuts: &[(f32, f32)],
    b: u16,
    e: u16,
) -> Option<f32> {
    let settings = slice.settings();
    let w = settings.road_width;
    // Each MCL's points walked from the end at the hole, with their arc lengths.
    let walk = |id: u16| {
        let i = (id / 2) as usize;
        let mut pts = plan.points(&plan.mcls[ends.mcls[i] as usize]);
        if id % 2 == 1 {
            pts.reverse();
        }
        let mut cum = [0.0f32; crate::config::MCL_POINTS];
        polyline::cumulative(&pts, &mut cum);
        (pts, cum)
    };
    let (pb, cb) = walk(b);
    let (pe, ce) = walk(e);
    let (cb, ce) = (&cb[..pb.len()], &ce[..pe.len()]);
    let room = |len: f32, id: u16| {
        let (lo, hi) = cuts[(id / 2) as usize];
        // The far end's cut, if any, from the far end.
        let far = if id % 2 == 0 { len - hi.fmin(len) } else { lo };
        len - far - 2.0 * w
    };
    let (lb, le) = (
        cb.last().copied().unwrap_or(0.0),
        ce.last().copied().unwrap_or(0.0),
    );
    let most = (MAX_TURN_ROADS * w)
        .fmin(0.5 * room(lb, b))
        .fmin(0.5 * room(le, e));
    // The gaps either side of the MCL of end `id` at `p` (direction `dir` from the hole): the
    // one toward `other`, and the one away from it.
    let gaps = |id: u16, p: Point, dir: Point, other: Point| {
        let i = id / 2;
        let me = ends.mcls[i as usize];
        let fan = Fan {
            me,
            at: i,
            cut: cuts,
            ..*fan
        };
        let (left_n, left, right) = band_at(slice, plan, p, dir, &fan)?;
        Some(if (other - p).dot(left_n) >= 0.0 {
            (left, right)
        } else {
            (right, left)
        })
    };
    let step = STEP_PER_ROAD * w;
    let mut s = MIN_TURN_ROADS * w;
    // The farthest level so far at which the MCLs beside the pair fill what it leaves.
    let mut last = None;
    while s <= most {
        let (p, dp) = polyline::point_along(&pb, cb, s);
        let (q, dq) = polyline::point_along(&pe, ce, s);
        let (toward_e, beside_b) = gaps(b, p, dp, q)?;
        let (toward_b, beside_e) = gaps(e, q, dq, p)?;
        let crowded = toward_e.fmin(toward_b).fmin(beside_b).fmin(beside_e) < settings.min_width;
        // Across the pair, from the MCL beside one to the MCL beside the other.
        let span = beside_b + p.dist(q) + beside_e;
        let limit = if s <= NEAR_ROADS * w {
            SPAN_NEAR_PER_MAX_WIDTH
        } else {
            SPAN_PER_MAX_WIDTH
        };
        if !crowded || span > limit * settings.max_width {
            break;
        }
        last = Some(s);
        s += step;
    }
    last
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_end_is_cut_where_its_side_of_the_stretch_is() {
        // MCL 0 cut at its `from` end, MCL 1 at its far end, MCL 2 whole.
        let cuts = [(0.5, f32::INFINITY), (0.0, 3.0), (0.0, f32::INFINITY)];
        let cut: [bool; 6] = core::array::from_fn(|id| is_cut(&cuts, id as u16));
        assert_eq!(cut, [true, false, false, true, false, false]);
        // An MCL past the end of the cuts is whole.
        assert!(!is_cut(&cuts, 6) && !is_cut(&cuts, 7));
    }
}
