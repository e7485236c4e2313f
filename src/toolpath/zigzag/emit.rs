//! Depositing the zigzag: a road out and back along each MCL (banded, or a meander where the
//! fan outgrows the widest road), and the arcs along the keep-out curves between MCL ends.

use super::ends::{Arcs, Ends};
use super::turns::is_cut;
use super::{EDGE_MARGIN, END_STEPS, NONE};
use crate::config::MCL_POINTS;
use crate::error::Limit;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polyline, Point};
use crate::keep_out::{self, KeepOut};
use crate::toolpath::composition::{along, mcl_end_materials};
use crate::toolpath::meander::band::{band_at, road_at, Band, Fan};
use crate::toolpath::meander::{meander, opening_stroke, too_wide, Strokes};
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Material, Plan, Slice};
use heapless::Vec;

/// A stretch of keep-out curve beside an MCL's end that no arc lays
/// ([`Arcs::bare_beside`](super::ends::Arcs::bare_beside)): where a meander reaches that end,
/// the road lays the half of the stretch next to it, as a stroke along the strip.
#[derive(Clone, Copy)]
pub(super) struct Strip<'a> {
    pub curve: &'a KeepOut<'a>,
    /// The curve's index (a hole's, or `holes` for the wall).
    pub c: usize,
    /// The MCL end's parameter on the curve.
    pub param: f32,
    /// Which way the bare stretch runs from the end (forward: increasing parameter).
    pub forward: bool,
    /// Half the bare stretch's length: how far the MCL's share of it reaches.
    pub reach: f32,
}

/// Shortest strip a meander lays beside its MCL's end, in road widths: a stroke's end nearer
/// the MCL than this leaves no strip worth a turn. On the random bench's first 40 slices the
/// zigzag's mean coverage and overfill move by at most 0.0001 between 0.1, 0.25 and 0.5.
const STRIP_MIN: f32 = 0.25;

impl<'a> Strip<'a> {
    /// The bare stretch beside end `id` ([`Arcs::bare_beside`]), unless `id` leads into a
    /// splice's inner arc (whose outer arc shares the strip there).
    pub(super) fn beside(
        arcs: &Arcs,
        ends: &Ends,
        curves: &'a [KeepOut<'a>],
        id: u16,
    ) -> Option<Strip<'a>> {
        if inner_end(ends, curves, id) {
            return None;
        }
        let (forward, reach) = arcs.bare_beside(ends, curves, id)?;
        let c = ends.curve[id as usize] as usize;
        Some(Strip {
            curve: &curves[c],
            c,
            param: ends.param[id as usize],
            forward,
            reach,
        })
    }

    /// The curve's parameter `d` along the strip from the end.
    fn param_at(&self, d: f32) -> f32 {
        if self.forward {
            self.param + d
        } else {
            self.param - d
        }
    }

    /// The curve's point `d` along the strip from the end.
    fn toward(&self, d: f32) -> Point {
        self.curve.at(self.param_at(d))
    }

    /// Arriving at the end from a meander's last stroke, whose end is at `tip`: lays the strip
    /// from beside `tip` in to the end (the end's own point left out: the MCL lays it), if
    /// `tip` lies on the strip's side at least [`STRIP_MIN`] from the end. Returns whether it
    /// laid it.
    fn lay_in(&self, slice: &Slice, tip: Point, sink: &mut impl PathSink) -> Result<bool, Error> {
        let s = self.curve.param_of(tip);
        let ahead = self.curve.wrap(if self.forward {
            s - self.param
        } else {
            self.param - s
        });
        if ahead >= 0.5 * self.curve.length() {
            return Ok(false);
        }
        self.lay(slice, ahead, true, sink)
    }

    /// Leaving the end (on the MCL at `p`) into a meander whose first stroke's band is `band`:
    /// lays the strip out to the stroke's end on its side, if that stands at least
    /// [`STRIP_MIN`] from the end. Returns whether the strip lies on the band's left, if it
    /// laid it.
    fn lay_out(
        &self,
        slice: &Slice,
        p: Point,
        (left_n, left, right): Band,
        sink: &mut impl PathSink,
    ) -> Result<Option<bool>, Error> {
        let w = slice.settings().road_width;
        let on_left = (self.toward(w) - p).dot(left_n) >= 0.0;
        let half = 0.5 * if on_left { left } else { right };
        Ok(self.lay(slice, half, false, sink)?.then_some(on_left))
    }

    /// Lays the strip between `d` along it (at most its share, less the round end's half road)
    /// and the end, toward the end (`inward`) or away from it, the end's own point left out;
    /// nothing where that is shorter than [`STRIP_MIN`]. Returns whether it laid it.
    fn lay(
        &self,
        slice: &Slice,
        d: f32,
        inward: bool,
        sink: &mut impl PathSink,
    ) -> Result<bool, Error> {
        let w = slice.settings().road_width;
        let d = d.fmin(self.reach - 0.5 * w);
        if d < STRIP_MIN * w {
            return Ok(false);
        }
        let far = self.param_at(d);
        let (s0, s1, forward) = if inward {
            (far, self.param, !self.forward)
        } else {
            (self.param, far, self.forward)
        };
        let material = slice.material_at(self.c);
        let width = w - 2.0 * EDGE_MARGIN;
        let mut out = Ok(());
        self.curve.arc(s0, s1, forward, |at, s| {
            let off = self.curve.wrap(s - self.param);
            let at_end = off.fmin(self.curve.length() - off) < 1e-6;
            if out.is_ok() && !at_end {
                let v = Vertex {
                    at,
                    material,
                    width,
                    deposit: true,
                };
                out = emit_move(slice, sink, v);
            }
        });
        out.map(|()| true)
    }
}

