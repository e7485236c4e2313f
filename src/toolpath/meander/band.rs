//! The band each road of the zigzag owns along its MCL (a sibling of the meander that fills a
//! band too wide for one road): the MCLs laid and their boxes ([`Fan`]), how far the ground
//! reaches across an MCL on either side before the next road ([`band_at`]), and the road's
//! width and place in its band ([`road_at`]).

use heapless::Vec;

use super::near::{self, Near};
use super::probe::{features_within, touch};
use crate::config::MAX_MCLS;
use crate::error::Limit;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polygon, primitives, Point};
use crate::toolpath::zigzag::EDGE_MARGIN;
use crate::{Error, Plan, Slice};
use core::cell::RefCell;

/// The band a road along an MCL owns at a point ([`band_at`]): the unit normal to the left of
/// the MCL, and the distances to the neighbouring MCL on the left and on the right.
pub(in crate::toolpath) type Band = (Point, f32, f32);

/// The MCLs a zigzag lays, which the band of each road is measured against ([`band_at`]),
/// and the boxes around them (to skip those too far to matter).
#[derive(Clone, Copy)]
pub(in crate::toolpath) struct Fan<'a> {
    /// The plan index of the MCL the road runs along.
    pub me: u16,
    /// Its place in `laid`: the MCLs next to it there (its neighbours around the feature) are
    /// measured first, so the nearest bound the search early.
    pub at: u16,
    /// Plan indices of the MCLs laid.
    pub laid: &'a [u16],
    /// The box around each MCL laid, in the order of `laid`.
    pub boxes: &'a [(Point, Point)],
    /// The box around each run of [`CHUNK`] MCLs in `laid` (neighbours around a feature, so
    /// one box rules out several far ones at once).
    pub chunks: &'a [(Point, Point)],
    /// The MCL segments near the last query ([`Near`]), for the next.
    pub near: &'a RefCell<Near>,
    /// Whether the keep-out strip nearest to a point lies on a stretch of its curve that no
    /// arc lays, at least the given arc length from either end of that stretch (the zigzag's
    /// [`Arcs::bare`](crate::toolpath::zigzag) once its arcs are chosen; `None`: every strip
    /// is kept for an arc). A stroke's end runs on into such a strip
    /// ([`stroke`](super::stroke)).
    pub bare: Option<&'a dyn Fn(Point, f32) -> bool>,
    /// The stretch of each MCL laid that its road lays, by arc length from its `from` end, in
    /// the order of `laid` (the zigzag's short turns cut an MCL's end back, `turns`); an MCL
    /// past the end of it is laid whole.
    pub cut: &'a [(f32, f32)],
}

impl Fan<'_> {
    /// [`Slice::clearance`] at `q`, from the edges [`Near`] holds where they answer it.
    pub(in crate::toolpath) fn clearance(&self, slice: &Slice, q: Point) -> f32 {
        self.near
            .try_borrow_mut()
            .ok()
            .filter(|_| !near::unasked())
            .and_then(|mut near| near.clearance(slice, q))
            .unwrap_or_else(|| slice.clearance(q))
    }
}

/// How many MCLs laid in a row share one of [`Fan::chunks`]' boxes.
pub(super) const CHUNK: usize = 8;

/// [`Fan::boxes`]' buffer.
pub(in crate::toolpath) type FanBoxes = Vec<(Point, Point), MAX_MCLS>;
/// [`Fan::chunks`]' buffer.
pub(in crate::toolpath) type FanChunks = Vec<(Point, Point), { MAX_MCLS.div_ceil(CHUNK) }>;

/// Fills [`Fan::boxes`] and [`Fan::chunks`] for the MCLs `laid` (plan indices).
pub(in crate::toolpath) fn fan_boxes(
    plan: &Plan,
    laid: &[u16],
    boxes: &mut FanBoxes,
    chunks: &mut FanChunks,
) -> Result<(), Error> {
    boxes.clear();
    chunks.clear();
    for &k in laid {
        boxes
            .push(plan.mcl_box(&plan.mcls[k as usize]))
            .map_err(|_| Limit::Mcls.error())?;
    }
    for run in boxes.chunks(CHUNK) {
        chunks
            .push(primitives::union_all(run))
            .map_err(|_| Limit::Mcls.error())?;
    }
    Ok(())
}

