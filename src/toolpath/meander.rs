//! The zigzag's roads along its MCLs ([`super::zigzag`]): the band each MCL's road owns
//! between its neighbouring MCLs, the road's width and place in it, and the meander that fills
//! a band wider than the widest road.

use crate::geometry::{polyline, Point};
use crate::toolpath::composition::along;
use crate::toolpath::zigzag::{EDGE_MARGIN, NONE};
use crate::toolpath::{emit_move, PathSink, Vertex};
use crate::{Error, Plan, Slice};

/// A road meanders only where its band is wider than the widest road by this many road
/// widths: a narrower excess costs less left as slivers either side than paid for with the
/// turns of a meander of one or two strokes (which lap back over the wide road around them).
const MEANDER_MARGIN: f32 = 0.5;

/// The band a road along an MCL owns at a point ([`band_at`]): the unit normal to the left of
/// the MCL, and the distances to the neighbouring MCL on the left and on the right.
pub(super) type Band = (Point, f32, f32);

/// Whether a band is wider than the widest road
/// ([`max_width`](crate::Settings::max_width)) by [`MEANDER_MARGIN`]: there the road meanders
/// ([`meander`]).
pub(super) fn too_wide(slice: &Slice, band: Option<Band>) -> bool {
    let settings = slice.settings();
    band.is_some_and(|(_, l, r)| {
        0.5 * (l + r) > settings.max_width + MEANDER_MARGIN * settings.road_width
    })
}

/// The band the road along an MCL owns at `p` (direction `dir`): the unit normal to the left of
/// the MCL and the distances to the nearest neighbouring MCL on the left and on the right (a
/// side without a neighbour mirrors the other); the road owns half of each gap. `None` where
/// `dir` is degenerate.
pub(super) fn band_at(
    slice: &Slice,
    plan: &Plan,
    p: Point,
    dir: Point,
    near: &[u16; 4],
) -> Option<Band> {
    let w = slice.settings().road_width;
    let len = dir.norm();
    if len < 1e-6 {
        return None;
    }
    // Unit normal to the left of the MCL.
    let left_n = Point::new(-dir.y / len, dir.x / len);
    let (mut left, mut right) = (f32::INFINITY, f32::INFINITY);
    for (k, &m) in near.iter().enumerate() {
        if m == NONE || near[..k].contains(&m) {
            continue;
        }
        let other = plan.points(&plan.mcls[m as usize]);
        let mut best = (f32::INFINITY, Point::new(0.0, 0.0));
        for seg in other.windows(2) {
            let (q, _) = polyline::closest_on_segment(seg[0], seg[1], p);
            let d = q.dist(p);
            if d < best.0 {
                best = (d, q);
            }
        }
        if left_n.dot(best.1 - p) > 0.0 {
            left = left.min(best.0);
        } else {
            right = right.min(best.0);
        }
    }
    let (left, right) = match (left.is_finite(), right.is_finite()) {
        (true, true) => (left, right),
        (true, false) => (left, left),
        (false, true) => (right, right),
        (false, false) => (w, w),
    };
    Some((left_n, left, right))
}

/// Where the band an MCL's road owns ([`band_at`]) is wider than the widest road
/// ([`max_width`](crate::Settings::max_width)), as it is where MCLs fan apart toward the wall,
/// in large cells and around long channels, the road fills it with a meander: strokes across
/// the band, from its right edge to its left edge and back, a road apart, advancing along the
/// MCL. The strokes stand on one grid over the whole MCL (a road apart, evenly), not per move:
/// an MCL's vertices are mostly nearer each other than a road, and a move shorter than a road
/// holds one stroke or none. Emits the strokes along the MCL's move from `a` to `b` (arc
/// lengths `sa`, `sb` of `len` from the `from` end, materials `ma`, `mb` at its ends),
/// `right_first` the side the next stroke starts on, `in_meander` set to whether the last
/// sample was a stroke.
#[allow(clippy::too_many_arguments)]
pub(super) fn meander(
    slice: &Slice,
    plan: &Plan,
    (a, b): (Point, Point),
    (sa, sb, len): (f32, f32, f32),
    (ma, mb): (&crate::Material, &crate::Material),
    near: &[u16; 4],
    (right_first, in_meander): (&mut bool, &mut bool),
    sink: &mut impl PathSink,
) -> Result<(), Error> {
    let w = slice.settings().road_width;
    if len < 1e-6 || (sb - sa).abs() < 1e-9 {
        return Ok(());
    }
    // Strokes stand a road apart (a little less, evenly) over the whole MCL, at arc lengths
    // `(k + 1/2) spacing` from its `from` end, whatever the spacing of its vertices: a move
    // shorter than a road holds one stroke or none, a long one several.
    let count = libm::ceilf(len / w).max(1.0);
    let spacing = len / count;
    let dir = b - a;
    // The strokes on this move, in walking order: from `sa` (included) toward `sb`.
    let first = if sb > sa {
        libm::ceilf(sa / spacing - 0.5)
    } else {
        libm::floorf(sa / spacing - 0.5)
    };
    let step = if sb > sa { 1.0 } else { -1.0 };
    let mut k = first;
    loop {
        let s = (k + 0.5) * spacing;
        let inside = if sb > sa { s < sb } else { s > sb };
        if !inside || k < 0.0 || k >= count {
            break;
        }
        let t = ((s - sa) / (sb - sa)).clamp(0.0, 1.0);
        let material = along(ma, mb, s, len);
        *in_meander = stroke(
            slice,
            plan,
            a.lerp(b, t),
            dir,
            spacing,
            material,
            near,
            right_first,
            sink,
        )?;
        k += step;
    }
    Ok(())
}

