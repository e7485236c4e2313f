//! The arcs of the zigzag: the stretches of keep-out curve between two MCL ends that the road
//! runs along ([`emit_arc`]), how each lies among the others (alone, or a splice's outer or
//! inner arc: [`Arc`], [`arc_of`]), and the strip two arcs of a splice share
//! ([`shared_strip`]). A sibling of `emit`, which lays the MCLs between them.

use super::ends::Ends;
use super::turns::is_cut;
use super::{EDGE_MARGIN, NONE};
use crate::error::Limit;
use crate::geometry::primitives::MinMax;
use crate::geometry::Point;
use crate::keep_out::{self, KeepOut};
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Slice};
use heapless::Vec;

/// How far before and after the inner arc's ends a splice's outer arc runs on the nearer line,
/// in road widths ([`emit_arc`]). On the benchmark's 200 random slices the zigzag's median
/// overfill is 0.048 with none (the outer arc stepping down at the inner arc's ends), 0.041
/// with one road. On 15 of them that miss the bar (mean change of overfill, coverage): half a
/// road -0.0053, +0.00003; one -0.0080, -0.00015; one and a half -0.0086, -0.00045.
const SPLICE_LEAD: f32 = 1.0;

/// How an arc of a curve lies among the others.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Arc {
    /// Alone on its stretch of curve.
    Plain,
    /// A splice's outer arc: it passes the ends of the inner arc, and shares the stretch
    /// between them (arc lengths from its start, along it) with that arc.
    Outer(f32, f32),
    /// A splice's inner arc: between two neighbouring ends, under an outer arc.
    Inner,
}

/// The ends of curve `c` strictly between `from` and `to` going forward (increasing arc
/// length) or back: how many, and whether they are paired among themselves (arcs never
/// cross, so an arc may pass over only an arc nested inside it).
pub(super) fn spanned(ends: &Ends, c: usize, from: u16, to: u16, forward: bool) -> (usize, bool) {
    let (lo, hi) = ends.ranges[c];
    let (lo, n) = (lo as usize, (hi - lo) as usize);
    // Steps from `from` to end `id` in the direction of travel.
    let steps = |id: u16| {
        let (pf, k) = (
            ends.slot[from as usize] as usize,
            ends.slot[id as usize] as usize,
        );
        if forward {
            (k + n - pf) % n
        } else {
            (pf + n - k) % n
        }
    };
    let count = steps(to).saturating_sub(1);
    let pf = ends.slot[from as usize] as usize;
    let closed = (1..=count).all(|k| {
        let p = if forward { pf + k } else { pf + n - k };
        let mate = ends.arc[ends.order[lo + p % n] as usize];
        mate != NONE && (1..=count).contains(&steps(mate))
    });
    (count, closed)
}

/// The arc length from parameter `s0` to `s` along `curve`, going forward (increasing arc
/// length) or back.
fn along_curve(curve: &KeepOut<'_>, s0: f32, s: f32, forward: bool) -> f32 {
    if forward {
        curve.wrap(s - s0)
    } else {
        curve.wrap(s0 - s)
    }
}

/// The arc of curve `c` from end `from` to end `to`: which way it runs (forward: increasing
/// arc length; [`arc_of_direction`]), and its [`Arc`] role.
pub(super) fn arc_of(
    ends: &Ends,
    curve: &KeepOut<'_>,
    c: usize,
    from: u16,
    to: u16,
) -> (bool, Arc) {
    let s0 = ends.param[from as usize];
    let (forward, (count, closed)) = arc_of_direction(ends, curve, c, from, to);
    let (lo, hi) = ends.ranges[c];
    if hi - lo < 4 || !closed {
        return (forward, Arc::Plain);
    }
    // The end `k` steps from `from` along the arc's direction.
    let at = |k: isize| ends.beside(from, if forward { k } else { -k });
    let along = |id: u16| along_curve(curve, s0, ends.param[id as usize], forward);
    match count {
        // Over a nested arc: the outer arc of a splice.
        2 => (forward, Arc::Outer(along(at(1)), along(at(2)))),
        // Under one: the arc from the end before to the end after passes over exactly these
        // two.
        0 => {
            let (before, after) = (at(-1), at(2));
            let outer = ends.arc[before as usize] == after && {
                arc_of_direction(ends, curve, c, before, after) == (forward, (2, true))
            };
            (forward, if outer { Arc::Inner } else { Arc::Plain })
        }
        _ => (forward, Arc::Plain),
    }
}