/// The `step`-th of `0..n` outward from `at`: `at`, `at + 1`, `at - 1`, `at + 2`, ... (mod `n`,
/// each once over `step` in `0..n`).
fn outward(at: usize, step: usize, n: usize) -> usize {
    let half = step.div_ceil(2);
    if step % 2 == 1 {
        let i = at + half;
        if i >= n {
            i - n
        } else {
            i
        }
    } else if half > at {
        at + n - half
    } else {
        at - half
    }
}

/// How far the ground across the MCL at `p` reaches along the unit normal `n` before it is
/// another road's, as the gap to a neighbour (the road owns half of it): twice the radius of
/// the largest ball centred on the normal that touches the MCL at `p` and no other MCL laid,
/// so each road fills up to the medial line between it and the next, from whatever side that
/// comes, and neighbouring roads' strokes meet without overlap however the MCLs fan, curve or
/// end; or, where the normal meets a feature first, twice the room up to its keep-out strip
/// (a road wide, where the arcs run). The MCL the road runs along counts too, away from `p`
/// (a curved MCL may face itself). Both sides at once: along `n` and along `-n`.
pub(super) fn reach(slice: &Slice, plan: &Plan, p: Point, n: Point, fan: &Fan<'_>) -> [f32; 2] {
    // The segments and edges held near `p` answer most queries (those whose balls stay
    // inside their disk); the rest search every feature and every MCL laid.
    let near = match fan.near.try_borrow_mut() {
        Ok(mut near) if !near::unasked() => near.reach_both(slice, plan, p, n, fan),
        _ => [None, None],
    };
    let back = n * -1.0;
    [(near[0], n), (near[1], back)]
        .map(|(near, n)| near.map_or_else(|| search(slice, plan, p, n, fan), |best| 2.0 * best))
}

/// [`reach`] along `n` alone, searching every feature and every MCL laid.
pub(super) fn search(slice: &Slice, plan: &Plan, p: Point, n: Point, fan: &Fan<'_>) -> f32 {
    let w = slice.settings().road_width;
    let strip = w + 2.0 * EDGE_MARGIN;
    // The wall stops every ray from inside it, but a ray through one of its vertices may
    // slip between the two edges by rounding: then the MCLs alone bound the band (as the
    // disk of `Near` bounds it where it holds no edge met), and with none either the band
    // is empty.
    let hit = features_within(slice, p, n, 0.0);
    let mut best = if hit.is_finite() {
        (hit - strip).fmax(0.0)
    } else {
        f32::INFINITY
    };
    // From the MCL's own place in `laid` outward: its neighbours first.
    let count = fan.laid.len();
    let runs = fan.chunks.len();
    let at = (fan.at as usize).min(count.saturating_sub(1)) / CHUNK;
    for step in 0..runs {
        let c = outward(at, step, runs);
        // A ball of radius t from p reaches no point farther than 2 t from p.
        if polygon::bbox_distance2(fan.chunks[c], p) >= 4.0 * best * best {
            continue;
        }
        for i in c * CHUNK..((c + 1) * CHUNK).min(count) {
            reach_mcl(plan, p, n, fan, i, w, &mut best);
        }
    }
    if best.is_finite() {
        2.0 * best
    } else {
        0.0
    }
}

/// [`reach`]'s search over the `i`-th MCL of `fan.laid`: lowers `best` to the radius of the
/// first ball along `p + t n` that touches it.
fn reach_mcl(plan: &Plan, p: Point, n: Point, fan: &Fan<'_>, i: usize, w: f32, out: &mut f32) {
    let mut best = *out;
    let (m, bbox) = (fan.laid[i], fan.boxes[i]);
    if polygon::bbox_distance2(bbox, p) >= 4.0 * best * best {
        return;
    }
    laid_segments(plan, fan, i, |seg| {
        touch(p, n, seg, m == fan.me, w, &mut best);
        true
    });
    *out = best;
}