/// One stroke of a [`meander`] across the band at `q` (the MCL's direction `dir`), `spacing`
/// from the last, if the band there is wider than the widest road: from the side
/// `right_first` names to the other, which the next stroke then starts from. Returns whether
/// the band is that wide (whether `q` belongs to a meander).
#[allow(clippy::too_many_arguments)]
fn stroke(
    slice: &Slice,
    plan: &Plan,
    q: Point,
    dir: Point,
    spacing: f32,
    material: crate::Material,
    near: &[u16; 4],
    right_first: &mut bool,
    sink: &mut impl PathSink,
) -> Result<bool, Error> {
    let settings = slice.settings();
    let band = band_at(slice, plan, q, dir, near);
    let Some((left_n, left, right)) = band.filter(|_| too_wide(slice, band)) else {
        return Ok(false);
    };
    let ws = spacing.max(settings.min_width);
    // Each side as far out as the band reaches, pulled back toward the MCL where the
    // stroke would leave the region (the band of an MCL whose neighbour lies beyond a
    // feature, a pinch).
    let side = |reach: f32, sign: f32| {
        [1.0f32, 0.75, 0.5, 0.25, 0.0]
            .iter()
            .map(|f| q + left_n * (sign * f * reach))
            .find(|&e| {
                // Room for the stroke off every keep-out curve's strip (each feature's own
                // material's place, where an arc may run): its edge a road off the feature.
                slice.clearance(e) >= settings.road_width + 0.5 * ws + 2.0 * EDGE_MARGIN
                    && !slice.segment_crosses_feature(q, e)
            })
            .unwrap_or(q)
    };
    let sides = [
        side((0.5 * right - 0.5 * ws).max(0.0), -1.0),
        side((0.5 * left - 0.5 * ws).max(0.0), 1.0),
    ];
    let order = if *right_first { [0, 1] } else { [1, 0] };
    for k in order {
        emit_move(
            slice,
            sink,
            Vertex {
                at: sides[k],
                material,
                width: ws,
                deposit: true,
            },
        )?;
    }
    *right_first = !*right_first;
    Ok(true)
}

/// Where the road along MCL polyline `pts` passes vertex `j`, and its width there.
///
/// The road covers its share of the gaps to the nearest neighbouring road on either side
/// (distances `l` and `r` of its band): from half-way to the left one to half-way to
/// the right one. So it is `(l + r) / 2` wide and its centre lies `(r - l) / 4` toward the
/// wider gap; two neighbours then meet half-way between their MCLs where MCLs fan out or crowd
/// in, without gap or overlap. The width stays within the slice's
/// [`min_width`](crate::Settings::min_width) .. [`max_width`](crate::Settings::max_width) and
/// at most twice the point's clearance from the features, less [`EDGE_MARGIN`] each side (the
/// shift is left out where it would come nearer a feature than half the narrowest road); the
/// MCL's end vertices (`end`: on keep-out curves, where the arcs to the next MCL leave) stay
/// where they are and are at most a road width wide, so nothing spills. `band` is the band
/// the road owns at `p` ([`band_at`]).
pub(super) fn road_at(slice: &Slice, p: Point, end: bool, band: Option<Band>) -> (Point, f32) {
    let settings = slice.settings();
    let w = settings.road_width;
    let Some((left_n, left, right)) = band else {
        return (p, w);
    };
    let width = (0.5 * (left + right)).clamp(settings.min_width, settings.max_width);
    let cap = |q: Point| 2.0 * (slice.clearance(q) - EDGE_MARGIN);
    if end {
        return (p, width.min(w - 2.0 * EDGE_MARGIN));
    }
    let shifted = p - left_n * (0.25 * (right - left)).clamp(-0.25 * width, 0.25 * width);
    // The shift toward the wider gap may bring the road nearer a feature than half the
    // narrowest road: then it stays on its MCL.
    let at = if cap(shifted) >= settings.min_width {
        shifted
    } else {
        p
    };
    (at, width.min(cap(at)))
}
