//! Depositing the zigzag: a road out and back along each MCL (banded, or a meander where the
//! fan outgrows the widest road), and the arcs along the keep-out curves between MCL ends.

use super::arc::{inner_end, off_curve, shared_strip};
use super::ends::{Arcs, Ends};
use super::{EDGE_MARGIN, END_STEPS};
use crate::config::MCL_POINTS;
use crate::error::Limit;
use crate::geometry::primitives::MinMax;
use crate::geometry::{polyline, Point};
use crate::keep_out::KeepOut;
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

/// Deposits MCL `k` from its `from` end (`forward`) or from its far end, `fan` the MCLs laid
/// its band is measured against ([`band_at`]), `spliced` the curve of each end (`from` end
/// first) that leads into a splice's inner arc ([`inner_end`]), `strips` the bare stretches
/// beside its ends ([`Strip`]); the first vertex of a piece is reached by travel
/// (`travel_to_start`). Returns how many stretches of it were laid in lanes
/// (`meander::lanes`).
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
) -> Result<u16, Error> {
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
            if strokes.in_lanes(at_cum) && !is_end {
                continue;
            }
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
    Ok(strokes.laned)
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