/// Deposits MCL `k` from its `from` end (`forward`) or from its far end, `near` its
/// neighbouring MCLs ([`neighbours`]), `spliced` the curve of each end (`from` end first) that
/// leads into a splice's inner arc ([`inner_end`]); the first vertex of a piece is reached by
/// travel.
#[allow(clippy::too_many_arguments)]
pub(super) fn emit_mcl(
    slice: &Slice,
    plan: &Plan,
    k: usize,
    fan: &Fan<'_>,
    spliced: [Option<usize>; 2],
    strips: [Option<Strip<'_>>; 2],
    forward: bool,
    travel_to_start: bool,
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    let (ma, mb) = mcl_end_materials(slice, plan, k);
    // The stretch of it the road lays (a short turn cuts an end back, `turns`), and the
    // materials at its ends.
    let (pts, ma, mb) = laid_stretch(
        plan.points(&plan.mcls[k]),
        fan.cut.get(fan.at as usize),
        (ma, mb),
    )?;
    // Arc length at every vertex, summed from the `from` end either way, so both ends carry
    // exactly their feature's material.
    let mut cum = [0.0f32; crate::config::MCL_POINTS];
    polyline::cumulative(&pts, &mut cum);
    let n = pts.len();
    let len = cum[n - 1];
    // The MCL's vertices in walking order, with extra ones near both ends (`END_STEPS`).
    let order = |step: usize| if forward { step } else { n - 1 - step };
    // Cannot fail: at most `END_STEPS.len()` extras before and after one vertex.
    let mut stops: Vec<(Point, Point, f32, bool), { 2 * END_STEPS.len() + 2 }> = Vec::new();
    // Extra stops on the move from end vertex `e` toward vertex `q`, nearest the end first;
    // on a move that is both first and last, each end's stay on its own half.
    let (pts, cum) = (&pts, &cum);
    let extras = |e: usize, q: usize| {
        let seg = pts[e].dist(pts[q]);
        let reach = if n == 2 { 0.5 * seg } else { seg - 1e-4 };
        END_STEPS
            .iter()
            .filter(move |&&f| f * w < reach)
            .map(move |&f| {
                let t = f * w / seg;
                let at_cum = cum[e] + (cum[q] - cum[e]) * t;
                (pts[e].lerp(pts[q], t), pts[q] - pts[e], at_cum, false)
            })
    };
    let mut strokes = Strokes::new();
    // A point on the bare strip beside the far end, if any: a meander's run reaching that end
    // ends on its side ([`meander`]).
    let closing = strips[1].map(|strip| strip.toward(w));
    for step in 0..n {
        // Whether a strip beside this end was laid: the extra stops there are not.
        let mut stripped = false;
        let i = order(step);
        let dir = pts[(i + 1).min(n - 1)] - pts[i.saturating_sub(1)];
        let is_end = step == 0 || step + 1 == n;
        stops.clear();
        if step + 1 == n && n >= 2 {
            // Approaching the far end.
            for stop in extras(i, order(step - 1)).rev() {
                stops.push(stop).map_err(|_| Limit::PathVertices.error())?;
            }
        }
        stops
            .push((pts[i], dir, cum[i], is_end))
            .map_err(|_| Limit::PathVertices.error())?;
        if step == 0 && n >= 2 {
            // Leaving the first end.
            for stop in extras(i, order(1)) {
                stops.push(stop).map_err(|_| Limit::PathVertices.error())?;
            }
        }
        if step + 1 == n && n >= 2 {
            // A meander reaching the far end beside a bare strip lays the strip from its
            // stroke's end on that side, on to the end.
            if let (Some(strip), Some(tip)) = (strips[1], strokes.tip()) {
                stripped = strip.lay_in(slice, tip, sink)?;
            }
        }
        for (k, &(p, dir, at_cum, is_end)) in stops.iter().enumerate() {
            if stripped && !is_end {
                continue;
            }
            // Inside a meander (the last sample before was a stroke, and the band here is
            // wide too) the strokes fill the band: no road along the MCL's middle.
            let band = band_at(slice, plan, p, dir, fan);
            if strokes.in_meander && !is_end && step != 0 && step + 1 != n && too_wide(slice, band)
            {
                continue;
            }
            strokes.in_meander = false;
            let (mut at, mut width) = road_at(slice, fan, p, is_end, band);
            // Next to an end into a splice's inner arc (the curve, and whether this stop is
            // the end itself or one of the stops within a road of it: the extra stops beside
            // it, and the MCL's own vertices nearer it than the first of them).
            let beside = match step {
                0 => spliced[0].map(|c| (c, k == 0)),
                _ if step + 1 == n => spliced[1].map(|c| (c, k + 1 == stops.len())),
                _ => {
                    let from_start = if forward { at_cum } else { len - at_cum };
                    if from_start < w {
                        spliced[0].map(|c| (c, false))
                    } else if len - from_start < w {
                        spliced[1].map(|c| (c, false))
                    } else {
                        None
                    }
                }
            };
            match beside {
                // The end lies on the inner arc's line, a quarter road off the curve.
                Some((c, true)) => {
                    let (share, _, farther) = shared_strip(slice);
                    at = off_curve(slice, c, at, farther);
                    width = share;
                }
                // The stops beside it run next to the outer arc, which lays the strip's half
                // nearer the feature (its far edge `w / 2 - margin` off the feature,
                // [`shared_strip`]): each keeps its edge out of that half by moving away from
                // the feature, at its width, instead of laying a lens over the outer arc.
                // Narrowing instead left the neighbouring roads' share of the band bare (on
                // the random bench's first 40 slices, overfill -0.0017 and coverage -0.0011
                // narrowed, -0.0009 and +0.0002 moved). Before, only the extra stops kept out
                // (narrowed, or left out below `min_width`: 18 of those 40 met the bar, 22
                // now), and the MCL's own vertices nearer the end went on at the band's width.
                Some((c, false)) => {
                    let (clearance, away) = slice.clearance_gradient_to(c, at);
                    let lack = (0.5 * w - EDGE_MARGIN) - (clearance - 0.5 * width);
                    if lack > 0.0 {
                        at = at + away * lack;
                    }
                }
                None => {}
            }
            let v = Vertex {
                at,
                material: along(&ma, &mb, at_cum, len),
                width,
                // Reached by travel only at the start of a piece; else the arc before leads
                // here.
                deposit: step != 0 || k != 0 || !travel_to_start,
            };
            emit_move(slice, sink, v)?;
            if step == 0 && k == 0 && n >= 2 {
                // A meander leaving the first end beside a bare strip: the road lays the strip
                // out to where the first stroke's end on that side stands, and starts there.
                let opening = strips[0].and_then(|strip| {
                    let walk = (&pts[..], &cum[..n]);
                    let band = opening_stroke(slice, plan, walk, forward, fan, &mut strokes)?;
                    Some((strip, band))
                });
                if let Some((strip, band)) = opening {
                    if let Some(on_left) = strip.lay_out(slice, p, band, sink)? {
                        strokes.right_first = !on_left;
                        strokes.opened = true;
                        stripped = true;
                    }
                }
            }
        }
        if step + 1 < n {
            let j = order(step + 1);
            meander(
                slice,
                plan,
                (&pts[..], &cum[..n]),
                (pts[i], pts[j]),
                (cum[i], cum[j], len),
                (&ma, &mb),
                fan,
                closing,
                &mut strokes,
                sink,
            )?;
        }
    }
    Ok(())
}

/// The stretch of an MCL (its points `whole`) between the arc lengths `cut` from its `from`
/// end ([`Fan::cut`], the whole MCL where `None`), and the materials there of the blend
/// between its ends' `materials`.
fn laid_stretch(
    whole: Vec<Point, MCL_POINTS>,
    cut: Option<&(f32, f32)>,
    (ma, mb): (Material, Material),
) -> Result<(Vec<Point, MCL_POINTS>, Material, Material), Error> {
    let Some(&(lo, hi)) = cut.filter(|&&(lo, hi)| lo > 0.0 || hi < f32::INFINITY) else {
        return Ok((whole, ma, mb));
    };
    // Vertices nearer a cut than this are left out (the cut's point stands for them).
    const NEAR: f32 = 1e-4;
    let len = polyline::length(&whole);
    let hi = hi.fmin(len);
    let mut out = Vec::new();
    // Never full: at most as many points as the MCL's.
    let full = |_| Limit::PathVertices.error();
    out.push(polyline::point_at(&whole, lo)).map_err(full)?;
    let mut s = 0.0;
    for j in 1..whole.len().saturating_sub(1) {
        s += whole[j - 1].dist(whole[j]);
        if s > lo + NEAR && s < hi - NEAR {
            out.push(whole[j]).map_err(full)?;
        }
    }
    out.push(polyline::point_at(&whole, hi)).map_err(full)?;
    Ok((out, along(&ma, &mb, lo, len), along(&ma, &mb, hi, len)))
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cut_mcl_lays_the_stretch_between_its_cuts_in_the_blend_there() {
        // An L: 2 mm along x, then 2 mm along y; from material a to material b.
        let whole: Vec<Point, MCL_POINTS> = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 2.0)]
            .iter()
            .map(|&(x, y)| Point::new(x, y))
            .collect();
        let (a, b) = ([1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]);
        // Uncut: the MCL as it is.
        let (pts, ma, mb) = laid_stretch(whole.clone(), None, (a, b)).unwrap();
        assert_eq!((&pts[..], ma, mb), (&whole[..], a, b));
        let (pts, ..) = laid_stretch(whole.clone(), Some(&(0.0, f32::INFINITY)), (a, b)).unwrap();
        assert_eq!(&pts[..], &whole[..]);
        // Cut 0.5 mm from the start and 1 mm from the end: from (0.5, 0) to (2, 1), the
        // vertex at (1, 0) kept, and the blend an eighth and three quarters of the way.
        let (pts, ma, mb) = laid_stretch(whole.clone(), Some(&(0.5, 3.0)), (a, b)).unwrap();
        let want = [(0.5, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 1.0)];
        assert_eq!(pts.len(), want.len());
        for (p, &(x, y)) in pts.iter().zip(&want) {
            assert!(p.dist(Point::new(x, y)) < 1e-6, "{p:?}");
        }
        assert!(
            (ma[0] - 0.875).abs() < 1e-6 && (ma[1] - 0.125).abs() < 1e-6,
            "{ma:?}"
        );
        assert!(
            (mb[0] - 0.25).abs() < 1e-6 && (mb[1] - 0.75).abs() < 1e-6,
            "{mb:?}"
        );
        // A cut at a vertex leaves it out (the cut's point stands for it).
        let (pts, ..) = laid_stretch(whole, Some(&(1.0, f32::INFINITY)), (a, b)).unwrap();
        assert_eq!(pts.len(), 3);
        assert!(pts[0].dist(Point::new(1.0, 0.0)) < 1e-6);
    }
}