/// Which way the arc of curve `c` from `from` to `to` runs, and what it passes over
/// ([`spanned`]): the way that passes over no end but those of an arc nested inside it; of
/// two such ways (or none), the one over fewer ends, then the shorter.
pub(super) fn arc_of_direction(
    ends: &Ends,
    curve: &KeepOut<'_>,
    c: usize,
    from: u16,
    to: u16,
) -> (bool, (usize, bool)) {
    let (s0, s1) = (ends.param[from as usize], ends.param[to as usize]);
    let ways = [true, false].map(|fwd| spanned(ends, c, from, to, fwd));
    let shorter = curve.wrap(s1 - s0) <= curve.wrap(s0 - s1);
    let forward = match (ways[0], ways[1]) {
        ((_, true), (_, false)) => true,
        ((_, false), (_, true)) => false,
        ((a, _), (b, _)) if a != b => a < b,
        _ => shorter,
    };
    (forward, ways[usize::from(!forward)])
}

/// Whether end `id` starts or ends a splice's inner arc ([`Arc::Inner`]).
pub(super) fn inner_end(ends: &Ends, curves: &[KeepOut<'_>], id: u16) -> bool {
    let mate = ends.arc[id as usize];
    if mate == NONE {
        return false;
    }
    let c = ends.curve[id as usize] as usize;
    arc_of(ends, &curves[c], c, id, mate).1 == Arc::Inner
}

/// How two arcs share one stretch of a keep-out curve's strip (a splice, [`emit_arc`]): the
/// width of each, and how far off the keep-out curve (away from the feature) the nearer and
/// the farther one run. Half a road each, a quarter road either side of the curve, when the
/// slice's [`min_width`](crate::Settings::min_width) allows; wider and nearer the curve (so
/// overlapping) when it does not; their outer edges [`EDGE_MARGIN`] inside the strip.
pub(super) fn shared_strip(slice: &Slice) -> (f32, f32, f32) {
    let w = slice.settings().road_width;
    let share = (0.5 * w - 2.0 * EDGE_MARGIN)
        .fmax(slice.settings().min_width)
        .fmin(w - 2.0 * EDGE_MARGIN);
    let nearer = 0.5 * share + EDGE_MARGIN - 0.5 * w;
    let farther = 0.5 * w - 0.5 * share - EDGE_MARGIN;
    (share, nearer, farther)
}

/// `p`, on the keep-out curve of curve `c` (a hole index, or `holes` for the wall), moved
/// `delta` farther from its feature (nearer for a negative `delta`).
pub(super) fn off_curve(slice: &Slice, c: usize, p: Point, delta: f32) -> Point {
    let (_, away) = slice.clearance_gradient_to(c, p);
    p + away * delta
}

/// Deposits the arc of curve `c` from end `from` to end `to` (the way that passes no other
/// end but those the arc spans).
///
/// A splice lays two arcs over one stretch of curve (the outer arc passing the inner arc's
/// ends). There they share the road's strip half and half instead of both covering it: the
/// outer arc runs a quarter road nearer the feature and the inner one a quarter road farther,
/// both half a road wide ([`shared_strip`]), and the MCLs into the inner arc end on its line
/// ([`inner_end`]). The outer arc keeps to its half from [`SPLICE_LEAD`] before the inner
/// arc's first end to as far after its last: the MCLs into the inner arc are as wide as their
/// bands there, and a full-width outer arc beside them doubled a lens a road across at each.
/// Where the curve runs into a notch of its feature and back out along itself, the arc cuts
/// across the notch's mouth instead ([`keep_out::skip_folds`]).
///
/// Near either end a full-width arc is no wider than keeps its round end within the MCL's
/// share of the stretch beyond, half the way to the next end outside the arc: where MCL ends
/// crowd closer than a road (a strong fan round a small hole), a road-wide arc laid a crescent
/// over the next MCL's road at every turn. On the random bench's 200 slices the zigzag's
/// median overfill fell from 0.0373 to 0.0343, coverage unchanged (the strip the arc leaves
/// is within half a road of the feature), and 97 slices met the bar instead of 83.
pub(super) fn emit_arc(
    slice: &Slice,
    ends: &Ends,
    curve: &KeepOut<'_>,
    c: usize,
    (from, to): (u16, u16),
    cuts: &[(f32, f32)],
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    let material = slice.material_at(c);
    let (s0, s1) = (ends.param[from as usize], ends.param[to as usize]);
    let (forward, role) = match arc_of(ends, curve, c, from, to) {
        // A splice's outer arc whose inner pair turns short (`turns`) has the stretch to
        // itself.
        (forward, Arc::Outer(..))
            if is_cut(cuts, ends.beside(from, if forward { 1 } else { -1 })) =>
        {
            (forward, Arc::Plain)
        }
        role => role,
    };
    let vertex = |at: Point, width: f32| Vertex {
        at,
        material,
        width,
        deposit: true,
    };
    let (share, nearer_by, farther_by) = shared_strip(slice);
    let shared = |p: Point, nearer: bool| {
        let delta = if nearer { nearer_by } else { farther_by };
        vertex(off_curve(slice, c, p, delta), share)
    };
    let w = w - 2.0 * EDGE_MARGIN;
    // The curve's vertices strictly between the two MCL ends (the MCLs carry the ends), with
    // their arc lengths from `s0`.
    // `arc` gives both ends and at most every vertex in between: a full buffer is a
    // contour of more vertices than the core holds.
    let mut inner: Vec<(Point, f32), { crate::config::MAX_VERTICES + 2 }> = Vec::new();
    let mut full = false;
    curve.arc(s0, s1, forward, |p, s| {
        full |= inner.push((p, along_curve(curve, s0, s, forward))).is_err();
    });
    if full {
        return Err(Limit::Vertices.error());
    }
    let half = 0.5 * slice.settings().road_width;
    // A chord across a fold's mouth keeps half a road from every feature, and the edge margin
    // more (a chord that only just fits at the arc's width was broken where a neighbouring
    // move did not: random slice 72's zigzag had 15 starts with half a road less the margin,
    // 12 without folds skipped and with this): it crosses no spike of the feature it skips.
    let fits = |a: Point, b: Point| {
        // A chord is at most `FOLD_GAP` road widths long: at most `8 FOLD_GAP` steps.
        let steps = libm::ceilf(4.0 * a.dist(b) / half).fmax(1.0);
        (1..steps as u32)
            .all(|k| slice.clearance(a.lerp(b, k as f32 / steps)) >= half + EDGE_MARGIN)
    };
    keep_out::skip_folds(&mut inner, slice.settings().road_width, fits);
    let between = inner.iter().skip(1).take(inner.len().saturating_sub(2));
    // How far along the curve the ends next to the arc's ends lie, outside the arc: the MCLs
    // there own half of that stretch each.
    let outside_gap = |id: u16, away_forward: bool| {
        let next = ends.beside(id, if away_forward { 1 } else { -1 });
        let param = |e: u16| ends.param[e as usize];
        along_curve(curve, param(id), param(next), away_forward)
    };
    let (gap0, gap1) = (outside_gap(from, !forward), outside_gap(to, forward));
    let total = inner.last().map_or(0.0, |&(_, along)| along);
    let min_width = slice.settings().min_width;
    let capped = |along: f32| {
        w.fmin(2.0 * along + gap0)
            .fmin(2.0 * (total - along) + gap1)
            .fmax(min_width)
    };
    match role {
        Arc::Plain => {
            for &(p, along) in between {
                emit_move(slice, sink, vertex(p, capped(along)))?;
            }
        }
        Arc::Inner => {
            for &(p, _) in between {
                emit_move(slice, sink, shared(p, false))?;
            }
        }
        Arc::Outer(x, y) => {
            // The shared stretch starts and ends a little before and after the inner arc's
            // ends: the MCLs into them run on the inner line there, as wide as their bands.
            let lead = SPLICE_LEAD * slice.settings().road_width;
            // Where the shared stretch reaches the arc's own end, the MCL there runs straight
            // to (or from) the shared line: a full-width vertex on the curve at the MCL's end
            // would be a move of no length at a road's width into the narrow MCL end, a disc
            // laid over the neighbouring road (53 of them on random slice 3).
            let (from_start, to_end) = (x - lead <= 0.0, y + lead >= total);
            let (x, y) = ((x - lead).fmax(0.0), (y + lead).fmin(total));
            let point = |along: f32| curve.at(if forward { s0 + along } else { s0 - along });
            let mut state = 0;
            // The curve's points, then past its end (`None`): a shared stretch reaching beyond
            // the last point is entered and left there.
            for item in between.map(Some).chain(core::iter::once(None)) {
                let along = item.map_or(f32::INFINITY, |&(_, along)| along);
                if state == 0 && along > x {
                    if !from_start {
                        emit_move(slice, sink, vertex(point(x), capped(x)))?;
                    }
                    emit_move(slice, sink, shared(point(x), true))?;
                    state = 1;
                }
                if state == 1 && along >= y {
                    emit_move(slice, sink, shared(point(y), true))?;
                    if !to_end {
                        emit_move(slice, sink, vertex(point(y), capped(y)))?;
                    }
                    state = 2;
                }
                if let Some(&(p, along)) = item {
                    let v = if state == 1 {
                        shared(p, true)
                    } else {
                        vertex(p, capped(along))
                    };
                    emit_move(slice, sink, v)?;
                }
            }
        }
    }
    Ok(())
}