/// Calls `f` on every segment of the `i`-th MCL of `fan.laid` that its road lays, in order
/// from its `from` end, until `f` returns false: the whole MCL, or the stretch of it that
/// [`Fan::cut`] leaves (its segments there clipped to the stretch).
pub(in crate::toolpath) fn laid_segments(
    plan: &Plan,
    fan: &Fan<'_>,
    i: usize,
    mut f: impl FnMut([Point; 2]) -> bool,
) {
    let mut pts = plan.points_iter(&plan.mcls[fan.laid[i] as usize]);
    let Some(mut prev) = pts.next() else {
        return;
    };
    let Some(&(lo, hi)) = fan
        .cut
        .get(i)
        .filter(|&&(lo, hi)| lo > 0.0 || hi < f32::INFINITY)
    else {
        for q in pts {
            if !f([prev, q]) {
                return;
            }
            prev = q;
        }
        return;
    };
    let mut s = 0.0;
    for q in pts {
        let l = prev.dist(q);
        let (s0, s1) = (s, s + l);
        s = s1;
        if s1 > lo && s0 < hi && l > 0.0 {
            let a = if s0 < lo {
                prev.lerp(q, (lo - s0) / l)
            } else {
                prev
            };
            let b = if s1 > hi {
                prev.lerp(q, (hi - s0) / l)
            } else {
                q
            };
            if !f([a, b]) {
                return;
            }
        }
        prev = q;
    }
}

/// The band the road along an MCL owns at `p` (direction `dir`): the unit normal to the left of
/// the MCL and how far the ground reaches across it on the left and on the right before the
/// next road ([`reach`]: the first MCL laid that the normal meets, or a feature's keep-out
/// strip); the road owns half of each gap. `None` where `dir` is degenerate.
pub(in crate::toolpath) fn band_at(
    slice: &Slice,
    plan: &Plan,
    p: Point,
    dir: Point,
    fan: &Fan<'_>,
) -> Option<Band> {
    let len = dir.norm();
    if len < 1e-6 {
        return None;
    }
    // Unit normal to the left of the MCL.
    let left_n = Point::new(-dir.y / len, dir.x / len);
    let [left, right] = reach(slice, plan, p, left_n, fan);
    Some((left_n, left, right))
}

/// Where the road along MCL polyline `pts` passes vertex `j`, and its width there.
///
/// The road covers its share of the gaps to the nearest neighbouring road on either side
/// (distances `l` and `r` of its band): from half-way to the left one to half-way to
/// the right one. So it is `(l + r) / 2` wide and its centre lies `(r - l) / 4` toward the
/// wider gap; two neighbours then meet half-way between their MCLs where MCLs fan out or crowd
/// in, without gap or overlap. The shift is at most half the road's width (its edge on the
/// MCL), which binds only where the width does: at a quarter of the width, which bound the
/// bands up to three times wider on one side than on the other, a road beside a pair that
/// turns short of a hole (`zigzag::turns`) left a wedge bare between it and the road beyond;
/// on the random bench's first 40 slices, before turns, the zigzag's coverage rose 0.0012
/// with it and its overfill 0.0001. The width stays within the slice's
/// [`min_width`](crate::Settings::min_width) .. [`max_width`](crate::Settings::max_width) and
/// at most twice the point's clearance from the features, less [`EDGE_MARGIN`] each side (the
/// shift is left out where it would come nearer a feature than half the narrowest road); the
/// MCL's end vertices (`end`: on keep-out curves, where the arcs to the next MCL leave) stay
/// where they are and are at most a road width wide, so nothing spills. `band` is the band
/// the road owns at `p` ([`band_at`]).
pub(in crate::toolpath) fn road_at(
    slice: &Slice,
    fan: &Fan<'_>,
    p: Point,
    end: bool,
    band: Option<Band>,
) -> (Point, f32) {
    let settings = slice.settings();
    let w = settings.road_width;
    let Some((left_n, left, right)) = band else {
        return (p, w);
    };
    let width = (0.5 * (left + right)).clamp(settings.min_width, settings.max_width);
    let cap = |q: Point| 2.0 * (fan.clearance(slice, q) - EDGE_MARGIN);
    if end {
        return (p, width.fmin(w - 2.0 * EDGE_MARGIN));
    }
    let shifted = p - left_n * (0.25 * (right - left)).clamp(-0.5 * width, 0.5 * width);
    // The shift toward the wider gap may bring the road nearer a feature than half the
    // narrowest road: then it stays on its MCL.
    let shifted_cap = cap(shifted);
    if shifted_cap >= settings.min_width {
        (shifted, width.fmin(shifted_cap))
    } else {
        (p, width.fmin(cap(p)))
    }
}
